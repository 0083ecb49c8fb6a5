//! `hindsight batch LOG_OR_DIR... --out DIR`: every log of an archive reconstructed, in
//! parallel across logs, each into its own hive-style partition, with one summary table.

use super::console;
use super::OutputFailed;
use anyhow::{Context, Result};
use hindsight::batch;
use hindsight::output::batch_tables::MissionRow;
use hindsight::recon::config::Config;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Reconstruct every log of an archive: in parallel across logs, resumable, shardable.
///
/// Each LOG (an .mcap or .bag file, or a ROS 2 sqlite3 bag folder) or DIR (every such log
/// under it, recursively) is reconstructed
/// as `hindsight reconstruct` would, with --config, into DIR/mission=<log file stem>/ (a
/// hive-style partition: DuckDB, polars and pyarrow read DIR/mission=*/trajectory.parquet
/// with the mission as a column). Then:
///
///   batch_summary.parquet   one row per mission: status (done, complete, failed), error,
///                           run time, duration, distance, final 1-sigma, the verdict on the
///                           uncertainty, and the truth scores when the log has /truth
///                           (a shard writes batch_summary.shard-I-of-N.parquet)
///
/// A mission whose outputs are complete (its summary.json, written last, names the same
/// log) is not run again: a rerun resumes. A log that fails is reported and the others go
/// on; the exit status is then 3.
///
/// --shard I/N takes the logs whose place in the sorted list is I modulo N (I from 0), so that
/// N machines split an archive without coordinating: a Slurm array job passes
/// --shard $SLURM_ARRAY_TASK_ID/N, a Kubernetes indexed job --shard $JOB_COMPLETION_INDEX/N.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct BatchArgs {
    /// Logs (.mcap, .bag, ROS 2 bag folders) and folders holding them.
    #[arg(required = true, value_name = "LOG_OR_DIR")]
    pub logs: Vec<PathBuf>,

    /// Output folder: one mission=<name> folder per log, and the batch summary.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Logs reconstructed at once [default: the number of cores]. Each takes the memory of
    /// one reconstruction.
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,

    /// This machine's share of the logs: I/N takes every N-th log from the I-th (0 <= I < N).
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,

    /// Settings file for every mission (see `hindsight config`).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// Reconstruct complete missions again.
    #[arg(long)]
    pub force: bool,
}

fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| format!("`{text}`: give I/N, e.g. 0/4"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|_| format!("`{text}`: `{v}` is not a whole number"))
    };
    let (i, n) = (parse(i)?, parse(n)?);
    if n == 0 || i >= n {
        return Err(format!("`{text}`: I must be in 0..N and N at least 1"));
    }
    Ok((i, n))
}

/// The batch's logs cannot be listed as given (exit status 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ArchiveError(String);

/// The logs of the arguments, sorted: files as given, folders searched for logs (see
/// [`walk`]); a folder that is a ROS 2 sqlite3 bag is one log.
pub fn collect_logs(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut logs = Vec::new();
    for p in paths {
        if p.is_dir() && p.join("metadata.yaml").is_file() {
            logs.push(p.clone());
        } else if p.is_dir() {
            let before = logs.len();
            walk(p, &mut logs).with_context(|| format!("listing {}", p.display()))?;
            if logs.len() == before {
                return Err(ArchiveError(format!(
                    "no log (.mcap, .bag, or a ROS 2 bag folder) under {}",
                    p.display()
                ))
                .into());
            }
        } else if p.is_file() {
            logs.push(p.clone());
        } else {
            return Err(ArchiveError(format!("{}: no such file or folder", p.display())).into());
        }
    }
    logs.sort();
    logs.dedup();
    Ok(logs)
}

/// The logs under `dir`: MCAP files, ROS 1 bags, and ROS 2 sqlite3 bag folders (a folder
/// with a `metadata.yaml` beside `.db3` files is one log).
fn walk(dir: &Path, logs: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() && path.join("metadata.yaml").is_file() {
            logs.push(path);
        } else if path.is_dir() {
            walk(&path, logs)?;
        } else if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap") || e.eq_ignore_ascii_case("bag"))
        {
            logs.push(path);
        }
    }
    Ok(())
}

/// Each log with its mission name (the file stem); two logs of one name are refused.
fn missions(logs: &[PathBuf]) -> Result<Vec<(String, PathBuf)>> {
    let mut named: Vec<(String, PathBuf)> = logs
        .iter()
        .map(|l| (batch::mission_name(l), l.clone()))
        .collect();
    named.sort();
    if let Some(w) = named.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(ArchiveError(format!(
            "two logs would both be mission `{}`: {} and {}; rename one, or run them in \
             separate batches",
            w[0].0,
            w[0].1.display(),
            w[1].1.display()
        ))
        .into());
    }
    Ok(named)
}

/// The logs of shard `i` of `n`: those whose place in the list is `i` modulo `n`.
pub fn shard<T: Clone>(items: &[T], i: usize, n: usize) -> Vec<T> {
    items.iter().skip(i).step_by(n.max(1)).cloned().collect()
}

/// Some missions of a batch failed (exit status 3); the others are complete.
#[derive(Debug, thiserror::Error)]
#[error("{failed} of {total} missions failed (see batch_summary: status, error)")]
pub struct MissionsFailed {
    pub failed: usize,
    pub total: usize,
}

pub fn run(args: BatchArgs) -> Result<()> {
    let started = Instant::now();
    let config = batch_config(args.config.as_deref())?;
    let all = missions(&collect_logs(&args.logs)?)?;
    let (i, n) = args.shard.unwrap_or((0, 1));
    let mine = shard(&all, i, n);
    std::fs::create_dir_all(&args.out).with_context(|| OutputFailed {
        path: args.out.clone(),
    })?;
    let user_quiet = console::quiet();
    let tell = |text: String| {
        if !user_quiet {
            eprintln!("{text}");
        }
    };
    tell(format!(
        "{} logs{}; {} here",
        all.len(),
        args.shard
            .map(|(i, n)| format!(", shard {i}/{n}"))
            .unwrap_or_default(),
        mine.len()
    ));
    let bar = console::bar(mine.len() as u64, "batch", "missions");
    // The missions' own messages would interleave: each says its outcome in one line.
    console::set_quiet(true);
    let one = |(name, log): &(String, PathBuf)| -> MissionRow {
        let row = batch::run_mission(log, &args.out, &config, args.force);
        debug_assert_eq!(&row.mission, name);
        bar.suspend(|| tell(outcome_line(&row)));
        bar.inc(1);
        row
    };
    let rows: Vec<MissionRow> = match args.jobs {
        Some(j) => rayon::ThreadPoolBuilder::new()
            .num_threads(j.max(1))
            .build()
            .context("starting the worker threads")?
            .install(|| mine.par_iter().map(one).collect()),
        None => mine.par_iter().map(one).collect(),
    };
    bar.finish_and_clear();
    console::set_quiet(user_quiet);

    let path = write_batch_outputs(&rows, &args)?;
    let failed = rows.iter().filter(|r| r.status == "failed").count();
    let count = |s: &str| rows.iter().filter(|r| r.status == s).count();
    console::say!(
        "{} missions in {:.1} s: {} done, {} complete already, {failed} failed; wrote {}",
        rows.len(),
        started.elapsed().as_secs_f64(),
        count("done"),
        count("complete"),
        path.display()
    );
    if failed > 0 {
        return Err(MissionsFailed {
            failed,
            total: rows.len(),
        }
        .into());
    }
    Ok(())
}

/// The batch's settings: a bad configuration fails every mission, so it is said once, up
/// front.
fn batch_config(path: Option<&Path>) -> Result<Config> {
    let Some(c) = path else {
        return Ok(Config::default());
    };
    let mut config: Config = super::config_command::read(c, None)?;
    super::reconstruct::read_vehicle_file(&mut config)
        .with_context(|| format!("configuration {}", c.display()))?;
    Ok(config)
}

/// batch_summary.parquet and the batch's report.html (each named for its shard); returns the
/// summary's path.
fn write_batch_outputs(rows: &[MissionRow], args: &BatchArgs) -> Result<PathBuf> {
    batch::write_summary(rows, &args.out, args.shard).with_context(|| OutputFailed {
        path: args.out.clone(),
    })
}

fn outcome_line(r: &MissionRow) -> String {
    match r.status {
        "failed" => format!(
            "failed    mission={}: {}",
            r.mission,
            r.error.as_deref().unwrap_or_default()
        ),
        status => format!(
            "{status:<9} mission={}: {:.0} s, {:.0} m, final 1-sigma {:.2} m{}{}",
            r.mission,
            r.duration_s.unwrap_or(f64::NAN),
            r.distance_travelled_m.unwrap_or(f64::NAN),
            r.final_horizontal_sigma_smoothed_m.unwrap_or(f64::NAN),
            r.smoothed_horizontal_rms_m
                .map(|e| format!(", {e:.2} m RMS against /truth"))
                .unwrap_or_default(),
            r.run_time_s
                .map(|t| format!(" ({t:.1} s)"))
                .unwrap_or_default()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_every_log_once() {
        let logs: Vec<usize> = (0..23).collect();
        for n in 1..=7 {
            let mut seen: Vec<usize> = (0..n).flat_map(|i| shard(&logs, i, n)).collect();
            seen.sort();
            assert_eq!(seen, logs, "{n} shards");
        }
        assert_eq!(parse_shard("2/4"), Ok((2, 4)));
        assert!(parse_shard("4/4").is_err() && parse_shard("1/0").is_err());
        assert!(parse_shard("x").is_err() && parse_shard("a/2").is_err());
    }
}
