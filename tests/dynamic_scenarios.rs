//! The simulator's hydrodynamic scenarios: the 6-DOF NPS AUV II flown by its autopilot
//! through seed 000's Table 1 mission and the manoeuvres, with the contract's streams.
//!
//! `cargo test --release --test dynamic_scenarios -- --nocapture`

mod common;

use hindsight::angle::wrap_pi;
use hindsight::filters::ins::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use hindsight::geodesy;
use hindsight::sim::dynamic::{from_scenario, DynamicTruth};
use hindsight::sim::inertial::perfect_imu;
use hindsight::sim::scenario::Scenario;
use hindsight::sim::truth::{TruthSample, TruthSource};
use hindsight::vehicle::six_dof::plan::Phase;
use nalgebra::UnitQuaternion;

const DT: f64 = 0.01;

fn truth_of(name: &str, seed: u64) -> (Scenario, DynamicTruth) {
    let s = Scenario::built_in(name).unwrap();
    let (truth, _) = from_scenario(&s, seed, DT).unwrap().unwrap();
    (s, truth)
}

/// Samples `truth` every step to its end, calling `each` with the time, the sample and the
/// truth (for its references and state).
fn fly(truth: &mut DynamicTruth, each: &mut dyn FnMut(f64, &TruthSample, &DynamicTruth)) {
    let steps = (truth.duration_s() / DT).round() as usize;
    for k in 0..=steps {
        let t = k as f64 * DT;
        let sample = truth.sample(t);
        each(t, &sample, truth);
    }
}

/// Seed 000's Table 1 mission, 5.5 h: depth within 5 m of the commanded depth throughout,
/// heading within 5 deg of the commanded heading in the cruise phases, and the profile's
/// landmarks (300 m, 150 m, the surface) reached.
#[test]
fn long_dive_flies_the_table_1_profile() {
    let (scenario, mut truth) = truth_of("long-dive-dynamic", 1);
    assert!((truth.duration_s() - 5.5 * 3600.0).abs() < 1e-6);
    let phases = scenario.phases.clone();
    let mut worst_depth: f64 = 0.0;
    let mut worst_heading_cruise: f64 = 0.0;
    let mut deepest: f64 = 0.0;
    let mut depth_at = Vec::new();
    let mut worst_roll: f64 = 0.0;
    let (mut min_speed, mut max_speed) = (f64::MAX, f64::MIN);
    fly(&mut truth, &mut |t, sample, truth| {
        let Some(reference) = truth.reference() else {
            return;
        };
        let depth = -sample.height_m;
        deepest = deepest.max(depth);
        if reference.depth_held {
            worst_depth = worst_depth.max((depth - reference.depth_m).abs());
        }
        if matches!(phases[reference.phase], Phase::Cruise { .. }) {
            if let Some(h) = reference.heading_rad {
                let e = wrap_pi(sample.euler_rad[2] - h).to_degrees().abs();
                worst_heading_cruise = worst_heading_cruise.max(e);
            }
        }
        worst_roll = worst_roll.max(sample.euler_rad[0].to_degrees().abs());
        if t > 60.0 {
            min_speed = min_speed.min(sample.speed_m_s);
            max_speed = max_speed.max(sample.speed_m_s);
        }
        // Depth at the ends of Table 1's phases (h): 0.75 (spiral end), 1.0, 5.0, 5.5.
        for end_h in [0.75, 1.0, 5.0, 5.5] {
            if (t - end_h * 3600.0).abs() < DT / 2.0 {
                depth_at.push((end_h, depth));
            }
        }
    });
    println!(
        "long-dive-dynamic (5.5 h): depth within {worst_depth:.2} m of its command, heading within \
         {worst_heading_cruise:.2} deg of its command in cruise, deepest {deepest:.1} m, roll within \
         {worst_roll:.1} deg, speed {min_speed:.3}-{max_speed:.3} m/s; depth at phase ends (h, m): {depth_at:.1?}"
    );
    assert!(worst_depth < 5.0, "depth error {worst_depth} m");
    assert!(worst_heading_cruise < 5.0, "heading error {worst_heading_cruise} deg");
    assert!((deepest - 300.0).abs() < 5.0, "deepest {deepest} m");
    let at = |h: f64| depth_at.iter().find(|(e, _)| *e == h).unwrap().1;
    assert!((at(0.75) - 300.0).abs() < 5.0);
    assert!((at(1.0) - 150.0).abs() < 5.0);
    assert!((at(5.0) - 150.0).abs() < 5.0);
    assert!(at(5.5) < 1.0, "surface: {} m", at(5.5));
}

/// Worst position (m), velocity (m/s) and attitude (deg) errors of a strapdown solution
/// fed the error-free IMU of scenario `name`'s dynamic truth sampled every `dt` s, from the
/// true initial state.
fn mechanized(name: &str, dt: f64) -> (f64, f64, f64) {
    let s = Scenario::built_in(name).unwrap();
    let (mut truth, _) = from_scenario(&s, 1, dt).unwrap().unwrap();
    let first = truth.sample(0.0);
    let imu = |s: &TruthSample| {
        let m = perfect_imu(&s.motion, s.lat_rad, s.height_m);
        ImuSample {
            omega_ib_body: m.omega_ib_body,
            specific_force_body: m.specific_force_body,
        }
    };
    let mut nav = NavState {
        lat_rad: first.lat_rad,
        lon_rad: first.lon_rad,
        height_m: first.height_m,
        vel_ned_m_s: first.motion.vel_ned,
        ned_from_body: UnitQuaternion::from_rotation_matrix(&first.motion.ned_from_body),
    };
    let damping = HeightDamping::critical(0.05);
    let mut previous = imu(&first);
    let (mut worst_m, mut worst_v, mut worst_deg): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let steps = (truth.duration_s() / dt).round() as usize;
    for k in 1..=steps {
        let s = truth.sample(k as f64 * dt);
        let now = imu(&s);
        nav = propagate(&nav, &previous, &now, dt, Some((damping, s.height_m)));
        previous = now;
        let (n, e) = geodesy::local_north_east_m(s.lat_rad, s.lon_rad, nav.lat_rad, nav.lon_rad);
        worst_m = worst_m.max(n.hypot(e));
        worst_v = worst_v.max((nav.vel_ned_m_s - s.motion.vel_ned).norm());
        let q = UnitQuaternion::from_rotation_matrix(&s.motion.ned_from_body);
        worst_deg = worst_deg.max((nav.ned_from_body.inverse() * q).angle().to_degrees());
    }
    (worst_m, worst_v, worst_deg)
}

/// The synthesised IMU is the dynamic truth's: mechanized from the true initial state with
/// the error-free IMU, the strapdown solution stays on the truth through the manoeuvres, and
/// what it does lose is the strapdown algorithm's own sampling error (it shrinks with the
/// step: the drop's first seconds, fins slewing at their rate limit, have the largest rate
/// curvature).
#[test]
fn perfect_imu_of_the_dynamics_mechanizes_back_to_the_truth() {
    for name in ["turning-circle", "zigzag-rudder-20-20", "zigzag-planes-10-10", "drop-entry"] {
        let (m, v, deg) = mechanized(name, 0.01);
        let (m5, v5, deg5) = mechanized(name, 0.002);
        println!(
            "{name}: perfect IMU mechanized: at 100 Hz position within {m:.4} m, velocity {v:.5} m/s, \
             attitude {deg:.6} deg; at 500 Hz {m5:.4} m, {v5:.6} m/s, {deg5:.7} deg"
        );
        assert!(m < 0.6 && v < 0.005 && deg < 1e-4, "{name}");
        assert!(m5 < 0.05 && v5 < 5e-4 && deg5 < 1e-5, "{name}");
        // The loss is the algorithm's: five times finer, at least ten times smaller.
        assert!(m5 < m / 10.0 && deg5 < deg / 10.0, "{name}");
    }
}
