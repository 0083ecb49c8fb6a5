//! Ship-relative USBL (issue 58) through the default run: `usbl-raw-survey`'s raw range,
//! bearing and elevation with the ship's pose from its own GNSS, heading and tilt, each with
//! its own errors. Scored against `/truth` and the `usbl_truth` record (which observations
//! were outliers), which the reconstruction never reads.
//!
//! The observations here carry their time of validity and their delay (`stamp =
//! "validity_and_delay"`, as EvoLogics' two times give them): the delay of raw observations
//! stamped on receipt is not estimated yet.

use crate::common;
use hindsight::config::Section;
use hindsight::contract::UsblObservation;
use hindsight::filters::ins::aid_table::Sensor;
use hindsight::filters::ins::usbl::UsblAid;
use hindsight::recon::config::Config;
use hindsight::recon::plan::Part;
use hindsight::recon::score::scores;
use hindsight::recon::Streams;
use hindsight::sim::scenario::Scenario;
use hindsight::sim::sensors::usbl::UsblStamp;
use std::collections::BTreeSet;

/// What one seed's default run did with its observations, against the simulator's truth.
#[derive(Debug)]
struct RawRun {
    seed: u64,
    median_sigma_m: f64,
    smoothed_rms_m: f64,
    forward_rms_m: f64,
    forward_nees_inside: f64,
    smoothed_nees_inside: f64,
    outliers: usize,
    outliers_refused: usize,
    good: usize,
    good_refused: usize,
}

fn raw_run(scenario: &Scenario, seed: u64) -> RawRun {
    let log = common::simulated(scenario, seed);
    let outlier_receipts: BTreeSet<i64> = log.metadata["usbl_truth"]["outlier_receipt_stamps_ns"]
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    let observations: &[UsblObservation] = log.role();
    // The outliers by their time of validity (each observation carries its delay).
    let outlier_stamps: BTreeSet<i64> = observations
        .iter()
        .filter(|o| {
            let received = o.stamp_ns + (o.received_after_s.unwrap() * 1e9).round() as i64;
            outlier_receipts.contains(&received)
        })
        .map(|o| o.stamp_ns)
        .collect();
    assert_eq!(outlier_stamps.len(), outlier_receipts.len());
    let config = Config::default();
    let aiding = config.usbl.aid(&config.acoustic_fix, false).unwrap();
    let aid = UsblAid::new(observations, Streams::of(&log).ship, &aiding);
    let mut sigmas: Vec<f64> = (0..aid.observations().len())
        .filter(|&i| !outlier_stamps.contains(&aid.observations()[i].stamp_ns))
        .map(|i| aid.positioned_sigma_m(i))
        .collect();
    sigmas.sort_by(f64::total_cmp);
    let median_sigma_m = sigmas[sigmas.len() / 2];

    let r = log.reconstruct(&config);
    let (mut outliers, mut outliers_refused, mut good, mut good_refused) = (0, 0, 0, 0);
    for res in (r.solved.run.residuals.iter()).filter(|x| x.sensor == Sensor::Usbl) {
        if outlier_stamps.contains(&res.stamp_ns) {
            outliers += 1;
            outliers_refused += usize::from(!res.accepted);
        } else {
            good += 1;
            good_refused += usize::from(!res.accepted);
        }
    }
    assert_eq!(
        outliers,
        outlier_stamps.len(),
        "every outlier reached the filter"
    );
    let (fwd, smo) = common::output_errors(Streams::of(&log).truth, &r.solved);
    let (fwd, smo) = (scores(&fwd).unwrap(), scores(&smo).unwrap());
    RawRun {
        seed,
        median_sigma_m,
        smoothed_rms_m: smo.horizontal_rms_m,
        forward_rms_m: fwd.horizontal_rms_m,
        forward_nees_inside: fwd.nees_horizontal_inside_95,
        smoothed_nees_inside: smo.nees_horizontal_inside_95,
        outliers,
        outliers_refused,
        good,
        good_refused,
    }
}

/// `usbl-raw-survey` with its times of validity told, seeds 1-3, default run: the smoothed
/// horizontal RMS at most half the observations' median positioned sigma (their own noise
/// and the ship's errors); at least 99 % of the outliers refused and at most 1 % of the good
/// observations; the smoothed horizontal NEES inside its 95 % bounds for at least 90 % of the
/// epochs over the seeds.
///
/// Not yet held, so not asserted: the forward NEES bar (90 % on each seed). Measured
/// 95.8, 85.6 and 94.9 % on seeds 1-3: the ship's heading error, correlated over 10 s, is
/// taken as white in each observation's noise (issue 58's notes).
#[test]
fn a_raw_usbl_survey_is_placed_by_its_observations_and_refuses_its_outliers() {
    let mut scenario = Scenario::built_in("usbl-raw-survey").unwrap();
    scenario.usbl.as_mut().unwrap().stamp = UsblStamp::ValidityAndDelay;
    let runs: Vec<RawRun> = (1..=3).map(|seed| raw_run(&scenario, seed)).collect();
    for run in &runs {
        eprintln!(
            "seed {}: NEES inside forward {:.1} %, smoothed {:.1} %; {run:?}",
            run.seed,
            100.0 * run.forward_nees_inside,
            100.0 * run.smoothed_nees_inside
        );
    }
    for run in &runs {
        assert!(
            run.smoothed_rms_m <= 0.5 * run.median_sigma_m,
            "seed {}: smoothed RMS {:.2} m against a median sigma of {:.2} m",
            run.seed,
            run.smoothed_rms_m,
            run.median_sigma_m
        );
        assert!(run.forward_rms_m <= run.median_sigma_m, "{run:?}");
    }
    let smoothed_nees =
        runs.iter().map(|r| r.smoothed_nees_inside).sum::<f64>() / runs.len() as f64;
    assert!(smoothed_nees >= 0.9, "{smoothed_nees}");
    let outliers: usize = runs.iter().map(|r| r.outliers).sum();
    let refused: usize = runs.iter().map(|r| r.outliers_refused).sum();
    let good: usize = runs.iter().map(|r| r.good).sum();
    let good_refused: usize = runs.iter().map(|r| r.good_refused).sum();
    assert!(outliers >= 20, "{outliers} outliers");
    assert!(
        refused as f64 >= 0.99 * outliers as f64,
        "{refused} of {outliers} outliers refused"
    );
    assert!(
        good_refused as f64 <= 0.01 * good as f64,
        "{good_refused} of {good} good observations refused"
    );
}

/// Stamped on receipt, as shipped: without a delay the observations are left out, named in
/// a warning and the plan; with the delay given (the simulator's, from `usbl_truth`) they
/// are placed where they were valid, every outlier refused and no good one.
#[test]
fn raw_observations_stamped_on_receipt_wait_for_their_delay() {
    let scenario = Scenario::built_in("usbl-raw-survey").unwrap();
    let log = common::simulated(&scenario, 1);
    let r = log.reconstruct(&Config::default());
    let usbl = (r.summary.plan.decisions.iter())
        .find(|d| d.part == Part::Aid(Sensor::Usbl))
        .unwrap();
    assert!(!usbl.used, "{usbl:?}");
    let warnings: Vec<String> = r.summary.warnings.iter().map(|w| w.to_string()).collect();
    assert!(
        warnings.iter().any(|w| w.contains("USBL observations were left out")
            && w.contains("receipt_delay_s")),
        "{warnings:?}"
    );
    let truth = &log.metadata["usbl_truth"];
    let delay_s: f64 = truth["receipt_delay_s"].parse().unwrap();
    let outlier_receipts: BTreeSet<i64> = truth["outlier_receipt_stamps_ns"]
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    let given = format!("[acoustic_fix]\nreceipt_delay_s = {delay_s}\n");
    let r = log.reconstruct(&Config::from_toml(&given).unwrap());
    let delay_ns = (delay_s * 1e9).round() as i64;
    let (mut outliers, mut outliers_refused, mut good, mut good_refused) = (0, 0, 0, 0);
    for res in (r.solved.run.residuals.iter()).filter(|x| x.sensor == Sensor::Usbl) {
        if outlier_receipts.contains(&(res.stamp_ns + delay_ns)) {
            outliers += 1;
            outliers_refused += usize::from(!res.accepted);
        } else {
            good += 1;
            good_refused += usize::from(!res.accepted);
        }
    }
    let observations = log.role::<UsblObservation>().len();
    eprintln!(
        "delay {delay_s:.3} s given: {} of {observations} observations applied; \
         {outliers_refused} of {outliers} outliers and {good_refused} of {good} good ones \
         refused",
        outliers + good
    );
    // The last observation may fall after the ship's last pose.
    assert!(outliers + good + 1 >= observations);
    assert_eq!(outliers, outlier_receipts.len());
    assert_eq!(outliers_refused, outliers);
    assert!(good_refused as f64 <= 0.01 * good as f64);
}
