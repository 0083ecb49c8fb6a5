//! A batch of missions, one mission at a time: what `hindsight batch` does for each log of an
//! archive, and what a task of a distributed engine (Dask, Ray) calls. Each mission is
//! reconstructed into its own hive-style partition, `OUT/mission=<name>/`, and gives one row
//! of `batch_summary.parquet`; the rows are written together at the end
//! ([`write_summary`]). Only the row crosses back to the caller: the tables go to disk from
//! the mission's own process.

use crate::output::batch_tables::{batch_summary, MissionRow};
use crate::output::files::Folder;
use crate::output::report::{Block, Report, Section};
use crate::output::WriteError;
use crate::recon::config::Config;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A mission's name: its log's file stem (a ROS 2 bag folder's name).
pub fn mission_name(log: &Path) -> String {
    log.file_stem()
        .map_or_else(|| "log".to_string(), |s| s.to_string_lossy().into_owned())
}

/// The mission's partition under `out`.
pub fn partition(out: &Path, mission: &str) -> PathBuf {
    out.join(format!("mission={mission}"))
}

/// An error and its causes, joined by `: ` (as the command line prints them).
pub fn error_chain(err: &(dyn std::error::Error + 'static)) -> String {
    let mut text = err.to_string();
    let mut source = err.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// A mission's summary.json, if it is there and names `log`: its outputs are complete (the
/// summary is renamed into place last).
fn complete_summary(dir: &Path, log: &Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    let summary: serde_json::Value = serde_json::from_str(&text).ok()?;
    (summary["log"].as_str() == Some(&log.display().to_string())).then_some(summary)
}

fn row_from(mission: &str, log: &Path, summary: &serde_json::Value) -> MissionRow {
    let f = |path: &[&str]| {
        path.iter()
            .try_fold(summary, |v, k| v.get(*k))
            .and_then(|v| v.as_f64())
    };
    MissionRow {
        mission: mission.to_string(),
        log: log.display().to_string(),
        duration_s: f(&["duration_s"]),
        distance_travelled_m: f(&["distance_travelled_m"]),
        final_horizontal_sigma_forward_m: f(&["final_sigma", "forward", "horizontal_m"]),
        final_horizontal_sigma_smoothed_m: f(&["final_sigma", "smoothed", "horizontal_m"]),
        consistent: summary["consistency"]["consistent"].as_bool(),
        forward_horizontal_rms_m: f(&["truth", "forward", "horizontal_rms_m"]),
        smoothed_horizontal_rms_m: f(&["truth", "smoothed", "horizontal_rms_m"]),
        ..MissionRow::default()
    }
}

/// Reconstructs one mission into `dir` as `reconstruct` would; a panic is a failure of this
/// mission, not carried into the others.
fn reconstruct_into(log: &Path, dir: &Path, config: &Config) -> Result<(), String> {
    let job = crate::Job::new(log, config.clone());
    let reconstructed = || -> Result<(), crate::reconstruction::Error> {
        crate::reconstruct(&job, Default::default())?.write(dir)?;
        Ok(())
    };
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(reconstructed)) {
        Ok(result) => result.map_err(|e| error_chain(&e)),
        Err(_) => Err("internal error (a panic) while reconstructing: please report it".into()),
    }
}

/// One mission of a batch: its outputs already complete in its partition (unless `force`),
/// else reconstructed now; its row either way (a failure is a row too, with its error).
pub fn run_mission(log: &Path, out: &Path, config: &Config, force: bool) -> MissionRow {
    let name = mission_name(log);
    let dir = partition(out, &name);
    if let Some(summary) = complete_summary(&dir, log).filter(|_| !force) {
        return MissionRow {
            status: "complete",
            ..row_from(&name, log, &summary)
        };
    }
    let t = Instant::now();
    let outcome = reconstruct_into(log, &dir, config);
    let run_time_s = Some(t.elapsed().as_secs_f64());
    let summary = outcome.and_then(|()| {
        complete_summary(&dir, log).ok_or_else(|| "no summary.json after the run".to_string())
    });
    match summary {
        Ok(summary) => MissionRow {
            status: "done",
            run_time_s,
            ..row_from(&name, log, &summary)
        },
        Err(error) => MissionRow {
            mission: name,
            log: log.display().to_string(),
            status: "failed",
            error: Some(error),
            run_time_s,
            ..MissionRow::default()
        },
    }
}

/// Why the batch's own outputs could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SummaryError {
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error("drawing the batch's report")]
    Report(#[source] crate::output::plots::PlotError),
}

/// `batch_summary.parquet` and the batch's `report.html` in `out` (each named for its shard
/// `(i, n)`, as `batch_summary.shard-I-of-N.parquet`); returns the summary's path.
pub fn write_summary(
    rows: &[MissionRow],
    out: &Path,
    shard: Option<(usize, usize)>,
) -> Result<PathBuf, SummaryError> {
    let named = |stem: &str, ext: &str| match shard {
        Some((i, n)) => format!("{stem}.shard-{i}-of-{n}.{ext}"),
        None => format!("{stem}.{ext}"),
    };
    let (summary, page) = (named("batch_summary", "parquet"), named("report", "html"));
    let mut folder = Folder::create(out)?;
    let table = batch_summary(rows).map_err(WriteError::at(&out.join(&summary)))?;
    folder.table(&summary, table)?;
    let html = report(rows, out).to_html().map_err(SummaryError::Report)?;
    folder.text(&page, &html)?;
    folder.commit()?;
    Ok(out.join(summary))
}

/// The batch's page: every mission's outcome (each mission's own report.html is in its
/// folder).
fn report(rows: &[MissionRow], out: &Path) -> Report {
    let na = |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |v| format!("{v:.digits$}"));
    let table = rows
        .iter()
        .map(|r| {
            vec![
                r.mission.clone(),
                r.status.to_string(),
                na(r.duration_s, 0),
                na(r.distance_travelled_m, 0),
                na(r.final_horizontal_sigma_smoothed_m, 2),
                r.consistent
                    .map_or("-", |c| if c { "yes" } else { "NO" })
                    .to_string(),
                na(r.smoothed_horizontal_rms_m, 2),
                na(r.run_time_s, 1),
            ]
        })
        .collect();
    let failed: Vec<String> = rows
        .iter()
        .filter_map(|r| Some(format!("mission={}: {}", r.mission, r.error.as_ref()?)))
        .collect();
    Report {
        title: format!("hindsight batch: {} missions", rows.len()),
        subtitle: out.display().to_string(),
        sections: vec![
            Section::new("Missions")
                .with(Block::text(
                    "Each mission's outputs and its own report.html are in mission=<name>/. \
                     complete: its outputs were there already (not run again).",
                ))
                .with(Block::table(
                    [
                        "mission",
                        "status",
                        "duration s",
                        "distance m",
                        "final 1-sigma m",
                        "consistent",
                        "RMS vs truth m",
                        "run time s",
                    ],
                    table,
                )),
            Section::new("Failed missions").with(Block::Warnings(failed)),
        ],
        footer: format!("hindsight {}", env!("CARGO_PKG_VERSION")),
    }
}
