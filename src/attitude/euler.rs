//! What seed 001's three filters (EKF, UKF, CF) share: a state of Euler angles
//! `[roll, pitch, yaw]` (Z-Y-X, rad), turned by the gyro, corrected by the "no filtering"
//! attitude of eq. 1-3 as the measurement; and the driver that runs any of them over a log.
//!
//! The paper propagates with the Euler-rate kinematics (Table 1 lines 1-4; its line 1 drops
//! the `r` term that Tables 2 and 3 keep: the kinematics below have it):
//!
//! ```text
//! roll'  = p + (q sin(roll) + r cos(roll)) tan(pitch)
//! pitch' = q cos(roll) - r sin(roll)
//! yaw'   = (q sin(roll) + r cos(roll)) / cos(pitch)
//! ```
//!
//! which are singular at pitch +-90 deg. hindsight turns the mean through the quaternion
//! instead ([`propagate`]: the exact rotation of the gyro's rate over the step, equal to the
//! paper's Euler step to first order in the step and defined at any attitude), and converts
//! to Euler angles after each step. The covariance uses the paper's transition
//! `A = I + dt d(rates)/d(angles)` ([`transition`]), checked against finite differences of
//! the paper's Euler step in the tests; near pitch +-90 deg its `1 / cos(pitch)` is bounded
//! (at [`MIN_COS_PITCH`]) so that it stays finite. Euler angles are what these filters
//! estimate (it is the method being compared); every other part of hindsight works in
//! quaternions.

use super::{from_gravity_and_field, AhrsInputs, AttitudeSample};
use crate::angle::wrap_pi;
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};

/// Euler angles `[roll, pitch, yaw]`, rad.
pub type Euler = Vector3<f64>;

/// Smallest `|cos(pitch)|` the transition divides by.
pub const MIN_COS_PITCH: f64 = 1e-3;

/// The attitude of Euler angles (`ned_from_body`).
pub fn to_quaternion(x: &Euler) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(x[0], x[1], x[2])
}

/// The Euler angles of an attitude, roll and yaw in (-pi, pi], pitch in [-pi/2, pi/2].
pub fn from_quaternion(q: &UnitQuaternion<f64>) -> Euler {
    let (roll, pitch, yaw) = q.euler_angles();
    Euler::new(roll, pitch, yaw)
}

/// `a - b` with roll and yaw wrapped to (-pi, pi].
pub fn difference(a: &Euler, b: &Euler) -> Euler {
    Euler::new(wrap_pi(a[0] - b[0]), a[1] - b[1], wrap_pi(a[2] - b[2]))
}

/// Roll and yaw wrapped to (-pi, pi].
pub fn wrapped(x: &Euler) -> Euler {
    Euler::new(wrap_pi(x[0]), x[1], wrap_pi(x[2]))
}

/// The Euler-angle rates of body rates `w_body` (p, q, r) at attitude `x` (Table 1 lines 1-3).
pub fn rates(x: &Euler, w_body: &Vector3<f64>) -> Euler {
    let (sr, cr) = x[0].sin_cos();
    let (sp, cp) = x[1].sin_cos();
    let cp = bounded_cos(cp);
    let (p, q, r) = (w_body.x, w_body.y, w_body.z);
    let qr = q * sr + r * cr;
    Euler::new(p + qr * sp / cp, q * cr - r * sr, qr / cp)
}

/// The paper's Euler step over `dt` (Table 1 line 4): `x + rates(x, w) dt`.
pub fn euler_step(x: &Euler, w_body: &Vector3<f64>, dt: f64) -> Euler {
    x + rates(x, w_body) * dt
}

/// The transition of the paper's Euler step, `A = I + dt d(rates)/d(angles)` (Table 1
/// line 5, which its print leaves symbolic).
pub fn transition(x: &Euler, w_body: &Vector3<f64>, dt: f64) -> Matrix3<f64> {
    let (sr, cr) = x[0].sin_cos();
    let (sp, cp) = x[1].sin_cos();
    let cp = bounded_cos(cp);
    let (q, r) = (w_body.y, w_body.z);
    let qr = q * sr + r * cr; // q sin(roll) + r cos(roll)
    let dqr = q * cr - r * sr; // its derivative by roll
    let jacobian = Matrix3::new(
        dqr * sp / cp,
        qr / (cp * cp),
        0.0,
        -qr,
        0.0,
        0.0,
        dqr / cp,
        qr * sp / (cp * cp),
        0.0,
    );
    Matrix3::identity() + jacobian * dt
}

fn bounded_cos(c: f64) -> f64 {
    if c.abs() < MIN_COS_PITCH {
        MIN_COS_PITCH.copysign(c)
    } else {
        c
    }
}

/// The attitude `dt` after `x` turning at `w_body` (rad/s): the exact rotation, as Euler
/// angles. Defined at any attitude.
pub fn propagate(x: &Euler, w_body: &Vector3<f64>, dt: f64) -> Euler {
    from_quaternion(&(to_quaternion(x) * UnitQuaternion::from_scaled_axis(w_body * dt)))
}

/// Seed 001's measurement (eq. 1-3): roll and pitch from the accelerometer, yaw from the
/// tilt-compensated magnetometer plus the declination.
pub fn measurement(
    specific_force_body: &Vector3<f64>,
    field_body: &Vector3<f64>,
    declination_rad: f64,
) -> Euler {
    from_quaternion(&from_gravity_and_field(
        specific_force_body,
        field_body,
        declination_rad,
    ))
}

/// A covariance the filters can use: the symmetric part of `m` with its eigenvalues raised
/// to at least `floor`. Returns the matrix and, when it had to change it, the eigenvalues
/// it found (so the caller can say so).
pub fn positive_definite(m: &Matrix3<f64>, floor: f64) -> (Matrix3<f64>, Option<Vector3<f64>>) {
    let sym = (m + m.transpose()) * 0.5;
    let eig = SymmetricEigen::new(sym);
    if eig.eigenvalues.min() >= floor && sym == *m {
        return (*m, None);
    }
    let raised = eig.eigenvalues.map(|e| e.max(floor));
    let fixed = eig.eigenvectors * Matrix3::from_diagonal(&raised) * eig.eigenvectors.transpose();
    ((fixed + fixed.transpose()) * 0.5, Some(eig.eigenvalues))
}

/// One of seed 001's filters: a pure step from the previous state, the gyro's rate over the
/// step and the eq. 1-3 measurement at its end.
pub trait EulerFilter {
    type State;
    /// The state at the first sample, from its measurement.
    fn start(&self, z: &Euler) -> Self::State;
    /// The state `dt` later.
    fn step(&self, prior: &Self::State, w_body: &Vector3<f64>, dt: f64, z: &Euler) -> Self::State;
    /// The attitude of a state.
    fn attitude(state: &Self::State) -> Euler;
}

/// Runs a filter over the inputs: the attitude at every IMU stamp from the first one that
/// has a magnetometer reading (the measurement needs one), and the final state.
pub fn run<F: EulerFilter>(
    filter: &F,
    inputs: &AhrsInputs<'_>,
) -> (Vec<AttitudeSample>, Option<F::State>) {
    let z_at = |m: &crate::contract::Imu| {
        let field = inputs.mag_at(m.stamp_ns)?;
        Some(measurement(
            &Vector3::from(m.specific_force),
            &field,
            inputs.declination_rad,
        ))
    };
    let mut out = Vec::with_capacity(inputs.imu.len());
    let Some(start) = inputs.imu.iter().position(|m| z_at(m).is_some()) else {
        return (out, None);
    };
    let first = &inputs.imu[start];
    let mut state = filter.start(&z_at(first).unwrap_or_default());
    out.push(sample(first.stamp_ns, &F::attitude(&state)));
    for pair in inputs.imu[start..].windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let dt = (b.stamp_ns - a.stamp_ns) as f64 * 1e-9;
        let Some(z) = z_at(b) else { continue };
        if dt <= 0.0 {
            continue;
        }
        let w = (Vector3::from(a.angular_velocity) + Vector3::from(b.angular_velocity)) * 0.5;
        state = filter.step(&state, &w, dt, &z);
        out.push(sample(b.stamp_ns, &F::attitude(&state)));
    }
    (out, Some(state))
}

fn sample(stamp_ns: i64, x: &Euler) -> AttitudeSample {
    AttitudeSample {
        stamp_ns,
        ned_from_body: to_quaternion(x),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Table 1 line 5 against central differences of the paper's Euler step, at random
    /// attitudes and rates.
    #[test]
    fn transition_matches_finite_differences() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(51);
        let dt = 0.01;
        for _ in 0..500 {
            let x = Euler::new(
                rng.random_range(-3.1..3.1),
                rng.random_range(-1.4..1.4),
                rng.random_range(-3.1..3.1),
            );
            let w = Vector3::from_fn(|_, _| rng.random_range(-2.0..2.0));
            let a = transition(&x, &w, dt);
            let h = 1e-6;
            for j in 0..3 {
                let mut up = x;
                let mut down = x;
                up[j] += h;
                down[j] -= h;
                let column = (euler_step(&up, &w, dt) - euler_step(&down, &w, dt)) / (2.0 * h);
                for i in 0..3 {
                    let err = (column[i] - a[(i, j)]).abs();
                    assert!(
                        err < 1e-7 * (1.0 + a[(i, j)].abs()),
                        "A[{i},{j}] = {} vs {} at {x:?}",
                        a[(i, j)],
                        column[i]
                    );
                }
            }
        }
    }

    /// The quaternion step and the paper's Euler step agree to second order in the step.
    #[test]
    fn propagation_agrees_with_the_paper_to_first_order() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(52);
        for _ in 0..200 {
            let x = Euler::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-1.2..1.2),
                rng.random_range(-3.0..3.0),
            );
            let w = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
            let (d1, d2) = (
                difference(&propagate(&x, &w, 1e-3), &euler_step(&x, &w, 1e-3)).norm(),
                difference(&propagate(&x, &w, 2e-3), &euler_step(&x, &w, 2e-3)).norm(),
            );
            // Second order: halving the step quarters the difference.
            assert!(d1 < 1e-4 && d2 < 4.5 * d1 + 1e-12, "{d1} {d2}");
        }
        // And at pitch 90 deg the quaternion step stays finite.
        let x = propagate(
            &Euler::new(0.0, 1.5, 0.0),
            &Vector3::new(0.0, 0.2, 0.3),
            0.5,
        );
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn an_indefinite_covariance_is_raised_and_reported() {
        // Seed 001 Table 7's measurement covariance as printed: not positive definite.
        let printed = Matrix3::new(0.07, 0.07, 0.07, 0.07, 0.1, 0.07, 0.07, 0.07, 0.02);
        let (fixed, found) = positive_definite(&printed, 1e-6);
        assert!(found.unwrap().min() < 0.0);
        assert!(fixed.cholesky().is_some());
        let good = Matrix3::identity() * 0.1;
        assert_eq!(positive_definite(&good, 1e-6), (good, None));
    }
}
