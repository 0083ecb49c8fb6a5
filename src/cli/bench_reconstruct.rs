//! `hindsight bench --reconstruct`: the reconstruction's speed and memory on a simulated
//! mission, against plain ingest of the same log.

use anyhow::{Context, Result};
use hindsight::ingest::{self, IngestOptions};
use hindsight::recon::{self, config::Config, Streams};
use hindsight::sim::scenario::Scenario;
use std::path::Path;
use std::time::{Duration, Instant};

/// The sensors of seed 000's Table 2, which the `long-dive` scenario simulates.
const LONG_DIVE_CONFIG: &str = include_str!("../../configs/long-dive.toml");

/// What the bench measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Ingest, forward filter and smoother in this process; the command once for its memory.
    Stages,
    /// [`Mode::Stages`], and the command's report.html share.
    WithReport,
    /// The whole default command, each stage against its ingest.
    DefaultRun,
}

/// Simulates `scenario` (seed 0) to a temporary file, then measures as `mode` says.
pub fn run(scenario_name: &str, repeat: usize, keep: Option<&Path>, mode: Mode) -> Result<()> {
    let scenario =
        Scenario::built_in(scenario_name).with_context(|| format!("scenario `{scenario_name}`"))?;
    eprintln!("simulating `{scenario_name}` (seed 0) ...");
    super::bench::with_log_file(
        keep,
        |w| Ok(hindsight::sim::run::run(&scenario, 0, w).map(|_| ())?),
        |path| match mode {
            Mode::DefaultRun => default_run_cost(path, repeat, scenario_name),
            Mode::Stages => measure(path, repeat, scenario_name),
            Mode::WithReport => {
                measure(path, repeat, scenario_name)?;
                report_cost(path, repeat, scenario_name)
            }
        },
    )
}

/// Runs `hindsight reconstruct` (this executable, `--quiet`) on the log `repeat` times and
/// prints the medians of the command's wall time and of its report's share (report.html and
/// the PNGs, as summary.json's `run_time_s.report` gives it).
fn report_cost(log: &Path, repeat: usize, scenario: &str) -> Result<()> {
    let (dir, config) = scratch(scenario, "report")?;
    let out = dir.join("out");
    let (mut wall, mut report, mut html_mb) = (Vec::new(), Vec::new(), 0.0);
    for _ in 0..repeat {
        wall.push(run_command(log, Some(&config), &out)?.0);
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json"))?)?;
        report.push(summary["run_time_s"]["report"].as_f64().unwrap_or(f64::NAN));
        html_mb = std::fs::metadata(out.join("report.html"))?.len() as f64 / 1e6;
    }
    let _ = std::fs::remove_dir_all(&dir);
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (wall, report) = (median(&mut wall), median(&mut report));
    println!(
        "reconstruct command {wall:.2} s, of which report.html and its PNGs {report:.2} s: \
         {:.1} % of the run, {:.1} % on top of the run without them (medians of {repeat}); \
         report.html {html_mb:.2} MB",
        100.0 * report / wall,
        100.0 * report / (wall - report)
    );
    Ok(())
}

/// The stages of summary.json's `run_time_s`, as the bench names them.
const STAGES: [(&str, &str); 10] = [
    ("ingest", "ingest"),
    ("plan", "plan"),
    ("magnetometer", "magnetometer"),
    ("alignment", "align"),
    ("self-tuning", "tune"),
    ("forward filter", "forward"),
    ("clock search", "clock_search"),
    ("smoother", "smoother"),
    ("outputs", "outputs"),
    ("  of which report", "report"),
];

/// Runs the default command (no configuration) `repeat` times and prints each stage's median
/// and its ratio to the median ingest, then the whole command's.
fn default_run_cost(log: &Path, repeat: usize, scenario: &str) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("hindsight-bench-default-{}", std::process::id()));
    let out = dir.join("out");
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); STAGES.len() + 1];
    for _ in 0..repeat {
        let wall = run_command(log, None, &out)?.0;
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json"))?)?;
        for (k, (_, key)) in STAGES.iter().enumerate() {
            times[k].push(summary["run_time_s"][key].as_f64().unwrap_or(f64::NAN));
        }
        times[STAGES.len()].push(wall);
    }
    let _ = std::fs::remove_dir_all(&dir);
    let medians: Vec<f64> = times
        .iter_mut()
        .map(|v| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        })
        .collect();
    let ingest = medians[0];
    println!(
        "log: {scenario} (seed 0); `hindsight reconstruct LOG --out DIR` with no configuration, \
         medians of {repeat} runs"
    );
    println!(
        "{:<22} {:>9} {:>16}",
        "stage", "median s", "ratio to ingest"
    );
    let names = STAGES.iter().map(|(n, _)| *n).chain(["whole command"]);
    for (name, s) in names.zip(&medians) {
        println!("{name:<22} {s:>9.2} {:>16.2}", s / ingest);
    }
    Ok(())
}

/// Runs `hindsight reconstruct` (this executable, `--quiet`, self-tuning as by default) on
/// `log` into `out`, with `config` when given: its wall time, s, and its peak resident
/// memory, bytes (`None` off Unix).
fn run_command(log: &Path, config: Option<&Path>, out: &Path) -> Result<(f64, Option<u64>)> {
    let exe = std::env::current_exe().context("locating this executable")?;
    let t = Instant::now();
    let mut command = std::process::Command::new(&exe);
    command.arg("reconstruct").arg(log).arg("--out").arg(out);
    if let Some(config) = config {
        command.arg("--config").arg(config);
    }
    let status = command.arg("--quiet").status()?;
    let wall = t.elapsed().as_secs_f64();
    anyhow::ensure!(status.success(), "reconstruct failed on the bench log");
    Ok((wall, children_peak_rss_bytes()))
}

/// The largest peak resident memory of the child processes waited for so far.
#[cfg(unix)]
fn children_peak_rss_bytes() -> Option<u64> {
    // SAFETY: getrusage writes one `rusage` into the zeroed struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) } == 0;
    // Linux reports kilobytes, macOS bytes.
    let unit = if cfg!(target_os = "macos") { 1 } else { 1024 };
    ok.then(|| u64::try_from(usage.ru_maxrss).ok().map(|v| v * unit))
        .flatten()
}

#[cfg(not(unix))]
fn children_peak_rss_bytes() -> Option<u64> {
    None
}

/// A scratch directory holding the bench's configuration file.
fn scratch(scenario: &str, name: &str) -> Result<(std::path::PathBuf, std::path::PathBuf)> {
    let dir = std::env::temp_dir().join(format!("hindsight-bench-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let config = dir.join("config.toml");
    std::fs::write(
        &config,
        if scenario == "long-dive" {
            LONG_DIVE_CONFIG
        } else {
            ""
        },
    )?;
    Ok((dir, config))
}

fn measure(path: &Path, repeat: usize, scenario: &str) -> Result<()> {
    let config = if scenario == "long-dive" {
        hindsight::config::load(LONG_DIVE_CONFIG)?
    } else {
        Config::default()
    };
    // As `reconstruct` reads a log.
    let opts = IngestOptions {
        keep_log_times: false,
        ..IngestOptions::default()
    };
    let file_mb = std::fs::metadata(path)?.len() as f64 / 1e6;

    let mut ingest_t = Vec::new();
    let mut forward_t = Vec::new();
    let mut smoother_t = Vec::new();
    let mut tune_t = Vec::new();
    let (mut epochs, mut direct) = (0, false);
    for _ in 0..repeat {
        let t = Instant::now();
        let log = ingest::read_log(path, &opts)?;
        ingest_t.push(t.elapsed());
        let mission = log.mission()?;
        let streams = Streams::of(&log);
        // Self-tuning as `reconstruct` runs it by default (its candidates in parallel).
        let t = Instant::now();
        let (tuned, _) = recon::tune::tune(&streams, &mission, &config);
        tune_t.push(t.elapsed());
        let r = recon::run_configured(&streams, &mission, &tuned)?;
        forward_t.push(r.timing.forward);
        smoother_t.push(r.timing.smoother);
        epochs = r.forward.len();
        direct = r.smoothed.is_direct();
    }
    // The command a user runs, once, for its peak memory (and its wall time).
    let (dir, config_path) = scratch(scenario, "peak")?;
    let command = run_command(path, Some(&config_path), &dir.join("out"));
    let _ = std::fs::remove_dir_all(&dir);
    let (command_s, peak) = command?;
    let median = |v: &mut Vec<Duration>| {
        v.sort();
        v[v.len() / 2].as_secs_f64()
    };
    let (ingest, forward, smoother, tuning) = (
        median(&mut ingest_t),
        median(&mut forward_t),
        median(&mut smoother_t),
        median(&mut tune_t),
    );
    println!(
        "log: {scenario} (seed 0), {file_mb:.1} MB; {epochs} filter epochs; medians of {repeat} runs; forward filter on one thread (its temporary file written from a second), smoother's links (predicted covariances and gains) on a second thread beside its recursion, ingest decoding on its threads; temporary files {}"
    , if direct { "past the system's cache (O_DIRECT)" } else { "through the system's cache" });
    println!(
        "{:<22} {:>9} {:>16}",
        "stage", "median s", "ratio to ingest"
    );
    for (name, s) in [
        ("ingest", ingest),
        ("forward filter", forward),
        ("smoother", smoother),
        ("forward + smoother", forward + smoother),
        ("ingest + both", ingest + forward + smoother),
    ] {
        println!("{name:<22} {s:>9.2} {:>16.2}", s / ingest);
    }
    let untuned = ingest + forward + smoother;
    println!(
        "self-tuning {tuning:.2} s ({} threads): a reconstruction with it takes {:.2}x the time \
         of one without ({:.2} s against {untuned:.2} s)",
        rayon::current_num_threads(),
        (untuned + tuning) / untuned,
        untuned + tuning
    );
    match peak {
        Some(bytes) => println!(
            "`hindsight reconstruct` on this log: {command_s:.1} s, peak memory {:.0} MB \
             (self-tuning, forward, smoother and every output)",
            bytes as f64 / 1e6
        ),
        None => println!(
            "`hindsight reconstruct` on this log: {command_s:.1} s; peak memory not available \
             on this system"
        ),
    }
    Ok(())
}
