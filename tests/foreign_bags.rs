//! Logs as people keep them, written by other people's tools from the json sample logs
//! (`tests/fixtures/bags/make_bag_fixtures.py`): ROS 1 bags by `rosbags` (lz4 and bz2
//! chunks), ROS 1 in MCAP by the official `mcap-ros1-support` writer, ROS 2 sqlite3 bags by
//! `rosbags` (as Humble writes them, without definitions, and with the file's definitions).
//! Both frame conventions. Each holds the json original's values, reconstructs within 1 mm of
//! it, and the pool runs give the same attitude comparison within 1 mm. Each also carries the
//! simulator's truth as a vehicle INS's `nav_msgs/Odometry`, the reference track when it is
//! named for the truth role.

use crate::common;
use hindsight::contract::{
    Altimeter, Depth, Dvl, GnssFix, Imu, MagneticField, Message, Streams, Truth,
};
use hindsight::ingest::{read_log, read_log_from, Container, IngestOptions, Log, Mission};
use hindsight::recon::config::Config;
use hindsight::recon::run_configured as reconstruct;
use hindsight::sim::writer::{to_bytes, LogWriter, WriterOptions};
use std::path::{Path, PathBuf};

/// The window of the sample logs the fixtures hold (the script's WINDOW_S).
const WINDOW_NS: u64 = 60_000_000_000;

/// A fixture: its file, container, and the DVL's topic (TwistWithCovarianceStamped on
/// `/vehicle/dvl/twist`, without altitude; a driver's DVL message on `/vehicle/dvl`, with it).
type Fixture = (&'static str, Container, &'static str);
const TWIST: &str = "/vehicle/dvl/twist";
const DRIVER: &str = "/vehicle/dvl";
const SURVEYS: [Fixture; 3] = [
    ("survey_noetic_rep103.bag", Container::Ros1Bag, TWIST),
    ("survey_ros1_native.mcap", Container::Mcap, TWIST),
    ("survey_humble_rep103", Container::Ros2Sqlite, TWIST),
];
const POOLS: [Fixture; 3] = [
    // Water Linked's waterlinked_a50_ros_driver/DVL.
    ("pool_noetic_native.bag", Container::Ros1Bag, DRIVER),
    ("pool_ros1_rep103.mcap", Container::Mcap, TWIST),
    // The UUV Simulator's uuv_sensor_ros_plugins_msgs/DVL.
    ("pool_jazzy_native", Container::Ros2Sqlite, DRIVER),
];
/// The fixtures' odometry: the simulator's truth, as a vehicle INS would publish it.
const ODOMETRY: &str = "/ins/odometry";
const SURVEY: &str = "survey-short-seed1.mcap";
const POOL: &str = "pool-rectangle-seed1.mcap";

fn fixture(name: &str) -> PathBuf {
    common::repo_path("tests/fixtures/bags").join(name)
}

fn sample(name: &str) -> PathBuf {
    common::repo_path("sample-logs").join(name)
}

/// Copies the messages of `T`'s role logged within the window, as `keep` leaves them.
fn copy<T: Message + Clone>(
    w: &mut LogWriter<std::io::Cursor<Vec<u8>>>,
    log: &Log,
    t0: u64,
    keep: impl Fn(T) -> T,
) {
    let Some(s) = log.role_topic::<T>().and_then(|t| log.stream(t)) else {
        return;
    };
    for (m, &t) in s.messages::<T>().unwrap().iter().zip(&s.log_time_ns) {
        if t - t0 <= WINDOW_NS {
            w.write(T::DEFAULT_TOPIC, &keep(m.clone()), t).unwrap();
        }
    }
}

/// The json sample log cut to the window, with the streams a bag can hold (those of a
/// standard ROS type), as the script cut it; and its mission. Without `dvl_altitude` the
/// DVL's altitude is left out, as TwistWithCovarianceStamped has no place for it.
fn json_window(sample_name: &str, dvl_altitude: bool) -> (Vec<u8>, Mission) {
    let full = read_log(&sample(sample_name), &IngestOptions::default()).unwrap();
    let mission = full.mission().unwrap();
    let t0 = full
        .streams
        .iter()
        .filter_map(|s| s.log_time_ns.first())
        .min()
        .copied()
        .unwrap();
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&mission)?;
        copy::<Imu>(w, &full, t0, |m| m);
        copy::<MagneticField>(w, &full, t0, |m| m);
        copy::<Dvl>(w, &full, t0, |m| Dvl {
            altitude: m.altitude.filter(|_| dvl_altitude),
            ..m
        });
        copy::<Depth>(w, &full, t0, |m| m);
        copy::<Altimeter>(w, &full, t0, |m| m);
        copy::<GnssFix>(w, &full, t0, |m| m);
        copy::<Truth>(w, &full, t0, |m| m);
        Ok(())
    })
    .unwrap();
    (bytes, mission)
}

fn json_log(sample_name: &str, dvl_altitude: bool) -> (Log, Mission) {
    let (bytes, mission) = json_window(sample_name, dvl_altitude);
    let log = read_log_from(&bytes[..], &IngestOptions::default()).unwrap();
    (log, mission)
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} against {b}");
}

/// Every role's messages equal the json original's, to the precision the ROS type carries.
fn assert_same_values(name: &str, json: &Log, ros: &Log) {
    let (j, r) = (Streams::of(json), Streams::of(ros));
    assert!(!j.imu.is_empty() && !j.dvl.is_empty(), "{name}");
    // Sign changes are exact; the DVL's lock goes through covariance[0].
    assert!(j.imu == r.imu, "{name}: IMU differs");
    assert!(j.mag == r.mag, "{name}: magnetometer differs");
    assert!(j.dvl == r.dvl, "{name}: DVL differs");
    assert_eq!(j.depth.len(), r.depth.len(), "{name}");
    for (a, b) in j.depth.iter().zip(r.depth) {
        assert_eq!(a.stamp_ns, b.stamp_ns);
        assert_close(a.depth, b.depth, 1e-9, "depth through FluidPressure");
    }
    assert_eq!(j.altimeter.len(), r.altimeter.len(), "{name}");
    for (a, b) in j.altimeter.iter().zip(r.altimeter) {
        assert_eq!(a.stamp_ns, b.stamp_ns);
        assert_eq!(b.altitude, a.altitude as f32 as f64, "Range is float32");
    }
    assert_eq!(j.gnss.len(), r.gnss.len(), "{name}");
    for (a, b) in j.gnss.iter().zip(r.gnss) {
        assert_eq!(
            (a.stamp_ns, a.latitude_deg, a.longitude_deg),
            (b.stamp_ns, b.latitude_deg, b.longitude_deg)
        );
        assert_close(a.horizontal_sigma_m, b.horizontal_sigma_m, 1e-12, "sigma");
    }
}

#[test]
fn every_container_holds_the_json_values() {
    for (sample_name, fixtures) in [(SURVEY, SURVEYS), (POOL, POOLS)] {
        for (name, container, dvl_topic) in fixtures {
            let (json, _) = json_log(sample_name, dvl_topic == DRIVER);
            let log = read_log(&fixture(name), &IngestOptions::default()).unwrap();
            assert_eq!(log.file.container, container, "{name}");
            assert_eq!(log.role_topic::<Imu>(), Some("/vehicle/imu/data"), "{name}");
            assert_eq!(log.role_topic::<Dvl>(), Some(dvl_topic), "{name}");
            // The survey bag holds /tf and /rosout besides: one line says they are skipped.
            // The odometry is not read unless it is named.
            let mut expected = match name {
                "survey_noetic_rep103.bag" => vec![
                    "skipped 2 topics of types hindsight does not read (112 messages): /tf \
                     (`tf2_msgs/TFMessage` in ros1, 56), /rosout (`rosgraph_msgs/Log` in ros1, 56)"
                        .to_string(),
                ],
                _ => vec![],
            };
            let odometry = log.skipped.iter().find(|s| s.topic == ODOMETRY).unwrap();
            expected.push(format!(
                "{ODOMETRY} (`{}`, {} messages) was not read: a topic of this type is read only \
                 when it is named for the truth role",
                odometry.schema_name,
                json.role::<Truth>().len()
            ));
            assert_eq!(log.warnings(), expected, "{name}");
            assert!(log.role::<Truth>().is_empty(), "{name}");
            assert_same_values(name, &json, &log);
        }
    }
    // The ROS 1 MCAP files are the official writer's.
    let log = read_log(&fixture(SURVEYS[1].0), &IngestOptions::default()).unwrap();
    assert!(log.file.library.contains("mcap-ros1-support/0.9.0"));
    assert_eq!(log.streams[0].message_encoding, "ros1");
}

/// `hindsight COMMAND LOG --out OUT EXTRA...`, which must succeed; what it said on stderr.
fn run_cli(command: &str, log: &Path, out: &Path, extra: &[&str]) -> String {
    let o = common::run_on(command, log, out, extra);
    assert!(o.status.success(), "{}", common::stderr(&o));
    common::stderr(&o)
}

/// Reads a fixture with its odometry named for the truth role.
fn with_reference(name: &str) -> Log {
    let options = IngestOptions {
        topics: [("truth".to_string(), ODOMETRY.to_string())].into(),
        ..IngestOptions::default()
    };
    read_log(&fixture(name), &options).unwrap()
}

#[test]
fn an_odometry_named_for_truth_is_the_reference_track() {
    for (sample_name, fixtures) in [(SURVEY, SURVEYS), (POOL, POOLS)] {
        let (json, mission) = json_log(sample_name, false);
        let defaults = common::defaults_of(&mission);
        let truth = json.role::<Truth>();
        assert!(truth.len() > 500, "{sample_name}");
        for (name, _, _) in fixtures {
            let mut log = with_reference(name);
            assert_eq!(log.role_topic::<Truth>(), Some(ODOMETRY), "{name}");
            log.settle_mission(&defaults).unwrap();
            let track = log.role::<Truth>();
            assert_eq!(track.len(), truth.len(), "{name}");
            for (a, b) in truth.iter().zip(track) {
                assert_eq!(a.stamp_ns, b.stamp_ns, "{name}");
                let degrees = [
                    a.latitude_deg - b.latitude_deg,
                    a.longitude_deg - b.longitude_deg,
                ];
                // 1e-11 deg is about a micrometre.
                assert!(
                    degrees.iter().all(|d| d.abs() < 1e-11),
                    "{name}: {a:?} {b:?}"
                );
                let ned = [
                    a.north_m - b.north_m,
                    a.east_m - b.east_m,
                    a.down_m - b.down_m,
                ];
                assert!(ned.iter().all(|d| d.abs() < 1e-9), "{name}: {ned:?}");
                for i in 0..3 {
                    assert_eq!(a.velocity_body[i], b.velocity_body[i], "{name}");
                    assert_eq!(a.angular_velocity[i], b.angular_velocity[i], "{name}");
                    assert_close(a.velocity_ned[i], b.velocity_ned[i], 1e-9, "velocity_ned");
                    let angle = hindsight::angle::wrap_pi(a.attitude[i] - b.attitude[i]);
                    assert!(angle.abs() < 1e-9, "{name}: attitude {a:?} {b:?}");
                }
            }
        }
    }
}

/// The default run of a bag, its odometry named for truth, is scored as the json original
/// against its /truth: the same errors, within a millimetre.
#[test]
fn a_bag_is_scored_against_its_odometry_as_the_original_against_its_truth() {
    let dir = common::scratch_dir("bags-odometry");
    let (bytes, mission) = json_window(SURVEY, false);
    let json_path = dir.join("survey-window.mcap");
    std::fs::write(&json_path, bytes).unwrap();
    let run = |log: &Path, out: &Path, extra: &[&str]| run_cli("reconstruct", log, out, extra);
    let (json_out, bag_out) = (dir.join("json"), dir.join("bag"));
    run(&json_path, &json_out, &[]);
    let origin = format!(
        "{},{}",
        mission.origin_latitude_deg, mission.origin_longitude_deg
    );
    let named = format!("truth={ODOMETRY}");
    let bag = fixture(SURVEYS[0].0);
    // A bag has no mission record: what the original's says is given.
    let mut given = vec!["--topic", &named, "--origin", &origin];
    let declination = mission.magnetic_declination_deg.map(|d| d.to_string());
    if let Some(d) = &declination {
        given.extend(["--declination", d]);
    }
    let said = run(&bag, &bag_out, &given);
    assert!(!said.contains("reference track"), "{said}");
    common::assert_same_float_columns(
        &json_out.join("errors.parquet"),
        &bag_out.join("errors.parquet"),
        "errors against the odometry",
    );
    // Without the origin, it comes from the first GNSS fix, and the run says the scores
    // may carry the difference.
    let said = run(&bag, &dir.join("bag-fix-origin"), &["--topic", &named]);
    assert!(
        said.contains("/ins/odometry: the reference track's world frame is placed on the origin"),
        "{said}"
    );
}

#[test]
fn the_same_missions_in_every_container_reconstruct_within_a_millimetre() {
    let config = Config::default();
    for (sample_name, fixtures) in [(SURVEY, SURVEYS), (POOL, POOLS)] {
        let (json, mission) = json_log(sample_name, false);
        // A bag has no mission record: the sample's origin and vehicle are given.
        let defaults = common::defaults_of(&mission);
        let reference = reconstruct(&Streams::of(&json), &mission, &config).unwrap();
        assert!(reference.smoothed.len() > 500, "{sample_name}");
        for (name, _, _) in fixtures {
            let log = read_log(&fixture(name), &IngestOptions::default()).unwrap();
            let mission = log.mission_or(&defaults).unwrap();
            let r = reconstruct(&Streams::of(&log), &mission, &config).unwrap();
            common::assert_within_a_millimetre(name, &reference, &r);
        }
    }
}

#[test]
fn the_same_pool_run_in_every_container_gives_attitude_within_a_millimetre() {
    let dir = common::scratch_dir("bags-attitude");
    let (bytes, mission) = json_window(POOL, false);
    let json_path = dir.join("pool-window.mcap");
    std::fs::write(&json_path, bytes).unwrap();
    let attitude = |log: &Path, out: &Path, extra: &[&str]| {
        run_cli("attitude", log, out, extra);
    };
    let json_out = dir.join("json");
    attitude(&json_path, &json_out, &[]);
    let origin = format!(
        "{},{}",
        mission.origin_latitude_deg, mission.origin_longitude_deg
    );
    let declination = mission.magnetic_declination_deg.unwrap().to_string();
    for (name, _, _) in POOLS {
        let out = dir.join(name.replace('.', "-"));
        attitude(
            &fixture(name),
            &out,
            &[
                "--origin",
                &origin,
                "--declination",
                &declination,
                "--topic",
                &format!("truth={ODOMETRY}"),
            ],
        );
        for file in ["attitude.parquet", "attitude_summary.parquet"] {
            let what = format!("{name} {file}");
            common::assert_same_float_columns(&json_out.join(file), &out.join(file), &what);
        }
    }
}

#[test]
fn info_names_the_container_and_reconstruct_reads_a_bag_folder() {
    for (name, words) in [
        ("survey_noetic_rep103.bag", "ROS 1 bag (format 2.0)"),
        ("survey_humble_rep103", "ROS 2 bag (sqlite3)"),
        ("survey_ros1_native.mcap", "mcap-ros1-support"),
    ] {
        let o = common::hindsight(&["info", fixture(name).to_str().unwrap()]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains(words), "{name}: {text}");
        assert!(
            text.contains("roles not at their default topic: imu /vehicle/imu/data"),
            "{text}"
        );
    }
    let out = common::scratch_dir("bags-reconstruct");
    let bag = fixture("survey_humble_rep103");
    let before: Vec<_> = std::fs::read_dir(&bag)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let o = common::hindsight(&[
        "reconstruct",
        bag.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(out.join("trajectory.parquet").exists());
    let after: Vec<_> = std::fs::read_dir(&bag)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(
        before.len(),
        after.len(),
        "nothing written beside the database"
    );
}

/// A real Water Linked A50, recorded by `rosbag record` (waterlinked/dvl-a50-ros-driver's
/// `dvl_circle.bag`, MIT): every reading of the driver's message, as hindsight reads it,
/// equals the DVL's own JSON output published beside it (`tests/fixtures/real`).
#[test]
fn a_real_water_linked_bag_reads_as_the_dvl_reported() {
    let dir = common::repo_path("tests/fixtures/real");
    let log = read_log(
        &dir.join("waterlinked_a50_circle.bag"),
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(log.file.container, Container::Ros1Bag);
    assert_eq!(log.role_topic::<Dvl>(), Some("/dvl/data"));
    let dvl = log.role::<Dvl>();
    let expected =
        std::fs::read_to_string(dir.join("waterlinked_a50_circle_expected.csv")).unwrap();
    let rows: Vec<Vec<&str>> = expected
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(dvl.len(), rows.len());
    let number = |s: &str| s.parse::<f64>().unwrap();
    for (d, row) in dvl.iter().zip(&rows) {
        assert_eq!(d.stamp_ns, row[0].parse::<i64>().unwrap());
        // The DVL's own frame is the contract's body frame (x forward, z down).
        assert_eq!(d.velocity, [number(row[1]), number(row[2]), number(row[3])]);
        assert_eq!(d.valid, row[4] == "1");
        let altitude = number(row[5]);
        assert_eq!(d.altitude, (altitude > 0.0).then_some(altitude));
    }
    let unlocked = dvl.iter().filter(|d| !d.valid).count();
    assert_eq!(unlocked, 75, "readings without bottom lock");
}
