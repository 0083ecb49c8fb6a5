//! An IMU's motion content per axis and frequency band, the figures
//! `real-sensor-figures.md` gives for real vehicles: the gyro's first-difference scatter, its
//! RMS in 1-50 Hz (vibration) and 0.05-1 Hz (the sea, the vehicle's own wobble), and the
//! accelerometer's RMS in 1-50 Hz. `hindsight info --spectra` prints them, so that a log (a
//! simulated scenario's, a real one's) can be set beside the measured table.
//!
//! The bands are cut by second-order Butterworth sections (high-pass at the band's low edge,
//! low-pass at its high edge, each run forwards and backwards: zero phase) on the samples as
//! logged, at their mean rate; a band's edge above 0.45 of the rate is taken there.

use crate::contract::Imu;
use serde::Serialize;
use std::f64::consts::PI;

/// Per body axis (x, y, z).
pub type PerAxis = [f64; 3];

/// An IMU's motion content.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ImuBands {
    pub rate_hz: f64,
    /// The gyro's first-difference standard deviation over sqrt(2), deg/s.
    pub gyro_difference_deg_s: PerAxis,
    /// The gyro's RMS in 1-50 Hz, deg/s.
    pub gyro_vibration_deg_s: PerAxis,
    /// The gyro's RMS in 0.05-1 Hz, deg/s.
    pub gyro_sea_deg_s: PerAxis,
    /// The accelerometer's RMS in 1-50 Hz, m/s^2.
    pub accel_vibration_m_s2: PerAxis,
}

/// The figures of `imu`; `None` with fewer than 100 samples.
pub fn imu_bands(imu: &[Imu]) -> Option<ImuBands> {
    if imu.len() < 100 {
        return None;
    }
    let rate_hz = 1.0 / super::moving::mean_interval_s(imu)?;
    let axis = |k: usize, gyro: bool| -> Vec<f64> {
        imu.iter()
            .map(|m| {
                if gyro {
                    m.angular_velocity[k].to_degrees()
                } else {
                    m.specific_force[k]
                }
            })
            .collect()
    };
    let per_axis = |f: &dyn Fn(usize) -> f64| [f(0), f(1), f(2)];
    Some(ImuBands {
        rate_hz,
        gyro_difference_deg_s: per_axis(&|k| difference_scatter(&axis(k, true))),
        gyro_vibration_deg_s: per_axis(&|k| band_rms(&axis(k, true), rate_hz, 1.0, 50.0)),
        gyro_sea_deg_s: per_axis(&|k| band_rms(&axis(k, true), rate_hz, 0.05, 1.0)),
        accel_vibration_m_s2: per_axis(&|k| band_rms(&axis(k, false), rate_hz, 1.0, 50.0)),
    })
}

/// The standard deviation of first differences over sqrt(2).
fn difference_scatter(x: &[f64]) -> f64 {
    let d: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / d.len() as f64;
    (var / 2.0).sqrt()
}

/// The RMS of `x` (sampled at `rate_hz`) in the band `lo_hz`-`hi_hz`.
pub fn band_rms(x: &[f64], rate_hz: f64, lo_hz: f64, hi_hz: f64) -> f64 {
    let hi_hz = hi_hz.min(0.45 * rate_hz);
    let high = Biquad::butterworth(lo_hz / rate_hz, true);
    let low = Biquad::butterworth(hi_hz / rate_hz, false);
    let y = low.zero_phase(&high.zero_phase(x));
    // The edges' transients are left out: a tenth of the series, at most 5 periods of lo_hz.
    let skip = ((5.0 * rate_hz / lo_hz) as usize).min(y.len() / 10);
    let kept = &y[skip..y.len() - skip];
    (kept.iter().map(|v| v * v).sum::<f64>() / kept.len().max(1) as f64).sqrt()
}

/// A second-order section (RBJ's Butterworth, Q = 1/sqrt(2)).
#[derive(Debug, Clone, Copy)]
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

impl Biquad {
    /// High- or low-pass at `f` cycles per sample.
    fn butterworth(f: f64, high: bool) -> Biquad {
        let w = 2.0 * PI * f;
        let (sw, cw) = w.sin_cos();
        let alpha = sw / 2.0_f64.sqrt();
        let a0 = 1.0 + alpha;
        let b = if high {
            [(1.0 + cw) / 2.0, -(1.0 + cw), (1.0 + cw) / 2.0]
        } else {
            [(1.0 - cw) / 2.0, 1.0 - cw, (1.0 - cw) / 2.0]
        };
        Biquad {
            b: b.map(|v| v / a0),
            a: [-2.0 * cw / a0, (1.0 - alpha) / a0],
        }
    }

    fn run(&self, x: impl Iterator<Item = f64>) -> Vec<f64> {
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        x.map(|x0| {
            let y0 =
                self.b[0] * x0 + self.b[1] * x1 + self.b[2] * x2 - self.a[0] * y1 - self.a[1] * y2;
            (x2, x1, y2, y1) = (x1, x0, y1, y0);
            y0
        })
        .collect()
    }

    /// Forwards, then backwards.
    fn zero_phase(&self, x: &[f64]) -> Vec<f64> {
        let forward = self.run(x.iter().copied());
        let mut back = self.run(forward.into_iter().rev());
        back.reverse();
        back
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tone's RMS is kept in its band and cut outside it.
    #[test]
    fn a_tone_shows_in_its_band_only() {
        let rate = 100.0;
        let tone = |f: f64| -> Vec<f64> {
            (0..60_000)
                .map(|k| (2.0 * PI * f * k as f64 / rate).sin())
                .collect()
        };
        let rms = 0.5f64.sqrt();
        let vib = band_rms(&tone(10.0), rate, 1.0, 50.0);
        assert!((vib / rms - 1.0).abs() < 0.02, "{vib}");
        let sea = band_rms(&tone(0.2), rate, 0.05, 1.0);
        assert!((sea / rms - 1.0).abs() < 0.05, "{sea}");
        assert!(band_rms(&tone(10.0), rate, 0.05, 1.0) < 0.01 * rms);
        assert!(band_rms(&tone(0.01), rate, 1.0, 50.0) < 0.01 * rms);
    }
}
