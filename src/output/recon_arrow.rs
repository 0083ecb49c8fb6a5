//! A reconstruction's tables as Arrow record batches in memory, for a library caller (the
//! Python package hands them over without a copy): the rows trajectory.parquet,
//! residuals.parquet and errors.parquet hold, from one read of the solutions, as
//! `recon_folder` writes them.

use super::parquet::ROWS_PER_BATCH;
use super::recon_blocks::{self, joined};
use super::recon_tables;
use crate::reconstruction::{Error, Reconstruction};
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;

/// The output folder's tables: each a list of batches of one schema, never empty (a table
/// with no rows is one empty batch, which carries the schema).
#[derive(Debug, Clone)]
pub struct ArrowTables {
    /// trajectory.parquet: each block of epochs' forward rows, then its smoothed rows.
    pub trajectory: Vec<RecordBatch>,
    /// residuals.parquet.
    pub residuals: Vec<RecordBatch>,
    /// errors.parquet (no rows without a truth).
    pub errors: Vec<RecordBatch>,
}

/// A failure to build a table: said as a read-back failure.
fn arrow_failed(source: ArrowError) -> Error {
    Error::ReadBack {
        what: "building the tables",
        source: std::io::Error::other(source),
    }
}

/// The tables of `r`.
pub fn tables(r: &Reconstruction) -> Result<ArrowTables, Error> {
    let truth = r.truth.read()?;
    let origin = r.origin_rad;
    let (to_trajectory, trajectory_blocks) = recon_blocks::channel();
    let (to_scores, score_blocks) = recon_blocks::channel();
    let (to_errors, block_errors) = std::sync::mpsc::sync_channel(1);
    let (read, trajectory, errors) = std::thread::scope(|s| {
        let trajectory = s.spawn(|| -> Result<Vec<RecordBatch>, ArrowError> {
            let mut out = vec![recon_tables::trajectory_batch("forward", &[], origin)?];
            for b in trajectory_blocks {
                out.extend(recon_blocks::trajectory_batches(&b, origin)?);
            }
            Ok(out)
        });
        let errors = s.spawn(|| -> Result<Vec<RecordBatch>, ArrowError> {
            let mut out = vec![recon_tables::errors_batch("forward", &[])?];
            for block in block_errors {
                out.extend(recon_blocks::errors_batches(&block)?);
            }
            Ok(out)
        });
        let mut to = vec![to_trajectory];
        if !truth.is_empty() {
            to.push(to_scores);
            s.spawn(|| recon_blocks::score(score_blocks, &truth, &[], Some(to_errors)));
        }
        let read = recon_blocks::read_blocks(&r.solved, &r.kept_rows, to);
        (read, joined(trajectory), joined(errors))
    });
    read.map_err(|source| Error::ReadBack {
        what: "reading the solutions back",
        source,
    })?;
    let residuals = (r.solved.run.residuals.chunks(ROWS_PER_BATCH))
        .map(recon_tables::residuals_batch)
        .collect::<Result<Vec<_>, _>>();
    let mut residuals = residuals.map_err(arrow_failed)?;
    if residuals.is_empty() {
        residuals.push(recon_tables::residuals_batch(&[]).map_err(arrow_failed)?);
    }
    Ok(ArrowTables {
        trajectory: with_rows(trajectory.map_err(arrow_failed)?),
        residuals: with_rows(residuals),
        errors: with_rows(errors.map_err(arrow_failed)?),
    })
}

/// The batches with rows; the first (empty) one when none has any, for the schema.
fn with_rows(mut batches: Vec<RecordBatch>) -> Vec<RecordBatch> {
    if batches.iter().any(|b| b.num_rows() > 0) {
        batches.retain(|b| b.num_rows() > 0);
    } else {
        batches.truncate(1);
    }
    batches
}
