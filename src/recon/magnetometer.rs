//! The log's magnetometer readings made ready for the heading: saturated readings taken out,
//! and hard and soft iron fitted to the log's own readings when the vehicle turned through
//! enough headings and the fit is a clear gain (`attitude::mag_calibration`); the field's median magnitude, the reference
//! against which a disturbed reading is recognised.

use super::config::MagConfig;
use crate::attitude::mag_calibration::{self, MagCalibration};
use crate::attitude::mag_checks::{self, SaturatedSpan};
use crate::contract::MagneticField;
use nalgebra::Vector3;

/// Above this field-magnitude variation beyond the noise (a fraction of the magnitude), an
/// uncalibrated magnetometer is taken to have a deviation: a hard iron of horizontal size h
/// moves the magnitude by about h cos(I) and the heading by about h / (B cos(I)), so at an
/// inclination I of 60 deg, 0.5 % of variation (rms) is a deviation of about 1.6 deg
/// amplitude.
pub const DEVIATION_MAGNITUDE_VARIATION: f64 = 0.005;

/// Readings ready for use, with what was done to them.
#[derive(Debug, Clone, Default)]
pub struct PreparedMag {
    /// The readings to use; emptied once the forward pass has used them (a day at 50 Hz is
    /// 160 MB), [`PreparedMag::used`] still counting them.
    pub readings: Vec<MagneticField>,
    /// How many readings were prepared for use.
    pub used: usize,
    pub saturated: Vec<SaturatedSpan>,
    /// The calibration applied, or why none was.
    pub calibration: Option<MagCalibration>,
    pub calibration_skipped: Option<String>,
    /// The field magnitude's rms variation beyond the sensor noise, as a fraction of the
    /// magnitude, of the readings used (after calibration, when applied).
    pub magnitude_variation: f64,
    /// The readings carry a deviation nobody removed: a calibration was asked for but not
    /// applied (too few headings, or not trusted), and the field magnitude varies beyond
    /// [`DEVIATION_MAGNITUDE_VARIATION`]. Their heading error then depends on the heading and
    /// holds as long as the heading does (a survey lane).
    pub deviation_unknown: bool,
    /// Median magnitude of the readings used, T (0 without readings).
    pub reference_norm_t: f64,
}

impl PreparedMag {
    /// What was done, without the readings (kept for the summary once a pass used them).
    pub fn without_readings(&self) -> PreparedMag {
        PreparedMag {
            readings: Vec::new(),
            used: self.used,
            saturated: self.saturated.clone(),
            calibration: self.calibration,
            calibration_skipped: self.calibration_skipped.clone(),
            magnitude_variation: self.magnitude_variation,
            deviation_unknown: self.deviation_unknown,
            reference_norm_t: self.reference_norm_t,
        }
    }
}

/// Saturation check, then the calibration (when asked and the turns allow), then the
/// reference magnitude and the deviation check.
pub(crate) fn prepare(mag: &[MagneticField], cfg: &MagConfig) -> PreparedMag {
    prepare_owned(mag.to_vec(), cfg)
}

/// [`prepare`], the readings moved in and prepared in place (a day at 50 Hz is 160 MB).
pub(crate) fn prepare_owned(mag: Vec<MagneticField>, cfg: &MagConfig) -> PreparedMag {
    if mag.is_empty() {
        return PreparedMag::default();
    }
    let (mut clean, saturated) = mag_checks::without_saturation_owned(mag, cfg.saturation_repeats);
    let (readings, calibration, calibration_skipped) = if cfg.calibrate {
        match mag_calibration::fit(&clean) {
            Ok(c) => match c.trusted() {
                Ok(()) => {
                    c.apply_to(&mut clean);
                    (clean, Some(c), None)
                }
                Err(why) => (clean, None, Some(format!("fitted, but not applied: {why}"))),
            },
            Err(e) => (clean, None, Some(e.to_string())),
        }
    } else {
        let skipped = "not asked for (mag.calibrate = false)".to_string();
        (clean, None, Some(skipped))
    };
    let magnitude_variation = magnitude_variation(&readings);
    let deviation_unknown = cfg.calibrate
        && calibration.is_none()
        && magnitude_variation > DEVIATION_MAGNITUDE_VARIATION;
    let mut norms: Vec<f64> = readings
        .iter()
        .map(|m| Vector3::from(m.magnetic_field).norm())
        .collect();
    norms.sort_by(f64::total_cmp);
    let reference_norm_t = norms.get(norms.len() / 2).copied().unwrap_or(0.0);
    PreparedMag {
        used: readings.len(),
        readings,
        saturated,
        calibration,
        calibration_skipped,
        magnitude_variation,
        deviation_unknown,
        reference_norm_t,
    }
}

/// The field magnitude's variation beyond the sensor's noise, relative to its mean: the
/// readings' magnitude variance less the noise variance (half the variance of successive
/// differences, as the noise is white and the field changes slowly between readings).
fn magnitude_variation(readings: &[MagneticField]) -> f64 {
    let norms: Vec<f64> = readings
        .iter()
        .map(|m| Vector3::from(m.magnetic_field).norm())
        .collect();
    if norms.len() < 3 {
        return 0.0;
    }
    let n = norms.len() as f64;
    let mean = norms.iter().sum::<f64>() / n;
    let var = norms.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let noise_var =
        norms.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (n - 1.0));
    (var - noise_var).max(0.0).sqrt() / mean
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn reading(k: usize, field: [f64; 3]) -> MagneticField {
        MagneticField {
            stamp_ns: k as i64 * 100_000_000,
            magnetic_field: field,
        }
    }

    /// A saturated stretch (an axis stuck at its extreme) is taken out and reported; a run
    /// without turns is not calibrated, and says why.
    #[test]
    fn saturated_readings_are_left_out_and_reported() {
        let mut mag: Vec<MagneticField> = (0..200)
            .map(|k| {
                let a = k as f64 * 0.01;
                reading(k, [2.0e-5 * a.cos(), 2.0e-5 * a.sin(), 4.0e-5])
            })
            .collect();
        for m in &mut mag[50..60] {
            m.magnetic_field[0] = 6.0e-5;
        }
        let p = prepare(&mag, &MagConfig::default());
        assert_eq!(p.saturated.len(), 1);
        assert_eq!(p.saturated[0].readings, 10);
        assert_eq!(p.readings.len(), 190);
        assert!(p.calibration.is_none());
        assert!(p.calibration_skipped.unwrap().contains("sectors"));
        // The magnitude does not change with the heading: nothing says there is a deviation.
        assert!(!p.deviation_unknown);
        assert!((p.reference_norm_t - 2.0e-5f64.hypot(4.0e-5)).abs() < 1e-9);
        assert!(prepare(&[], &MagConfig::default()).readings.is_empty());
    }

    /// Lanes at two headings and the turns between them (too few headings to calibrate),
    /// level, in a field of 30 uT horizontal and 40 uT down, with 300 nT of white noise.
    fn lanes(hard_iron_t: [f64; 3]) -> Vec<MagneticField> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(71);
        let (b_h, b_down) = (3.0e-5, 4.0e-5);
        (0..6000)
            .map(|k| {
                // 0.1 s apart: 100 s lanes at 160 deg, joined by 100 s turns from and back
                // to 20 deg (14 of 36 sectors).
                let t = (k % 3000) as f64 * 0.1;
                let heading_deg = match t {
                    t if t < 100.0 => 20.0 + 140.0 * t / 100.0,
                    t if t < 200.0 => 160.0,
                    _ => 160.0 - 140.0 * (t - 200.0) / 100.0,
                };
                let (s, c) = heading_deg.to_radians().sin_cos();
                let noise: [f64; 3] = std::array::from_fn(|_| {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    3.0e-7 * n
                });
                let field = [
                    b_h * c + hard_iron_t[0] + noise[0],
                    -b_h * s + hard_iron_t[1] + noise[1],
                    b_down + hard_iron_t[2] + noise[2],
                ];
                reading(k, field)
            })
            .collect()
    }

    /// An uncalibrated hard iron shows in the field magnitude's variation over the headings
    /// flown, and marks the deviation unknown; the noise alone does not.
    #[test]
    fn an_uncalibrated_hard_iron_is_recognised_from_the_field_magnitude() {
        let noisy = prepare(&lanes([0.0; 3]), &MagConfig::default());
        assert!(noisy.calibration.is_none());
        // The noise's variance is removed up to its estimate's own spread: a floor of about
        // sigma (2 / n)^(1/4) = 0.6 % x 0.14 = 0.08 % for these 6000 readings.
        assert!(noisy.magnitude_variation < 0.3 * DEVIATION_MAGNITUDE_VARIATION);
        assert!(!noisy.deviation_unknown);

        let iron = prepare(&lanes([3.0e-6, -2.0e-6, 1.5e-6]), &MagConfig::default());
        assert!(iron.calibration.is_none());
        assert!(iron.magnitude_variation > 3.0 * DEVIATION_MAGNITUDE_VARIATION);
        assert!(iron.deviation_unknown);

        // Asked not to calibrate, the user vouches for the readings.
        let cfg = MagConfig {
            calibrate: false,
            ..MagConfig::default()
        };
        assert!(!prepare(&lanes([3.0e-6, -2.0e-6, 1.5e-6]), &cfg).deviation_unknown);
    }
}
