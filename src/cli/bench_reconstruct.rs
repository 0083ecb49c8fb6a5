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

/// Simulates `scenario` (seed 0) to a temporary file, then times ingest, the forward filter
/// and the smoother over `repeat` runs each (medians), and the peak memory of one whole
/// reconstruction (ingest, forward, smoother).
pub fn run(scenario_name: &str, repeat: usize, keep: Option<&Path>, report: bool) -> Result<()> {
    let scenario =
        Scenario::built_in(scenario_name).with_context(|| format!("scenario `{scenario_name}`"))?;
    eprintln!("simulating `{scenario_name}` (seed 0) ...");
    super::bench::with_log_file(
        keep,
        |w| Ok(hindsight::sim::run::run(&scenario, 0, w).map(|_| ())?),
        |path| {
            measure(path, repeat, scenario_name)?;
            if report {
                report_cost(path, repeat, scenario_name)?;
            }
            Ok(())
        },
    )
}

/// Runs `hindsight reconstruct` (this executable, `--quiet`) on the log `repeat` times and
/// prints the medians of the command's wall time and of its report's share (report.html and
/// the PNGs, as summary.json's `run_time_s.report` gives it).
fn report_cost(log: &Path, repeat: usize, scenario: &str) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("hindsight-bench-report-{}", std::process::id()));
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
    let exe = std::env::current_exe().context("locating this executable")?;
    let out = dir.join("out");
    let (mut wall, mut report, mut html_mb) = (Vec::new(), Vec::new(), 0.0);
    for _ in 0..repeat {
        let t = Instant::now();
        let status = std::process::Command::new(&exe)
            .arg("reconstruct")
            .arg(log)
            .arg("--out")
            .arg(&out)
            .arg("--config")
            .arg(&config)
            .arg("--quiet")
            .status()?;
        wall.push(t.elapsed().as_secs_f64());
        anyhow::ensure!(status.success(), "reconstruct failed on the bench log");
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

/// Peak resident memory of this process since the last reset, bytes (Linux; `None`
/// elsewhere).
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Resets the peak-memory mark (Linux 4.0 and later).
fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn measure(path: &Path, repeat: usize, scenario: &str) -> Result<()> {
    let config = if scenario == "long-dive" {
        Config::from_toml(LONG_DIVE_CONFIG)?
    } else {
        Config::default()
    };
    let opts = IngestOptions::default();
    let file_mb = std::fs::metadata(path)?.len() as f64 / 1e6;

    // One whole reconstruction first, for the peak memory.
    let reset = reset_peak_rss();
    let (ingest_once, forward_once, smoother_once, epochs) = {
        let t = Instant::now();
        let log = ingest::read_log(path, &opts)?;
        let ingest = t.elapsed();
        let mission = log.mission()?;
        let streams = Streams::of(&log);
        let pass = recon::forward(&streams, &mission, &config)?;
        let depth_used = !streams.depth.is_empty();
        drop(log);
        let epochs = pass.run.records.len();
        let r = recon::finish(pass, &config, depth_used)?;
        (ingest, r.timing.forward, r.timing.smoother, epochs)
    };
    let peak = peak_rss_bytes().filter(|_| reset);

    let mut ingest_t = vec![ingest_once];
    let mut forward_t = vec![forward_once];
    let mut smoother_t = vec![smoother_once];
    let mut tune_t = Vec::new();
    for k in 0..repeat {
        let t = Instant::now();
        let log = ingest::read_log(path, &opts)?;
        if k > 0 {
            ingest_t.push(t.elapsed());
        }
        let mission = log.mission()?;
        let streams = Streams::of(&log);
        // Self-tuning as `reconstruct` runs it by default (its candidates in parallel).
        let t = Instant::now();
        let (tuned, _) = recon::tune::tune(&streams, &mission, &config);
        tune_t.push(t.elapsed());
        if k > 0 {
            let r = recon::reconstruct(&streams, &mission, &tuned)?;
            forward_t.push(r.timing.forward);
            smoother_t.push(r.timing.smoother);
        }
    }
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
        "log: {scenario} (seed 0), {file_mb:.1} MB; {epochs} filter epochs; medians of {repeat} runs, one thread"
    );
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
            "peak memory of one reconstruction (ingest, forward, smoother): {:.0} MB",
            bytes as f64 / 1e6
        ),
        None => println!("peak memory: not available on this system"),
    }
    Ok(())
}
