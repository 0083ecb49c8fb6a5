//! `hindsight identify` as a user runs it: outputs, the console table, and bad input (no
//! /fins, no manoeuvre, too short, a bad option).

use crate::common;
use arrow_array::{Float64Array, RecordBatch, StringArray};
use common::{hindsight, read_parquet, stderr};
use hindsight::contract::{Attitude, ControlSurfaces, Depth, Dvl, Imu};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::sim::zigzag::{self, ZigzagSpec};
use std::path::{Path, PathBuf};

/// A zig-zag log (changed by `edit`) written to a scratch folder.
fn log(dir: &Path, name: &str, edit: impl Fn(&mut ZigzagSpec)) -> PathBuf {
    let mut spec = ZigzagSpec::built_in(name).unwrap();
    edit(&mut spec);
    let bytes = to_bytes(WriterOptions::default(), |w| {
        zigzag::run(&spec, 1, w)?;
        Ok(())
    })
    .unwrap();
    let path = dir.join(format!("{name}.mcap"));
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The zig-zag 10-5 log rewritten without one topic (its mission and the other inputs kept).
fn without(dir: &Path, topic: &str) -> PathBuf {
    let full = common::read(&std::fs::read(log(dir, "zigzag-10-5", |_| {})).unwrap());
    fn copy<T: hindsight::contract::Message>(
        w: &mut hindsight::sim::writer::LogWriter<std::io::Cursor<Vec<u8>>>,
        log: &hindsight::ingest::Log,
        topic: &str,
        skip: &str,
    ) -> Result<(), hindsight::sim::writer::WriteError> {
        if topic != skip {
            for m in log.messages::<T>(topic).unwrap() {
                w.write(topic, m, m.stamp_ns() as u64)?;
            }
        }
        Ok(())
    }
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&full.mission().unwrap())?;
        copy::<Imu>(w, &full, "/imu", topic)?;
        copy::<ControlSurfaces>(w, &full, "/fins", topic)?;
        copy::<Attitude>(w, &full, "/attitude", topic)?;
        copy::<Dvl>(w, &full, "/dvl", topic)?;
        copy::<Depth>(w, &full, "/depth", topic)?;
        Ok(())
    })
    .unwrap();
    let path = dir.join(format!("without-{}.mcap", topic.trim_start_matches('/')));
    std::fs::write(&path, bytes).unwrap();
    path
}

fn run(logs: &[&Path], out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["identify".to_string()];
    args.extend(logs.iter().map(|p| p.to_str().unwrap().to_string()));
    args.extend(["--out".to_string(), out.to_str().unwrap().to_string()]);
    args.extend(extra.iter().map(|s| s.to_string()));
    hindsight(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

#[test]
fn both_runs_give_every_output() {
    let dir = common::scratch_dir("identify-cli");
    let a = log(&dir, "zigzag-5-5", |_| {});
    let b = log(&dir, "zigzag-10-5", |_| {});
    let before = std::fs::read(&a).unwrap();
    let out = dir.join("out");
    let o = run(&[&a, &b], &out, &["--perturb", "0.2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&a).unwrap(), before, "input untouched");
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(console.contains("M_qdot"), "{console}");
    assert!(
        console.contains("warning: Z_wdot is poorly determined"),
        "{console}"
    );
    assert!(!console.contains("POOR FIT"), "{console}");
    // coefficients.parquet: ten rows, estimate and sigma, the flag.
    let c = &read_parquet(&out.join("coefficients.parquet"))[0];
    assert_eq!(c.num_rows(), 10);
    let names = common::column::<StringArray>(c, "name");
    assert_eq!(names.value(8), "M_qdot");
    let estimate = common::column::<Float64Array>(c, "estimate");
    let sigma = common::column::<Float64Array>(c, "sigma");
    // M_qdot, the one coefficient these runs determine: within 3 sigma of seed 004's truth.
    assert!((estimate.value(8) - -0.005198).abs() < 3.0 * sigma.value(8));
    for name in [
        "correlation.parquet",
        "coefficient_history.parquet",
        "fit.parquet",
    ] {
        let rows: usize = read_parquet(&out.join(name))
            .iter()
            .map(RecordBatch::num_rows)
            .sum();
        assert!(rows >= 10, "{name}: {rows}");
    }
    let fit = read_parquet(&out.join("fit.parquet"));
    let rows: usize = fit.iter().map(RecordBatch::num_rows).sum();
    assert_eq!(rows, 2 * 20_001);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for log_fit in summary["fit"].as_array().unwrap() {
        for ch in ["q", "theta", "w", "depth"] {
            let v = log_fit[ch]["normalised_rms"].as_f64().unwrap();
            assert!((0.9..1.1).contains(&v), "{ch}: {v}");
        }
    }
    for png in ["convergence.png", "fit_theta.png", "fit_w.png"] {
        assert_eq!(&std::fs::read(out.join(png)).unwrap()[1..4], b"PNG");
    }
}

#[test]
fn a_forced_coefficient_that_breaks_the_model_is_a_poor_fit() {
    let dir = common::scratch_dir("identify-cli-forced");
    let a = log(&dir, "zigzag-10-5", |_| {});
    let o = run(&[&a], &dir.join("out"), &["--fix", "Z_delta=0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(console.contains("POOR FIT"), "{console}");
    assert!(
        console
            .lines()
            .any(|l| l.starts_with("Z_delta") && l.contains("(fixed)")),
        "{console}"
    );
}

#[test]
fn bad_input_is_named() {
    let dir = common::scratch_dir("identify-cli-bad");
    // A straight run: the plane never moves.
    let straight = log(&dir, "zigzag-5-5", |s| s.plane_deg = 0.0);
    let o = run(&[&straight], &dir.join("out1"), &[]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("no manoeuvre"), "{}", stderr(&o));
    // Shorter than the model's slowest time constant.
    let short = log(&dir, "zigzag-10-5", |s| s.duration_s = 30.0);
    let o = run(&[&short], &dir.join("out2"), &[]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("shorter than the model's slowest time constant"),
        "{}",
        stderr(&o)
    );
    // No /fins: the same log without its input.
    let no_fins = without(&dir, "/fins");
    let o = run(&[&no_fins], &dir.join("out3"), &[]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no stern-plane input on /fins"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("out3").exists());
    // A coefficient name that does not exist.
    let o = run(&[&straight], &dir.join("out4"), &["--fix", "Z_ww=0"]);
    common::assert_refused(&o, "unknown coefficient `Z_ww`");
}

/// Without /attitude, theta comes from hindsight's own attitude (gyro and accelerometer);
/// starting values from a file.
#[test]
fn own_attitude_and_a_start_file() {
    let dir = common::scratch_dir("identify-cli-own");
    let no_attitude = without(&dir, "/attitude");
    let start = dir.join("start.toml");
    std::fs::write(&start, "M_qdot = -0.006\nZ_w = -0.025\n").unwrap();
    let out = dir.join("out");
    let o = run(
        &[&no_attitude],
        &out,
        &["--initial", start.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("theta from hindsight's attitude"),
        "{}",
        stderr(&o)
    );
    let c = &read_parquet(&out.join("coefficients.parquet"))[0];
    let initial = common::column::<Float64Array>(c, "initial");
    assert_eq!((initial.value(0), initial.value(8)), (-0.025, -0.006));
    // The model still explains the motion (measured: theta fit 99.8 %; the own pitch is
    // smoothed, so its residuals are below the /attitude sensor's sigma).
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let theta = summary["fit"][0]["theta"]["fit_percent"].as_f64().unwrap();
    println!(
        "theta fit with hindsight's own attitude: {theta:.1} %; {}",
        summary["fit"][0]
    );
    assert!(theta > 90.0, "{theta}");
    // A start file naming an unknown coefficient is refused.
    std::fs::write(&start, "Z_ww = 1.0\n").unwrap();
    let o = run(
        &[&no_attitude],
        &dir.join("out2"),
        &["--initial", start.to_str().unwrap()],
    );
    common::assert_refused(&o, "unknown coefficient `Z_ww`");
}

/// `hindsight config identify` prints every key, and that text read back with `--config` is accepted;
/// a bad value is named with its key and the file, a failing exit, and nothing is written.
#[test]
fn the_configuration_is_printed_and_read() {
    let dir = common::scratch_dir("identify-cli-config");
    let printed = hindsight(&["config", "identify"]);
    assert!(printed.status.success(), "{}", stderr(&printed));
    let text = String::from_utf8_lossy(&printed.stdout).into_owned();
    for key in [
        "[noise]",
        "learn = true",
        "max_residual_lag1",
        "[ekf]",
        "[refinement]",
    ] {
        assert!(text.contains(key), "{key} in {text}");
    }
    let a = log(&dir, "zigzag-10-5", |_| {});
    let config = dir.join("identify.toml");
    std::fs::write(&config, text.replace("learn = true", "learn = false")).unwrap();
    let out = dir.join("out");
    let o = run(&[&a], &out, &["--config", config.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["noise"]["learnt"], false);
    assert!(String::from_utf8_lossy(&o.stdout).contains("sensor noise as given"));

    std::fs::write(&config, "[noise]\ndepth_m = -0.01\n").unwrap();
    let bad_out = dir.join("bad-out");
    let o = run(&[&a], &bad_out, &["--config", config.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("noise.depth_m") && err.contains("identify.toml"),
        "{err}"
    );
    assert!(!bad_out.exists());
}

/// `--suggest` as a user follows it: the suggestion printed with the simulator command that
/// flies it, that command run, the logs identified again with the ballast given, and the
/// sigma of every coefficient it names lower, near the prediction.
#[test]
fn a_suggestion_is_printed_and_followed() {
    let dir = common::scratch_dir("identify-cli-suggest");
    let simulate = |args: &[&str]| {
        let o = hindsight(&[&["simulate"], args].concat());
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let (a, b) = (dir.join("zz55.mcap"), dir.join("zz105.mcap"));
    simulate(&[
        "--scenario",
        "zigzag-5-5",
        "--seed",
        "1",
        "--out",
        a.to_str().unwrap(),
    ]);
    simulate(&[
        "--scenario",
        "zigzag-10-5",
        "--seed",
        "1001",
        "--out",
        b.to_str().unwrap(),
    ]);
    let out = dir.join("out");
    let o = run(&[&a, &b], &out, &["--suggest"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let console = String::from_utf8_lossy(&o.stdout);
    assert!(console.contains("experiment design"), "{console}");
    let summary = |out: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
    };
    let best = summary(&out)["design"]["candidates"][0].clone();
    let how = best["how"].as_str().unwrap();
    assert!(console.contains(how), "{console}");
    // "fly it, then identify from all the logs with --weight-minus-buoyancy candidate.mcap=N;
    // in the simulator: hindsight simulate --scenario ... --out candidate.mcap"
    let ballast = how
        .split_whitespace()
        .find_map(|w| w.strip_prefix("candidate.mcap="))
        .map(|n| n.trim_end_matches(';'))
        .expect(how);
    let command = how
        .split("in the simulator: hindsight simulate ")
        .nth(1)
        .expect(how);
    let candidate = dir.join("candidate.mcap");
    let mut args: Vec<&str> = command
        .split_whitespace()
        .map(|w| {
            if w == "candidate.mcap" {
                candidate.to_str().unwrap()
            } else {
                w
            }
        })
        .collect();
    args.extend(["--seed", "2001"]);
    simulate(&args);
    let again = dir.join("again");
    let given = format!("candidate.mcap={ballast}");
    let o = run(
        &[&a, &b, &candidate],
        &again,
        &["--weight-minus-buoyancy", &given],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("W - B = {ballast} N")),
        "{}",
        stderr(&o)
    );
    // Each coefficient's estimate and 1-sigma.
    let table = |out: &Path| -> Vec<(f64, f64)> {
        let c = &read_parquet(&out.join("coefficients.parquet"))[0];
        let column = |name: &str| common::column::<Float64Array>(c, name).clone();
        let (e, s) = (column("estimate"), column("sigma"));
        (0..10).map(|i| (e.value(i), s.value(i))).collect()
    };
    let (now, after) = (table(&out), table(&again));
    let names = hindsight::vehicle::heave_pitch::NAMES;
    let named = best["determines"].as_array().unwrap();
    assert!(!named.is_empty(), "{best}");
    for n in named {
        let i = names
            .iter()
            .position(|x| *x == n.as_str().unwrap())
            .unwrap();
        // The prediction is in % of the estimate it was made at.
        let predicted =
            best["predicted_sigma_percent"][names[i]].as_f64().unwrap() / 100.0 * now[i].0.abs();
        println!(
            "{}: 1-sigma now {:.3e}, predicted {predicted:.3e}, after {:.3e}",
            names[i], now[i].1, after[i].1
        );
        assert!(
            predicted < 0.5 * now[i].1 && after[i].1 < 0.5 * now[i].1,
            "{}",
            names[i]
        );
        assert!(
            (0.67..1.5).contains(&(after[i].1 / predicted)),
            "{}",
            names[i]
        );
    }
    // A ballast for a log that is not there, and a ballast for a scenario that is no zig-zag.
    let o = run(
        &[&a],
        &dir.join("bad"),
        &["--weight-minus-buoyancy", "nosuch.mcap=10"],
    );
    common::assert_refused(&o, "nosuch.mcap");
    let o = hindsight(&[
        "simulate",
        "--scenario",
        "survey-short",
        "--weight-minus-buoyancy",
        "10",
        "--out",
        dir.join("x.mcap").to_str().unwrap(),
    ]);
    common::assert_refused(&o, "zig-zags");
}
