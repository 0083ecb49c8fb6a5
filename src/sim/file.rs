//! A simulated log written to a file, as `hindsight simulate --out` writes it (zstd chunks),
//! staged under a temporary name and renamed into place when complete: for the library's
//! callers (the Python package).

use super::run::{run_with_progress, RunSummary, SimError};
use super::scenario::Scenario;
use super::writer::{LogWriter, WriterOptions};
use crate::output::atomic::Staging;
use std::path::{Path, PathBuf};

/// Why a simulated log could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SimFileError {
    #[error(transparent)]
    Run(#[from] SimError),
    #[error("writing {}", path.display())]
    Output {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Simulates `scenario` with `seed` into `out`, telling `progress` the fraction of the
/// mission done; nothing is left at `out` when it fails.
pub fn simulate_to_file(
    scenario: &Scenario,
    seed: u64,
    out: &Path,
    progress: impl FnMut(f64),
) -> Result<RunSummary, SimFileError> {
    let failed = |source| SimFileError::Output {
        path: out.to_path_buf(),
        source,
    };
    let mut staging = Staging::new();
    let file = staging.create(out).map_err(failed)?;
    let mut w = LogWriter::new(std::io::BufWriter::new(file), WriterOptions::default())
        .map_err(SimError::from)?;
    let summary = run_with_progress(scenario, seed, &mut w, progress)?;
    let buffered = w.finish().map_err(SimError::from)?;
    let file = buffered.into_inner().map_err(|e| failed(e.into_error()))?;
    file.sync_all().map_err(failed)?;
    staging.commit().map_err(failed)?;
    Ok(summary)
}
