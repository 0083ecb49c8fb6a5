//! The reset that keeps a heading no body-frame velocity can tell untold.
//!
//! A heading error and a velocity error turned with it, `(dv, psi) = (e_z x v, e_z)`, leave
//! every body-frame velocity reading as it is: without the Earth's rate, no DVL can tell them
//! apart, and the covariance must keep its prior sigma along that direction. But the
//! direction depends on the nominal velocity `v`. Carried over unchanged (the identity reset)
//! after a correction moved `v`, the covariance's unobservable direction is the old one, and
//! the next reading, linearised at the new `v`, sees the difference `e_z x dv` as information
//! about the heading: the EKF's classic inconsistency (the one observability-constrained and
//! invariant EKFs remove).
//!
//! Measured, default figures (`auv-at-sea-straight` with a 1 deg/h gyro and the true start
//! heading, 5 deg sigma): the heading sigma fell to 1.5 deg within 30 s while the error
//! stayed near 2 deg; with a 100 deg/h bias prior, where nothing at all tells the heading,
//! it fell to 1.8 deg. The covariance alone, propagated and updated at a fixed nominal (the
//! linear model), keeps 3.4 and 5.5 deg, and so does the filter with this reset.
//!
//! The reset `P <- J P J^T`, `J = I + t e_z^T` in the velocity rows' heading column with
//! `t = e_z x dv` ([`heading_turn`]), keeps the velocity's error relative to the heading's,
//! `dv - psi_z (e_z x v)` (the invariant EKF's velocity error, about the vertical only), so
//! the direction moves with `v`: `J (e_z x v, e_z) = (e_z x (v + dv), e_z)`. Only the heading:
//! the tilt is observable, and for it (and for any other error) the identity is this error
//! state's exact reset. Only once the DVL has been read: without body-frame velocity
//! readings the turn would only tie the velocity to the heading's innovations. Tried for the
//! model's and the propeller's velocities too, it made `drop-no-dvl` (model velocity and a
//! magnetometer) worse on 5 of 8 seeds, the model's lag read as heading either way; those
//! aids bridge DVL outages, with errors correlated over tens of seconds.

use super::error_state::{idx, ErrorMatrix, ErrorState};
use nalgebra::Vector3;

/// How the velocity's error turns with the heading's once a correction has moved the
/// nominal velocity by `dv`: `e_z x dv`, the turn of [`keep_heading_unobservable`].
pub fn heading_turn(dv: &Vector3<f64>) -> Vector3<f64> {
    Vector3::z().cross(dv)
}

/// A correction's horizontal move of the velocity larger than this many of the filter's own
/// sigmas before it is no small correction: the filter had gone astray (an untuned MEMS IMU
/// diverging by 1e10 m/s), where a first-order change of coordinates means nothing and the
/// identity reset is kept.
const SMALL_CORRECTION_SIGMAS: f64 = 5.0;

/// The variance of the horizontal velocity's error, north plus east, m^2/s^2 (before an
/// update: the scale [`turn_of`] judges its correction by).
pub fn horizontal_velocity_variance(p: &ErrorMatrix) -> f64 {
    p[(idx::VEL, idx::VEL)] + p[(idx::VEL + 1, idx::VEL + 1)]
}

/// The [`heading_turn`] of a correction that moved the velocity by `dv`, when it is a small
/// correction for a filter whose horizontal velocity variance was `variance` before it
/// ([`SMALL_CORRECTION_SIGMAS`]); `None` otherwise.
pub fn turn_of(dv: &Vector3<f64>, variance: f64) -> Option<Vector3<f64>> {
    let horizontal = dv.x * dv.x + dv.y * dv.y;
    (horizontal <= SMALL_CORRECTION_SIGMAS.powi(2) * variance).then(|| heading_turn(dv))
}

/// The covariance carried from the nominal a correction came from to the corrected one,
/// `P <- J P J^T`, `J = I + turn e_z^T` in the velocity rows' heading column (`turn` the
/// [`heading_turn`] of the correction's velocity part). See the module's documentation.
pub fn keep_heading_unobservable(p: &mut ErrorMatrix, turn: &Vector3<f64>) {
    reset_by(p, turn);
}

/// The smoothed error and its covariance at an epoch whose resets turned by `turn` (the sum
/// of its updates' [`heading_turn`]s), from the posterior's error coordinates to the prior's:
/// `J^-1 = I - E` ([`keep_heading_unobservable`]; `E` squares to zero, so the turns of
/// several updates add).
pub fn to_prior_coordinates(dx: &mut ErrorState, p: &mut ErrorMatrix, turn: &Vector3<f64>) {
    let back = -turn;
    let turned = back * dx[idx::ATT + 2];
    for k in 0..3 {
        dx[idx::VEL + k] += turned[k];
    }
    reset_by(p, &back);
}

/// `P <- J P J^T` with `J = I + E`, `E = e e_z^T` in the velocity rows' attitude columns (the
/// heading's column): `P + E P + P E^T + E P E^T`, touching the velocity rows and columns.
fn reset_by(p: &mut ErrorMatrix, e: &Vector3<f64>) {
    let ep = e * p.row(idx::ATT + 2);
    let epe = e * e.transpose() * p[(idx::ATT + 2, idx::ATT + 2)];
    let mut rows = p.fixed_rows_mut::<3>(idx::VEL);
    rows += &ep;
    let mut columns = p.fixed_columns_mut::<3>(idx::VEL);
    columns += ep.transpose();
    let mut vv = p.fixed_view_mut::<3, 3>(idx::VEL, idx::VEL);
    vv += epe;
}

#[cfg(test)]
mod tests {
    use super::super::error_state::N;
    use super::super::forward::{measure, DvlMounting, Estimate};
    use super::super::mechanization::NavState;
    use super::*;
    use nalgebra::{SVector, UnitQuaternion};

    fn estimate_at(vel_ned_m_s: Vector3<f64>, cov: ErrorMatrix) -> Estimate {
        Estimate {
            nav: NavState {
                lat_rad: 0.6,
                lon_rad: -2.0,
                height_m: -20.0,
                vel_ned_m_s,
                ned_from_body: UnitQuaternion::from_euler_angles(0.02, -0.03, 1.8),
            },
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            dvl: SVector::zeros(),
            water: SVector::zeros(),
            gyro_scale_z: 0.0,
            sound_speed_scale: 0.0,
            cov,
        }
    }

    /// The turn of the heading and the velocity with it, at nominal velocity `v`.
    fn unseen(v: &Vector3<f64>) -> ErrorState {
        let mut u = ErrorState::zeros();
        u.fixed_rows_mut::<3>(idx::VEL)
            .copy_from(&Vector3::z().cross(v));
        u[idx::ATT + 2] = 1.0;
        u
    }

    /// What a DVL at `v` (with a lever arm and a turning body) reads of the error `u`.
    fn dvl_reads(v: &Vector3<f64>, u: &ErrorState) -> Vector3<f64> {
        let est = estimate_at(*v, ErrorMatrix::identity());
        let mounting = DvlMounting::from_config([0.8, -0.1, 0.3], [0.0, 0.0, 45.0]);
        let omega = Vector3::new(0.01, -0.02, 0.05);
        let (_, h) = measure::dvl_velocity(&est, &measure_any(), &mounting, &omega);
        h * u
    }

    fn measure_any() -> Vector3<f64> {
        Vector3::new(1.9, 0.1, 0.0)
    }

    /// After a correction moves the nominal velocity, the covariance's direction that no DVL
    /// reading sees must be the one at the new velocity: with the identity reset the DVL
    /// reads the old direction as `e_z x dv` (a heading it could not tell), with this reset
    /// it reads nothing.
    #[test]
    fn the_dvl_reads_nothing_of_the_heading_after_a_correction_either() {
        let v = Vector3::new(-0.48, 1.94, 0.05);
        let dv = Vector3::new(0.03, -0.02, 0.01);
        assert!(dvl_reads(&v, &unseen(&v)).norm() < 1e-15);
        let identity_reset = dvl_reads(&(v + dv), &unseen(&v)).norm();
        assert!(identity_reset > 0.02, "{identity_reset}");
        // J u(v) = u(v + dv), with J applied as the reset applies it: to P = u u^T.
        let u = unseen(&v);
        let mut p = u * u.transpose();
        keep_heading_unobservable(&mut p, &heading_turn(&dv));
        let moved = unseen(&(v + dv));
        assert!((p - moved * moved.transpose()).amax() < 1e-15);
        assert!(dvl_reads(&(v + dv), &moved).norm() < 1e-15);
    }

    /// The reset keeps the covariance symmetric positive definite, leaves every block but
    /// the velocity's rows and columns as they were, and [`to_prior_coordinates`] undoes it
    /// exactly (the mean too), for several updates' turns summed.
    #[test]
    fn the_smoother_undoes_the_reset_exactly() {
        let a = ErrorMatrix::from_fn(|i, j| ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.45);
        let p0 = a * a.transpose() + ErrorMatrix::identity() * 0.05;
        let turns = [
            heading_turn(&Vector3::new(0.2, -0.1, 0.3)),
            heading_turn(&Vector3::new(-0.05, 0.4, 0.0)),
        ];
        let mut p = p0;
        for t in &turns {
            keep_heading_unobservable(&mut p, t);
        }
        assert!(p.cholesky().is_some());
        assert!((p - p.transpose()).amax() < 1e-15);
        for i in 0..N {
            for j in 0..N {
                let velocity =
                    (idx::VEL..idx::VEL + 3).contains(&i) || (idx::VEL..idx::VEL + 3).contains(&j);
                if !velocity {
                    assert_eq!(p[(i, j)], p0[(i, j)]);
                }
            }
        }
        // The error in the prior's coordinates, and in the posterior's: J dx.
        let dx0 = ErrorState::from_fn(|i, _| (i as f64 * 0.37).sin());
        let sum = turns[0] + turns[1];
        let mut dx = dx0;
        let turned = sum * dx0[idx::ATT + 2];
        for k in 0..3 {
            dx[idx::VEL + k] += turned[k];
        }
        to_prior_coordinates(&mut dx, &mut p, &sum);
        assert!((dx - dx0).amax() < 1e-15);
        assert!((p - p0).amax() < 1e-12, "{}", (p - p0).amax());
    }
}
