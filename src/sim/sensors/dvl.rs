//! Doppler velocity log: body velocity over ground with scale error, bias and noise, bottom
//! lock only within a maximum altitude. Out of range (seed 003) it either reports no lock or,
//! if `out_of_range_noise_m_s` is set, keeps reporting a velocity buried in that much noise.

use super::normal;
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;

/// Parameters of the DVL.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DvlSpec {
    pub rate_hz: f64,
    /// 1-sigma scale-factor error per run, fraction.
    #[serde(default)]
    pub scale: f64,
    /// 1-sigma bias per axis per run, m/s.
    #[serde(default)]
    pub bias_m_s: f64,
    /// 1-sigma white noise per axis, m/s.
    #[serde(default)]
    pub noise_m_s: f64,
    /// Bottom lock is lost above this altitude, m.
    #[serde(default = "default_max_altitude")]
    pub max_altitude_m: f64,
    /// Out of range: 0 reports `valid = false`; above 0, a velocity with this 1-sigma noise
    /// and `valid = true` (a DVL that does not know it lost the bottom).
    #[serde(default)]
    pub out_of_range_noise_m_s: f64,
    /// Logging latency, s.
    #[serde(default)]
    pub latency_s: f64,
    /// The DVL stamps each reading this long after the instant it measured (its own clock's
    /// latency: ping averaging and processing), s.
    #[serde(default)]
    pub stamp_delay_s: f64,
    /// 1-sigma of an error correlated in time (first-order Gauss-Markov, per axis), m/s ...
    #[serde(default)]
    pub correlated_m_s: f64,
    /// ... and its correlation time, s.
    #[serde(default = "default_correlation_s")]
    pub correlation_s: f64,
    /// The DVL logs nothing after this time from the start, s (switched off or failed).
    #[serde(default)]
    pub until_s: Option<f64>,
    /// A known scale-factor error added to the drawn one, fraction (0.005 = 0.5 %).
    #[serde(default)]
    pub scale_error: f64,
    /// Mounting misalignment about the DVL's y and z axes (pitch, heading), deg: it reads
    /// `(1 + s)(I - [m x]) v + b` with `m = (0, pitch, heading)`.
    #[serde(default)]
    pub misalignment_deg: [f64; 2],
    /// The DVL's position from the IMU, body FRD, m: it reads the velocity over ground of
    /// that point, `v_b + omega_nb x l`.
    #[serde(default)]
    pub lever_arm_m: [f64; 3],
    /// Share of readings with a multipath error (a beam off a wall or the surface), and ...
    #[serde(default)]
    pub multipath_fraction: f64,
    /// ... that error's 1-sigma per axis, m/s.
    #[serde(default)]
    pub multipath_m_s: f64,
}

fn default_max_altitude() -> f64 {
    100.0
}

fn default_correlation_s() -> f64 {
    60.0
}

/// What the DVL logs at one ping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvlReading {
    pub velocity_body_m_s: Vector3<f64>,
    pub valid: bool,
    pub altitude_m: Option<f64>,
}

/// The DVL of one run.
#[derive(Debug, Clone)]
pub struct DvlSensor {
    spec: DvlSpec,
    /// Drawn scale-factor error.
    pub scale: f64,
    /// Drawn bias.
    pub bias_m_s: Vector3<f64>,
    /// The correlated error now.
    correlated_m_s: Vector3<f64>,
    rng: ChaCha8Rng,
}

impl DvlSensor {
    pub fn new(spec: DvlSpec, mut rng: ChaCha8Rng) -> Self {
        let scale = spec.scale * normal(&mut rng) + spec.scale_error;
        let bias_m_s = Vector3::from_fn(|_, _| spec.bias_m_s * normal(&mut rng));
        // Started from its stationary spread.
        let correlated_m_s = Vector3::from_fn(|_, _| spec.correlated_m_s * normal(&mut rng));
        DvlSensor {
            spec,
            scale,
            bias_m_s,
            correlated_m_s,
            rng,
        }
    }

    /// The correlated error one ping on.
    fn advance_correlated(&mut self) {
        if self.spec.correlated_m_s <= 0.0 {
            return;
        }
        let phi = (-1.0 / (self.spec.rate_hz * self.spec.correlation_s.max(1e-9))).exp();
        let drive = self.spec.correlated_m_s * (1.0 - phi * phi).sqrt();
        for k in 0..3 {
            self.correlated_m_s[k] = phi * self.correlated_m_s[k] + drive * normal(&mut self.rng);
        }
    }

    /// The reading of the body velocity (at the IMU) `velocity_body_m_s` while the body turns
    /// at `omega_nb_body` (rad/s), at that altitude.
    pub fn measure(
        &mut self,
        velocity_body_m_s: &Vector3<f64>,
        omega_nb_body: &Vector3<f64>,
        altitude_m: f64,
    ) -> DvlReading {
        let velocity_body_m_s =
            &(velocity_body_m_s + omega_nb_body.cross(&Vector3::from(self.spec.lever_arm_m)));
        let in_range = (0.0..=self.spec.max_altitude_m).contains(&altitude_m);
        self.advance_correlated();
        let correlated = self.correlated_m_s;
        // Drawn only when the DVL has multipath, so that other DVLs' draws stay as they were.
        let multipath = in_range
            && self.spec.multipath_fraction > 0.0
            && rand::Rng::random::<f64>(&mut self.rng) < self.spec.multipath_fraction;
        let mut noise = |sigma: f64| Vector3::from_fn(|_, _| sigma * normal(&mut self.rng));
        if in_range {
            let mut n = noise(self.spec.noise_m_s);
            if multipath {
                n += noise(self.spec.multipath_m_s);
            }
            let [pitch, heading] = self.spec.misalignment_deg.map(f64::to_radians);
            let turned =
                velocity_body_m_s - Vector3::new(0.0, pitch, heading).cross(velocity_body_m_s);
            DvlReading {
                velocity_body_m_s: (1.0 + self.scale) * turned + self.bias_m_s + correlated + n,
                valid: true,
                altitude_m: Some(altitude_m),
            }
        } else if self.spec.out_of_range_noise_m_s > 0.0 {
            let n = noise(self.spec.out_of_range_noise_m_s);
            DvlReading {
                velocity_body_m_s: velocity_body_m_s + n,
                valid: true,
                altitude_m: None,
            }
        } else {
            DvlReading {
                velocity_body_m_s: Vector3::zeros(),
                valid: false,
                altitude_m: None,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{rng_for, stream};
    use super::*;

    fn spec() -> DvlSpec {
        DvlSpec {
            rate_hz: 5.0,
            scale: 0.002,
            bias_m_s: 0.01,
            noise_m_s: 0.02,
            max_altitude_m: 100.0,
            out_of_range_noise_m_s: 0.0,
            latency_s: 0.0,
            stamp_delay_s: 0.0,
            correlated_m_s: 0.0,
            correlation_s: 60.0,
            until_s: None,
            scale_error: 0.0,
            misalignment_deg: [0.0; 2],
            lever_arm_m: [0.0; 3],
            multipath_fraction: 0.0,
            multipath_m_s: 0.0,
        }
    }

    #[test]
    fn recovers_bias_scale_and_noise_in_range() {
        let mut d = DvlSensor::new(spec(), rng_for(2, stream::DVL));
        let v = Vector3::new(5.0, 0.0, 0.0);
        let n = 100_000;
        let r: Vec<DvlReading> = (0..n)
            .map(|_| d.measure(&v, &Vector3::zeros(), 50.0))
            .collect();
        assert!(r.iter().all(|x| x.valid && x.altitude_m == Some(50.0)));
        let mean = r.iter().map(|x| x.velocity_body_m_s).sum::<Vector3<f64>>() / n as f64;
        let expected = (1.0 + d.scale) * v + d.bias_m_s;
        assert!((mean - expected).amax() < 5.0 * 0.02 / (n as f64).sqrt());
        let sd = (r
            .iter()
            .map(|x| (x.velocity_body_m_s.y - mean.y).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt();
        assert!((sd / 0.02 - 1.0).abs() < 0.02, "{sd}");
    }

    #[test]
    fn loses_lock_above_max_altitude_or_reports_noise() {
        let mut d = DvlSensor::new(spec(), rng_for(2, stream::DVL));
        let r = d.measure(&Vector3::new(5.0, 0.0, 0.0), &Vector3::zeros(), 150.0);
        assert!(!r.valid && r.altitude_m.is_none());
        let mut noisy = DvlSensor::new(
            DvlSpec {
                out_of_range_noise_m_s: 5.0,
                ..spec()
            },
            rng_for(2, stream::DVL),
        );
        let n = 20_000;
        let xs: Vec<f64> = (0..n)
            .map(|_| {
                noisy
                    .measure(&Vector3::new(5.0, 0.0, 0.0), &Vector3::zeros(), 150.0)
                    .velocity_body_m_s
                    .x
            })
            .collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let sd = (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(
            (sd / 5.0 - 1.0).abs() < 0.03 && (m - 5.0).abs() < 0.15,
            "{m} {sd}"
        );
    }
}
