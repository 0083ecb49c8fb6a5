//! `hindsight attitude` as a user runs it: outputs, console table, and bad input (no
//! magnetometer, no `end` mark, a saturating magnetometer, a bad config).

mod common;

use arrow_array::{Array, Float64Array, RecordBatch, StringArray, UInt64Array};
use common::{hindsight, read_parquet, stderr};
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
    let methods = b
        .column_by_name("method")
        .unwrap()
        .as_any()
        .downcast_ref::<StringArray>()
        .unwrap();
    let values = b
        .column_by_name(column)
        .unwrap()
        .as_any()
        .downcast_ref::<Float64Array>()
        .unwrap();
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
    let mut args = vec![
        "attitude",
        log.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    hindsight(&args)
}

#[test]
fn pool_log_gives_every_output() {
    let out = common::scratch_dir("attitude-pool");
    let before = std::fs::read(POOL).unwrap();
    let o = run(Path::new(POOL), &out, &["--mag-calibration", "auto"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(POOL).unwrap(), before, "input untouched");
    let err = stderr(&o);
    assert!(
        err.contains("magnetometer calibration (Ellipse fit"),
        "{err}"
    );
    assert!(
        err.contains("`ekf.measurement_noise` is not positive definite"),
        "{err}"
    );
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
    let repairs = b
        .column_by_name("covariance_repairs")
        .unwrap()
        .as_any()
        .downcast_ref::<UInt64Array>()
        .unwrap();
    assert!(repairs.iter().all(|r| r == Some(0)));
    for png in ["tracks_xy.png", "tracks_xz.png"] {
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
            "tracks_xy.png",
            "tracks_xz.png"
        ]
    );
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
    };
    edit(&mut s);
    let mission = log.mission().unwrap();
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&mission)?;
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

#[test]
fn without_an_end_mark_the_end_point_error_is_not_available() {
    let log = rewritten("attitude-no-end", |s| s.fixes.retain(|f| f.label != "end"));
    let out = log.with_file_name("out");
    let o = run(&log, &out, &["--methods", "raw,mekf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("no `end` mark"), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(
        console
            .lines()
            .any(|l| l.starts_with("raw") && l.contains("N/A")),
        "{console}"
    );
    let ends = summary_column(&out, "end_error_m");
    assert!(ends.iter().all(|(_, e)| e.is_none()), "{ends:?}");
    // The path is still there.
    assert!(summary_column(&out, "path_m")
        .iter()
        .all(|(_, p)| p.is_some()));
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
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("ukf.kappa"), "{}", stderr(&o));
    assert!(!dir.join("out").exists());
    // --print-config prints what parses back to the defaults.
    let o = hindsight(&["attitude", "--print-config"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(
        hindsight::attitude::config::AttitudeConfig::from_toml(&text).unwrap(),
        hindsight::attitude::config::AttitudeConfig::default()
    );
}
