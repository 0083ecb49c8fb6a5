//! When a sensor's gate may reopen.
//!
//! A sensor whose readings the gate rejects many times in a row is either right while the
//! filter has drifted beyond its own uncertainty, or wrong: a standing fault. A count alone
//! cannot tell the two apart, and reopening on a count injects a faulty sensor every few
//! readings. What tells them apart is the readings themselves:
//!
//! - **A healthy sensor and a drifted filter**: the readings follow the vehicle's smooth
//!   motion: a straight line in time per component taken out, what is left is the sensor's
//!   noise, within a chi-square bound of its variance inflated ([`INFLATION`]) for the
//!   motion's curvature. They agree with each other, and so do their innovations, but for
//!   the filter's own jumps (another sensor's update moves the prediction between two
//!   readings; those are the filter's, not the sensor's, so the readings are judged).
//! - **An erratic sensor**: the readings scatter far beyond its noise. They do not agree,
//!   and the gate stays shut.
//! - **A stuck sensor**: every reading repeats the ones before exactly (a real sensor's noise
//!   makes a run of exact repeats of every component all but impossible). A reading that
//!   repeats its predecessors never reopens the gate, however well the readings agree: a stuck
//!   sensor agrees with itself perfectly.

use crate::filters::kalman::chi_square_quantile;
use std::collections::VecDeque;

/// Sigma multiple the sensor's noise is inflated by when the rejected innovations are
/// compared with each other: room for the filter's drift to curve within the window.
pub const INFLATION: f64 = 5.0;

/// Probability of the chi-square bound on the scatter.
pub const AGREEMENT_PROBABILITY: f64 = 0.999;

/// A rejected reading, as the reopening judges it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rejected {
    pub t_s: f64,
    /// The reading as the sensor gave it, first `dims` components.
    pub value: [f64; 3],
    /// The sensor's noise variance per component (the diagonal of R).
    pub variance: [f64; 3],
    pub dims: usize,
}

/// The latest rejected readings of one sensor, oldest first.
#[derive(Debug, Clone, Default)]
pub struct RecentRejections {
    readings: VecDeque<Rejected>,
}

impl RecentRejections {
    /// Adds a rejected reading, keeping at most `capacity`.
    pub fn push(&mut self, reading: Rejected, capacity: usize) {
        if self.readings.len() == capacity {
            self.readings.pop_front();
        }
        if capacity > 0 {
            self.readings.push_back(reading);
        }
    }

    /// Forgets them (a reading was accepted).
    pub fn clear(&mut self) {
        self.readings.clear();
    }

    /// Whether the readings agree with each other: a straight line in time per component
    /// taken out, the rest is within the chi-square bound of their inflated noise. Fewer
    /// than three readings, or readings of different sizes, do not agree.
    pub fn agree(&self) -> bool {
        let n = self.readings.len();
        let Some(first) = self.readings.front() else {
            return false;
        };
        let dims = first.dims;
        if n < 3 || dims == 0 || self.readings.iter().any(|r| r.dims != dims) {
            return false;
        }
        let scatter: f64 = (0..dims).map(|c| self.detrended_scatter(c)).sum();
        scatter <= chi_square_quantile((n - 2) * dims, AGREEMENT_PROBABILITY)
    }

    /// Sum over the readings of the squared residual of component `c` from its least-squares
    /// line in time, each divided by its inflated variance.
    fn detrended_scatter(&self, c: usize) -> f64 {
        let n = self.readings.len() as f64;
        let t_mean = self.readings.iter().map(|r| r.t_s).sum::<f64>() / n;
        let y_mean = self.readings.iter().map(|r| r.value[c]).sum::<f64>() / n;
        let (mut stt, mut sty) = (0.0, 0.0);
        for r in &self.readings {
            let dt = r.t_s - t_mean;
            stt += dt * dt;
            sty += dt * (r.value[c] - y_mean);
        }
        let slope = if stt > 0.0 { sty / stt } else { 0.0 };
        self.readings
            .iter()
            .map(|r| {
                let fitted = y_mean + slope * (r.t_s - t_mean);
                (r.value[c] - fitted).powi(2) / (INFLATION.powi(2) * r.variance[c])
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    fn window(value: impl Fn(f64, &mut rand_chacha::ChaCha8Rng) -> [f64; 3]) -> RecentRejections {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut w = RecentRejections::default();
        for k in 0..20 {
            let t_s = 0.2 * k as f64;
            let reading = Rejected {
                t_s,
                value: value(t_s, &mut rng),
                variance: [0.01f64.powi(2); 3],
                dims: 3,
            };
            w.push(reading, 20);
        }
        w
    }

    fn noise(rng: &mut rand_chacha::ChaCha8Rng) -> f64 {
        0.01 * rng.sample::<f64, _>(StandardNormal)
    }

    /// A healthy sensor on a vehicle that speeds up 0.05 m/s per second: the readings agree,
    /// and the gate may reopen.
    #[test]
    fn a_healthy_sensors_readings_agree() {
        let w = window(|t, rng| {
            let common = 0.3 + 0.05 * t;
            [common + noise(rng), -common + noise(rng), noise(rng)]
        });
        assert!(w.agree());
        // Noise at twice the sensor's figure and a slight curve still agree (inflated).
        let w = window(|t, rng| [0.3 + 0.004 * t * t + 2.0 * noise(rng), 0.0, 0.0]);
        assert!(w.agree());
    }

    /// An erratic sensor: readings 0.3 m/s apart at random do not agree.
    #[test]
    fn an_erratic_sensor_does_not_agree() {
        let w = window(|_, rng| [30.0 * noise(rng), 0.0, 30.0 * noise(rng)]);
        assert!(!w.agree());
        // Readings that swing 0.5 m/s within seconds: no vehicle moves so.
        let w = window(|t, _| [0.5 * (1.5 * t).sin(), 0.5 * (1.5 * t).cos(), 0.0]);
        assert!(!w.agree());
    }

    #[test]
    fn the_window_keeps_the_latest_and_too_few_never_agree() {
        let mut w = RecentRejections::default();
        let r = |t_s| Rejected {
            t_s,
            value: [1.0, 0.0, 0.0],
            variance: [1.0; 3],
            dims: 1,
        };
        w.push(r(0.0), 3);
        w.push(r(1.0), 3);
        assert!(!w.agree());
        w.push(r(2.0), 3);
        w.push(r(3.0), 3);
        assert_eq!(w.readings.len(), 3);
        assert_eq!(w.readings.front().unwrap().t_s, 1.0);
        assert!(w.agree());
        w.clear();
        assert!(!w.agree());
        w.push(r(0.0), 0);
        assert!(w.readings.is_empty());
    }

    /// The judgement sees the readings' scatter about a line, nothing else: any offset and
    /// any steady drift leave it as it was. And a healthy sensor is refused only as often as
    /// the bound allows (0.1 % at five times its noise figure, less below): never, in 2000
    /// seeded windows of its noise at one to five times its figure.
    #[test]
    fn offsets_and_drifts_do_not_matter_and_healthy_noise_passes() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut refused = 0;
        for _ in 0..2000 {
            let scale: f64 = rng.random_range(1.0..5.0);
            let noise: Vec<[f64; 3]> = (0..20)
                .map(|_| std::array::from_fn(|_| scale * noise(&mut rng)))
                .collect();
            let offset: [f64; 3] = std::array::from_fn(|_| rng.random_range(-5.0..5.0));
            let drift: [f64; 3] = std::array::from_fn(|_| rng.random_range(-0.5..0.5));
            let make = |moved: bool| {
                let mut w = RecentRejections::default();
                for (k, n) in noise.iter().enumerate() {
                    let t_s = 0.2 * k as f64;
                    let value = std::array::from_fn(|c| {
                        n[c] + if moved {
                            offset[c] + drift[c] * t_s
                        } else {
                            0.0
                        }
                    });
                    let reading = Rejected {
                        t_s,
                        value,
                        variance: [0.01f64.powi(2); 3],
                        dims: 3,
                    };
                    w.push(reading, 20);
                }
                w
            };
            let (still, moved) = (make(false), make(true));
            let scatter =
                |w: &RecentRejections| (0..3).map(|c| w.detrended_scatter(c)).sum::<f64>();
            assert!((scatter(&still) - scatter(&moved)).abs() < 1e-6 * scatter(&still).max(1.0));
            refused += usize::from(!moved.agree());
        }
        assert_eq!(refused, 0);
    }
}
