//! Real recordings guard every change: the default run (no configuration) on the real pool
//! runs of a MEMS AUV in `../shared/benchmarks/sonia-pool` (AGPL-3.0: read from there, never
//! copied into the project), checked without a reference (`recon::sanity`):
//! - the share of DVL readings the gate rejects: at most 10 %;
//! - the smoothed track's length within 15 % of the DVL's own path;
//! - out of the water, no speed above 2 m/s.
//!
//! Each log's figures are also held against `tests/fixtures/real/pool_figures.json`, the
//! figures of the last change that landed: a change that makes a real log worse fails here,
//! whatever the simulated tests say. A change that improves one updates that file (the test
//! prints the table to paste into `docs/results/real-logs.md` and the new figures).
//!
//! The folder is found as `common::shared_dir` finds the shared material; without it the
//! test says clearly that it skipped (and fails when `HINDSIGHT_REQUIRE_SHARED` is set, as
//! CI sets it).
//!
//! `cargo test --release --test all real_logs:: -- --nocapture`

use crate::common;
use hindsight::ingest::{read_log, IngestOptions};
use hindsight::recon::config::Config;
use hindsight::recon::{sanity, Streams};
use std::path::PathBuf;

/// The pool runs, and whether each is lifted out of the water.
const POOL_RUNS: [(&str, bool); 3] = [
    ("TEST_PISCINE_20160123.mcap", false),
    ("TEST_PISCINE_20160305_CIRCLE.mcap", false),
    ("TEST_PISCINE_20160305_OUTOFWATER.mcap", true),
];

/// How much worse than the landed figures a figure may come out before the check fails:
/// one more rejected reading in a hundred, 2 % of the track's ratio, 5 % of the top speed.
const WORSE_REJECTED: f64 = 0.01;
const WORSE_RATIO: f64 = 0.02;
const WORSE_SPEED: f64 = 0.05;

fn pool_dir() -> Option<PathBuf> {
    common::shared_dir_if_any("benchmarks/sonia-pool", POOL_RUNS[0].0)
}

/// The landed figures of one log: rejected share, track over DVL path, top speed.
fn landed(name: &str) -> (f64, f64, f64) {
    let text = std::fs::read_to_string(common::repo_path("tests/fixtures/real/pool_figures.json"))
        .unwrap();
    let all: serde_json::Value = serde_json::from_str(&text).unwrap();
    let f = &all[name];
    let get = |k: &str| {
        f[k].as_f64()
            .unwrap_or_else(|| panic!("{name}: {k} missing"))
    };
    (
        get("dvl_rejected_share"),
        get("track_over_dvl_path"),
        get("max_speed_m_s"),
    )
}

#[test]
fn the_real_pool_runs_hold_the_bars_and_get_no_worse() {
    let Some(dir) = pool_dir() else {
        common::skip_unless_required(
            "HINDSIGHT_REQUIRE_SHARED",
            "../shared/benchmarks/sonia-pool is missing",
            "SKIPPED real_logs: ../shared/benchmarks/sonia-pool not found (set \
             HINDSIGHT_SHARED_DIR); the real pool runs were not checked",
        );
        return;
    };
    let mut failures = Vec::new();
    println!("| log | IMU graded | DVL rejected | track / DVL path | top speed m/s |");
    println!("|---|---|---|---|---|");
    for (name, out_of_water) in POOL_RUNS {
        let log = read_log(&dir.join(name), &IngestOptions::default()).unwrap();
        let streams = Streams::of(&log);
        // As `hindsight reconstruct LOG` runs it: the library's one entry, no settings.
        let job = hindsight::Job::new(&dir.join(name), Config::default());
        let outcome = hindsight::reconstruct(&job, hindsight::Observer::default()).unwrap();
        let s = sanity::of(&outcome.solved, streams.dvl).unwrap();
        let ratio = s.track_over_dvl_path().unwrap();
        let rejected = s.dvl_rejected_share();
        let model = outcome
            .summary
            .tuning
            .as_ref()
            .map_or("-".to_string(), |t| t.imu.model.clone());
        println!(
            "| {name} | {model} | {:.1} % ({} of {}) | {ratio:.3} ({:.1} / {:.1} m) | {:.2} |",
            100.0 * rejected,
            s.dvl_rejected,
            s.dvl_readings,
            s.track_length_m,
            s.dvl_path_m,
            s.max_speed_m_s
        );
        println!(
            "  \"{}\": {{ \"dvl_rejected_share\": {rejected:.4}, \"track_over_dvl_path\": \
             {ratio:.4}, \"max_speed_m_s\": {:.3} }}",
            name.trim_end_matches(".mcap"),
            s.max_speed_m_s
        );
        let (was_rejected, was_ratio, was_speed) = landed(name.trim_end_matches(".mcap"));
        if rejected > was_rejected + WORSE_REJECTED {
            failures.push(format!(
                "{name}: {:.1} % of the DVL rejected, {:.1} % when it landed",
                100.0 * rejected,
                100.0 * was_rejected
            ));
        }
        if (ratio - 1.0).abs() > (was_ratio - 1.0).abs() + WORSE_RATIO {
            failures.push(format!(
                "{name}: track {ratio:.3} of the DVL's path, {was_ratio:.3} when it landed"
            ));
        }
        if s.max_speed_m_s > was_speed * (1.0 + WORSE_SPEED) {
            failures.push(format!(
                "{name}: top speed {:.2} m/s, {was_speed:.2} when it landed",
                s.max_speed_m_s
            ));
        }
        // The bars. The out-of-water run's DVL path counts only its 37 s in the
        // water, so its track is not the bar's subject (docs/results/real-logs.md).
        if rejected > 0.10 {
            failures.push(format!(
                "{name}: {:.1} % rejected (bar 10 %)",
                100.0 * rejected
            ));
        }
        if !out_of_water && (ratio - 1.0).abs() > 0.15 {
            failures.push(format!(
                "{name}: track {ratio:.3} of the DVL path (bar 15 %)"
            ));
        }
        if out_of_water && s.max_speed_m_s > 2.0 {
            failures.push(format!(
                "{name}: {:.2} m/s out of the water (bar 2 m/s)",
                s.max_speed_m_s
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
