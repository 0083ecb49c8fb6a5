//! `hindsight bench`: throughput of ingest on a generated log.

use anyhow::{Context, Result};
use hindsight::ingest::{self, IngestOptions};
use hindsight::sim::{synthetic, writer};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Measure ingest throughput on a generated log, one thread; or, with --reconstruct, the
/// reconstruction (forward filter and smoother) on a simulated mission.
///
/// The log is a synthetic survey (IMU 100 Hz, magnetometer 50 Hz, DVL 5 Hz, EM log, depth
/// and altimeter 2 Hz, RPM 1 Hz, fins, attitude and truth 10 Hz, the acoustic messages 1 Hz).
///
/// Stages, each timed over --repeat runs (median printed):
///   scan          container only: read, decompress chunks, walk records
///   ingest        scan + JSON decode + validation + sort + statistics, on one thread
///   ingest, N threads  the same with the messages decoded on other threads while the
///                 reader reads and decompresses (what every command does), and its speed-up
///   merge         the time-ordered k-way merge over all topics of the ingested log
///   ingest+merge  the sum of the two medians: a log from file to one event stream
///
/// With --log FILE: that log (any form hindsight reads) instead of a generated one.
///
/// With --cdr: the same log's streams of standard ROS 2 types (IMU, magnetometer, DVL as
/// TwistWithCovarianceStamped, depth as FluidPressure, altimeter as Range, attitude as
/// QuaternionStamped) written as a ROS 2 recording in CDR, REP-103 frames, and its ingest
/// timed the same way (schema-driven CDR decoding, frame conversion, validation).
/// With --as: the same streams in another container or encoding: `cdr` (as --cdr), `ros1`
/// (ROS 1 messages in MCAP, as `mcap convert` writes a bag), `bag` (a ROS 1 bag, lz4 chunks),
/// `db3` (a ROS 2 sqlite3 bag as Humble writes it).
///
/// With --reconstruct: the scenario (default long-dive, 5.5 h; seed 0) is simulated, then
/// ingest, forward filter and smoother are timed (medians, and their ratio to ingest), and
/// the `reconstruct` command is run once for its wall time and peak memory. With --report besides: the
/// `reconstruct` command itself is run on that log --repeat times (with the scenario's
/// configuration) and the time of its report.html and PNGs is set against the command's
/// (medians). With --default-run instead: the whole default command (no configuration) is
/// run --repeat times and each of its stages (summary.json's run_time_s) set against its own
/// ingest: `hindsight bench --reconstruct --default-run --scenario long-dive-dynamic`.
///
/// With --attitude: every attitude method on a 1-hour 100 Hz AHRS log (pool-circle flown
/// for an hour), each on one thread and all in parallel (medians).
///
/// With --identify: seed 004's two zig-zag logs identified jointly, both stages (medians).
///
/// With --simulate: a scenario (default long-dive-dynamic: seed 000's 5.5 h mission flown
/// by the 6-DOF model, RK4 at 100 Hz) simulated and written to a file on one thread, its
/// dynamics alone, and the kinematic long-dive for the ratio (medians).
/// The forms a log can be benchmarked in besides json in MCAP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LogForm {
    /// ROS 2 messages (CDR) in MCAP.
    Cdr,
    /// ROS 1 messages in MCAP.
    Ros1,
    /// A ROS 1 bag (format 2.0), lz4 chunks.
    Bag,
    /// A ROS 2 bag in sqlite3 storage.
    Db3,
}

#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct BenchArgs {
    /// Length of the generated log, minutes.
    #[arg(long, default_value_t = 60.0)]
    pub minutes: f64,

    /// Runs per stage; medians are reported.
    #[arg(long, default_value_t = 5)]
    pub repeat: usize,

    /// Seed of the generated log.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Keep the generated log at this path (otherwise a temporary file is removed).
    #[arg(long, value_name = "FILE")]
    pub keep: Option<PathBuf>,

    /// Benchmark the ingest of the log written as a ROS 2 recording (CDR) instead of JSON
    /// (the same as --as cdr).
    #[arg(long, conflicts_with = "format")]
    pub cdr: bool,

    /// Benchmark the ingest of the log written in another form than JSON in MCAP.
    #[arg(long = "as", value_name = "FORM", value_enum)]
    pub format: Option<LogForm>,

    /// Benchmark the ingest of this log (any form hindsight reads) instead of a generated one.
    #[arg(long, value_name = "LOG", conflicts_with_all = ["format", "cdr"])]
    pub log: Option<PathBuf>,

    /// Benchmark the reconstruction on a simulated scenario instead of ingest alone.
    #[arg(long)]
    pub reconstruct: bool,

    /// With --reconstruct: also time report.html and its PNGs within `reconstruct` runs.
    #[arg(long, requires = "reconstruct")]
    pub report: bool,

    /// With --reconstruct: time the whole default command (`hindsight reconstruct LOG --out
    /// DIR`, no configuration: plan, alignment, tuning, passes, outputs, report), each stage
    /// as its ratio to the command's own ingest (medians of --repeat runs).
    #[arg(long, requires = "reconstruct", conflicts_with = "report")]
    pub default_run: bool,

    /// Benchmark every attitude method on a 1-hour 100 Hz AHRS log (simulated) instead.
    #[arg(long, conflicts_with = "reconstruct")]
    pub attitude: bool,

    /// Benchmark the identification of seed 004's two zig-zags (both stages) instead.
    #[arg(long, conflicts_with_all = ["reconstruct", "attitude"])]
    pub identify: bool,

    /// Benchmark the simulator (and writer) on a scenario instead.
    #[arg(long, conflicts_with_all = ["reconstruct", "attitude", "identify"])]
    pub simulate: bool,

    /// Built-in scenario of --reconstruct (default long-dive) or --simulate (default
    /// long-dive-dynamic).
    #[arg(long)]
    pub scenario: Option<String>,
}

pub fn run(args: BenchArgs) -> Result<()> {
    anyhow::ensure!(
        args.minutes > 0.0 && args.minutes <= 24.0 * 60.0,
        "--minutes must be in (0, 1440]"
    );
    anyhow::ensure!(args.repeat >= 1, "--repeat must be at least 1");
    if args.identify {
        return super::bench_identify::run(args.repeat);
    }
    if args.attitude {
        return super::bench_attitude::run(args.repeat, args.keep.as_deref());
    }
    if args.reconstruct {
        let scenario = args.scenario.as_deref().unwrap_or("long-dive");
        let mode = if args.default_run {
            super::bench_reconstruct::Mode::DefaultRun
        } else if args.report {
            super::bench_reconstruct::Mode::WithReport
        } else {
            super::bench_reconstruct::Mode::Stages
        };
        return super::bench_reconstruct::run(scenario, args.repeat, args.keep.as_deref(), mode);
    }
    if args.simulate {
        let scenario = args.scenario.as_deref().unwrap_or("long-dive-dynamic");
        return super::bench_simulate::run(scenario, args.repeat, args.keep.as_deref());
    }
    anyhow::ensure!(
        args.scenario.is_none(),
        "--scenario goes with --reconstruct or --simulate"
    );
    if let Some(log) = &args.log {
        return measure(log, args.repeat);
    }
    eprintln!("generating a {} min log ...", args.minutes);
    let spec = synthetic::SurveySpec {
        duration_s: args.minutes * 60.0,
        seed: args.seed,
        ..Default::default()
    };
    let form = if args.cdr {
        Some(LogForm::Cdr)
    } else {
        args.format
    };
    if let Some(form) = form {
        return with_log_file(
            None,
            |w| Ok(synthetic::write_survey(w, &spec)?),
            |json| {
                let log = ingest::read_log(json, &IngestOptions::default())?;
                bench_as(&log, form, args.keep.as_deref(), args.repeat)
            },
        );
    }
    with_log_file(
        args.keep.as_deref(),
        |w| Ok(synthetic::write_survey(w, &spec)?),
        |path| measure(path, args.repeat),
    )
}

/// Writes a log with `write` to `keep` (or a temporary file, removed afterwards) and runs
/// `measure` on it.
/// Writes `log` in `form` (at `keep`, or a temporary path removed after) and times its ingest.
fn bench_as(
    log: &ingest::Log,
    form: LogForm,
    keep: Option<&std::path::Path>,
    repeat: usize,
) -> Result<()> {
    use hindsight::ingest::ros::{map::Convention, msg::Dialect};
    use hindsight::sim::{bag, ros};
    let settings = Default::default();
    let convention = Convention::Rep103;
    let dialect = match form {
        LogForm::Cdr => Dialect::Ros2,
        LogForm::Ros1 => Dialect::Ros1,
        LogForm::Bag | LogForm::Db3 => {
            let path = keep.map(|p| p.to_path_buf()).unwrap_or_else(|| {
                let ext = if form == LogForm::Bag {
                    "bag"
                } else {
                    "db3-bag"
                };
                std::env::temp_dir().join(format!("hindsight-bench-{}.{ext}", std::process::id()))
            });
            match form {
                LogForm::Bag => bag::write_ros1_bag(log, convention, &settings, &path)?,
                _ => bag::write_sqlite_bag(log, convention, &settings, &path)?,
            };
            let result = measure(&path, repeat);
            if keep.is_none() {
                let _ = std::fs::remove_file(&path).or_else(|_| std::fs::remove_dir_all(&path));
            }
            return result;
        }
    };
    with_log_file(
        keep,
        |w| {
            ros::write_standard_streams(log, dialect, convention, &settings, w)?;
            Ok(())
        },
        |path| measure(path, repeat),
    )
}

pub(super) fn with_log_file(
    keep: Option<&std::path::Path>,
    write: impl FnOnce(&mut writer::LogWriter<std::io::BufWriter<std::fs::File>>) -> Result<()>,
    measure: impl FnOnce(&std::path::Path) -> Result<()>,
) -> Result<()> {
    let path = keep.map(|p| p.to_path_buf()).unwrap_or_else(|| {
        static FILES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = FILES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        std::env::temp_dir().join(format!("hindsight-bench-{}-{n}.mcap", std::process::id()))
    });
    let file =
        std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = writer::LogWriter::new(
        std::io::BufWriter::new(file),
        writer::WriterOptions::default(),
    )?;
    write(&mut w)?;
    w.finish()?;
    let result = measure(&path);
    if keep.is_none() {
        let _ = std::fs::remove_file(&path);
    }
    result
}

/// Bytes of a file, or of the files in a folder (a sqlite3 bag).
fn disk_bytes(path: &std::path::Path) -> u64 {
    match std::fs::read_dir(path) {
        Ok(entries) => entries
            .filter_map(|e| e.ok()?.metadata().ok())
            .map(|m| m.len())
            .sum(),
        Err(_) => std::fs::metadata(path).map_or(0, |m| m.len()),
    }
}

fn measure(path: &std::path::Path, repeat: usize) -> Result<()> {
    let file_bytes = disk_bytes(path) as f64;
    let totals = ingest::scan_log(path)?;
    println!(
        "log: {}  {:.1} MB on disk, {} messages, {:.1} MB of payload",
        path.display(),
        file_bytes / 1e6,
        totals.messages,
        totals.payload_bytes as f64 / 1e6
    );
    let opts = IngestOptions {
        decode_threads: 1,
        ..IngestOptions::default()
    };
    let scan = time(repeat, || Ok(ingest::scan_log(path)?.messages))?;
    let ingest_only = time(
        repeat,
        || Ok(ingest::read_log(path, &opts)?.message_count()),
    )?;
    let parallel = IngestOptions::default();
    let threads = parallel
        .decode_threads
        .min(std::thread::available_parallelism().map_or(1, usize::from));
    let ingest_parallel = time(repeat, || {
        Ok(ingest::read_log(path, &parallel)?.message_count())
    })?;
    let log = ingest::read_log(path, &opts)?;
    let merge = time(repeat, || {
        let events = hindsight::align::merged(&log.streams);
        Ok(events.fold(0u64, |acc, e| acc ^ e.stamp_ns as u64))
    })?;
    let total = ingest_only + merge;
    let n = totals.messages as f64;
    println!(
        "{:<14} {:>10} {:>14} {:>12} {:>12}",
        "stage", "median s", "messages/s", "file MB/s", "payload MB/s"
    );
    for (name, d) in [
        ("scan", scan),
        ("ingest", ingest_only),
        ("merge", merge),
        ("ingest+merge", total),
    ] {
        let s = d.as_secs_f64();
        println!(
            "{name:<14} {s:>10.3} {:>14.0} {:>12.1} {:>12.1}",
            n / s,
            file_bytes / s / 1e6,
            totals.payload_bytes as f64 / s / 1e6
        );
    }
    let share = |d: Duration| 100.0 * d.as_secs_f64() / total.as_secs_f64();
    println!(
        "time shares of ingest+merge: container {:.0} %, decode+validate+sort {:.0} %, merge {:.0} %",
        share(scan),
        share(ingest_only.saturating_sub(scan)),
        share(merge)
    );
    println!(
        "ingest with {threads} decoding thread(s) beside the reader (the default): {:.3} s, \
         {:.2}x the speed of one thread (medians of {repeat}; {} cores here)",
        ingest_parallel.as_secs_f64(),
        ingest_only.as_secs_f64() / ingest_parallel.as_secs_f64(),
        std::thread::available_parallelism().map_or(1, usize::from)
    );
    Ok(())
}

/// Median wall time of `repeat` runs of `f`.
fn time(repeat: usize, mut f: impl FnMut() -> Result<u64>) -> Result<Duration> {
    let mut times = Vec::with_capacity(repeat);
    for _ in 0..repeat {
        let t = Instant::now();
        std::hint::black_box(f()?);
        times.push(t.elapsed());
    }
    times.sort();
    Ok(times[times.len() / 2])
}

/// Median wall time of `repeat` runs of `f` (at least one), seconds.
pub(super) fn median_seconds(repeat: usize, f: &dyn Fn()) -> f64 {
    let mut times: Vec<f64> = (0..repeat.max(1))
        .map(|_| {
            let t = std::time::Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}
