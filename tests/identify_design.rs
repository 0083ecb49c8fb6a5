//! `identify --suggest`: the experiment design's predictions, checked by
//! following them. Seed 004's two zig-zags identify the heave and pitch groups poorly; each
//! suggestion is flown in the simulator (the true coefficients, the sensor noise, a
//! seed of its own) or applied (a coefficient held at its true value), the logs are
//! identified again, and the reported sigma of every coefficient the suggestion names must
//! fall as predicted.
//!
//! `cargo test --release --test all identify_design:: -- --nocapture`

use crate::common;
use hindsight::identify::design::{
    predicted_covariance, suggest, Addition, DesignSettings, Manoeuvre, Suggestion,
};
use hindsight::identify::record::Record;
use hindsight::identify::settings::Settings;
use hindsight::identify::{identify, perturbed, Identification};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::sim::zigzag::{self, ZigzagNoise, ZigzagSpec};
use hindsight::vehicle::heave_pitch::{Coefficients, NAMES, TRUE_COEFFICIENTS};

fn read(spec: &ZigzagSpec, seed: u64) -> Record {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        zigzag::run(spec, seed, w)?;
        Ok(())
    })
    .unwrap();
    Record::from_log(&spec.name, &common::read(&bytes), None).unwrap()
}

/// Seed 004's two runs, each with noise of its own.
fn logs() -> Vec<Record> {
    [("zigzag-5-5", 1), ("zigzag-10-5", 1001)]
        .iter()
        .map(|(name, seed)| read(&ZigzagSpec::built_in(name).unwrap(), *seed))
        .collect()
}

/// The candidate zig-zag flown by the true vehicle with the sensors.
fn flown(m: &Manoeuvre, seed: u64) -> Record {
    let mut spec =
        ZigzagSpec::built_in(&format!("zigzag-{}-{}", m.plane_deg, m.trigger_deg)).unwrap();
    spec.duration_s = m.duration_s;
    spec.plane_rate_deg_s = m.plane_rate_deg_s;
    spec.constants.speed_m_s = m.speed_m_s;
    spec.constants.weight_minus_buoyancy_n = m.weight_minus_buoyancy_n;
    spec.noise = ZigzagNoise::realistic();
    let mut r = read(&spec, seed);
    // The ballast is known (that is the suggestion); the speed is measured by the DVL.
    r.weight_minus_buoyancy_n = Some(m.weight_minus_buoyancy_n);
    r
}

fn sigma(id: &Identification, i: usize) -> f64 {
    id.refined.covariance[(i, i)].sqrt()
}

/// Follows `s` and checks every coefficient it names: predicted and reported sigma both
/// below the sigma now, the reported one near the prediction, the truth within 3 sigma.
fn follow(s: &Suggestion, before: &Identification, records: &[Record], seed: u64) {
    let truth = Coefficients::from(TRUE_COEFFICIENTS);
    let mut settings = Settings::default();
    let mut logs = records.to_vec();
    match s.addition {
        Addition::Zigzag(m) => logs.push(flown(&m, seed)),
        Addition::Known(i) => settings.fixed[i] = Some(truth[i]),
    }
    let after = identify(&logs, &perturbed(&truth, 0.2), &settings);
    assert!(
        after.fit_warnings(&settings).is_empty(),
        "{:?}",
        after.fit_warnings(&settings)
    );
    println!("{} ({} reversals)", s.description, s.reversals);
    assert!(!s.determines.is_empty(), "names nothing");
    for i in 0..10 {
        let rel = |v: f64| 100.0 * v / truth[i].abs();
        let named = s.determines.contains(&NAMES[i]);
        println!(
            "  {:<8} 1-sigma now {:>8.3} %  predicted {:>8.3} %  reported after {:>8.3} %  error after {:>8.3} %{}",
            NAMES[i],
            rel(sigma(before, i)),
            rel(s.sigma(i)),
            rel(sigma(&after, i)),
            rel(after.refined.coefficients[i] - truth[i]),
            if named { "  (named)" } else { "" }
        );
        if !named {
            continue;
        }
        assert!(
            s.sigma(i) < 0.5 * sigma(before, i),
            "{}: predicted",
            NAMES[i]
        );
        assert!(
            sigma(&after, i) < 0.5 * sigma(before, i),
            "{}: reported",
            NAMES[i]
        );
        let ratio = sigma(&after, i) / s.sigma(i);
        assert!(
            (0.67..1.5).contains(&ratio),
            "{}: reported / predicted {ratio}",
            NAMES[i]
        );
        let error = (after.refined.coefficients[i] - truth[i]).abs();
        assert!(
            error < 3.0 * sigma(&after, i),
            "{}: {error} vs sigma {}",
            NAMES[i],
            sigma(&after, i)
        );
    }
}

#[test]
fn following_the_suggestions_lowers_the_sigma_as_predicted() {
    let settings = Settings::default();
    let records = logs();
    let truth = Coefficients::from(TRUE_COEFFICIENTS);
    let before = identify(&records, &perturbed(&truth, 0.2), &settings);
    // The information the predictions add to is the identification's own: its inverse is
    // the reported covariance.
    let inverse = predicted_covariance(&before.refined.information, &settings.fixed).unwrap();
    for i in 0..10 {
        let (a, b) = (inverse[(i, i)], before.refined.covariance[(i, i)]);
        assert!((a / b - 1.0).abs() < 1e-6, "{}: {a} vs {b}", NAMES[i]);
    }
    let suggestions = suggest(&before, &records, &settings, &DesignSettings::default());
    // The best: the zig-zag with a known ballast change, which breaks the heave equation's
    // common scale (a known force) and the pitch group's collinearity (a steady w).
    let best = &suggestions[0];
    assert!(
        matches!(best.addition, Addition::Zigzag(m) if m.weight_minus_buoyancy_n != 0.0),
        "{}",
        best.description
    );
    follow(best, &before, &records, 2001);
    // The best manoeuvre without a ballast change: another speed.
    let speed = suggestions
        .iter()
        .find(|s| matches!(s.addition, Addition::Zigzag(m) if m.weight_minus_buoyancy_n == 0.0))
        .unwrap();
    follow(speed, &before, &records, 2002);
    // Z_wdot known from elsewhere (here: its true value).
    let known = suggestions
        .iter()
        .find(|s| s.addition == Addition::Known(1))
        .unwrap();
    follow(known, &before, &records, 0);
}
