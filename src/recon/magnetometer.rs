//! The log's magnetometer readings made ready for the heading: saturated readings taken out,
//! and hard and soft iron fitted to the log's own readings when the vehicle turned through
//! enough headings and the fit is a clear gain (`attitude::mag_calibration`); the field's median magnitude, the reference
//! against which a disturbed reading is recognised.

use super::config::MagConfig;
use crate::attitude::mag_calibration::{self, MagCalibration, Untrusted};
use crate::attitude::mag_checks::{self, SaturatedSpan};
use crate::contract::MagneticField;
use nalgebra::Vector3;

/// Readings ready for use, with what was done to them.
#[derive(Debug, Clone, Default)]
pub struct PreparedMag {
    pub readings: Vec<MagneticField>,
    pub saturated: Vec<SaturatedSpan>,
    /// The calibration applied, or why none was.
    pub calibration: Option<MagCalibration>,
    pub calibration_skipped: Option<String>,
    /// The readings' deviation is unknown: a calibration was asked for but could not be
    /// fitted (too few headings) or was not trusted for a reason other than the readings
    /// looking calibrated already. Their heading error then depends on the heading and holds
    /// as long as the heading does.
    pub deviation_unknown: bool,
    /// Median magnitude of the readings used, T (0 without readings).
    pub reference_norm_t: f64,
}

/// Saturation check, then the calibration (when asked and the turns allow), then the
/// reference magnitude.
pub fn prepare(mag: &[MagneticField], cfg: &MagConfig) -> PreparedMag {
    if mag.is_empty() {
        return PreparedMag::default();
    }
    let (clean, saturated) = mag_checks::without_saturation(mag, cfg.saturation_repeats);
    let (readings, calibration, calibration_skipped, deviation_unknown) = if cfg.calibrate {
        match mag_calibration::fit(&clean) {
            Ok(c) => match c.trusted() {
                Ok(()) => (c.applied(&clean), Some(c), None, false),
                Err(why) => {
                    let unknown = !matches!(why, Untrusted::LittleGain { .. });
                    let skipped = format!("fitted, but not applied: {why}");
                    (clean, None, Some(skipped), unknown)
                }
            },
            Err(e) => (clean, None, Some(e.to_string()), true),
        }
    } else {
        let skipped = "not asked for (mag.calibrate = false)".to_string();
        (clean, None, Some(skipped), false)
    };
    let mut norms: Vec<f64> = readings
        .iter()
        .map(|m| Vector3::from(m.magnetic_field).norm())
        .collect();
    norms.sort_by(f64::total_cmp);
    let reference_norm_t = norms.get(norms.len() / 2).copied().unwrap_or(0.0);
    PreparedMag {
        readings,
        saturated,
        calibration,
        calibration_skipped,
        deviation_unknown,
        reference_norm_t,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(p.deviation_unknown);
        assert!((p.reference_norm_t - 2.0e-5f64.hypot(4.0e-5)).abs() < 1e-9);
        assert!(prepare(&[], &MagConfig::default()).readings.is_empty());
    }
}
