//! Coefficient identification on seed 004's zig-zags (simulated, seeded sensor noise at the
//! realistic levels), started 20 % off on every coefficient; scored against the true
//! coefficients the simulator used.
//!
//! `cargo test --release --test all identify:: -- --nocapture`
//! Monte Carlo (100 seeds): `cargo test --release --test all identify:: -- --ignored --nocapture`

// Coefficients are indexed in parallel arrays (names, true values, estimates, covariance).
#![allow(clippy::needless_range_loop)]

use crate::common;
use hindsight::identify::identifiability::assess;
use hindsight::identify::output_error::{refine, Refined};
use hindsight::identify::record::Record;
use hindsight::identify::settings::Settings;
use hindsight::identify::{ekf, identify, perturbed};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::sim::zigzag::{self, ZigzagNoise, ZigzagSpec};
use hindsight::vehicle::heave_pitch::{Coefficients, NAMES, TRUE_COEFFICIENTS};

fn record(name: &str, seed: u64, noise: ZigzagNoise) -> Record {
    let spec = ZigzagSpec {
        noise,
        ..ZigzagSpec::built_in(name).unwrap()
    };
    let bytes = to_bytes(WriterOptions::default(), |w| {
        zigzag::run(&spec, seed, w)?;
        Ok(())
    })
    .unwrap();
    Record::from_log(name, &common::read(&bytes), None).unwrap()
}

fn both(seed: u64, noise: ZigzagNoise) -> Vec<Record> {
    ["zigzag-5-5", "zigzag-10-5"]
        .iter()
        .map(|n| record(n, seed, noise))
        .collect()
}

fn truth() -> Coefficients {
    Coefficients::from(TRUE_COEFFICIENTS)
}

fn relative_error(c: &Coefficients, i: usize) -> f64 {
    (c[i] - TRUE_COEFFICIENTS[i]) / TRUE_COEFFICIENTS[i]
}

fn sigma(cov: &nalgebra::SMatrix<f64, 10, 10>, i: usize) -> f64 {
    cov[(i, i)].sqrt()
}

fn print(label: &str, c: &Coefficients, cov: &nalgebra::SMatrix<f64, 10, 10>) {
    println!("{label}");
    for i in 0..10 {
        println!(
            "  {:<8} true {:>11.6}  estimate {:>11.6}  error {:>8.3} %  1-sigma {:>8.3} %  error/sigma {:>5.2}",
            NAMES[i],
            TRUE_COEFFICIENTS[i],
            c[i],
            relative_error(c, i) * 100.0,
            sigma(cov, i) / TRUE_COEFFICIENTS[i].abs() * 100.0,
            (c[i] - TRUE_COEFFICIENTS[i]).abs() / sigma(cov, i)
        );
    }
}

/// Seed 1, both runs, the sensor noise: what the data determine and how well.
#[test]
fn identification_on_seeded_zigzags() {
    let settings = Settings::default();
    let records = both(1, ZigzagNoise::realistic());
    let start = perturbed(&truth(), 0.2);
    let e = ekf::run(&records, &start, &settings);
    print("EKF stage (both runs)", &e.coefficients, &e.covariance);
    let r: Refined = refine(&records, &e.coefficients, &settings);
    print(
        "output-error refinement (both runs)",
        &r.coefficients,
        &r.covariance,
    );
    println!(
        "normalised residual RMS (q, theta, w, depth): {:.3?}; {} iterations",
        r.normalised_rms, r.iterations
    );
    assert_eq!(e.failed_updates, 0);
    assert!(r.converged);
    // The model fits to the sensor noise in every channel.
    for v in r.normalised_rms {
        assert!((0.9..1.1).contains(&v), "{:?}", r.normalised_rms);
    }
    // Both stages are consistent: the truth is inside 3 sigma of each, for all ten.
    for i in 0..10 {
        for (stage, c, cov) in [
            ("ekf", &e.coefficients, &e.covariance),
            ("refined", &r.coefficients, &r.covariance),
        ] {
            let z = (c[i] - TRUE_COEFFICIENTS[i]).abs() / sigma(cov, i);
            assert!(z < 3.0, "{stage} {}: {z:.2} sigma", NAMES[i]);
        }
    }
    // What the data determine (measured): M_qdot to 0.13 %, nothing else to 5 %: the rest
    // is flagged, not printed as a confident number.
    let flagged: Vec<String> = assess(
        &r.coefficients,
        &r.covariance,
        &settings.fixed,
        &settings.thresholds,
    )
    .into_iter()
    .filter(|d| d.poorly_determined)
    .map(|d| d.name)
    .collect();
    println!("flagged as poorly determined: {flagged:?}");
    assert!(!flagged.iter().any(|n| n == "M_qdot"));
    for name in [
        "Z_w", "Z_wdot", "Z_q", "Z_qdot", "Z_delta", "M_w", "M_wdot", "M_q",
    ] {
        assert!(flagged.iter().any(|n| n == name), "{name} not flagged");
    }
}

/// Without noise, from 20 % off, the refinement finds the truth; started at the truth it
/// stays there (no drift).
#[test]
fn noise_free_logs_give_the_truth() {
    let settings = Settings::default();
    let records = both(1, ZigzagNoise::none());
    let e = ekf::run(&records, &perturbed(&truth(), 0.2), &settings);
    let r = refine(&records, &e.coefficients, &settings);
    let from_truth = refine(&records, &truth(), &settings);
    for i in 0..10 {
        let (a, b) = (
            relative_error(&r.coefficients, i),
            relative_error(&from_truth.coefficients, i),
        );
        println!(
            "noise-free {:<8} from 20 % off {:>10.6} %, from the truth {:>10.6} %",
            NAMES[i],
            a * 100.0,
            b * 100.0
        );
        // Z_qdot is 1e-4 of the heave inertia: the least determined even without noise.
        let bound = if NAMES[i] == "Z_qdot" { 1e-3 } else { 2e-5 };
        assert!(a.abs() < bound && b.abs() < bound, "{}: {a} {b}", NAMES[i]);
    }
}

/// The heave equation's coefficients are unidentifiable because scaling the whole equation
/// (m - Z_wdot, Z_w, Z_q + m U, Z_qdot, Z_delta) leaves the motion unchanged (but for the
/// tiny m z_G q^2 term): with Z_wdot known (e.g. from an added-mass estimate) the others are
/// found to a few tenths of a percent.
#[test]
fn knowing_z_wdot_resolves_the_heave_equation() {
    let mut settings = Settings::default();
    settings.fixed[1] = Some(TRUE_COEFFICIENTS[1]);
    let records = both(1, ZigzagNoise::realistic());
    let e = ekf::run(&records, &perturbed(&truth(), 0.2), &settings);
    let r = refine(&records, &e.coefficients, &settings);
    print("Z_wdot known", &r.coefficients, &r.covariance);
    for name in ["Z_w", "Z_q", "Z_delta"] {
        let i = NAMES.iter().position(|n| *n == name).unwrap();
        let rel_sigma = sigma(&r.covariance, i) / TRUE_COEFFICIENTS[i].abs();
        assert!(rel_sigma < 0.003, "{name}: {rel_sigma}");
        assert!((r.coefficients[i] - TRUE_COEFFICIENTS[i]).abs() < 3.0 * sigma(&r.covariance, i));
    }
}

/// A wrong model structure, a coefficient forced to zero. Measured on these runs: without
/// Z_w, Z_delta or M_qdot the model cannot fit (residuals several times the sensor noise);
/// without M_w, M_wdot, M_q, M_delta, Z_wdot, Z_q or Z_qdot it still fits to the noise,
/// because the zig-zags' regressors are nearly collinear and the other coefficients absorb
/// the missing one: the tool cannot tell those structures apart, and says so by flagging
/// the coefficients as poorly determined.
#[test]
fn a_wrong_structure_fits_poorly() {
    let records = both(1, ZigzagNoise::realistic());
    let worst = |index: usize| {
        let mut settings = Settings::default();
        settings.fixed[index] = Some(0.0);
        let e = ekf::run(&records, &perturbed(&truth(), 0.2), &settings);
        let r = refine(&records, &e.coefficients, &settings);
        println!(
            "{} forced to 0: normalised residual RMS {:.2?}",
            NAMES[index], r.normalised_rms
        );
        r.normalised_rms.into_iter().fold(0.0, f64::max)
    };
    let index = |name: &str| NAMES.iter().position(|n| *n == name).unwrap();
    for (name, bound) in [("Z_w", 3.0), ("Z_delta", 3.0), ("M_qdot", 2.0)] {
        assert!(worst(index(name)) > bound, "{name}");
    }
    for name in ["M_w", "M_delta"] {
        assert!(worst(index(name)) < 1.1, "{name}");
    }
}

/// logs whose sensors are 2.5-3 times noisier than the defaults. With the noise
/// learnt from the residuals (the default) the fit is not called poor, the learnt noise is
/// the simulator's, and the truth is within 3 sigma for all ten coefficients; with the
/// defaults taken as they are, the same logs are a POOR FIT. A wrong structure (Z_w forced to
/// zero) is still a POOR FIT with the noise learnt: its residuals are slow, not white.
#[test]
fn noise_unlike_the_defaults_is_learnt() {
    let noise = ZigzagNoise {
        gyro_deg_s: 0.03,
        pitch_deg: 0.05,
        dvl_m_s: 0.006,
        depth_m: 0.03,
        ..ZigzagNoise::realistic()
    };
    let records = vec![
        record("zigzag-5-5", 3, noise),
        record("zigzag-10-5", 1003, noise),
    ];
    let start = perturbed(&truth(), 0.2);
    let settings = Settings::default();
    let id = identify(&records, &start, &settings);
    let learnt = id.noise.sigma;
    println!(
        "learnt in {} refinements: q {:.5} deg/s, theta {:.5} deg, w {:.5} m/s, depth {:.5} m",
        id.noise.rounds,
        learnt.q_rad_s.to_degrees(),
        learnt.theta_rad.to_degrees(),
        learnt.w_m_s,
        learnt.depth_m
    );
    print(
        "noise learnt",
        &id.refined.coefficients,
        &id.refined.covariance,
    );
    for (got, want) in [
        (learnt.q_rad_s.to_degrees(), noise.gyro_deg_s),
        (learnt.theta_rad.to_degrees(), noise.pitch_deg),
        (learnt.w_m_s, noise.dvl_m_s),
        (learnt.depth_m, noise.depth_m),
    ] {
        assert!(
            (got / want - 1.0).abs() < 0.05,
            "learnt {got}, simulated {want}"
        );
    }
    let warnings = id.fit_warnings(&settings);
    assert!(
        warnings.iter().all(|w| !w.contains("POOR FIT")),
        "{warnings:?}"
    );
    for i in 0..10 {
        let error = (id.refined.coefficients[i] - TRUE_COEFFICIENTS[i]).abs();
        assert!(
            error < 3.0 * sigma(&id.refined.covariance, i),
            "{}: {error} against sigma {}",
            NAMES[i],
            sigma(&id.refined.covariance, i)
        );
    }

    let given = Settings {
        learn_noise: false,
        ..Settings::default()
    };
    let as_given = identify(&records, &start, &given);
    let warnings = as_given.fit_warnings(&given);
    println!("noise as given: {warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("POOR FIT")));

    let mut wrong = Settings::default();
    wrong.fixed[0] = Some(0.0);
    let forced = identify(&records, &start, &wrong);
    let warnings = forced.fit_warnings(&wrong);
    println!("Z_w forced to 0: {warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("POOR FIT")));
}

/// Monte Carlo over 100 seeds: the spread of the refined estimates against the sigma the
/// tool reports (median over the seeds), so that the reported uncertainty can be trusted.
///
/// The two logs of a seed take independent noise (seeds `s` and `s + 1000`). With one seed
/// for both, the simulator gives both manoeuvres the same noise sequence, sample for sample;
/// the pitch group, set by the contrast between the two runs, then scattered at only 0.44
/// of its sigma, which an earlier version of this study took for a conservative sigma.
#[test]
#[ignore = "100 seeds x 2 logs: about 95 s; run with --ignored"]
fn monte_carlo_spread_matches_reported_sigma() {
    const SEEDS: u64 = 100;
    let settings = Settings::default();
    // As `hindsight identify` runs by default: both stages, the noise learnt from the fit.
    let runs: Vec<Refined> = (1..=SEEDS)
        .map(|seed| {
            let records = vec![
                record("zigzag-5-5", seed, ZigzagNoise::realistic()),
                record("zigzag-10-5", seed + 1000, ZigzagNoise::realistic()),
            ];
            identify(&records, &perturbed(&truth(), 0.2), &settings).refined
        })
        .collect();
    let mut ratios = Vec::new();
    for i in 0..10 {
        let errors: Vec<f64> = runs
            .iter()
            .map(|r| relative_error(&r.coefficients, i))
            .collect();
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let spread = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>()
            / (errors.len() - 1) as f64)
            .sqrt();
        let mut each: Vec<f64> = runs
            .iter()
            .map(|r| sigma(&r.covariance, i) / TRUE_COEFFICIENTS[i].abs())
            .collect();
        each.sort_by(f64::total_cmp);
        println!(
            "    reported sigma min {:.3} % median {:.3} % max {:.3} %",
            each[0] * 100.0,
            each[each.len() / 2] * 100.0,
            each[each.len() - 1] * 100.0
        );
        let reported = each[each.len() / 2];
        println!(
            "{:<8} mean error {:>8.3} %, spread {:>8.3} %, reported sigma {:>8.3} %, ratio {:.2}",
            NAMES[i],
            mean * 100.0,
            spread * 100.0,
            reported * 100.0,
            spread / reported
        );
        ratios.push(spread / reported);
    }
    // An efficient estimator's spread equals its sigma; over 100 seeds the ratio itself
    // scatters by about 7 %. Measured: 0.87 (heave group) to 1.13 (M_qdot).
    for (i, r) in ratios.iter().enumerate() {
        assert!(
            (0.8..=1.2).contains(r),
            "{}: spread / reported sigma {r:.2}",
            NAMES[i]
        );
    }
}
