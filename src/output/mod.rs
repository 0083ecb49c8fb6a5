//! Output at the edge: Arrow tables built from decoded streams, Parquet files, all written
//! under temporary names and renamed only when every file of a run is complete.
//!
//! May import: `contract`, `ingest` (types), `align`, `filters` and `geodesy` (solutions),
//! `time`, `arrow-*`, `parquet`, `std::fs`.

pub mod atomic;
pub mod attitude_tables;
pub mod batch_tables;
mod columns;
pub mod foxglove;
pub mod identify_tables;
pub mod parquet;
pub mod plots;
pub mod recon_tables;
pub mod report;
pub mod study_tables;
pub mod tables;
