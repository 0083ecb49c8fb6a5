//! The IMU's white noise where the vehicle is still: on deck, on the bottom, or held before a
//! launch. There the Allan deviation of the gyro and the accelerometer at 1 s gives the angle
//! and velocity random walks directly, with no model of the motion.
//!
//! A second of IMU data is still when its mean rate is under [`MAX_RATE_DEG_S`], its mean
//! specific force is gravity's size (within [`MAX_GRAVITY_OFFSET_M_S2`]) and points where the
//! previous second's did (within [`MAX_TILT_CHANGE_DEG`]: waves and slow turns fail this), and
//! any bottom-locked DVL reading in it is under [`MAX_DVL_SPEED_M_S`] (a vehicle cruising
//! straight and level looks still to the IMU alone). Runs of [`MIN_STRETCH_S`] or more still
//! seconds are stretches; the longest is used. An IMU much noisier than a MEMS one (an angle
//! random walk over about 20 deg/sqrt(h)) fails these tests even when still: the maximum
//! likelihood search (`imu`) then finds its noise alone.

use crate::contract::{Dvl, Imu};
use nalgebra::Vector3;
use serde::Serialize;

pub const MIN_STRETCH_S: f64 = 60.0;
pub const MAX_RATE_DEG_S: f64 = 1.0;
pub const MAX_GRAVITY_OFFSET_M_S2: f64 = 0.1;
pub const MAX_TILT_CHANGE_DEG: f64 = 0.2;
pub const MAX_DVL_SPEED_M_S: f64 = 0.05;
/// Standard gravity, m/s^2 (the local value differs by under 0.03 m/s^2).
pub(crate) const G0: f64 = 9.80665;
const NS_PER_S: f64 = 1e9;

/// The white noise measured in a still stretch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StillNoise {
    pub from_ns: i64,
    pub to_ns: i64,
    /// Angle random walk, deg/sqrt(h) (the gyro's Allan deviation at 1 s, axes pooled).
    pub gyro_arw_deg_rt_h: f64,
    /// Velocity random walk, ug/sqrt(Hz) (the accelerometer's Allan deviation at 1 s).
    pub accel_vrw_ug_rt_hz: f64,
    /// One-second clusters the estimate rests on.
    pub clusters: usize,
    /// The most the biases can wander, as the stretch's Allan deviation allows (see
    /// `walk_bound`): the gyro's rate random walk, deg/h/sqrt(h), and the
    /// accelerometer's, ug/sqrt(h). `None` when the stretch is too short to tell.
    pub gyro_bias_walk_bound_deg_h_rt_h: Option<f64>,
    pub accel_bias_walk_bound_ug_rt_h: Option<f64>,
}

impl StillNoise {
    pub fn duration_s(&self) -> f64 {
        (self.to_ns - self.from_ns) as f64 / NS_PER_S
    }

    /// The gyro's bias instability the stretch allows for a first-order Gauss-Markov bias of
    /// correlation time `correlation_s` (whose random walk is `B sqrt(2 / T)`), deg/h.
    pub fn gyro_bias_instability_bound_deg_h(&self, correlation_s: f64) -> Option<f64> {
        self.gyro_bias_walk_bound_deg_h_rt_h
            .map(|k| k * (correlation_s / 3600.0 / 2.0).sqrt())
    }

    /// The same for the accelerometer, ug.
    pub fn accel_bias_instability_bound_ug(&self, correlation_s: f64) -> Option<f64> {
        self.accel_bias_walk_bound_ug_rt_h
            .map(|k| k * (correlation_s / 3600.0 / 2.0).sqrt())
    }
}

/// Means of consecutive clusters that an Allan deviation of the bound rests on, at least.
const MIN_AVERAGES: usize = 9;

/// The largest rate random walk `K` (per sqrt(s)) that the 1 s cluster means allow: a bias
/// that walks gives an Allan deviation of at least `K sqrt(tau / 3)` at every cluster time,
/// so `K <= sqrt(3 / tau) sigma(tau)`, least at the longest cluster times. Each Allan
/// deviation is raised by twice its relative scatter (`1 / sqrt(2 (n - 1))` for `n` means
/// on three axes) before the least is taken, so that a low draw does not make the bound
/// too tight. Cluster times 1, 2, 4, ... s with at least [`MIN_AVERAGES`] means each;
/// `None` with fewer than three of them.
fn walk_bound(means: &[Vector3<f64>]) -> Option<f64> {
    let mut bounds = Vec::new();
    let mut m = 1;
    while means.len() / m >= MIN_AVERAGES {
        let averaged: Vec<Vector3<f64>> = means
            .chunks_exact(m)
            .map(|c| c.iter().sum::<Vector3<f64>>() / m as f64)
            .collect();
        let scatter = 1.0 / (2.0 * (3 * (averaged.len() - 1)) as f64).sqrt();
        let tau = m as f64;
        bounds.push((3.0 / tau).sqrt() * allan_deviation(&averaged) * (1.0 + 2.0 * scatter));
        m *= 2;
    }
    (bounds.len() >= 3).then(|| bounds.into_iter().fold(f64::INFINITY, f64::min))
}

/// One second of IMU data: its mean rate and specific force, and its span of samples.
struct Second {
    from: usize,
    to: usize,
    rate: Vector3<f64>,
    force: Vector3<f64>,
}

fn seconds(imu: &[Imu]) -> Vec<Second> {
    let Some(t0) = imu.first().map(|m| m.stamp_ns) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut from = 0;
    while from < imu.len() {
        let k = (imu[from].stamp_ns - t0) / NS_PER_S as i64;
        let end = t0 + (k + 1) * NS_PER_S as i64;
        let to = from + imu[from..].partition_point(|m| m.stamp_ns < end);
        let n = (to - from) as f64;
        let (rate, force) =
            imu[from..to]
                .iter()
                .fold((Vector3::zeros(), Vector3::zeros()), |(r, f), m| {
                    (
                        r + Vector3::from(m.angular_velocity),
                        f + Vector3::from(m.specific_force),
                    )
                });
        out.push(Second {
            from,
            to,
            rate: rate / n,
            force: force / n,
        });
        from = to;
    }
    out
}

/// Whether the DVL shows no motion over `[from_ns, to_ns)`.
fn dvl_still(dvl: &[Dvl], from_ns: i64, to_ns: i64) -> bool {
    let start = dvl.partition_point(|d| d.stamp_ns < from_ns);
    dvl[start..]
        .iter()
        .take_while(|d| d.stamp_ns < to_ns)
        .filter(|d| d.valid)
        .all(|d| Vector3::from(d.velocity).norm() < MAX_DVL_SPEED_M_S)
}

/// The longest still stretch of at least [`MIN_STRETCH_S`], as a range of seconds.
fn longest_still(imu: &[Imu], dvl: &[Dvl], secs: &[Second]) -> Option<std::ops::Range<usize>> {
    let still = |i: usize| {
        let s = &secs[i];
        let previous = i.checked_sub(1).map(|p| &secs[p])?;
        let steady = previous.force.angle(&s.force).to_degrees() < MAX_TILT_CHANGE_DEG;
        let quiet = s.rate.norm().to_degrees() < MAX_RATE_DEG_S
            && (s.force.norm() - G0).abs() < MAX_GRAVITY_OFFSET_M_S2;
        let from_ns = imu[s.from].stamp_ns;
        let to_ns = imu[s.to - 1].stamp_ns + 1;
        Some(steady && quiet && dvl_still(dvl, from_ns, to_ns))
    };
    let mut best: Option<std::ops::Range<usize>> = None;
    let mut start: Option<usize> = None;
    for i in 0..=secs.len() {
        let is_still = i < secs.len() && still(i) == Some(true);
        match (is_still, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if best.as_ref().is_none_or(|b| i - s > b.len()) {
                    best = Some(s..i);
                }
                start = None;
            }
            _ => {}
        }
    }
    best.filter(|b| b.len() as f64 >= MIN_STRETCH_S)
}

/// Seconds left out at each end of a stretch (the motion starts or stops there).
const EDGE_S: usize = 5;
/// The median of a chi-square variable with one degree of freedom.
const CHI2_1_MEDIAN: f64 = 0.454_936;

/// Allan deviation at the clusters' length from consecutive cluster means, the axes pooled:
/// from the median of the squared differences (a difference ~ N(0, 2 sigma^2)), so that a
/// jolt or the onset of motion at an end does not inflate it.
fn allan_deviation(means: &[Vector3<f64>]) -> f64 {
    let mut squares: Vec<f64> = means
        .windows(2)
        .flat_map(|w| (w[1] - w[0]).iter().map(|d| d * d).collect::<Vec<_>>())
        .collect();
    squares.sort_by(f64::total_cmp);
    (squares[squares.len() / 2] / (2.0 * CHI2_1_MEDIAN)).sqrt()
}

/// The IMU's white noise from the longest still stretch of the log, if it has one.
pub fn still_noise(imu: &[Imu], dvl: &[Dvl]) -> Option<StillNoise> {
    let secs = seconds(imu);
    let range = longest_still(imu, dvl, &secs)?;
    // Whole one-second clusters only (the first and last may be cut by the stretch's ends).
    let inner = range.start + EDGE_S..range.end - EDGE_S;
    let clusters: Vec<&Second> = secs[inner].iter().filter(|s| s.to - s.from > 1).collect();
    let rates: Vec<Vector3<f64>> = clusters.iter().map(|s| s.rate).collect();
    let forces: Vec<Vector3<f64>> = clusters.iter().map(|s| s.force).collect();
    let (first, last) = (clusters.first()?, clusters.last()?);
    // At tau = 1 s, N = sigma(tau) sqrt(tau): rad/sqrt(s) and m/s/sqrt(s).
    let arw_rad_rt_s = allan_deviation(&rates);
    let vrw_m_s_rt_s = allan_deviation(&forces);
    Some(StillNoise {
        from_ns: imu[first.from].stamp_ns,
        to_ns: imu[last.to - 1].stamp_ns,
        gyro_arw_deg_rt_h: arw_rad_rt_s.to_degrees() * 60.0,
        accel_vrw_ug_rt_hz: vrw_m_s_rt_s / (G0 * 1e-6),
        clusters: clusters.len(),
        // rad/s/sqrt(s) -> deg/h/sqrt(h); m/s^2/sqrt(s) -> ug/sqrt(h).
        gyro_bias_walk_bound_deg_h_rt_h: walk_bound(&rates).map(|k| k.to_degrees() * 3600.0 * 60.0),
        accel_bias_walk_bound_ug_rt_h: walk_bound(&forces).map(|k| k / (G0 * 1e-6) * 60.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recon::tune::test_noise;

    /// 100 Hz samples: still for `still_s` (tilted, with Earth rate and white noise of the
    /// given densities), then turning at 5 deg/s.
    fn log(still_s: usize, arw_deg_rt_h: f64, vrw_ug_rt_hz: f64) -> Vec<Imu> {
        log_with_walk(still_s, arw_deg_rt_h, vrw_ug_rt_hz, 0.0, 71)
    }

    /// [`log`] with the gyro's bias walking at `walk_deg_h_rt_h` on each axis.
    fn log_with_walk(
        still_s: usize,
        arw_deg_rt_h: f64,
        vrw_ug_rt_hz: f64,
        walk_deg_h_rt_h: f64,
        seed: u64,
    ) -> Vec<Imu> {
        let fs = 100.0;
        let (gyro_sigma, accel_sigma) = test_noise::per_sample(arw_deg_rt_h, vrw_ug_rt_hz, fs);
        let mut n = test_noise::normal(seed);
        // rad/s per sqrt(s), times sqrt(dt).
        let step = (walk_deg_h_rt_h / 3600.0 / 60.0).to_radians() * (1.0 / fs).sqrt();
        let mut bias = Vector3::zeros();
        let gravity = Vector3::new(0.3, -0.2, -9.79);
        (0..(still_s + 120) * 100)
            .map(|k| {
                let turning = k >= still_s * 100;
                let rate_z = if turning { 5f64.to_radians() } else { 4e-5 };
                bias += Vector3::new(n(step), n(step), n(step));
                Imu {
                    stamp_ns: 1_000_000_000_000 + k as i64 * 10_000_000,
                    angular_velocity: [
                        bias.x + n(gyro_sigma),
                        2e-5 + bias.y + n(gyro_sigma),
                        rate_z + bias.z + n(gyro_sigma),
                    ],
                    specific_force: (gravity
                        + Vector3::new(n(accel_sigma), n(accel_sigma), n(accel_sigma)))
                    .into(),
                }
            })
            .collect()
    }

    /// A gyro bias that walks at K is bounded at or above K, and not far above it where the
    /// walk shows over the white noise; without a walk the bound is what the white noise
    /// allows, and it shrinks as the stretch grows.
    #[test]
    fn a_still_stretch_bounds_the_bias_walk() {
        for seed in 1..=5 {
            let noise = still_noise(&log_with_walk(600, 0.3, 80.0, 30.0, seed), &[]).unwrap();
            let bound = noise.gyro_bias_walk_bound_deg_h_rt_h.unwrap();
            assert!((30.0..90.0).contains(&bound), "{noise:?}");
            let b = noise.gyro_bias_instability_bound_deg_h(3600.0).unwrap();
            assert!((b - bound * 0.5f64.sqrt()).abs() < 1e-9);
        }
        let short = still_noise(&log(120, 0.3, 80.0), &[]).unwrap();
        let long = still_noise(&log(1200, 0.3, 80.0), &[]).unwrap();
        let (s, l) = (
            short.gyro_bias_walk_bound_deg_h_rt_h.unwrap(),
            long.gyro_bias_walk_bound_deg_h_rt_h.unwrap(),
        );
        assert!(l < 0.5 * s, "{short:?} {long:?}");
        assert!(long.accel_bias_walk_bound_ug_rt_h.unwrap() > 0.0);
    }

    #[test]
    fn allan_deviation_at_one_second_gives_the_random_walks() {
        for (arw, vrw) in [(0.05, 30.0), (1.8, 80.0), (10.0, 400.0)] {
            let noise = still_noise(&log(600, arw, vrw), &[]).unwrap();
            assert!((noise.duration_s() - 590.0).abs() < 2.0, "{noise:?}"); // 5 s off each end
            assert!(
                (noise.gyro_arw_deg_rt_h / arw - 1.0).abs() < 0.1,
                "{noise:?}"
            );
            assert!(
                (noise.accel_vrw_ug_rt_hz / vrw - 1.0).abs() < 0.1,
                "{noise:?}"
            );
        }
    }

    #[test]
    fn motion_is_not_still() {
        // Too short a still start, then turning: none.
        assert_eq!(still_noise(&log(30, 0.05, 30.0), &[]), None);
        assert_eq!(still_noise(&[], &[]), None);
        // Still to the IMU, but the DVL says it moves (straight and level at 1.5 m/s).
        let imu = log(600, 0.05, 30.0);
        let dvl: Vec<Dvl> = (0..600 * 5)
            .map(|k| Dvl {
                stamp_ns: 1_000_000_000_000 + k * 200_000_000,
                velocity: [1.5, 0.0, 0.0],
                valid: true,
                altitude: Some(20.0),
            })
            .collect();
        assert_eq!(still_noise(&imu, &dvl), None);
    }
}
