//! Estimators. Pure: models in, estimates out; no I/O and no `ingest`/`output` imports.
//!
//! May import: `geodesy`, `frames`, `angle`, `time`, `nalgebra`.

pub mod heading;
pub mod ins;
pub mod kalman;
pub mod velocity;
