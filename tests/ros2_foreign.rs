//! ROS 2 recordings written by the official Python writer (`mcap-ros2-support` 0.6.0) from
//! the json sample logs: `tests/fixtures/ros2/make_ros2_fixtures.py` made them.
//! Both frame conventions and both distros' definitions; the values after conversion are the
//! json original's, and the same mission reconstructs and gives attitude within 1 mm.

use crate::common;
use hindsight::contract::{
    Altimeter, Depth, Dvl, GnssFix, Imu, MagneticField, Message, Propeller, SpeedLog, Streams,
    Truth,
};
use hindsight::ingest::ros::map::Convention;
use hindsight::ingest::{read_log, read_log_from, IngestOptions, Log};
use hindsight::recon::config::Config;
use hindsight::recon::run_configured as reconstruct;
use hindsight::sim::writer::{to_bytes, LogWriter, WriterOptions};
use std::path::PathBuf;

/// The window of the survey sample log the fixtures hold (the script's WINDOW_S).
const WINDOW_NS: u64 = 120_000_000_000;

fn fixture(name: &str) -> PathBuf {
    common::repo_path("tests/fixtures/ros2").join(name)
}

fn sample(name: &str) -> PathBuf {
    common::repo_path("sample-logs").join(name)
}

/// Copies the messages of `T`'s role logged within the window.
fn copy<T: Message>(w: &mut LogWriter<std::io::Cursor<Vec<u8>>>, log: &Log, t0: u64) {
    let Some(s) = log.role_topic::<T>().and_then(|t| log.stream(t)) else {
        return;
    };
    for (m, &t) in s.messages::<T>().unwrap().iter().zip(&s.log_time_ns) {
        if t - t0 <= WINDOW_NS {
            w.write(T::DEFAULT_TOPIC, m, t).unwrap();
        }
    }
}

/// The json survey sample log cut to the fixtures' window, as the script cut it.
fn json_survey_window() -> Log {
    let full = read_log(
        &sample("survey-short-seed1.mcap"),
        &IngestOptions::default(),
    )
    .unwrap();
    let t0 = full
        .streams
        .iter()
        .filter_map(|s| s.log_time_ns.first())
        .min()
        .copied()
        .unwrap();
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&full.mission().unwrap())?;
        copy::<Imu>(w, &full, t0);
        copy::<MagneticField>(w, &full, t0);
        copy::<Dvl>(w, &full, t0);
        copy::<SpeedLog>(w, &full, t0);
        copy::<Depth>(w, &full, t0);
        copy::<Altimeter>(w, &full, t0);
        copy::<Propeller>(w, &full, t0);
        copy::<GnssFix>(w, &full, t0);
        copy::<Truth>(w, &full, t0);
        Ok(())
    })
    .unwrap();
    read_log_from(&bytes[..], &IngestOptions::default()).unwrap()
}

/// Reads a fixture; the Jazzy survey's magnetometer is FRD under `mag_link`, so its
/// convention is given, as a user would with `--frame /vehicle/mag=native`.
fn ros2(name: &str) -> Log {
    let mut options = IngestOptions::default();
    if name.contains("native") {
        options
            .frame_conventions
            .insert("/vehicle/mag".into(), Convention::Native);
    }
    read_log(&fixture(name), &options).unwrap()
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} against {b}");
}

/// Compares every role's messages with the json original's, to the precision the ROS 2 type
/// carries.
fn assert_same_values(json: &Log, ros: &Log, dvl_has_altitude: bool) {
    let (j, r) = (Streams::of(json), Streams::of(ros));
    assert_eq!(j.imu, r.imu, "IMU: sign changes are exact");
    assert_eq!(j.mag, r.mag);
    assert_eq!(j.eml, r.eml);
    assert_eq!(j.rpm, r.rpm);
    assert_eq!(j.truth, r.truth);
    assert_eq!(j.dvl.len(), r.dvl.len());
    for (a, b) in j.dvl.iter().zip(r.dvl) {
        assert_eq!(
            (a.stamp_ns, a.velocity, a.valid),
            (b.stamp_ns, b.velocity, b.valid)
        );
        let expected = if dvl_has_altitude { a.altitude } else { None };
        assert_eq!(b.altitude, expected);
    }
    assert_eq!(j.depth.len(), r.depth.len());
    for (a, b) in j.depth.iter().zip(r.depth) {
        assert_eq!(a.stamp_ns, b.stamp_ns);
        // Through FluidPressure: 1e5 Pa and back.
        assert_close(a.depth, b.depth, 1e-9, "depth");
    }
    assert_eq!(j.altimeter.len(), r.altimeter.len());
    for (a, b) in j.altimeter.iter().zip(r.altimeter) {
        assert_eq!(a.stamp_ns, b.stamp_ns);
        assert_eq!(b.altitude, a.altitude as f32 as f64, "Range is float32");
    }
    assert_eq!(j.gnss.len(), r.gnss.len());
    for (a, b) in j.gnss.iter().zip(r.gnss) {
        assert_eq!(
            (a.stamp_ns, a.latitude_deg, a.longitude_deg),
            (b.stamp_ns, b.latitude_deg, b.longitude_deg)
        );
        assert_close(a.horizontal_sigma_m, b.horizontal_sigma_m, 1e-12, "sigma");
    }
    assert!(!j.imu.is_empty() && !j.dvl.is_empty() && !j.gnss.is_empty());
}

#[test]
fn humble_rep103_and_jazzy_native_recordings_hold_the_json_values() {
    let json = json_survey_window();
    let humble = ros2("survey_humble_rep103.mcap");
    assert!(humble.file.library.contains("mcap-ros2-support/0.6.0"));
    assert_eq!(humble.role_topic::<Imu>(), Some("/vehicle/imu/data"));
    assert_eq!(
        humble.role_topic::<Dvl>(),
        Some("/vehicle/dvl/twist"),
        "TwistWithCovarianceStamped"
    );
    assert_same_values(&json, &humble, false);
    let jazzy = ros2("survey_jazzy_native.mcap");
    assert_eq!(
        jazzy.role_topic::<Dvl>(),
        Some("/vehicle/dvl"),
        "marine_acoustic_msgs/Dvl"
    );
    assert_same_values(&json, &jazzy, true);

    // Without the override, `mag_link` reads as REP-103: y and z change sign.
    let misread = read_log(
        &fixture("survey_jazzy_native.mcap"),
        &IngestOptions::default(),
    )
    .unwrap();
    let (a, b) = (&Streams::of(&json).mag[3], &Streams::of(&misread).mag[3]);
    assert_eq!(b.magnetic_field[1], -a.magnetic_field[1]);
}

#[test]
fn the_same_mission_in_json_and_in_ros2_reconstructs_within_a_millimetre() {
    let json = json_survey_window();
    let mission = json.mission().unwrap();
    let defaults = common::defaults_of(&mission);
    let config = Config::default();
    let reference = reconstruct(&Streams::of(&json), &mission, &config).unwrap();
    assert!(reference.forward.len() > 1000 && reference.smoothed.len() > 1000);
    for name in ["survey_humble_rep103.mcap", "survey_jazzy_native.mcap"] {
        let log = ros2(name);
        let r = reconstruct(
            &Streams::of(&log),
            &log.mission_or(&defaults).unwrap(),
            &config,
        )
        .unwrap();
        common::assert_within_a_millimetre(name, &reference, &r);
    }
}

#[test]
fn the_same_pool_run_in_json_and_in_ros2_gives_attitude_within_a_millimetre() {
    let json_out = common::scratch_dir("ros2-attitude-json");
    let ros_out = common::scratch_dir("ros2-attitude-ros2");
    let json_log = sample("pool-rectangle-seed1.mcap");
    let ros_log = fixture("pool_jazzy_rep103.mcap");
    let o = common::hindsight(&[
        "attitude",
        json_log.to_str().unwrap(),
        "--out",
        json_out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    // No mission record in a rosbag2 file: the pool's origin and declination are given.
    let mission = read_log(&json_log, &IngestOptions::default())
        .unwrap()
        .mission()
        .unwrap();
    let origin = format!(
        "{},{}",
        mission.origin_latitude_deg, mission.origin_longitude_deg
    );
    let declination = mission.magnetic_declination_deg.unwrap().to_string();
    let o = common::hindsight(&[
        "attitude",
        ros_log.to_str().unwrap(),
        "--origin",
        &origin,
        "--declination",
        &declination,
        "--out",
        ros_out.to_str().unwrap(),
    ]);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("imu: /vehicle/imu/data (the one topic of its type)"),
        "{err}"
    );
    for file in ["attitude.parquet", "attitude_summary.parquet"] {
        common::assert_same_float_columns(&json_out.join(file), &ros_out.join(file), file);
    }
    let rows = common::float_columns(&json_out.join("attitude.parquet"))[0]
        .1
        .len();
    assert!(rows > 6 * 20_000, "{rows}");
}

#[test]
fn info_export_and_reconstruct_read_a_ros2_recording() {
    let log = fixture("survey_humble_rep103.mcap");
    let log = log.to_str().unwrap();
    let o = common::hindsight(&["info", log]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("roles not at their default topic: imu /vehicle/imu/data"),
        "{text}"
    );
    assert!(text.contains("sensor_msgs/msg/NavSatFix"), "{text}");

    let out = common::scratch_dir("ros2-export");
    let o = common::hindsight(&["export", log, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(std::fs::read_dir(&out).unwrap().count() > 3);

    // Without a mission record, the origin is the first GNSS fix.
    let out = common::scratch_dir("ros2-reconstruct");
    let o = common::hindsight(&["reconstruct", log, "--out", out.to_str().unwrap()]);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("gnss: /vehicle/gps/fix"), "{err}");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(
        summary.contains("origin from the first GNSS fix"),
        "{summary}"
    );
}

/// The same zig-zag as a ROS 2 recording (hindsight's own CDR writer: IMU, attitude as
/// QuaternionStamped, depth as FluidPressure, DVL as TwistWithCovarianceStamped, REP-103;
/// /fins stays json), every topic moved under /vehicle so each role is found by its type,
/// identifies as its json original.
#[test]
fn a_ros2_zigzag_identifies_as_its_json_original() {
    use hindsight::sim::ros::{write_as_ros2, Others};
    use hindsight::sim::zigzag::{self, ZigzagSpec};
    let dir = common::scratch_dir("ros2-identify");
    let spec = ZigzagSpec::built_in("zigzag-10-5").unwrap();
    let json = to_bytes(WriterOptions::default(), |w| {
        zigzag::run(&spec, 1, w)?;
        Ok(())
    })
    .unwrap();
    let log = read_log_from(&json[..], &IngestOptions::default()).unwrap();
    let ros = to_bytes(WriterOptions::default(), |w| {
        let vehicle = |t: &str| format!("/vehicle{t}");
        write_as_ros2(
            &log,
            Convention::Rep103,
            &Default::default(),
            Others::Json,
            &vehicle,
            w,
        )?;
        Ok(())
    })
    .unwrap();
    let (json_log, ros_log) = (dir.join("zigzag.mcap"), dir.join("zigzag-ros2.mcap"));
    std::fs::write(&json_log, json).unwrap();
    std::fs::write(&ros_log, ros).unwrap();
    let mut outs = Vec::new();
    for (name, path) in [("json", &json_log), ("ros2", &ros_log)] {
        let out = dir.join(name);
        let o = common::hindsight(&[
            "identify",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{name}: {}", common::stderr(&o));
        outs.push(out);
    }
    let (a, b) = (
        common::float_columns(&outs[0].join("coefficients.parquet")),
        common::float_columns(&outs[1].join("coefficients.parquet")),
    );
    assert!(!a.is_empty() && a.len() == b.len());
    // The inputs differ by rounding (the attitude through a quaternion, the depth through a
    // pressure); the fit stops at its tolerance, so the estimates agree to that, not to the
    // last bit: within 1e-3 of their sigma.
    let column = |cols: &[(String, Vec<f64>)], name: &str| {
        cols.iter().find(|(n, _)| n == name).unwrap().1.clone()
    };
    let (estimate_a, estimate_b) = (column(&a, "estimate"), column(&b, "estimate"));
    let sigma = column(&a, "sigma");
    assert!(!estimate_a.is_empty());
    for ((p, q), s) in estimate_a.iter().zip(&estimate_b).zip(&sigma) {
        println!(
            "estimate {p:.9e} against {q:.9e}: {:.1e} sigma",
            (p - q).abs() / s
        );
        assert!((p - q).abs() <= 1e-3 * s, "{p} against {q} (sigma {s})");
    }
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        for (p, q) in x.iter().zip(y) {
            assert!(
                (p - q).abs() <= 1e-3 * p.abs().max(1e-9) || (p.is_nan() && q.is_nan()),
                "{name}: {p} against {q}"
            );
        }
    }
}
