//! The DVL dead reckoning of seed 001's pool tests (simulated `pool-circle` and
//! `pool-rectangle`, seed 1) with each attitude method available so far, scored by the
//! end-point error against the `end` mark, and the yaw RMS against `/truth`.
//!
//! `cargo test --release --test pool_attitude -- --nocapture`

mod common;

use hindsight::attitude::dead_reckoning::dead_reckon;
use hindsight::attitude::score::reference_from_truth;
use hindsight::attitude::{euler, mekf, raw, AhrsInputs, AttitudeSample};
use hindsight::contract::{Dvl, Imu, MagneticField, PositionFix, Truth};
use hindsight::filters::ins::forward::DvlMounting;
use hindsight::sim::scenario::Scenario;
use nalgebra::Vector3;

/// End-point error (m) and yaw RMS against the truth (deg) of each method, by name.
fn pool(name: &str) -> Vec<(&'static str, f64, f64)> {
    let scenario = Scenario::built_in(name).unwrap();
    let log = common::simulated_log(&scenario, 1);
    let imu: &[Imu] = log.messages("/imu").unwrap();
    let mag: &[MagneticField] = log.messages("/mag").unwrap();
    let dvl: &[Dvl] = log.messages("/dvl").unwrap();
    let truth: &[Truth] = log.messages("/truth").unwrap();
    let marks: &[PositionFix] = log.messages("/position_fix").unwrap();
    let mark = |label: &str| {
        let m = marks.iter().find(|m| m.label == label).unwrap();
        Vector3::new(m.north_m, m.east_m, m.down_m.unwrap_or(0.0))
    };
    let (start, end) = (mark("start"), mark("end"));
    let declination_rad = log
        .mission()
        .unwrap()
        .magnetic_declination_deg
        .unwrap()
        .to_radians();
    let inputs = AhrsInputs {
        imu,
        mag,
        declination_rad,
        initial_yaw_rad: None,
    };
    let reference = reference_from_truth(truth);
    let settings = mekf::MekfSettings::default();
    let filters = hindsight::attitude::config::AttitudeConfig::default()
        .filters()
        .unwrap();
    let methods: Vec<(&'static str, Vec<AttitudeSample>)> = vec![
        ("truth", reference.clone()),
        ("raw", raw::run(&inputs)),
        ("ekf", euler::run(&filters.ekf, &inputs).0),
        ("ukf", euler::run(&filters.ukf, &inputs).0),
        ("cf", euler::run(&filters.cf, &inputs).0),
        ("mekf", mekf::run(&inputs, &settings).0),
        (
            "mekf-smoothed",
            mekf::run_smoothed(&inputs, &settings).unwrap().0,
        ),
    ];
    methods
        .into_iter()
        .map(|(name, attitude)| {
            let track = dead_reckon(&attitude, dvl, &DvlMounting::default(), start);
            let end_error = (track.last().unwrap().ned_m - end).xy().norm();
            let yaw = hindsight::attitude::score::rms(&attitude, &reference, |_| true)
                .map_or(0.0, |r| r.heading_deg);
            (name, end_error, yaw)
        })
        .collect()
}

#[test]
fn dead_reckoning_with_each_attitude() {
    for scenario in ["pool-circle", "pool-rectangle"] {
        let scores = pool(scenario);
        for (name, end, yaw) in &scores {
            println!(
                "{scenario:<15} {name:<14} end-point error {end:6.3} m, heading RMS {yaw:6.3} deg"
            );
        }
        let get = |n: &str| scores.iter().find(|s| s.0 == n).unwrap();
        // With the true attitude only the DVL's own errors remain.
        assert!(get("truth").1 < 0.5, "{:?}", get("truth"));
        // The ranking measured on these seeded logs.
        assert!(get("mekf-smoothed").2 < get("mekf").2);
        assert!(get("mekf").2 < get("raw").2);
    }
}
