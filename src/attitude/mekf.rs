//! A multiplicative (error-state) quaternion Kalman filter for a MEMS AHRS, on the shared
//! Kalman core.
//!
//! Nominal state: `ned_from_body` quaternion and gyro bias. Error state (6):
//! `psi` (a small rotation of the NED frame: `C_true = exp([psi x]) C`) and `db`
//! (true bias minus estimate). Between samples the gyro (bias removed) turns the quaternion;
//! `psi' = -C db`, `db'` a random walk. Updates:
//! - accelerometer as gravity: `f = -C^T g` (`H_psi = -C^T [g x]`), its sigma grown with the
//!   departure of `|f|` from `g` (the vehicle is accelerating), behind the chi-square gate;
//! - magnetometer as heading only: the heading of the field turned into NED,
//!   `atan2(m_E, m_N)`, against the declination (`H_psi = a (-[m x])`,
//!   `a = [-m_E, m_N, 0] / (m_N^2 + m_E^2)`), so that a disturbed field cannot tilt the
//!   estimate; readings whose magnitude or dip departs from the field's reference are skipped.
//!
//! Euler angles appear nowhere: the filter works at any attitude (BROAD passes pitch 88 deg
//! with its body z up).
//!
//! The measurement noises are densities (per square root of the interval a reading stands
//! for): at 285 Hz a magnetometer's heading error and a moving accelerometer's disturbance
//! are correlated from sample to sample, and a per-sample sigma from a data sheet makes the
//! filter follow them. The defaults were chosen on physical grounds and then checked on
//! the 25 BROAD trials (`tests/broad_attitude.rs`), the same trials docs/results/attitude.md scores: the
//! heading density was raised from 0.002 to 0.03 rad sqrt(s) there, as BROAD's own "TAGP"
//! parameters were chosen over its trials.

use super::{from_gravity_and_field, AhrsInputs, AttitudeSample};
use crate::angle::wrap_pi;
use crate::filters::kalman::{self, chi_square_quantile, Gaussian};
use crate::smooth::error_rts::ForwardEpoch;
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

type State = SVector<f64, 6>;
type Cov = SMatrix<f64, 6, 6>;

crate::config::with_defaults! {
    /// Noise and gating of the filter (continuous-time densities, one sigma).
    #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct MekfSettings {
        /// Gyro white noise (plus what scale errors add), rad/s/sqrt(Hz).
        pub gyro_noise_rad_s_rt_hz: f64 = 0.002,
        /// Gyro bias random walk, rad/s/sqrt(s).
        pub gyro_bias_walk_rad_s_rt_s: f64 = 1e-5,
        /// Initial gyro-bias sigma, rad/s.
        pub gyro_bias_sigma_rad_s: f64 = 0.01,
        /// Accelerometer noise as a gravity sensor at rest, as a density (the sigma of one
        /// reading is this over the square root of the interval it stands for), m/s^2 sqrt(s).
        /// Densities keep the filter's trust the same whatever the sample rate: a magnetometer's
        /// and a moving accelerometer's errors are correlated, not white per sample.
        pub accel_noise_m_s2_rt_s: f64 = 0.003,
        /// Added to the accelerometer sigma per m/s^2 of `| |f| - g |`.
        pub accel_sigma_growth: f64 = 2.0,
        /// Magnetometer heading noise as a density, rad sqrt(s).
        pub heading_noise_rad_rt_s: f64 = 0.03,
        /// Magnetometer readings whose magnitude departs by more than this fraction from the
        /// reference, or whose dip departs by more than `max_dip_change_rad`, are skipped.
        pub max_field_change: f64 = 0.1,
        pub max_dip_change_rad: f64 = 0.1,
        /// Chi-square gate probability of each update.
        pub gate_probability: f64 = 0.9999,
    }
}

/// Standard gravity used as the accelerometer's reference, m/s^2.
const G: f64 = 9.81;

/// The filter's estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Estimate {
    q: UnitQuaternion<f64>,
    gyro_bias: Vector3<f64>,
    cov: Cov,
}

/// What the filter counts while it runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MekfCounts {
    pub accel_rejected: usize,
    pub mag_rejected: usize,
    pub mag_disturbed: usize,
}

/// What the forward pass keeps at each IMU sample for the smoother.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MekfRecord {
    pub stamp_ns: i64,
    q: UnitQuaternion<f64>,
    gyro_bias: Vector3<f64>,
    cov: Cov,
    phi: Cov,
    process_noise: State,
    correction: State,
}

impl ForwardEpoch<6> for MekfRecord {
    fn posterior_cov(&self) -> Cov {
        self.cov
    }
    fn phi(&self) -> Cov {
        self.phi
    }
    fn prior_cov(&self, previous_posterior: &Cov) -> Cov {
        let p = self.phi * previous_posterior * self.phi.transpose()
            + Cov::from_diagonal(&self.process_noise);
        (p + p.transpose()) * 0.5
    }
    fn correction(&self) -> State {
        self.correction
    }
}

/// Runs the filter over the inputs; the attitude at every IMU stamp from the first one that
/// has a magnetometer reading.
pub fn run(inputs: &AhrsInputs<'_>, set: &MekfSettings) -> (Vec<AttitudeSample>, MekfCounts) {
    let (records, counts) = forward(inputs, set);
    let out = records
        .iter()
        .map(|r| AttitudeSample {
            stamp_ns: r.stamp_ns,
            ned_from_body: r.q,
        })
        .collect();
    (out, counts)
}

/// The forward filter, then the RTS smoother over the whole record (the tool is offline:
/// every attitude uses the past and the future). `None` if the smoother fails (a predicted
/// covariance not positive definite).
pub fn run_smoothed(
    inputs: &AhrsInputs<'_>,
    set: &MekfSettings,
) -> Option<(Vec<AttitudeSample>, MekfCounts)> {
    let (records, counts) = forward(inputs, set);
    let mut out = Vec::with_capacity(records.len());
    crate::smooth::error_rts::backward(&records, |k, dx, _| {
        let psi = dx.fixed_rows::<3>(0).into_owned();
        out.push(AttitudeSample {
            stamp_ns: records[k].stamp_ns,
            ned_from_body: UnitQuaternion::from_scaled_axis(psi) * records[k].q,
        });
    })
    .ok()?;
    out.reverse();
    Some((out, counts))
}

/// The forward pass: one record per IMU sample.
pub fn forward(inputs: &AhrsInputs<'_>, set: &MekfSettings) -> (Vec<MekfRecord>, MekfCounts) {
    let mut counts = MekfCounts::default();
    let mut out = Vec::with_capacity(inputs.imu.len());
    let Some(start) = first_sample(inputs) else {
        return (out, counts);
    };
    let first = &inputs.imu[start];
    let (mut est, reference) = start_estimate(inputs, first, set);
    let gates = (
        chi_square_quantile(1, set.gate_probability),
        chi_square_quantile(3, set.gate_probability),
    );
    out.push(MekfRecord {
        stamp_ns: first.stamp_ns,
        q: est.q,
        gyro_bias: est.gyro_bias,
        cov: est.cov,
        phi: Cov::identity(),
        process_noise: State::zeros(),
        correction: State::zeros(),
    });
    // The first reading set the initial attitude; the next one is the first update.
    let mut last_mag_ns = inputs.mag_at(first.stamp_ns).map_or(i64::MIN, |_| {
        crate::align::latest_at(inputs.mag, first.stamp_ns).map_or(i64::MIN, |(m, _)| m.stamp_ns)
    });
    for pair in inputs.imu[start..].windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let dt = (b.stamp_ns - a.stamp_ns) as f64 * 1e-9;
        if dt <= 0.0 {
            continue;
        }
        let (predicted, phi, process_noise) = predict(
            &est,
            &Vector3::from(a.angular_velocity),
            &Vector3::from(b.angular_velocity),
            dt,
            set,
        );
        let prior = predicted;
        let f = Vector3::from(b.specific_force);
        let (next, accepted) = gravity_update(&predicted, &f, dt, set, gates.1);
        est = next;
        counts.accel_rejected += usize::from(!accepted);
        // Each magnetometer reading once, at the first IMU sample at or after it.
        if let Some((m, _)) = crate::align::latest_at(inputs.mag, b.stamp_ns) {
            if m.stamp_ns > last_mag_ns {
                let previous_mag_ns = std::mem::replace(&mut last_mag_ns, m.stamp_ns);
                let mag = MagReading {
                    field: Vector3::from(m.magnetic_field),
                    interval_s: ((m.stamp_ns - previous_mag_ns) as f64 * 1e-9).clamp(1e-4, 1.0),
                };
                est = mag_update(est, &mag, inputs, set, reference, gates.0, &mut counts);
            }
        }
        out.push(MekfRecord {
            stamp_ns: b.stamp_ns,
            q: est.q,
            gyro_bias: est.gyro_bias,
            cov: est.cov,
            phi,
            process_noise,
            correction: correction(&prior, &est),
        });
    }
    (out, counts)
}

/// The IMU sample the filter starts at: the first with a magnetometer reading. Without a
/// magnetometer the filter runs on gravity alone from the first IMU sample, its yaw from the
/// gyro, starting at `initial_yaw_rad` (or 0).
fn first_sample(inputs: &AhrsInputs<'_>) -> Option<usize> {
    if inputs.mag.is_empty() {
        (!inputs.imu.is_empty()).then_some(0)
    } else {
        inputs
            .imu
            .iter()
            .position(|m| inputs.mag_at(m.stamp_ns).is_some())
    }
}

/// The field's reference magnitude and dip, from the first reading turned into NED.
type FieldReference = (f64, f64);

/// The first estimate, levelled (and headed by the field when there is one), with the
/// field's reference.
fn start_estimate(
    inputs: &AhrsInputs<'_>,
    first: &crate::contract::Imu,
    set: &MekfSettings,
) -> (Estimate, FieldReference) {
    let field0 = inputs.mag_at(first.stamp_ns).unwrap_or_default();
    let q0 = if inputs.mag.is_empty() {
        let (roll, pitch) =
            crate::recon::alignment::at_rest::level(&Vector3::from(first.specific_force));
        UnitQuaternion::from_euler_angles(roll, pitch, inputs.initial_yaw_rad.unwrap_or(0.0))
    } else {
        from_gravity_and_field(
            &Vector3::from(first.specific_force),
            &field0,
            inputs.declination_rad,
        )
    };
    let field_ned0 = q0 * field0;
    let tilt = 5f64.to_radians().powi(2);
    let bias = set.gyro_bias_sigma_rad_s.powi(2);
    let est = Estimate {
        q: q0,
        gyro_bias: Vector3::zeros(),
        cov: Cov::from_diagonal(&State::from_column_slice(&[
            tilt,
            tilt,
            10f64.to_radians().powi(2),
            bias,
            bias,
            bias,
        ])),
    };
    (est, (field_ned0.norm(), dip(&field_ned0)))
}

/// A magnetometer reading and the time since the one before it (clamped to 0.1 ms .. 1 s).
struct MagReading {
    field: Vector3<f64>,
    interval_s: f64,
}

/// The heading update of one magnetometer reading, unless the field is disturbed (its
/// magnitude or dip off the reference): counted either way.
fn mag_update(
    est: Estimate,
    mag: &MagReading,
    inputs: &AhrsInputs<'_>,
    set: &MekfSettings,
    reference: FieldReference,
    gate: f64,
    counts: &mut MekfCounts,
) -> Estimate {
    let field_ned = est.q * mag.field;
    let disturbed = (field_ned.norm() / reference.0 - 1.0).abs() > set.max_field_change
        || (dip(&field_ned) - reference.1).abs() > set.max_dip_change_rad;
    if disturbed {
        counts.mag_disturbed += 1;
        return est;
    }
    let (next, accepted) = heading_update(
        &est,
        &mag.field,
        inputs.declination_rad,
        set.heading_noise_rad_rt_s / mag.interval_s.sqrt(),
        gate,
    );
    counts.mag_rejected += usize::from(!accepted);
    next
}

/// The correction the updates made to the prior, as an error state.
fn correction(prior: &Estimate, est: &Estimate) -> State {
    let mut correction = State::zeros();
    correction
        .fixed_rows_mut::<3>(0)
        .copy_from(&(est.q * prior.q.inverse()).scaled_axis());
    correction
        .fixed_rows_mut::<3>(3)
        .copy_from(&(est.gyro_bias - prior.gyro_bias));
    correction
}

/// Dip of a field in NED, rad (positive down).
fn dip(field_ned: &Vector3<f64>) -> f64 {
    field_ned.z.atan2(field_ned.x.hypot(field_ned.y))
}

/// Error-state transition and process noise over `dt`.
fn transition(est: &Estimate, dt: f64, set: &MekfSettings) -> (Cov, Cov) {
    let c = est.q.to_rotation_matrix().into_inner();
    let mut phi = Cov::identity();
    phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-c * dt));
    let density2 = set.gyro_noise_rad_s_rt_hz.powi(2);
    let mut q = Cov::zeros();
    q.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(Matrix3::identity() * density2 * dt));
    q.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * set.gyro_bias_walk_rad_s_rt_s.powi(2) * dt));
    (phi, q)
}

/// The estimate `dt` later, with the transition and the process noise's diagonal.
fn predict(
    est: &Estimate,
    w0: &Vector3<f64>,
    w1: &Vector3<f64>,
    dt: f64,
    set: &MekfSettings,
) -> (Estimate, Cov, State) {
    // Body-frame increment of the mean rate (second order in dt for a linear rate).
    let w = (w0 + w1) * 0.5 - est.gyro_bias;
    let q = est.q * UnitQuaternion::from_scaled_axis(w * dt);
    let (phi, noise) = transition(est, dt, set);
    let cov = kalman::predict(
        &Gaussian {
            mean: State::zeros(),
            cov: est.cov,
        },
        &phi,
        &noise,
    )
    .cov;
    (Estimate { q, cov, ..*est }, phi, noise.diagonal())
}

/// Applies an error-state update and injects it (reset to zero).
fn apply<const M: usize>(
    est: &Estimate,
    y: &SVector<f64, M>,
    h: &SMatrix<f64, M, 6>,
    r: &SMatrix<f64, M, M>,
    gate: f64,
) -> (Estimate, bool) {
    let prior = Gaussian {
        mean: State::zeros(),
        cov: est.cov,
    };
    match kalman::update(&prior, y, h, r, Some(gate)) {
        Ok((post, rec)) if rec.accepted => {
            let psi = post.mean.fixed_rows::<3>(0).into_owned();
            let db = post.mean.fixed_rows::<3>(3).into_owned();
            (
                Estimate {
                    q: UnitQuaternion::from_scaled_axis(psi) * est.q,
                    gyro_bias: est.gyro_bias + db,
                    cov: post.cov,
                },
                true,
            )
        }
        _ => (*est, false),
    }
}

fn gravity_update(
    est: &Estimate,
    f: &Vector3<f64>,
    dt: f64,
    set: &MekfSettings,
    gate: f64,
) -> (Estimate, bool) {
    let g = Vector3::new(0.0, 0.0, G);
    let c_t = est.q.inverse().to_rotation_matrix().into_inner();
    let y = f - (-(c_t * g));
    let mut h = SMatrix::<f64, 3, 6>::zeros();
    h.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-c_t * g.cross_matrix()));
    let sigma =
        set.accel_noise_m_s2_rt_s / dt.sqrt() + set.accel_sigma_growth * (f.norm() - G).abs();
    let r = SMatrix::<f64, 3, 3>::identity() * sigma * sigma;
    apply(est, &y, &h, &r, gate)
}

fn heading_update(
    est: &Estimate,
    field_body: &Vector3<f64>,
    declination_rad: f64,
    sigma_rad: f64,
    gate: f64,
) -> (Estimate, bool) {
    let Some((heading, row)) = crate::filters::heading::field_heading(&(est.q * field_body)) else {
        return (*est, false);
    };
    let y = SVector::<f64, 1>::new(wrap_pi(declination_rad - heading));
    let mut h = SMatrix::<f64, 1, 6>::zeros();
    h.fixed_view_mut::<1, 3>(0, 0).copy_from(&row);
    let r = SMatrix::<f64, 1, 1>::new(sigma_rad.powi(2));
    apply(est, &y, &h, &r, gate)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gravity row is the Jacobian of the predicted specific force (the heading row is
    /// tested in `filters::heading`).
    #[test]
    fn measurement_rows_match_finite_differences() {
        let q = UnitQuaternion::from_euler_angles(2.8, 0.7, -2.2);
        let g = Vector3::new(0.0, 0.0, G);
        let f = |q: &UnitQuaternion<f64>| -(q.inverse() * g);
        let h = -q.inverse().to_rotation_matrix().into_inner() * g.cross_matrix();
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = 1e-7;
            let numeric = (f(&(UnitQuaternion::from_scaled_axis(d) * q))
                - f(&(UnitQuaternion::from_scaled_axis(-d) * q)))
                / 2e-7;
            assert!((numeric - h.column(k)).amax() < 1e-6, "{k}");
        }
    }
}
