//! The seed 002 study through `hindsight study`: the in-run alignment of a dropped
//! vehicle (IMU, propeller, depth, compass; no DVL), four cases of +-10 deg start roll and
//! pitch, scored against `/truth`. The 100-run study is the README's command; this is the
//! 10-run version, with the same criteria.

use crate::common;
use arrow_array::{Array, Float64Array, StringArray, UInt64Array};

fn column<'a, T: 'static>(b: &'a arrow_array::RecordBatch, name: &str) -> &'a T {
    b.column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<T>()
        .unwrap()
}

/// Roll and pitch errors after the alignment: mean <= 0.2 deg and sigma <= 0.15 deg in each
/// case (seed 002: mean 0.25-0.85, sigma 0.14-0.19), every run aligned, the time reported.
#[test]
fn seed_002_in_run_alignment_study_of_ten_runs() {
    let out = common::scratch_dir("study").join("out");
    let o = common::hindsight(&[
        "study",
        "--scenario",
        "drop-no-dvl",
        "--runs",
        "10",
        "--tilt",
        "10,10",
        "--tilt",
        "10,-10",
        "--tilt=-10,10",
        "--tilt=-10,-10",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    println!("{}", String::from_utf8_lossy(&o.stdout));
    let summary = &common::read_parquet(&out.join("summary.parquet"))[0];
    assert_eq!(summary.num_rows(), 4);
    let runs: &UInt64Array = column(summary, "runs");
    let aligned: &UInt64Array = column(summary, "aligned");
    for k in 0..4 {
        assert_eq!((runs.value(k), aligned.value(k)), (10, 10), "case {k}");
        for angle in ["roll", "pitch"] {
            let mean: &Float64Array = column(summary, &format!("{angle}_error_mean_deg"));
            let sigma: &Float64Array = column(summary, &format!("{angle}_error_sigma_deg"));
            assert!(
                mean.value(k).abs() <= 0.2,
                "case {k} {angle} mean {}",
                mean.value(k)
            );
            assert!(
                sigma.value(k) <= 0.15,
                "case {k} {angle} sigma {}",
                sigma.value(k)
            );
        }
        let after: &Float64Array = column(summary, "aligned_after_mean_s");
        assert!(after.value(k) > 1.0 && after.value(k) < 100.0);
    }
    assert!(out.join("error_vs_time.png").exists());
    let rows = &common::read_parquet(&out.join("runs.parquet"))[0];
    assert_eq!(rows.num_rows(), 40);
    let errors: &StringArray = column(rows, "error");
    assert_eq!(errors.null_count(), 40, "every run succeeded");
}

/// The same seeds give the same numbers whatever the thread count; no runs is refused.
#[test]
fn study_is_deterministic_and_refuses_no_runs() {
    let dir = common::scratch_dir("study-determinism");
    let table = |jobs: &str| {
        let out = dir.join(format!("jobs{jobs}"));
        let o = common::hindsight(&[
            "study",
            "--scenario",
            "drop-no-dvl",
            "--runs",
            "3",
            "--seed-base",
            "40",
            "--jobs",
            jobs,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        common::read_parquet(&out.join("runs.parquet"))
    };
    assert_eq!(table("1"), table("2"));
    let o = common::hindsight(&[
        "study",
        "--scenario",
        "drop-no-dvl",
        "--runs",
        "0",
        "--out",
        dir.join("none").to_str().unwrap(),
    ]);
    let text = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{text}");
    assert!(text.contains("--runs"), "{text}");
    assert!(!text.contains("panicked"), "{text}");
}

/// The RMS over the runs of a case's and solution's horizontal error (forward, smoothed)
/// and mean body-x velocity error at the row nearest `t_s`.
fn at_time(out: &std::path::Path, case: &str, solution: &str, t_s: f64) -> (f64, f64, f64) {
    let batches = common::read_parquet(&out.join("error_vs_time.parquet"));
    let mut best: Option<(f64, (f64, f64, f64))> = None;
    for b in &batches {
        let cases: &StringArray = column(b, "case");
        let solutions: &StringArray = column(b, "solution");
        let t: &Float64Array = column(b, "t_s");
        let fwd: &Float64Array = column(b, "forward_rms_m");
        let smo: &Float64Array = column(b, "smoothed_rms_m");
        let vx: &Float64Array = column(b, "body_x_velocity_error_mean_m_s");
        for i in 0..b.num_rows() {
            if cases.value(i) != case || solutions.value(i) != solution {
                continue;
            }
            let d = (t.value(i) - t_s).abs();
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, (fwd.value(i), smo.value(i), vx.value(i))));
            }
        }
    }
    best.unwrap_or_else(|| panic!("no row for {case} / {solution}"))
        .1
}

/// Seed 000's figures at 5 h (RMS over the runs, forward / smoothed / mean body-x velocity
/// error).
struct Seed000 {
    proposed2: (f64, f64, f64),
    proposed1: (f64, f64, f64),
    koifman2: (f64, f64, f64),
    koifman2_at_2h: (f64, f64, f64),
    pure2: (f64, f64, f64),
}

/// The seed 000 study: `long-dive-dynamic` at seed 000's SDINS rate (10 Hz), exact
/// and 10 % uncertain coefficients, each run reconstructed by pure SDINS, Koifman's virtual
/// sensor and the proposed model-aided filter, scored against `/truth`; the bars
/// that hold for any number of runs asserted.
fn seed_000_study(runs: u64) -> Seed000 {
    let out = common::scratch_dir(&format!("study000-{runs}")).join("out");
    let config = |name: &str| {
        format!(
            "{name}={}/configs/seed000-{name}.toml",
            env!("CARGO_MANIFEST_DIR")
        )
    };
    let (pure, koifman, proposed) = (config("pure"), config("koifman"), config("proposed"));
    let runs = runs.to_string();
    let o = common::hindsight(&[
        "study",
        "--scenario",
        "long-dive-dynamic",
        "--imu-rate-hz",
        "10",
        "--runs",
        &runs,
        "--coef-uncertainty",
        "0",
        "--coef-uncertainty",
        "0.1",
        "--solution",
        &pure,
        "--solution",
        &koifman,
        "--solution",
        &proposed,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    println!("{}", String::from_utf8_lossy(&o.stdout));
    let (case1, case2) = ("coefficients +-0 %", "coefficients +-10 %");
    let five_h = 5.0 * 3600.0;
    let f = Seed000 {
        proposed2: at_time(&out, case2, "proposed", five_h),
        proposed1: at_time(&out, case1, "proposed", five_h),
        koifman2: at_time(&out, case2, "koifman", five_h),
        koifman2_at_2h: at_time(&out, case2, "koifman", 2.0 * 3600.0),
        pure2: at_time(&out, case2, "pure", five_h),
    };
    let Seed000 {
        proposed2,
        proposed1,
        koifman2,
        koifman2_at_2h,
        pure2,
    } = f;
    println!(
        "at 5 h, RMS forward / smoothed: proposed case 2 {:.1} / {:.1} m, case 1 {:.1} / {:.1} m; \
         koifman case 2 {:.1} m (2 h: {:.1} m), mean body-x velocity error {:+.3} m/s; pure {:.1} m",
        proposed2.0, proposed2.1, proposed1.0, proposed1.1, koifman2.0, koifman2_at_2h.0, koifman2.2, pure2.0
    );
    // Seed 000: the proposed filter holds about 400 m in case 2; the bar is 300 m.
    assert!(
        proposed2.0 <= 300.0,
        "proposed, case 2, at 5 h: {:.1} m",
        proposed2.0
    );
    assert!(
        proposed1.0 < proposed2.0,
        "case 1 {:.1} m against case 2 {:.1} m",
        proposed1.0,
        proposed2.0
    );
    // Koifman's virtual sensor carries the model's errors: it drifts and ends far worse.
    assert!(koifman2.0 > 3.0 * proposed2.0 && koifman2.0 > koifman2_at_2h.0);
    // The smoother, with the fixes after the surfacing, at most halves the forward error.
    assert!(
        proposed2.1 <= 0.5 * proposed2.0,
        "smoothed {:.1} against forward {:.1}",
        proposed2.1,
        proposed2.0
    );
    // Both model-aided solutions beat the unaided INS.
    assert!(pure2.0 > koifman2.0.min(proposed2.0));
    f
}

/// The CI version: 3 runs per case (the bars hold with margins of 2 to 10 times: at 5 h the
/// proposed filter's forward RMS 30 m against its 300 m bar, Koifman's 690 m; 32 s alone on 2
/// cores, where 5 runs took twice that).
#[test]
fn seed_000_model_aided_study_of_three_runs() {
    seed_000_study(3);
}

/// The 100 runs per case (about 26 minutes on 2 cores, so not in CI):
/// `cargo test --release --test all study::seed_000_model_aided_study_of_100_runs -- --ignored
/// --nocapture`. With 100 runs the pure SDINS's RMS is close enough to its expectation to
/// be held to seed 000's figure: within 40 % of 1.4 km.
#[test]
#[ignore]
fn seed_000_model_aided_study_of_100_runs() {
    let f = seed_000_study(100);
    assert!(
        (0.6 * 1400.0..=1.4 * 1400.0).contains(&f.pure2.0),
        "pure SDINS at 5 h: {:.1} m",
        f.pure2.0
    );
}
