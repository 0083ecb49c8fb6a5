//! Identification with the 6-DOF model (issue 19, point 4): the horizontal-plane coefficients
//! (Y_v, Y_r, Y_delta_r, N_v, N_r, N_delta_r) of NPS AUV II from the simulator's rudder
//! zig-zag 20-20 (the 6-DOF model flown by its autopilot on the rotating Earth; navigation-
//! grade IMU, DVL with bias, scale error and 0.01 m/s noise), started 10 % off, everything
//! else held at the file's values; scored against the file's values, which the simulator
//! flew.
//!
//! `cargo test --release --test identify_six_dof -- --nocapture`

mod common;

use hindsight::contract::{ControlSurfaces, Dvl, Imu};
use hindsight::identify::record::RecordError;
use hindsight::identify::six_dof::{identify_six_dof, SixDofRecord, SixDofSettings};
use hindsight::sim::scenario::Scenario;
use hindsight::sim::writer::{to_bytes, WriterOptions};
use hindsight::vehicle::six_dof::description::Vehicle;

#[test]
fn rudder_zigzag_gives_the_horizontal_plane_coefficients() {
    let scenario = Scenario::built_in("zigzag-rudder-20-20").unwrap();
    let log = common::simulated_log(&scenario, 1);
    let record = SixDofRecord::from_log("zigzag-rudder-20-20", &log).unwrap();
    assert_eq!(record.manoeuvre.0, "rudder");
    let vehicle = Vehicle::built_in("nps-auv-ii").unwrap().unwrap();
    let settings = SixDofSettings::default();
    let truth: Vec<f64> = settings
        .free
        .iter()
        .map(|n| vehicle.coefficient(n))
        .collect();
    let start: Vec<f64> = truth
        .iter()
        .enumerate()
        .map(|(i, v)| v * if i % 2 == 0 { 1.1 } else { 0.9 })
        .collect();
    let id = identify_six_dof(&[record], &vehicle, Some(&start), &settings).unwrap();
    println!(
        "{} Levenberg-Marquardt iterations in the last of {} noise rounds, converged {}",
        id.iterations, id.noise_rounds, id.converged
    );
    assert!(id.converged);
    assert!(
        id.fit_warnings(&settings.thresholds).is_empty(),
        "{:?}",
        id.fit_warnings(&settings.thresholds)
    );
    for (i, name) in id.names.iter().enumerate() {
        let sigma = id.covariance[(i, i)].sqrt();
        let error = id.coefficients[i] - truth[i];
        let d = id.assessment.iter().find(|d| d.name == *name).unwrap();
        let relative_sigma = sigma / truth[i].abs();
        println!(
            "{name:<4} true {:>10.2}  start {:>10.2}  estimate {:>10.2}  error {:>7.3} %  1-sigma {:>6.3} %  error/sigma {:>5.2}  most correlated {:?}{}",
            truth[i],
            start[i],
            id.coefficients[i],
            100.0 * error / truth[i].abs(),
            100.0 * relative_sigma,
            error / sigma,
            d.most_correlated,
            if d.poorly_determined { "  (flagged)" } else { "" }
        );
        assert!(
            error.abs() < 3.0 * sigma,
            "{name}: {error} vs sigma {sigma}"
        );
        // Determined, as the sigma says: within 5 % (the correlation flag aside: a sigma
        // already holds the correlation's effect).
        if relative_sigma < settings.thresholds.max_relative_sigma {
            assert!(error.abs() < 0.05 * truth[i].abs(), "{name}: {error}");
        }
    }
    // The fit is to the noise: the learnt noise is the sensors' (gyro ARW 0.05 deg/rt h at
    // 100 Hz is 1.5e-4 rad/s; DVL 0.01 m/s).
    println!(
        "learnt noise: gyro {:?} rad/s, DVL {:?} m/s",
        &id.sigma[..3],
        &id.sigma[3..]
    );
    for s in &id.sigma[..3] {
        assert!((1.2e-4..1.8e-4).contains(s), "{s}");
    }
    for s in &id.sigma[3..] {
        assert!((0.008..0.012).contains(s), "{s}");
    }
    println!(
        "DVL bias {:?} m/s, scale error {:?}",
        id.dvl_bias_m_s, id.dvl_scale_error
    );
}

/// Without /rpm the model has no thrust: a clear error, naming the log and the topic.
#[test]
fn without_rpm_is_refused() {
    let scenario = Scenario::built_in("zigzag-rudder-20-20").unwrap();
    let full = common::simulated_log(&scenario, 1);
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_mission(&full.mission().unwrap())?;
        for m in full.messages::<Imu>("/imu").unwrap() {
            w.write("/imu", m, m.stamp_ns as u64)?;
        }
        for m in full.messages::<ControlSurfaces>("/fins").unwrap() {
            w.write("/fins", m, m.stamp_ns as u64)?;
        }
        for m in full.messages::<Dvl>("/dvl").unwrap() {
            w.write("/dvl", m, m.stamp_ns as u64)?;
        }
        Ok(())
    })
    .unwrap();
    let e = SixDofRecord::from_log("no-rpm", &common::read(&bytes)).unwrap_err();
    assert!(matches!(e, RecordError::NoRpm { .. }), "{e}");
    assert!(e.to_string().contains("/rpm"), "{e}");
}
