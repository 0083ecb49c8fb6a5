//! Log production: the project's MCAP writer and generated logs for tests, benchmarks and
//! `sample-logs/`.
//!
//! May import: `contract`, `ingest` (for [`Mission`](crate::ingest::Mission), and the logs
//! [`ros2`] rewrites), `align` (its merge), `time`, `mcap`.

pub mod bag;
pub mod dynamic;
pub mod file;
pub mod inertial;
pub mod profile;
pub mod ros;
pub mod run;
pub mod scenario;
pub mod sensors;
pub mod synthetic;
pub mod trajectory;
pub mod truth;
pub mod vibration;
pub mod writer;
pub mod zigzag;
