//! `hindsight export LOG --out DIR`: every topic to Parquet, plus all streams on one clock.

use super::console::out;
use super::{LogArgs, OutputFailed, PolicyArgs};
use anyhow::{bail, Context, Result};
use hindsight::ingest::{Log, Stream};
use hindsight::output::{atomic::Staging, parquet::write_batches, parquet::ROWS_PER_BATCH, tables};
use std::path::{Path, PathBuf};

/// Most rows accepted in aligned.parquet (protects against a typo in --rate).
const MAX_ALIGNED_ROWS: usize = 50_000_000;

/// Export a log to Parquet: one file per topic, and aligned.parquet on a common clock.
///
/// One file per topic (`imu.parquet`, `dvl.parquet`, ...) with
/// `stamp_ns` and `log_time_ns` as timestamp[ns, UTC] and one column per field (vectors as
/// `_x/_y/_z`, Euler triples as `_roll/_pitch/_yaw`, units in the column metadata), and
/// `aligned.parquet`: every stream sampled on a common clock, each with its latest value
/// and that value's age (`<topic>_age_s`).
///
/// Streams are sorted by stamp with duplicates dropped (see `hindsight info`). Files are
/// written under temporary names and renamed only when all are complete.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct ExportArgs {
    #[command(flatten)]
    pub log: LogArgs,

    #[command(flatten)]
    pub policy: PolicyArgs,

    /// Output folder (created if missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Rate of the common clock of aligned.parquet, Hz.
    #[arg(long, default_value_t = 10.0, value_name = "HZ", value_parser = parse_rate)]
    pub rate: f64,
}

fn parse_rate(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(hz) if hz.is_finite() && hz > 0.0 && hz <= 1e6 => Ok(hz),
        _ => Err(format!(
            "`{text}`: give a rate in Hz, above 0 and at most 1e6"
        )),
    }
}

pub fn run(args: ExportArgs) -> Result<()> {
    let period_ns = (1e9 / args.rate).round() as i64;
    let log = super::load(
        &args.log.log,
        &args.policy.ingest_options(&args.log.source),
        &args.log.offsets,
    )?;
    if log.message_count() == 0 {
        return Err(hindsight::ingest::IngestError::NoMessages)
            .with_context(|| format!("reading {}", args.log.log.display()));
    }
    let clock = clock(&log, period_ns)?;
    std::fs::create_dir_all(&args.out).with_context(|| OutputFailed {
        path: args.out.clone(),
    })?;
    let written = write_all(&log, &clock, &args.out)?;
    for (path, rows) in written {
        out!("{}  {rows} rows", path.display());
    }
    Ok(())
}

fn clock(log: &Log, period_ns: i64) -> Result<Vec<i64>> {
    let span = log
        .streams
        .iter()
        .filter_map(|s| s.timing.span_ns)
        .fold(None, |acc: Option<(i64, i64)>, (a, b)| {
            Some(acc.map_or((a, b), |(x, y)| (x.min(a), y.max(b))))
        });
    if let Some((a, b)) = span {
        let rows = (b.saturating_sub(a) / period_ns) as usize;
        if rows > MAX_ALIGNED_ROWS {
            bail!(
                "aligned.parquet would have {rows} rows (log spans {:.0} s); lower --rate",
                (b - a) as f64 * 1e-9
            );
        }
    }
    Ok(tables::aligned_clock(&log.streams, period_ns))
}

/// File stem of each stream: the topic without its leading slash, `/` as `.`, made unique.
fn file_stems(log: &Log) -> Vec<String> {
    let mut stems: Vec<String> = Vec::new();
    for s in &log.streams {
        let base = tables::topic_prefix(&s.topic)
            .trim_end_matches('_')
            .to_string();
        let mut stem = base.clone();
        let mut n = 2;
        while stems.contains(&stem) || stem == "aligned" {
            stem = format!("{base}_{n}");
            n += 1;
        }
        stems.push(stem);
    }
    stems
}

/// Writes every file under its staged name (topics in parallel with the aligned table), then
/// renames them all; on any failure nothing is renamed and the staged files are removed.
fn write_all(log: &Log, clock: &[i64], dir: &Path) -> Result<Vec<(PathBuf, usize)>> {
    use rayon::prelude::*;
    let mut staging = Staging::new();
    let mut jobs = Vec::new();
    for (stream, stem) in log.streams.iter().zip(file_stems(log)) {
        let path = dir.join(format!("{stem}.parquet"));
        let file = staging
            .create(&path)
            .with_context(|| OutputFailed { path: path.clone() })?;
        jobs.push((stream, path, file));
    }
    let aligned_path = dir.join("aligned.parquet");
    let aligned_file = staging
        .create(&aligned_path)
        .with_context(|| OutputFailed {
            path: aligned_path.clone(),
        })?;

    let (topics, aligned) = rayon::join(
        || {
            jobs.into_par_iter()
                .map(|(stream, path, file)| {
                    write_stream(stream, file)
                        .with_context(|| OutputFailed { path: path.clone() })?;
                    Ok((path, stream.samples.len()))
                })
                .collect::<Result<Vec<_>>>()
        },
        || {
            write_aligned(log, clock, aligned_file).with_context(|| OutputFailed {
                path: aligned_path.clone(),
            })
        },
    );
    let mut written = topics?;
    aligned?;
    written.push((aligned_path, clock.len()));
    staging.commit().with_context(|| OutputFailed {
        path: dir.to_path_buf(),
    })?;
    Ok(written)
}

fn write_stream(stream: &Stream, file: std::fs::File) -> Result<()> {
    let n = stream.samples.len();
    let mut start = 0;
    let mut next = || {
        (start < n).then(|| {
            let end = (start + ROWS_PER_BATCH).min(n);
            let b = tables::stream_batch(stream, start..end);
            start = end;
            b
        })
    };
    let first = next().unwrap_or_else(|| tables::stream_batch(stream, 0..0))?;
    write_batches(file, first, next)?;
    Ok(())
}

fn write_aligned(log: &Log, clock: &[i64], file: std::fs::File) -> Result<()> {
    let mut chunks = clock.chunks(ROWS_PER_BATCH);
    let first = tables::aligned_batch(&log.streams, chunks.next().unwrap_or(&[]))?;
    write_batches(file, first, || {
        chunks
            .next()
            .map(|c| tables::aligned_batch(&log.streams, c))
    })?;
    Ok(())
}
