//! Output at the edge: Arrow tables built from decoded streams, Parquet files, all written
//! under temporary names and renamed only when every file of a run is complete.
//!
//! May import: `contract`, `ingest` (types), `align`, `filters` and `geodesy` (solutions),
//! `time`, `arrow-*`, `parquet`, `std::fs`.

pub mod atomic;
pub mod attitude_tables;
pub mod batch_tables;
mod columns;
pub mod files;
pub mod foxglove;
pub mod identify_tables;
pub mod parquet;
pub mod plots;
pub mod recon_arrow;
pub mod recon_blocks;
pub mod recon_folder;
pub mod recon_report;
pub mod recon_tables;
pub mod report;
pub mod study_tables;
pub mod tables;

use std::path::{Path, PathBuf};

/// A file of an output folder could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

impl WriteError {
    /// The error of writing `path`, for `map_err`.
    pub fn at<E: Into<Box<dyn std::error::Error + Send + Sync>>>(
        path: &Path,
    ) -> impl FnOnce(E) -> WriteError + '_ {
        move |e| WriteError {
            path: path.to_path_buf(),
            source: e.into(),
        }
    }
}
