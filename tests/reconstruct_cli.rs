//! `hindsight reconstruct` and `hindsight config` as a user runs them: files, summary,
//! errors and exit codes.

use crate::common;
use arrow_array::{Array, RecordBatch, StringArray};
use common::{hindsight, read_parquet, stderr, SAMPLE};
use hindsight::config::Section;
use hindsight::contract::Dvl;
use hindsight::ingest::Mission;
use hindsight::recon::config::Config;
use hindsight::sim::writer::{to_bytes, WriterOptions};

/// A float column of one solution's rows of trajectory.parquet.
fn trajectory_column(batches: &[RecordBatch], name: &str, solution: &str) -> Vec<f64> {
    use arrow_array::{Float64Array, StringArray};
    let mut out = Vec::new();
    for b in batches {
        let solutions = common::column::<StringArray>(b, "solution");
        let values = common::column::<Float64Array>(b, name);
        out.extend(
            (0..b.num_rows())
                .filter(|&i| solutions.value(i) == solution)
                .map(|i| values.value(i)),
        );
    }
    out
}

/// `hindsight reconstruct SAMPLE --out OUT --config CONFIG`.
fn reconstruct_sample_with(
    out: &std::path::Path,
    config: &std::path::Path,
) -> std::process::Output {
    hindsight(&[
        "reconstruct",
        SAMPLE,
        "--out",
        out.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
    ])
}

fn rows(batches: &[RecordBatch]) -> usize {
    batches.iter().map(RecordBatch::num_rows).sum()
}

#[test]
fn reconstruct_writes_trajectory_residuals_errors_and_summary() {
    let out = common::scratch_dir("reconstruct");
    let before = std::fs::read(SAMPLE).unwrap();
    let o = hindsight(&["reconstruct", SAMPLE, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(SAMPLE).unwrap(), before, "input untouched");
    let err = stderr(&o);
    for source in [
        "from first GNSS fix",
        "   magnetometer, declination",
        "from levelling",
    ] {
        assert!(err.contains(source), "`{source}` not in: {err}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let per_solution = summary["trajectory_rows_per_solution"].as_u64().unwrap() as usize;
    // 363 s at 10 Hz.
    assert!((3600..=3640).contains(&per_solution), "{per_solution}");
    assert_eq!(summary["initialisation"]["heading_source"], "magnetometer");
    assert!(
        summary["truth"]["smoothed"]["horizontal_rms_m"]
            .as_f64()
            .unwrap()
            < 2.0
    );
    assert!(summary["distance_travelled_m"].as_f64().unwrap() > 300.0);
    for key in [
        "sensors",
        "final_sigma",
        "run_time_s",
        "config",
        "inputs",
        "warnings",
    ] {
        assert!(!summary[key].is_null(), "summary.json lacks {key}");
    }

    let trajectory = read_parquet(&out.join("trajectory.parquet"));
    assert_eq!(rows(&trajectory), 2 * per_solution);
    let schema = trajectory[0].schema();
    for column in [
        "stamp_ns",
        "solution",
        "latitude_deg",
        "north_m",
        "vel_down_m_s",
        "yaw_rad",
        "north_sigma_m",
        "yaw_sigma_rad",
        "gyro_bias_z_rad_s",
        "accel_bias_x_m_s2",
        "dvl_scale_factor",
        "dvl_misalignment_heading_rad",
        "dvl_bias_z_m_s",
        "eml_scale_factor",
        "current_north_m_s",
    ] {
        assert!(
            schema.field_with_name(column).is_ok(),
            "trajectory lacks {column}"
        );
    }
    let solutions: Vec<String> = trajectory
        .iter()
        .flat_map(|b| {
            let c = b.column_by_name("solution").unwrap();
            let s = c.as_any().downcast_ref::<StringArray>().unwrap();
            (0..s.len())
                .map(|i| s.value(i).to_string())
                .collect::<Vec<_>>()
        })
        .collect();
    assert_eq!(
        solutions.iter().filter(|s| *s == "forward").count(),
        per_solution
    );
    assert_eq!(
        solutions.iter().filter(|s| *s == "smoothed").count(),
        per_solution
    );

    let residuals = read_parquet(&out.join("residuals.parquet"));
    assert_eq!(
        rows(&residuals) as u64,
        summary["residuals"].as_u64().unwrap()
    );
    let errors = read_parquet(&out.join("errors.parquet"));
    assert_eq!(rows(&errors), 2 * per_solution);
    // Besides the report's pictures (tests/report.rs checks those against its figures).
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".png"))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "errors.parquet",
            "report.html",
            "residuals.parquet",
            "summary.json",
            "trajectory.mcap",
            "trajectory.parquet",
            "tuned.toml"
        ]
    );
    // trajectory.mcap: each solution's rows as Foxglove messages (ROS 2 CDR), the smoothed
    // fix at the trajectory's latitude, read by the ingest's ROS 2 reader from the definition
    // the file carries.
    let bytes = std::fs::read(out.join("trajectory.mcap")).unwrap();
    let mut counts = std::collections::BTreeMap::<(String, String), usize>::new();
    let mut first_fix: Option<(f64, f64)> = None;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!(
            (
                m.channel.message_encoding.as_str(),
                schema.encoding.as_str()
            ),
            ("cdr", "ros2msg")
        );
        if m.channel.topic == "/hindsight/smoothed/fix" && first_fix.is_none() {
            use hindsight::ingest::ros::{cdr::Plan, msg};
            let text = std::str::from_utf8(&schema.data).unwrap();
            let defs = msg::parse(&schema.name, text).unwrap();
            let plan = Plan::new(&defs, &["latitude", "position_covariance[8]"], &[]).unwrap();
            let got = plan.read(&m.data).unwrap();
            first_fix = Some((got.number[0], got.number[1]));
        }
        *counts
            .entry((m.channel.topic.clone(), schema.name.clone()))
            .or_default() += 1;
    }
    let expected: Vec<((String, String), usize)> = [
        ("/hindsight/forward/fix", "foxglove_msgs/msg/LocationFix"),
        ("/hindsight/forward/pose", "foxglove_msgs/msg/PoseInFrame"),
        ("/hindsight/smoothed/fix", "foxglove_msgs/msg/LocationFix"),
        ("/hindsight/smoothed/pose", "foxglove_msgs/msg/PoseInFrame"),
    ]
    .into_iter()
    .map(|(t, s)| ((t.to_string(), s.to_string()), per_solution))
    .collect();
    assert_eq!(counts.into_iter().collect::<Vec<_>>(), expected);
    let (latitude, up_variance) = first_fix.unwrap();
    let smoothed_latitude = trajectory_column(&trajectory, "latitude_deg", "smoothed")[0];
    assert!(
        (latitude - smoothed_latitude).abs() < 1e-9,
        "{latitude} against {smoothed_latitude}"
    );
    // The up variance is the down sigma squared.
    let down_sigma = trajectory_column(&trajectory, "down_sigma_m", "smoothed")[0];
    assert!(
        (up_variance.sqrt() - down_sigma).abs() < 1e-6 * down_sigma,
        "{up_variance} against {down_sigma}^2"
    );
    // Self-tuning's figures are reported and reusable as a configuration that fixes them.
    let tuning = &summary["tuning"];
    assert_eq!(tuning["imu"]["source"], "estimated", "{tuning}");
    let tuned = hindsight::recon::config::Config::from_toml(
        &std::fs::read_to_string(out.join("tuned.toml")).unwrap(),
    )
    .unwrap();
    assert!(tuned.fixed.contains("imu.gyro_arw_deg_rt_h") && tuned.fixed.contains("dvl.sigma_m_s"));
    assert_eq!(
        tuned.imu.spec().gyro_arw_deg_rt_h,
        tuning["imu"]["figures"]["gyro_arw_deg_rt_h"]
            .as_f64()
            .unwrap()
    );
}

/// `hindsight config SECTION` prints each command's documented defaults, which parse back
/// to them; `hindsight config` alone is reconstruct's.
#[test]
fn config_prints_the_documented_defaults() {
    fn printed<T: Section + PartialEq + std::fmt::Debug>(args: &[&str]) {
        let o = hindsight(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        assert_eq!(T::from_toml(&text).unwrap(), T::default(), "{args:?}");
        assert_eq!(text, T::DEFAULT_TOML);
    }
    use hindsight::{attitude::config::AttitudeConfig, identify::config::IdentifyConfig};
    printed::<Config>(&["config"]);
    printed::<Config>(&["config", "reconstruct"]);
    printed::<AttitudeConfig>(&["config", "attitude"]);
    printed::<IdentifyConfig>(&["config", "identify"]);
}

/// Every command that takes a settings file refuses an unknown key the same way: the file,
/// the key and its line named, a hint to the command that lists the keys, exit 2, and no
/// output written.
#[test]
fn every_command_refuses_an_unknown_key_naming_file_and_key() {
    let dir = common::scratch_dir("config-unknown-key");
    let log = dir.join("log.mcap");
    std::fs::copy(SAMPLE, &log).unwrap();
    let config = dir.join("settings.toml");
    std::fs::write(&config, "[dvl]\n\nsigma_ms = 0.1\n").unwrap();
    let out = dir.join("out");
    let (l, c, o) = (
        log.to_str().unwrap(),
        config.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    for (command, section) in [
        ("reconstruct", "reconstruct"),
        ("batch", "reconstruct"),
        ("attitude", "attitude"),
        ("identify", "identify"),
    ] {
        let run = hindsight(&[command, l, "--config", c, "--out", o]);
        let err = stderr(&run);
        assert_eq!(run.status.code(), Some(2), "{command}: {err}");
        let wanted = [
            "settings.toml",
            if section == "identify" {
                "dvl"
            } else {
                "sigma_ms"
            },
            "line",
            &format!("hindsight config {section}"),
        ];
        for w in wanted {
            assert!(err.contains(w), "{command}: {w:?} not in {err}");
        }
        assert!(!out.exists(), "{command} wrote {}", out.display());
    }
}

#[test]
fn bad_configuration_and_logs_without_imu_are_clear_errors() {
    let dir = common::scratch_dir("reconstruct-bad");
    let out = dir.join("out");
    let config = dir.join("bad.toml");
    std::fs::write(&config, "[dvl]\nsigma = 0.01\n").unwrap();
    let o = reconstruct_sample_with(&out, &config);
    common::assert_refused(&o, "sigma");
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().next().is_none());

    // A log with a mission and a DVL, but no IMU.
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&Mission {
            origin_latitude_deg: 35.0,
            origin_longitude_deg: 129.0,
            vehicle: "remus-100".into(),
            description: "no IMU".into(),
            initial_yaw_rad: None,
            magnetic_declination_deg: None,
        })?;
        for k in 0..10 {
            let d = Dvl {
                stamp_ns: 1_700_000_000_000_000_000 + k * 200_000_000,
                velocity: [1.0, 0.0, 0.0],
                valid: true,
                altitude: Some(20.0),
            };
            w.write("/dvl", &d, d.stamp_ns as u64)?;
        }
        Ok(())
    })
    .unwrap();
    let log = dir.join("no-imu.mcap");
    std::fs::write(&log, &bytes).unwrap();
    let o = hindsight(&[
        "reconstruct",
        log.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("no IMU data on /imu"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().next().is_none());
}

/// The epoch records of the sample log (3600 epochs) go to a temporary file beyond their
/// first block. Where no temporary file can be made (a full disk, a missing TMPDIR) the run
/// holds them in memory, says so, and writes the very same trajectory.
#[test]
fn without_a_temporary_file_the_records_stay_in_memory_and_the_result_is_the_same() {
    let run = |name: &str, tmpdir: Option<&std::path::Path>| {
        let out = common::scratch_dir(name);
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_hindsight"));
        command.args(["reconstruct", SAMPLE, "--out", out.to_str().unwrap()]);
        if let Some(dir) = tmpdir {
            command.env("TMPDIR", dir);
        }
        let o = command.output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        let warnings: Vec<(String, String)> = summary["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| {
                let text = |key: &str| w[key].as_str().unwrap().to_string();
                (text("code"), text("message"))
            })
            .collect();
        (
            std::fs::read(out.join("trajectory.parquet")).unwrap(),
            warnings,
        )
    };
    let (spilled, spilled_warnings) = run("spill-normal", None);
    let missing = std::env::temp_dir().join("hindsight-no-such-dir/deeper");
    let (held, held_warnings) = run("spill-missing", Some(&missing));
    assert_eq!(spilled, held, "the same trajectory either way");
    let held_in_memory = |(code, _): &&(String, String)| code == "held_in_memory";
    assert!(!spilled_warnings.iter().any(|w| held_in_memory(&w)));
    let said: Vec<&(String, String)> = held_warnings.iter().filter(held_in_memory).collect();
    assert_eq!(said.len(), 1, "{held_warnings:?}");
    let message = &said[0].1;
    assert!(message.starts_with("memory:"), "{message}");
    assert!(message.contains("hindsight-no-such-dir"), "{message}");
}

/// The plan is printed and kept in summary.json; a model aid the configuration forces on in a
/// log without `/fins` is refused with the reason (a warning, exit 0) and the rest runs.
#[test]
fn the_plan_is_shown_and_a_forced_part_the_log_cannot_support_is_refused() {
    let out = common::scratch_dir("reconstruct-plan");
    let config = out.with_extension("toml");
    std::fs::write(&config, "[model_velocity]\nuse = true\n").unwrap();
    let o = reconstruct_sample_with(&out, &config);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("plan (what is used and why):"), "{err}");
    assert!(
        err.contains("warning: model_velocity: switched on, but not used") && err.contains("/fins"),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let decisions = summary["plan"]["decisions"].as_array().unwrap();
    let model = decisions
        .iter()
        .find(|d| d["name"] == "model_velocity")
        .unwrap();
    assert_eq!(model["used"], false);
    assert_eq!(model["reason"], "forced_but_missing");
    let dvl = decisions.iter().find(|d| d["name"] == "dvl").unwrap();
    assert_eq!(dvl["used"], true);
    assert!(
        summary["truth"]["forward"]["horizontal_rms_m"]
            .as_f64()
            .unwrap()
            < 2.0
    );
}
