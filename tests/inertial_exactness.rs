//! The simulator's inertial synthesis and the library's mechanization agree: fed the
//! error-free IMU of the 1-hour `survey` scenario, the mechanization stays on the truth.

use hindsight::filters::ins::mechanization::{propagate, HeightDamping, ImuSample, NavState};
use hindsight::geodesy;
use hindsight::sim::inertial::perfect_imu;
use hindsight::sim::trajectory::{PositionIntegrator, Trajectory};
use nalgebra::{UnitQuaternion, Vector3};

/// The `survey` scenario's truth (surface start, dive, six lanes, surface: about 1 h).
fn survey_hour() -> Trajectory {
    hindsight::sim::scenario::Scenario::built_in("survey")
        .unwrap()
        .trajectory()
        .unwrap()
}

/// Worst errors of a mechanization run against the truth.
struct Flight {
    worst_horizontal_m: f64,
    worst_attitude_deg: f64,
    max_depth_m: f64,
}

/// Mechanizes `duration_s` of `traj` at 100 Hz from the true initial state, with the IMU of
/// `imu_at(t, lat/lon/h)`, the vertical channel damped on the true height; errors are
/// checked every 10 s and at the end.
fn fly(
    traj: &Trajectory,
    duration_s: f64,
    imu_at: impl Fn(f64, &Vector3<f64>) -> ImuSample,
) -> Flight {
    let dt = 0.01;
    let steps = (duration_s / dt).round() as usize;
    let mut truth = PositionIntegrator::new(traj);
    let kin0 = traj.kinematics(0.0);
    let mut nav = NavState {
        lat_rad: truth.position.x,
        lon_rad: truth.position.y,
        height_m: truth.position.z,
        vel_ned_m_s: kin0.vel_ned(),
        ned_from_body: UnitQuaternion::from_rotation_matrix(&kin0.ned_from_body()),
    };
    let damping = HeightDamping::critical(0.05);
    let mut imu_prev = imu_at(0.0, &truth.position);
    let mut f = Flight {
        worst_horizontal_m: 0.0,
        worst_attitude_deg: 0.0,
        max_depth_m: 0.0,
    };
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
            let q_truth = UnitQuaternion::from_rotation_matrix(&traj.kinematics(t).ned_from_body());
            f.worst_horizontal_m = f.worst_horizontal_m.max(n.hypot(e));
            f.worst_attitude_deg = f
                .worst_attitude_deg
                .max((nav.ned_from_body.inverse() * q_truth).angle().to_degrees());
            f.max_depth_m = f.max_depth_m.max(-truth.position.z);
        }
    }
    f
}

fn perfect(traj: &Trajectory) -> impl Fn(f64, &Vector3<f64>) -> ImuSample + '_ {
    |t, p| {
        let m = perfect_imu(&traj.kinematics(t).motion(), p.x, p.z);
        ImuSample {
            omega_ib_body: m.omega_ib_body,
            specific_force_body: m.specific_force_body,
        }
    }
}

#[test]
fn mechanization_of_perfect_imu_stays_on_truth_for_an_hour() {
    let traj = survey_hour();
    assert!(traj.duration_s() >= 3600.0, "{}", traj.duration_s());
    let f = fly(&traj, traj.duration_s(), perfect(&traj));
    // The trajectory really is the survey: it went down to its planned depth.
    assert!((f.max_depth_m - 30.0).abs() < 0.01, "{}", f.max_depth_m);
    println!(
        "after {:.0} s: worst horizontal error {:.4} m, worst attitude error {:.6} deg",
        traj.duration_s(),
        f.worst_horizontal_m,
        f.worst_attitude_deg
    );
    assert!(f.worst_horizontal_m < 1.0, "{} m", f.worst_horizontal_m);
    assert!(f.worst_attitude_deg < 0.01, "{} deg", f.worst_attitude_deg);
}

/// The check above can fail: the same flight with a gyro that misses the Earth rate (an error
/// of 15 deg/h, what a wrong synthesis would make) leaves its attitude bound within 10 min.
#[test]
fn a_gyro_without_earth_rate_fails_the_same_bounds() {
    let traj = survey_hour();
    let ideal = perfect(&traj);
    let f = fly(&traj, 600.0, |t, p| {
        let m = ideal(t, p);
        let body_from_ned = traj.kinematics(t).ned_from_body().inverse();
        ImuSample {
            omega_ib_body: m.omega_ib_body - body_from_ned * geodesy::earth_rate_ned(p.x),
            ..m
        }
    });
    assert!(
        f.worst_attitude_deg > 0.5,
        "10 min at 15 deg/h: {} deg",
        f.worst_attitude_deg
    );
}
