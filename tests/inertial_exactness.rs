//! The simulator's inertial synthesis and the library's mechanization agree: fed the
//! error-free IMU of the 1-hour `survey` scenario, the mechanization stays on the truth.

use hindsight::filters::ins::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use hindsight::geodesy;
use hindsight::sim::inertial::perfect_imu;
use hindsight::sim::trajectory::{PositionIntegrator, Trajectory};
use nalgebra::UnitQuaternion;

/// The `survey` scenario's truth (surface start, dive, six lanes, surface: about 1 h).
fn survey_hour() -> Trajectory {
    hindsight::sim::scenario::Scenario::built_in("survey")
        .unwrap()
        .trajectory()
        .unwrap()
}

#[test]
fn mechanization_of_perfect_imu_stays_on_truth_for_an_hour() {
    let traj = survey_hour();
    assert!(traj.duration_s() >= 3600.0, "{}", traj.duration_s());
    let rate_hz = 100.0;
    let dt = 1.0 / rate_hz;
    let steps = (traj.duration_s() * rate_hz).round() as usize;
    let mut truth = PositionIntegrator::new(&traj);
    let kin0 = traj.kinematics(0.0);
    let imu_at = |t: f64, p: &nalgebra::Vector3<f64>| {
        let m = perfect_imu(&traj.kinematics(t), p.x, p.z);
        ImuSample {
            omega_ib_body: m.omega_ib_body,
            specific_force_body: m.specific_force_body,
        }
    };
    let mut nav = NavState {
        lat_rad: truth.position.x,
        lon_rad: truth.position.y,
        height_m: truth.position.z,
        vel_ned_m_s: kin0.vel_ned(),
        ned_from_body: UnitQuaternion::from_rotation_matrix(&kin0.ned_from_body()),
    };
    let damping = HeightDamping::critical(0.05);
    let mut imu_prev = imu_at(0.0, &truth.position);
    let (mut worst_horizontal, mut worst_attitude) = (0.0f64, 0.0f64);
    let mut max_depth = 0.0f64;
    for k in 1..=steps {
        let t = k as f64 * dt;
        truth.advance_to(t);
        let imu = imu_at(t, &truth.position);
        nav = propagate(&nav, &imu_prev, &imu, dt, Some((damping, truth.position.z)));
        imu_prev = imu;
        if k % 1000 == 0 || k == steps {
            let (n, e) = geodesy::local_north_east_m(
                truth.position.x,
                truth.position.y,
                nav.lat_rad,
                nav.lon_rad,
            );
            worst_horizontal = worst_horizontal.max(n.hypot(e));
            let q_truth = UnitQuaternion::from_rotation_matrix(&traj.kinematics(t).ned_from_body());
            worst_attitude = worst_attitude.max((nav.ned_from_body.inverse() * q_truth).angle());
            max_depth = max_depth.max(-truth.position.z);
        }
    }
    // The trajectory really is the survey: it went down to its planned depth and travelled.
    assert!((max_depth - 30.0).abs() < 0.01, "{max_depth}");
    let (n, e) = geodesy::local_north_east_m(
        traj.start_position().0,
        traj.start_position().1,
        truth.position.x,
        truth.position.y,
    );
    println!(
        "after {:.0} s: worst horizontal error {worst_horizontal:.4} m, worst attitude error {:.6} deg, end {:.0} m from start",
        traj.duration_s(),
        worst_attitude.to_degrees(),
        n.hypot(e),
    );
    assert!(worst_horizontal < 1.0, "{worst_horizontal} m");
    assert!(
        worst_attitude.to_degrees() < 0.01,
        "{} deg",
        worst_attitude.to_degrees()
    );
}

/// The check above can fail: the same hour with a gyro that misses the Earth rate (an error
/// of 15 deg/h, what a wrong synthesis would make) drifts far outside its bounds.
#[test]
fn a_gyro_without_earth_rate_fails_the_same_bounds() {
    let traj = survey_hour();
    let dt = 0.01;
    let mut truth = PositionIntegrator::new(&traj);
    let kin0 = traj.kinematics(0.0);
    let imu_at = |t: f64, p: &nalgebra::Vector3<f64>| {
        let m = perfect_imu(&traj.kinematics(t), p.x, p.z);
        let body_from_ned = traj.kinematics(t).ned_from_body().inverse();
        ImuSample {
            omega_ib_body: m.omega_ib_body - body_from_ned * geodesy::earth_rate_ned(p.x),
            specific_force_body: m.specific_force_body,
        }
    };
    let mut nav = NavState {
        lat_rad: truth.position.x,
        lon_rad: truth.position.y,
        height_m: truth.position.z,
        vel_ned_m_s: kin0.vel_ned(),
        ned_from_body: UnitQuaternion::from_rotation_matrix(&kin0.ned_from_body()),
    };
    let mut imu_prev = imu_at(0.0, &truth.position);
    for k in 1..=60_000 {
        let t = k as f64 * dt;
        truth.advance_to(t);
        let imu = imu_at(t, &truth.position);
        nav = propagate(
            &nav,
            &imu_prev,
            &imu,
            dt,
            Some((HeightDamping::critical(0.05), truth.position.z)),
        );
        imu_prev = imu;
    }
    let (n, e) =
        geodesy::local_north_east_m(truth.position.x, truth.position.y, nav.lat_rad, nav.lon_rad);
    let q_truth = UnitQuaternion::from_rotation_matrix(&traj.kinematics(600.0).ned_from_body());
    let attitude_deg = (nav.ned_from_body.inverse() * q_truth).angle().to_degrees();
    assert!(
        n.hypot(e) > 1.0 || attitude_deg > 0.01,
        "{} m, {attitude_deg} deg",
        n.hypot(e)
    );
    assert!(attitude_deg > 0.5, "10 min at 15 deg/h: {attitude_deg} deg");
}
