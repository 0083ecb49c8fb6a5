//! The IMU's white noise while the vehicle moves, from the high-frequency content of its
//! samples: a vehicle's motion is smooth at the IMU's rate, its sensors' white noise is not.
//!
//! For samples `x_k = s(t_k) + n_k` of a smooth signal with white noise of variance
//! `sigma^2`, the fourth difference `x_{k+2} - 4 x_{k+1} + 6 x_k - 4 x_{k-1} + x_{k-2}` has
//! variance `70 sigma^2`, and the signal's part is its fourth derivative times `dt^4`: nothing
//! at 100 Hz for a hull's turns, waves or dives. The differences of the three axes are pooled;
//! outliers (a knock, a burst of stamps) are dropped robustly as for the aiding sensors
//! ([`super::white`]). Vibration at the IMU's rate (a propeller, a pump) adds to the
//! estimate: it is an upper bound of the white noise, as the filter should take it.
//!
//! The differences are of consecutive samples as logged: a host that stamps samples in bursts
//! moves their stamps, not their values. The sample interval is the mean over the log's
//! regular stretches (intervals under [`MAX_INTERVAL_S`]), which bursts do not bias.

use super::stationary::G0;
use super::white::MIN_DIFFERENCES;
use crate::contract::Imu;
use serde::Serialize;

/// Intervals longer than this are gaps: no difference spans one.
pub const MAX_INTERVAL_S: f64 = 0.5;
/// Variance of a fourth difference of unit white noise (1 + 16 + 36 + 16 + 1).
const FOURTH_DIFFERENCE_VARIANCE: f64 = 70.0;

/// The white noise measured from the IMU's own samples while it moved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MovingNoise {
    /// Angle random walk, deg/sqrt(h).
    pub gyro_arw_deg_rt_h: f64,
    /// Velocity random walk, ug/sqrt(Hz).
    pub accel_vrw_ug_rt_hz: f64,
    /// The mean sample interval, s.
    pub sample_interval_s: f64,
    /// Fourth differences (all axes) the estimates rest on.
    pub differences: usize,
}

/// The IMU's white noise from its samples; `None` when too few regular samples.
pub fn moving_noise(imu: &[Imu]) -> Option<MovingNoise> {
    let dt = mean_interval_s(imu)?;
    let (mut gyro, mut accel) = (Vec::new(), Vec::new());
    for w in imu.windows(5) {
        let span_s = (w[4].stamp_ns - w[0].stamp_ns) as f64 * 1e-9;
        if !(0.0..=4.0 * MAX_INTERVAL_S).contains(&span_s) {
            continue;
        }
        for axis in 0..3 {
            let d = |x: &dyn Fn(&Imu) -> f64| {
                x(&w[4]) - 4.0 * x(&w[3]) + 6.0 * x(&w[2]) - 4.0 * x(&w[1]) + x(&w[0])
            };
            gyro.push(d(&|m: &Imu| m.angular_velocity[axis]));
            accel.push(d(&|m: &Imu| m.specific_force[axis]));
        }
    }
    let sigma = |d: Vec<f64>| -> Option<(f64, usize)> {
        let n = d.len();
        // `white` takes second differences (variance 6 sigma^2): rescale to fourth ones.
        let w = super::white::white_noise_of_differences(d)?;
        Some((w.sigma * (6.0 / FOURTH_DIFFERENCE_VARIANCE).sqrt(), n))
    };
    let (gyro_sigma, n) = sigma(gyro)?;
    let (accel_sigma, _) = sigma(accel)?;
    if n < 3 * MIN_DIFFERENCES {
        return None;
    }
    // A rate's per-sample sigma times sqrt(dt): rad/sqrt(s) and m/s/sqrt(s).
    let root_dt = dt.sqrt();
    Some(MovingNoise {
        gyro_arw_deg_rt_h: (gyro_sigma * root_dt).to_degrees() * 60.0,
        accel_vrw_ug_rt_hz: accel_sigma * root_dt / (G0 * 1e-6),
        sample_interval_s: dt,
        differences: n,
    })
}

/// The mean interval between samples over the stretches without a gap, s.
pub fn mean_interval_s(imu: &[Imu]) -> Option<f64> {
    let max_ns = (MAX_INTERVAL_S * 1e9) as i64;
    let (sum, count) = imu
        .windows(2)
        .map(|w| w[1].stamp_ns - w[0].stamp_ns)
        .filter(|&d| (0..=max_ns).contains(&d))
        .fold((0_i64, 0_usize), |(s, c), d| (s + d, c + 1));
    (count > 0 && sum > 0).then(|| sum as f64 * 1e-9 / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recon::tune::test_noise;

    /// 100 Hz samples of a vehicle turning and rolling with the waves (0.15 Hz, 3 deg/s)
    /// under white noise of the given densities, stamped regularly or in host bursts.
    fn moving(arw_deg_rt_h: f64, vrw_ug_rt_hz: f64, bursty: bool) -> Vec<Imu> {
        let fs = 100.0;
        let (gyro_sigma, accel_sigma) = test_noise::per_sample(arw_deg_rt_h, vrw_ug_rt_hz, fs);
        let mut n = test_noise::normal(5);
        let mut stamp = 1_000_000_000_000_i64;
        (0..60_000)
            .map(|k| {
                let t = k as f64 / fs;
                let wave = 2.0 * std::f64::consts::PI * 0.15 * t;
                let roll_rate = 3f64.to_radians() * wave.sin();
                let yaw_rate = 3f64.to_radians() * (t / 60.0).sin();
                // Bursts: ten samples 2 us apart, then the rest of the 0.1 s.
                stamp += match (bursty, k % 10) {
                    (false, _) => 10_000_000,
                    (true, 0) => 100_000_000 - 9 * 2_000,
                    (true, _) => 2_000,
                };
                Imu {
                    stamp_ns: stamp,
                    angular_velocity: [
                        roll_rate + n(gyro_sigma),
                        n(gyro_sigma),
                        yaw_rate + n(gyro_sigma),
                    ],
                    specific_force: [
                        0.5 * wave.cos() + n(accel_sigma),
                        n(accel_sigma),
                        -9.8 + 0.3 * wave.sin() + n(accel_sigma),
                    ],
                }
            })
            .collect()
    }

    #[test]
    fn the_random_walks_come_from_the_samples_of_a_moving_imu() {
        // A fibre-optic, a tactical and a MEMS IMU.
        for (arw, vrw) in [(0.005, 15.0), (0.05, 30.0), (0.3, 80.0)] {
            for bursty in [false, true] {
                let m = moving_noise(&moving(arw, vrw, bursty)).unwrap();
                println!("{arw} {vrw} bursty {bursty}: {m:?}");
                assert!((m.sample_interval_s / 0.01 - 1.0).abs() < 1e-3, "{m:?}");
                assert!((m.gyro_arw_deg_rt_h / arw - 1.0).abs() < 0.05, "{m:?}");
                assert!((m.accel_vrw_ug_rt_hz / vrw - 1.0).abs() < 0.05, "{m:?}");
            }
        }
    }

    #[test]
    fn too_few_samples_give_nothing() {
        assert_eq!(moving_noise(&moving(0.05, 30.0, false)[..20]), None);
        assert_eq!(moving_noise(&[]), None);
    }
}
