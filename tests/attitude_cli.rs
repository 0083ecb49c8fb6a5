//! `hindsight attitude` as a user runs it: outputs, console table, and bad input (no
//! magnetometer, no `end` mark, no marks and no truth, a long DVL gap, a saturating
//! magnetometer, a bad config); the defaults on pool runs with a 5 uT hard iron.

use crate::common;
use arrow_array::{Array, Float64Array, RecordBatch, StringArray, UInt64Array};
use common::{hindsight, read_parquet, stderr};
use hindsight::config::Section;
use hindsight::contract::{Dvl, Imu, MagneticField, PositionFix, Truth};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use std::path::{Path, PathBuf};

const POOL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/sample-logs/pool-rectangle-seed1.mcap"
);

/// The summary's rows: method and the named nullable column.
fn summary_column(dir: &Path, column: &str) -> Vec<(String, Option<f64>)> {
    let batches = read_parquet(&dir.join("attitude_summary.parquet"));
    let b = &batches[0];
    let methods = common::column::<StringArray>(b, "method");
    let values = common::column::<Float64Array>(b, column);
    (0..b.num_rows())
        .map(|i| {
            (
                methods.value(i).to_string(),
                values.is_valid(i).then(|| values.value(i)),
            )
        })
        .collect()
}

fn run(log: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    common::run_on("attitude", log, out, extra)
}

#[test]
fn pool_log_gives_every_output() {
    let out = common::scratch_dir("attitude-pool");
    let before = std::fs::read(POOL).unwrap();
    // The defaults: the magnetometer calibrated, no covariance adjusted.
    let o = run(Path::new(POOL), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(POOL).unwrap(), before, "input untouched");
    let err = stderr(&o);
    assert!(
        err.contains("magnetometer calibration (Ellipse fit"),
        "{err}"
    );
    assert!(!err.contains("not positive definite"), "{err}");
    let console = String::from_utf8_lossy(&o.stdout);
    for m in ["raw", "ekf", "ukf", "cf", "mekf", "mekf-smoothed"] {
        assert!(
            console.lines().any(|l| l.starts_with(m)),
            "{m} not in {console}"
        );
    }
    // attitude.parquet: every method at every IMU stamp, positions on the track.
    let batches = read_parquet(&out.join("attitude.parquet"));
    let rows: usize = batches.iter().map(RecordBatch::num_rows).sum();
    assert!(rows > 6 * 20_000, "{rows}");
    for name in [
        "stamp_ns",
        "method",
        "roll_rad",
        "pitch_rad",
        "yaw_rad",
        "north_m",
        "east_m",
        "down_m",
    ] {
        assert!(batches[0].column_by_name(name).is_some(), "{name}");
    }
    // The summary: end-point error of every method, against the end mark, and truth errors.
    let ends = summary_column(&out, "end_error_m");
    assert_eq!(ends.len(), 6);
    assert!(
        ends.iter().all(|(_, e)| e.is_some_and(|e| e < 1.0)),
        "{ends:?}"
    );
    let yaw = summary_column(&out, "yaw_rms_deg");
    assert!(
        yaw.iter().all(|(_, y)| y.is_some_and(|y| y < 1.0)),
        "{yaw:?}"
    );
    let paths = summary_column(&out, "path_m");
    assert!(
        paths
            .iter()
            .all(|(_, p)| p.is_some_and(|p| (p - 100.8).abs() < 1.0)),
        "{paths:?}"
    );
    let b = &read_parquet(&out.join("attitude_summary.parquet"))[0];
    let repairs = common::column::<UInt64Array>(b, "covariance_repairs");
    assert!(repairs.iter().all(|r| r == Some(0)));
    for png in [
        "tracks_xy.png",
        "tracks_xz.png",
        "error_roll.png",
        "error_pitch.png",
        "error_heading.png",
    ] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
    // Nothing left behind but the outputs.
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "attitude.parquet",
            "attitude_summary.parquet",
            "error_heading.png",
            "error_pitch.png",
            "error_roll.png",
            "report.html",
            "tracks_xy.png",
            "tracks_xz.png"
        ]
    );
}

/// Seed 001's matrices as printed are a preset, adjusted with a note; `--mag-calibration
/// none` leaves the readings alone.
#[test]
fn the_seed001_preset_and_no_calibration() {
    let out = common::scratch_dir("attitude-preset");
    let o = run(
        Path::new(POOL),
        &out,
        &["--preset", "seed001", "--mag-calibration", "none"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("`ekf.measurement_noise` is not positive definite"),
        "{err}"
    );
    assert!(
        err.contains("`ukf.measurement_noise` is not positive definite"),
        "{err}"
    );
    assert!(!err.contains("magnetometer calibration"), "{err}");
}

/// The pool sample log rewritten with its streams changed by `edit`.
fn rewritten(name: &str, edit: impl Fn(&mut Streams)) -> PathBuf {
    let log = common::read(&std::fs::read(POOL).unwrap());
    let mut s = Streams {
        imu: log.messages("/imu").unwrap().to_vec(),
        mag: log.messages("/mag").unwrap().to_vec(),
        dvl: log.messages("/dvl").unwrap().to_vec(),
        fixes: log.messages("/position_fix").unwrap().to_vec(),
        truth: log.messages("/truth").unwrap().to_vec(),
        mission: log.mission().unwrap(),
    };
    edit(&mut s);
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&s.mission)?;
        for m in &s.imu {
            w.write("/imu", m, m.stamp_ns as u64)?;
        }
        for m in &s.mag {
            w.write("/mag", m, m.stamp_ns as u64)?;
        }
        for m in &s.dvl {
            w.write("/dvl", m, m.stamp_ns as u64)?;
        }
        for m in &s.fixes {
            w.write("/position_fix", m, m.stamp_ns as u64)?;
        }
        for m in &s.truth {
            w.write("/truth", m, m.stamp_ns as u64)?;
        }
        Ok(())
    })
    .unwrap();
    let path = common::scratch_dir(name).join("log.mcap");
    std::fs::write(&path, bytes).unwrap();
    path
}

struct Streams {
    imu: Vec<Imu>,
    mag: Vec<MagneticField>,
    dvl: Vec<Dvl>,
    fixes: Vec<PositionFix>,
    truth: Vec<Truth>,
    mission: hindsight::ingest::Mission,
}

/// A mission without a declination gets the World Magnetic Model's, said so.
#[test]
fn the_declination_comes_from_the_world_magnetic_model() {
    let log = rewritten("attitude-wmm", |s| {
        s.mission.magnetic_declination_deg = None
    });
    let out = log.with_file_name("out");
    let o = run(&log, &out, &["--methods", "raw"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Daejeon (36.37 N, 127.36 E) in 2023: about 8.8 deg west.
    let err = stderr(&o);
    let line = err
        .lines()
        .find(|l| l.contains("from the World Magnetic Model"))
        .unwrap_or_else(|| panic!("{err}"));
    let d: f64 = line
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap();
    assert!((-10.0..-8.0).contains(&d), "{line}");
}

#[test]
fn without_a_magnetometer_the_methods_that_need_it_are_skipped() {
    let log = rewritten("attitude-no-mag", |s| s.mag.clear());
    let out = log.with_file_name("out");
    let o = run(&log, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("no magnetometer readings on /mag: skipping raw, ekf, ukf, cf"),
        "{err}"
    );
    let ends = summary_column(&out, "end_error_m");
    let methods: Vec<&str> = ends.iter().map(|(m, _)| m.as_str()).collect();
    assert_eq!(methods, ["mekf", "mekf-smoothed"]);
    // Asking only for methods that need it is an error naming the cause.
    let o = run(&log, &out, &["--methods", "raw,ekf"]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no magnetometer readings"),
        "{}",
        stderr(&o)
    );
}

/// Without an `end` mark the run is scored by its closest return to the start (the pool run
/// comes back), and the table says so.
#[test]
fn without_an_end_mark_the_closest_return_is_scored() {
    let log = rewritten("attitude-no-end", |s| s.fixes.retain(|f| f.label != "end"));
    let out = log.with_file_name("out");
    let o = run(&log, &out, &["--methods", "raw,mekf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("no `end` mark"), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(
        console.contains("return: closest return of the track to its start"),
        "{console}"
    );
    assert!(console.contains("RMS error against /truth"), "{console}");
    let ends = summary_column(&out, "end_error_m");
    assert!(ends.iter().all(|(_, e)| e.is_none()), "{ends:?}");
    // The rectangle closes to within its end-point error of the marked run (0.3 m).
    let returns = summary_column(&out, "closest_return_m");
    assert!(
        returns.iter().all(|(_, r)| r.is_some_and(|r| r < 1.0)),
        "{returns:?}"
    );
    assert!(summary_column(&out, "path_m")
        .iter()
        .all(|(_, p)| p.is_some()));
    // A run that does not come back has no such score: N/A, said so.
    let log = rewritten("attitude-one-leg", |s| {
        s.fixes.retain(|f| f.label != "end");
        let cut = s.dvl[0].stamp_ns + 45_000_000_000; // the first leg only
        s.dvl.retain(|d| d.stamp_ns < cut);
    });
    let out = log.with_file_name("out");
    let o = run(&log, &out, &["--methods", "raw,mekf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(console.contains("the run does not come back"), "{console}");
    assert!(
        console
            .lines()
            .any(|l| l.starts_with("raw") && l.contains("N/A")),
        "{console}"
    );
}

/// With neither marks nor truth, the methods are compared with each other: angles against
/// the smoothed MEKF, tracks by their closest return; nothing claims to be against a truth.
#[test]
fn without_marks_or_truth_the_methods_are_compared() {
    let log = rewritten("attitude-no-reference", |s| {
        s.fixes.clear();
        s.truth.clear();
    });
    let out = log.with_file_name("out");
    let o = run(&log, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(
        console.contains("angles: RMS difference from mekf-smoothed"),
        "{console}"
    );
    assert!(!console.contains("against /truth"), "{console}");
    assert!(console.contains("closest return"), "{console}");
    let b = &read_parquet(&out.join("attitude_summary.parquet"))[0];
    let against = common::column::<StringArray>(b, "angles_against");
    assert!(against.iter().all(|a| a == Some("mekf-smoothed")));
    // The differences are numbers, zero only for the reference itself, and the raw
    // (sample-by-sample) attitude is the farthest from it.
    let yaw = summary_column(&out, "yaw_rms_deg");
    let of = |m: &str| yaw.iter().find(|(n, _)| n == m).unwrap().1.unwrap();
    assert!(of("mekf-smoothed") < 1e-9);
    for m in ["ekf", "ukf", "cf", "mekf"] {
        assert!(of(m) > 0.0 && of(m) < of("raw"), "{m}: {yaw:?}");
    }
    let returns = summary_column(&out, "closest_return_m");
    assert!(
        returns.iter().all(|(_, r)| r.is_some_and(|r| r < 1.0)),
        "{returns:?}"
    );
}

/// A 50 s stretch without bottom lock (the DVL reading a rising vehicle) is not bridged by
/// default, and is warned about; with the limit raised it is, and the travel is invented.
#[test]
fn a_long_dvl_gap_is_not_bridged() {
    let log = rewritten("attitude-dvl-gap", |s| {
        let from = s.dvl[0].stamp_ns + 60_000_000_000;
        let to = from + 50_000_000_000;
        for d in s
            .dvl
            .iter_mut()
            .filter(|d| (from..to).contains(&d.stamp_ns))
        {
            d.valid = false;
            d.velocity = [0.3, 0.0, -0.5];
            d.altitude = None;
        }
    });
    let out = log.with_file_name("out");
    let o = run(&log, &out, &["--methods", "mekf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("1 stretch(es) without a valid DVL reading longer than dvl.max_gap_s = 5 s"),
        "{err}"
    );
    assert!(err.contains("not bridged"), "{err}");
    let held = summary_column(&out, "path_m")[0].1.unwrap();
    // 50 s at 0.5 m/s not travelled (the true path is 100.8 m).
    assert!((held - 75.8).abs() < 2.0, "{held}");

    let config = log.with_file_name("long-gaps.toml");
    std::fs::write(&config, "[dvl]\nmax_gap_s = 100.0\n").unwrap();
    let o = run(
        &log,
        &out,
        &["--methods", "mekf", "--config", config.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("not bridged"), "{}", stderr(&o));
    let bridged = summary_column(&out, "path_m")[0].1.unwrap();
    assert!((bridged - 100.8).abs() < 1.0, "{bridged}");
}

/// The criterion: the project's pool scenarios with a 5 uT hard iron, run with the
/// defaults (no flags, no config): every method ends within 0.5 % of the path.
#[test]
fn pool_runs_with_a_5_ut_hard_iron_end_within_half_a_percent() {
    use hindsight::sim::scenario::Scenario;
    for name in ["pool-rectangle", "pool-circle"] {
        let mut scenario = Scenario::built_in(name).unwrap();
        let mag = scenario.mag.as_mut().unwrap();
        mag.hard_iron_nt = [4000.0, -3000.0, 0.0]; // 5 uT in the horizontal
        let dir = common::scratch_dir(&format!("attitude-hard-iron-{name}"));
        let log = dir.join("log.mcap");
        std::fs::write(&log, common::simulated_bytes(&scenario, 1)).unwrap();
        let out = dir.join("out");
        let o = run(&log, &out, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            !stderr(&o).contains("not positive definite"),
            "{}",
            stderr(&o)
        );
        println!("{name}\n{}", String::from_utf8_lossy(&o.stdout));
        let percent = summary_column(&out, "end_error_percent_of_path");
        assert_eq!(percent.len(), 6);
        for (method, p) in &percent {
            let p = p.unwrap();
            assert!(p < 0.5, "{name} {method}: {p:.2} % of the path");
        }
        // The calibration is what does it: without it no method comes near.
        let o = run(&log, &out, &["--mag-calibration", "none"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let percent = summary_column(&out, "end_error_percent_of_path");
        for (method, p) in &percent {
            let p = p.unwrap();
            assert!(
                p > 2.0,
                "{name} {method} uncalibrated: {p:.2} % of the path"
            );
        }
    }
}

#[test]
fn a_saturating_magnetometer_is_flagged() {
    // 5 s (250 readings at 50 Hz) with x clipped at the sensor's range.
    let log = rewritten("attitude-saturated", |s| {
        for m in &mut s.mag[2000..2250] {
            m.magnetic_field[0] = 250e-6;
        }
    });
    let out = log.with_file_name("out");
    let o = run(&log, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("magnetometer saturated"), "{err}");
    assert!(err.contains("(250 readings): not used"), "{err}");
    // Taken out, the readings do not spoil the heading.
    let yaw = summary_column(&out, "yaw_rms_deg");
    assert!(
        yaw.iter().all(|(_, y)| y.is_some_and(|y| y < 2.0)),
        "{yaw:?}"
    );
}

#[test]
fn a_bad_config_names_the_key() {
    let dir = common::scratch_dir("attitude-config");
    let config = dir.join("bad.toml");
    std::fs::write(&config, "[ukf]\nkappa = -4.0\n").unwrap();
    let o = run(
        Path::new(POOL),
        &dir.join("out"),
        &["--config", config.to_str().unwrap()],
    );
    common::assert_refused(&o, "ukf.kappa");
    assert!(!dir.join("out").exists());
    // The old --print-config still prints what parses back to the defaults.
    let o = hindsight(&["attitude", "--print-config"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(
        hindsight::attitude::config::AttitudeConfig::from_toml(&text).unwrap(),
        hindsight::attitude::config::AttitudeConfig::default()
    );
}
