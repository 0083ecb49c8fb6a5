//! A reconstruction's output folder: trajectory.parquet, trajectory.mcap, residuals.parquet,
//! errors.parquet (with a truth), tuned.toml (with self-tuning), report.html and its
//! pictures, summary.json; all staged and renamed into place together.
//!
//! The solutions are read back once, a block of epochs at a time ([`recon_blocks`]); each
//! table is written by a thread of its own as the blocks come. The writers' threads use no
//! rayon: the report, which does, is made on the calling thread (a rayon worker's, in a
//! batch), so that no thread waits on the pool from outside it.

use super::files::Folder;
use super::recon_blocks::{self, joined, Tables};
use super::recon_report;
use super::recon_tables;
use super::WriteError;
use crate::reconstruction::{Error, Reconstruction};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Writes every file of `r`'s output folder into `dir` (created if missing); returns their
/// paths, summary.json last.
pub fn write(r: &mut Reconstruction, dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let started = Instant::now();
    let mut folder = Folder::create(dir)?;
    write_tables(r, Tables::create(&mut folder, !r.truth.is_empty())?)?;
    if let Some(t) = &r.summary.tuning {
        folder.text("tuned.toml", &t.as_toml())?;
    }
    let report_started = Instant::now();
    r.summary.run_time_s.total = r.started.elapsed().as_secs_f64();
    folder.report(&report(r))?;
    r.summary.run_time_s.report = report_started.elapsed().as_secs_f64();
    r.summary.run_time_s.outputs = started.elapsed().as_secs_f64();
    r.summary.run_time_s.total = r.started.elapsed().as_secs_f64();
    folder.json("summary.json", &r.summary)?;
    Ok(folder.commit()?)
}

/// The page, from the summary, the solutions and what the log said.
fn report(r: &Reconstruction) -> super::report::Report {
    recon_report::build(&recon_report::Inputs {
        summary: &r.summary,
        r: &r.solved,
        samples: &r.scored.samples,
        origin_rad: r.origin_rad,
        from_log: &r.from_log,
        truth_errors: (r.scored.errors.as_ref()).map(|(f, s)| (&f.points[..], &s.points[..])),
        init_text: r.solved.init.to_string(),
    })
}

/// The tables, from one read of the solutions: trajectory.parquet (then residuals.parquet),
/// trajectory.mcap and errors.parquet each on a thread of its own.
fn write_tables(r: &Reconstruction, tables: Tables) -> Result<(), Error> {
    let Tables {
        trajectory,
        foxglove,
        residuals,
        errors,
    } = tables;
    let truth = match errors {
        Some(_) => r.truth.read()?,
        None => Vec::new(),
    };
    let solved = &r.solved;
    let origin = r.origin_rad;
    let (to_parquet, parquet_blocks) = recon_blocks::channel();
    let (to_mcap, mcap_blocks) = recon_blocks::channel();
    let (to_scores, score_blocks) = recon_blocks::channel();
    let (to_errors, block_errors) = std::sync::mpsc::sync_channel(1);
    let (read, parquet, mcap, errors_table) = std::thread::scope(|s| {
        let parquet = s.spawn(|| -> Result<(), WriteError> {
            recon_blocks::trajectory_parquet(trajectory, parquet_blocks, origin)?;
            let residuals_batch = recon_tables::residuals_batch;
            recon_blocks::write_chunks(residuals, &solved.run.residuals, residuals_batch)
        });
        let mcap = s.spawn(|| recon_blocks::trajectory_mcap(foxglove, mcap_blocks, origin));
        let errors_table = s.spawn(|| match errors {
            Some(file) => recon_blocks::errors_parquet(file, block_errors),
            None => Ok(()),
        });
        let mut to = vec![to_parquet, to_mcap];
        let scores = (!truth.is_empty()).then(|| {
            to.push(to_scores);
            s.spawn(|| recon_blocks::score(score_blocks, &truth, &[], Some(to_errors)))
        });
        let read = recon_blocks::read_blocks(solved, &r.kept_rows, to);
        if let Some(scores) = scores {
            joined(scores);
        }
        (read, joined(parquet), joined(mcap), joined(errors_table))
    });
    // A writer's own failure first: it is why the reading stopped.
    parquet?;
    mcap?;
    errors_table?;
    read.map_err(|source| Error::ReadBack {
        what: "reading the solutions back",
        source,
    })
}
