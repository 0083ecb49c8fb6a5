//! The long survey: `scenarios/survey-27h.toml` (the `survey` sensors: tactical IMU,
//! DVL with 0.2 % scale and 2 mm/s bias, magnetometer; 172 lanes, GNSS at both ends only),
//! reconstructed as a user would, with no configuration. The reported uncertainty must tell
//! the truth over the whole day: the horizontal NEES inside its 95 % bounds for at least
//! 70 % of the epochs, forward and smoothed (scored against the log's `/truth`).
//!
//! The memory bar on the same run: the `reconstruct` command's peak resident memory
//! (self-tuning, forward, smoother, every output) at most 1 GB.
//!
//! Too long for CI (a 1.4 GB log; about 4 minutes on 2 cores):
//! `cargo test --release --test all survey_27h:: -- --ignored --nocapture`

use crate::common;
use serde_json::Value;

#[test]
#[ignore = "27 h mission: about 4 minutes; run before changing the long-mission paths (docs/results/speed.md)"]
fn a_27_hour_survey_reports_honest_uncertainty() {
    let dir = common::scratch_dir("survey-27h");
    let log = dir.join("survey-27h.mcap");
    let out = dir.join("run");
    let log_s = log.to_str().unwrap();
    common::simulate_to(&log, "survey-27h", 1);
    let run = common::hindsight(&["reconstruct", log_s, "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", common::stderr(&run));
    eprintln!("{}", String::from_utf8_lossy(&run.stdout));
    // The largest child so far is the reconstruction (the simulator holds one lane's state).
    let peak_mb = children_peak_rss_bytes() as f64 / 1e6;
    eprintln!("reconstruct: peak resident memory {peak_mb:.0} MB");
    assert!(peak_mb <= 1000.0, "peak memory {peak_mb:.0} MB > 1 GB");

    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let truth = &summary["truth"];
    for solution in ["forward", "smoothed"] {
        let inside = truth[solution]["nees_horizontal_inside_95"]
            .as_f64()
            .unwrap();
        let rms = truth[solution]["horizontal_rms_m"].as_f64().unwrap();
        eprintln!(
            "{solution}: horizontal RMS {rms:.2} m, NEES inside its 95 % bounds {:.1} %",
            100.0 * inside
        );
        assert!(
            inside >= 0.70,
            "{solution} horizontal NEES inside its bounds {:.1} % < 70 %",
            100.0 * inside
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The largest peak resident memory of the child processes waited for so far, bytes (Linux
/// reports kilobytes).
fn children_peak_rss_bytes() -> u64 {
    // SAFETY: getrusage writes one `rusage` into the zeroed struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    assert_eq!(
        unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) },
        0
    );
    u64::try_from(usage.ru_maxrss).unwrap() * 1024
}
