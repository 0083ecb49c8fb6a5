//! One-number sensors: depth, EM log, echo sounder, and the propeller RPM relation.
//!
//! `out = (1 + s) truth + b + n` with a scale error `s ~ N(0, scale)` and bias
//! `b ~ N(0, bias)` drawn once per run, and white noise `n ~ N(0, noise)` per sample.

use super::normal;
use rand_chacha::ChaCha8Rng;

/// Error parameters of a one-number sensor (units of its measurement; scale as a fraction).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScalarSpec {
    /// 1-sigma scale-factor error, fraction (0.002 = 0.2 %).
    pub scale: f64,
    /// 1-sigma bias drawn per run.
    pub bias: f64,
    /// 1-sigma white noise per sample.
    pub noise: f64,
}

/// A one-number sensor in one run.
#[derive(Debug, Clone)]
pub struct ScalarSensor {
    /// Drawn scale-factor error.
    pub scale: f64,
    /// Drawn bias.
    pub bias: f64,
    noise: f64,
    rng: ChaCha8Rng,
}

impl ScalarSensor {
    pub fn new(spec: ScalarSpec, mut rng: ChaCha8Rng) -> Self {
        let scale = spec.scale * normal(&mut rng);
        let bias = spec.bias * normal(&mut rng);
        ScalarSensor {
            scale,
            bias,
            noise: spec.noise,
            rng,
        }
    }

    pub fn measure(&mut self, truth: f64) -> f64 {
        (1.0 + self.scale) * truth + self.bias + self.noise * normal(&mut self.rng)
    }
}

/// Propeller RPM with seed 002 eq. 8: `speed = (K + eps) rpm + noise`, so the logged
/// `rpm = (speed - noise) / (K + eps)`, with `eps ~ N(0, scale K)` drawn per run.
#[derive(Debug, Clone)]
pub struct Propeller {
    /// Nominal speed per rev/min, (m/s) / (rev/min).
    pub k_m_s_per_rpm: f64,
    /// Drawn error of `k`.
    pub eps_m_s_per_rpm: f64,
    noise_m_s: f64,
    rng: ChaCha8Rng,
}

/// Parameters of [`Propeller`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropellerSpec {
    /// Nominal speed per rev/min, (m/s) / (rev/min); required by kinematic scenarios.
    #[serde(default)]
    pub k_m_s_per_rpm: f64,
    /// 1-sigma of eps as a fraction of k.
    #[serde(default)]
    pub k_error: f64,
    /// 1-sigma speed noise, m/s.
    #[serde(default)]
    pub noise_m_s: f64,
}

impl Propeller {
    pub fn new(spec: PropellerSpec, mut rng: ChaCha8Rng) -> Self {
        let eps = spec.k_error * spec.k_m_s_per_rpm * normal(&mut rng);
        Propeller {
            k_m_s_per_rpm: spec.k_m_s_per_rpm,
            eps_m_s_per_rpm: eps,
            noise_m_s: spec.noise_m_s,
            rng,
        }
    }

    /// Logged rpm for a true speed through water.
    pub fn measure(&mut self, speed_m_s: f64) -> f64 {
        (speed_m_s - self.noise_m_s * normal(&mut self.rng))
            / (self.k_m_s_per_rpm + self.eps_m_s_per_rpm)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{rng_for, stream};
    use super::*;

    fn mean_std(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let m = xs.iter().sum::<f64>() / n;
        (
            m,
            (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
        )
    }

    #[test]
    fn recovers_scale_bias_and_noise() {
        let spec = ScalarSpec {
            scale: 0.01,
            bias: 0.5,
            noise: 0.2,
        };
        let mut s = ScalarSensor::new(spec, rng_for(3, stream::DEPTH));
        let n = 100_000;
        // Two truth levels separate scale from bias.
        let lo: Vec<f64> = (0..n).map(|_| s.measure(10.0)).collect();
        let hi: Vec<f64> = (0..n).map(|_| s.measure(110.0)).collect();
        let ((m_lo, sd_lo), (m_hi, sd_hi)) = (mean_std(&lo), mean_std(&hi));
        let se = 5.0 * 0.2 / (n as f64).sqrt();
        let scale = (m_hi - m_lo) / 100.0 - 1.0;
        assert!(
            (scale - s.scale).abs() < 2.0 * se / 100.0 + 1e-12,
            "{scale} vs {}",
            s.scale
        );
        assert!((m_lo - (1.0 + s.scale) * 10.0 - s.bias).abs() < se);
        assert!((sd_lo / 0.2 - 1.0).abs() < 0.02 && (sd_hi / 0.2 - 1.0).abs() < 0.02);
        let bias_rms = ((0..3000)
            .map(|seed| {
                ScalarSensor::new(spec, rng_for(seed, stream::DEPTH))
                    .bias
                    .powi(2)
            })
            .sum::<f64>()
            / 3000.0)
            .sqrt();
        assert!((bias_rms / 0.5 - 1.0).abs() < 0.05, "{bias_rms}");
    }

    #[test]
    fn propeller_relation_holds_in_the_mean() {
        let spec = PropellerSpec {
            k_m_s_per_rpm: 0.005,
            k_error: 0.02,
            noise_m_s: 0.05,
        };
        let mut p = Propeller::new(spec, rng_for(4, stream::RPM));
        let rpms: Vec<f64> = (0..50_000).map(|_| p.measure(5.0)).collect();
        let (m, sd) = mean_std(&rpms);
        let k = p.k_m_s_per_rpm + p.eps_m_s_per_rpm;
        assert!((k * m - 5.0).abs() < 5.0 * 0.05 / (50_000f64).sqrt());
        assert!((sd * k / 0.05 - 1.0).abs() < 0.02);
        assert!(p.eps_m_s_per_rpm != 0.0);
    }
}
