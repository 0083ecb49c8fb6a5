//! Coefficient identification on seed 004's zig-zags (simulated, seeded sensor noise),
//! started 20 % off on every coefficient.
//!
//! `cargo test --release --test identify -- --nocapture`

mod common;

use hindsight::identify::record::Record;
use hindsight::identify::settings::Settings;
use hindsight::identify::{ekf, perturbed};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::sim::zigzag::{self, ZigzagSpec};
use hindsight::vehicle::heave_pitch::{Coefficients, NAMES, TRUE_COEFFICIENTS};

fn record(name: &str, seed: u64) -> Record {
    let spec = ZigzagSpec::built_in(name).unwrap();
    let bytes = to_bytes(WriterOptions::default(), |w| {
        zigzag::run(&spec, seed, w)?;
        Ok(())
    })
    .unwrap();
    Record::from_log(name, &common::read(&bytes), None).unwrap()
}

fn relative_errors(c: &Coefficients) -> Vec<f64> {
    (0..10)
        .map(|i| (c[i] - TRUE_COEFFICIENTS[i]) / TRUE_COEFFICIENTS[i])
        .collect()
}

#[test]
fn ekf_stage_matches_seed_004() {
    let settings = Settings::default();
    let start = perturbed(&Coefficients::from(TRUE_COEFFICIENTS), 0.2);
    for logs in [vec!["zigzag-5-5"], vec!["zigzag-10-5"], vec!["zigzag-5-5", "zigzag-10-5"]] {
        let records: Vec<Record> = logs.iter().map(|n| record(n, 1)).collect();
        let r = ekf::run(&records, &start, &settings);
        let errors = relative_errors(&r.coefficients);
        println!("EKF on {logs:?}:");
        for i in 0..10 {
            println!(
                "  {:<8} {:>12.6e}  error {:>7.3} %  sigma {:>7.3} %",
                NAMES[i],
                r.coefficients[i],
                errors[i] * 100.0,
                r.covariance[(i, i)].sqrt() / TRUE_COEFFICIENTS[i].abs() * 100.0
            );
        }
        assert_eq!(r.failed_updates, 0);
    }
}

#[test]
fn probe_noise_free() {
    let settings = Settings::default();
    let start = perturbed(&Coefficients::from(TRUE_COEFFICIENTS), 0.2);
    let records: Vec<Record> = ["zigzag-5-5", "zigzag-10-5"]
        .iter()
        .map(|n| {
            let spec = ZigzagSpec {
                noise: zigzag::ZigzagNoise::none(),
                ..ZigzagSpec::built_in(n).unwrap()
            };
            let bytes = to_bytes(WriterOptions::default(), |w| {
                zigzag::run(&spec, 1, w)?;
                Ok(())
            })
            .unwrap();
            Record::from_log(n, &common::read(&bytes), None).unwrap()
        })
        .collect();
    let r = ekf::run(&records, &start, &settings);
    let errors = relative_errors(&r.coefficients);
    for i in 0..10 {
        println!("noise-free {:<8} error {:>7.3} %", NAMES[i], errors[i] * 100.0);
    }
    let f = hindsight::identify::output_error::refine(&records, &r.coefficients, &settings);
    let errors = relative_errors(&f.coefficients);
    println!("noise-free refined: {} iterations, rms {:?}", f.iterations, f.normalised_rms);
    for i in 0..10 {
        println!("noise-free refined {:<8} error {:>9.5} %  sigma {:>8.4} %", NAMES[i], errors[i] * 100.0,
            f.covariance[(i, i)].sqrt() / TRUE_COEFFICIENTS[i].abs() * 100.0);
    }
    let f = hindsight::identify::output_error::refine(&records, &Coefficients::from(TRUE_COEFFICIENTS), &settings);
    let errors = relative_errors(&f.coefficients);
    println!("noise-free from truth: {} iterations, rms {:?}, errors {:?}", f.iterations, f.normalised_rms, errors);
}

#[test]
fn probe_refined() {
    let settings = Settings::default();
    let start = perturbed(&Coefficients::from(TRUE_COEFFICIENTS), 0.2);
    for logs in [vec!["zigzag-5-5"], vec!["zigzag-10-5"], vec!["zigzag-5-5", "zigzag-10-5"]] {
        let records: Vec<Record> = logs.iter().map(|n| record(n, 1)).collect();
        let e = ekf::run(&records, &start, &settings);
        let r = hindsight::identify::output_error::refine(&records, &e.coefficients, &settings);
        let errors = relative_errors(&r.coefficients);
        println!("refined on {logs:?}: {} iterations, converged {}, normalised rms {:?}", r.iterations, r.converged, r.normalised_rms);
        for i in 0..10 {
            println!(
                "  {:<8} error {:>8.4} %  sigma {:>8.4} %",
                NAMES[i],
                errors[i] * 100.0,
                r.covariance[(i, i)].sqrt() / TRUE_COEFFICIENTS[i].abs() * 100.0
            );
        }
    }
}
