//! Real motion on top of a scenario's flight: the vibration of the hull and the propeller
//! (1-50 Hz) and the sea's oscillation (0.05-1 Hz), in rotation and translation, per body
//! axis. This is motion, not sensor noise: the IMU measures it correctly (its readings come
//! from the perturbed motion through [`super::inertial::perfect_imu`]) and the truth follows
//! it (attitude, velocity and position carry it). A method that reads a moving IMU's
//! high-frequency content as its white noise is fooled by it, as on real vehicles.
//!
//! Each axis and band is a sum of [`TONES`] sinusoids with frequencies spread
//! log-uniformly over the band and random phases (seeded), of equal amplitude, scaled so
//! that the band's RMS is the scenario's figure (`real-sensor-figures.md` gives them as
//! RMS per band and axis). The rotation is a small Z-Y-X Euler rotation of the body,
//! `ned_from_body' = ned_from_body R(phi, theta, psi)`, whose rate follows exactly from the
//! Euler rates: no coning is made up or lost. The translation is a body-frame velocity
//! perturbation; its displacement (under a millimetre) is integrated into the position.

use super::inertial::Motion;
use super::truth::TruthSample;
use nalgebra::{Rotation3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Sinusoids per axis and band.
pub const TONES: usize = 16;
/// The vibration band, Hz.
pub const VIBRATION_HZ: (f64, f64) = (1.0, 50.0);
/// The sea's band, Hz.
pub const SEA_HZ: (f64, f64) = (0.05, 1.0);

/// A scenario's real motion (`[motion]`): RMS per body axis (x forward, y starboard, z down).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionSpec {
    /// Body rate of the vibration in 1-50 Hz, deg/s RMS.
    pub vibration_rate_deg_s: [f64; 3],
    /// Acceleration of the vibration in 1-50 Hz, m/s^2 RMS.
    pub vibration_accel_m_s2: [f64; 3],
    /// Body rate of the sea's oscillation in 0.05-1 Hz, deg/s RMS.
    pub sea_rate_deg_s: [f64; 3],
}

impl MotionSpec {
    /// Every figure, for the scenario's checks.
    pub fn numbers(&self) -> Vec<f64> {
        [
            self.vibration_rate_deg_s,
            self.vibration_accel_m_s2,
            self.sea_rate_deg_s,
        ]
        .concat()
    }

    fn is_still(&self) -> bool {
        self.numbers().iter().all(|&x| x == 0.0)
    }
}

/// One sinusoid: `amplitude sin(omega t + phase)`.
#[derive(Debug, Clone, Copy)]
struct Tone {
    omega: f64,
    amplitude: f64,
    phase: f64,
}

/// A sum of tones with its value, rate and integral at a time.
#[derive(Debug, Clone, Default)]
struct Tones(Vec<Tone>);

impl Tones {
    /// Tones over `band` (Hz) whose sum has the RMS `rms`.
    fn draw(rms: f64, band: (f64, f64), rng: &mut ChaCha8Rng) -> Tones {
        if rms == 0.0 {
            return Tones::default();
        }
        // The RMS of a sum of n unit sinusoids is sqrt(n / 2).
        let amplitude = rms / (TONES as f64 / 2.0).sqrt();
        let (lo, hi) = (band.0.ln(), band.1.ln());
        Tones(
            (0..TONES)
                .map(|_| {
                    let f = (lo + rng.random::<f64>() * (hi - lo)).exp();
                    Tone {
                        omega: TAU * f,
                        amplitude,
                        phase: TAU * rng.random::<f64>(),
                    }
                })
                .collect(),
        )
    }

    /// The integral (from a zero mean) of the sum: `-a / omega cos(omega t + phase)`.
    fn integral(&self, t: f64) -> f64 {
        self.0
            .iter()
            .map(|k| -k.amplitude / k.omega * (k.omega * t + k.phase).cos())
            .sum()
    }

    fn value(&self, t: f64) -> f64 {
        self.0
            .iter()
            .map(|k| k.amplitude * (k.omega * t + k.phase).sin())
            .sum()
    }
}

/// The real motion of one run, applied to the truth sample by sample.
#[derive(Debug, Clone)]
pub struct RealMotion {
    /// Per axis, the rate's tones (both bands): the angle is their integral.
    rotation: [Tones; 3],
    /// Per axis, the acceleration's tones: the velocity is their integral.
    translation: [Tones; 3],
    /// The displacement so far (NED, m) and the time and NED velocity perturbation of the
    /// last sample, for its trapezoidal integral.
    displacement_ned_m: Vector3<f64>,
    last: Option<(f64, Vector3<f64>)>,
}

impl RealMotion {
    /// The run's motion, or `None` for a scenario without one.
    pub fn new(spec: &MotionSpec, mut rng: ChaCha8Rng) -> Option<RealMotion> {
        if spec.is_still() {
            return None;
        }
        let mut rotation: [Tones; 3] = Default::default();
        let mut translation: [Tones; 3] = Default::default();
        for axis in 0..3 {
            let vib = Tones::draw(
                spec.vibration_rate_deg_s[axis].to_radians(),
                VIBRATION_HZ,
                &mut rng,
            );
            let sea = Tones::draw(spec.sea_rate_deg_s[axis].to_radians(), SEA_HZ, &mut rng);
            rotation[axis] = Tones([vib.0, sea.0].concat());
            translation[axis] =
                Tones::draw(spec.vibration_accel_m_s2[axis], VIBRATION_HZ, &mut rng);
        }
        Some(RealMotion {
            rotation,
            translation,
            displacement_ned_m: Vector3::zeros(),
            last: None,
        })
    }

    /// The oscillation's Euler angles (roll, pitch, yaw) and their rates at `t_s`.
    fn euler(&self, t_s: f64) -> ([f64; 3], [f64; 3]) {
        // Zero-mean oscillations (not zero at the start): a value taken from the start would
        // leave a constant offset, a velocity's a steady drift of the position.
        let angle = |k: usize| self.rotation[k].integral(t_s);
        let rate = |k: usize| self.rotation[k].value(t_s);
        ([angle(0), angle(1), angle(2)], [rate(0), rate(1), rate(2)])
    }

    /// The sample with the real motion added (called at non-decreasing times).
    pub fn apply(&mut self, t_s: f64, sample: &mut TruthSample) {
        let ([phi, theta, psi], [dphi, dtheta, dpsi]) = self.euler(t_s);
        let body_from_shaken = Rotation3::from_euler_angles(phi, theta, psi);
        // The shaken body's rate relative to the flight's body, in its own axes (Z-Y-X
        // Euler rates).
        let (sp, cp) = phi.sin_cos();
        let (st, ct) = theta.sin_cos();
        let omega_shake = Vector3::new(
            dphi - dpsi * st,
            dtheta * cp + dpsi * ct * sp,
            -dtheta * sp + dpsi * ct * cp,
        );
        let m = sample.motion;
        let ned_from_body = m.ned_from_body * body_from_shaken;
        let omega_nb_body = body_from_shaken.inverse() * m.omega_nb_body + omega_shake;
        // The translation: a zero-mean body-frame velocity perturbation.
        let v = Vector3::from_fn(|k, _| self.translation[k].integral(t_s));
        let dv = Vector3::from_fn(|k, _| self.translation[k].value(t_s));
        let dv_ned = ned_from_body * v;
        let da_ned = ned_from_body * (dv + omega_nb_body.cross(&v));
        sample.motion = Motion {
            ned_from_body,
            vel_ned: m.vel_ned + dv_ned,
            accel_ned: m.accel_ned + da_ned,
            omega_nb_body,
        };
        if let Some((t0, v0)) = self.last {
            self.displacement_ned_m += 0.5 * (v0 + dv_ned) * (t_s - t0);
        }
        self.last = Some((t_s, dv_ned));
        let d = self.displacement_ned_m;
        // Under a millimetre: a sphere's radius converts it.
        let r = crate::geodesy::A_M + sample.height_m;
        sample.lat_rad += d.x / r;
        sample.lon_rad += d.y / (r * sample.lat_rad.cos());
        sample.height_m -= d.z;
        let (roll, pitch, yaw) = ned_from_body.euler_angles();
        sample.euler_rad = [roll, pitch, crate::angle::wrap_pi(yaw)];
        sample.speed_m_s = (ned_from_body.inverse() * sample.motion.vel_ned).x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::sensors::rng_for;

    fn spec() -> MotionSpec {
        MotionSpec {
            vibration_rate_deg_s: [0.08, 0.03, 0.015],
            vibration_accel_m_s2: [0.02, 0.03, 0.02],
            sea_rate_deg_s: [0.5, 0.2, 0.1],
        }
    }

    pub(super) fn level() -> TruthSample {
        let kin = crate::sim::trajectory::Kinematics {
            speed_m_s: 2.0,
            speed_rate_m_s2: 0.0,
            yaw_rad: 0.5,
            yaw_rate_rad_s: 0.0,
            pitch_rad: 0.0,
            pitch_rate_rad_s: 0.0,
            roll_rad: 0.0,
            roll_rate_rad_s: 0.0,
        };
        TruthSample {
            lat_rad: 0.6,
            lon_rad: 0.1,
            height_m: -30.0,
            motion: kin.motion(),
            euler_rad: [0.0, 0.0, 0.5],
            speed_m_s: 2.0,
            actuators: None,
        }
    }

    /// The body rate's RMS per axis is the spec's two bands together; the acceleration's is
    /// the vibration's.
    #[test]
    fn each_axis_has_its_rms() {
        let mut m = RealMotion::new(&spec(), rng_for(3, 13)).unwrap();
        let n = 200_000; // 2000 s at 100 Hz
        let (mut w2, mut a2) = (Vector3::zeros(), Vector3::zeros());
        for k in 0..n {
            let t = k as f64 * 0.01;
            let mut s = level();
            m.apply(t, &mut s);
            let body_from_ned = s.motion.ned_from_body.inverse();
            w2 += s
                .motion
                .omega_nb_body
                .component_mul(&s.motion.omega_nb_body);
            let a = body_from_ned * s.motion.accel_ned;
            a2 += a.component_mul(&a);
        }
        let s = spec();
        for k in 0..3 {
            let want = (s.vibration_rate_deg_s[k].powi(2) + s.sea_rate_deg_s[k].powi(2)).sqrt();
            let got = (w2[k] / n as f64).sqrt().to_degrees();
            assert!((got / want - 1.0).abs() < 0.05, "axis {k}: {got} vs {want}");
            let got = (a2[k] / n as f64).sqrt();
            let want = s.vibration_accel_m_s2[k];
            assert!((got / want - 1.0).abs() < 0.05, "axis {k}: {got} vs {want}");
        }
    }

    /// The attitude's rate is the body rate the IMU sees: integrating the shaken rate
    /// reproduces the shaken attitude (no coning made up), and the position follows the
    /// velocity.
    #[test]
    fn the_rate_integrates_to_the_attitude_and_the_velocity_to_the_position() {
        let mut m = RealMotion::new(&spec(), rng_for(4, 13)).unwrap();
        let dt = 0.001;
        let mut s0 = level();
        m.apply(0.0, &mut s0);
        let mut attitude = s0.motion.ned_from_body;
        let mut previous = s0;
        for k in 1..=300_000 {
            let t = k as f64 * dt;
            let mut s = level();
            m.apply(t, &mut s);
            // Midpoint rate over the step.
            let w = 0.5 * (previous.motion.omega_nb_body + s.motion.omega_nb_body);
            attitude *= Rotation3::new(w * dt);
            previous = s;
        }
        let err = (attitude.inverse() * previous.motion.ned_from_body).angle();
        // 300 s of 0.5 deg/s sea and 50 Hz vibration: the attitude follows to 1e-6 rad.
        assert!(err < 1e-6, "attitude off by {err} rad");
        // The displacement, the velocity perturbation's integral, stays under a millimetre
        // (no drift).
        assert!(
            m.displacement_ned_m.norm() < 1e-3,
            "{}",
            m.displacement_ned_m
        );
    }
}

#[cfg(test)]
mod at_the_imu_rate {
    use super::*;
    use crate::sim::sensors::rng_for;
    use nalgebra::{Quaternion, UnitQuaternion};

    /// RK4 over one interval of `q' = q (x) [0, w] / 2`, the rate linear between the samples,
    /// as the mechanization integrates the gyro.
    fn rk4(
        q: &UnitQuaternion<f64>,
        w0: &Vector3<f64>,
        w1: &Vector3<f64>,
        dt: f64,
    ) -> UnitQuaternion<f64> {
        let f = |q: &Quaternion<f64>, w: &Vector3<f64>| q * Quaternion::from_imag(*w) * 0.5;
        let wm = 0.5 * (w0 + w1);
        let y = *q.quaternion();
        let k1 = f(&y, w0);
        let k2 = f(&(y + k1 * (dt / 2.0)), &wm);
        let k3 = f(&(y + k2 * (dt / 2.0)), &wm);
        let k4 = f(&(y + k3 * dt), w1);
        UnitQuaternion::from_quaternion(y + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0))
    }

    /// The hull's motion sampled at 100 Hz, as the IMU gives it, and integrated as the
    /// mechanization does, follows the true attitude: the vibration up to 50 Hz makes no drift
    /// a fibre-optic gyro's bias would be confused with (under 0.005 deg/h over 400 s, against
    /// its 0.01; measured at most 0.0017 deg/h on seeds 1-3).
    #[test]
    fn sampled_at_100_hz_the_motion_makes_no_drift() {
        let spec = MotionSpec {
            vibration_rate_deg_s: [0.07, 0.02, 0.015],
            vibration_accel_m_s2: [0.015, 0.02, 0.015],
            sea_rate_deg_s: [0.3, 0.15, 0.06],
        };
        let dt = 0.01;
        let n = 40_000;
        for seed in 1..=3 {
            let mut m = RealMotion::new(&spec, rng_for(seed, 13)).unwrap();
            let sample = |m: &mut RealMotion, t: f64| {
                let mut s = super::tests::level();
                m.apply(t, &mut s);
                s
            };
            let first = sample(&mut m, 0.0);
            let mut q = UnitQuaternion::from_rotation_matrix(&first.motion.ned_from_body);
            let mut w0 = first.motion.omega_nb_body;
            let mut last = first;
            for k in 1..=n {
                let s = sample(&mut m, k as f64 * dt);
                q = rk4(&q, &w0, &s.motion.omega_nb_body, dt);
                w0 = s.motion.omega_nb_body;
                last = s;
            }
            let truth = UnitQuaternion::from_rotation_matrix(&last.motion.ned_from_body);
            let drift_deg_h = (truth * q.inverse()).scaled_axis() / (n as f64 * dt) * 3600.0;
            let worst = drift_deg_h.amax().to_degrees();
            assert!(worst < 0.005, "seed {seed}: {worst} deg/h");
        }
    }
}
