//! The DVL's calibration as the reconstruction estimated it: scale factor, bias and mounting
//! misalignment; the EM log's scale and the water current; the z gyro's scale factor; the
//! speed of sound's scale; with
//! their sigmas, and whether the
//! log told them (the sigma well under its prior) or they were only carried (considered) at
//! their prior.
//!
//! They are constants in the filter, so the forward pass's last estimate is the smoothed one.

use crate::filters::ins::error_state::idx;
use crate::filters::ins::record::Solution;
use serde::Serialize;

/// A sigma below this fraction of its prior counts as determined by the log.
const DETERMINED_BELOW: f64 = 0.5;

impl Estimated {
    /// An estimate with its sigma, determined when the sigma fell well under the prior's.
    fn new(value: f64, sigma: f64, prior_sigma: f64) -> Self {
        Estimated {
            value,
            sigma,
            determined: sigma < DETERMINED_BELOW * prior_sigma,
        }
    }
}

/// One estimated quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimated {
    pub value: f64,
    pub sigma: f64,
    /// The log determined it (else it was carried at its prior, as a consider term).
    pub determined: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Misalignment {
    pub heading: Estimated,
    pub pitch: Estimated,
}

/// The DVL's calibration (summary.json `dvl_calibration`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DvlCalibrationReport {
    /// About 1.0: the DVL reads `scale_factor` times the true velocity.
    pub scale_factor: Estimated,
    /// Bias along the DVL's x, y, z axes, m/s.
    pub bias_m_s: [Estimated; 3],
    /// Mounting misalignment beyond the configured rotation, deg.
    pub misalignment_deg: Misalignment,
}

/// The EM log's scale and the water current (summary.json `water`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaterReport {
    /// About 1.0: the EM log reads `eml_scale_factor` times the speed through the water.
    pub eml_scale_factor: Estimated,
    /// Current (water over ground) north and east at the end of the mission, m/s.
    pub current_m_s: [Estimated; 2],
}

/// The water report from the last forward solution, with the prior sigmas (EM-log scale,
/// current per axis m/s).
pub fn water_report(last: &Solution, prior_sigma: &[f64; 3]) -> WaterReport {
    let w = &last.point.water;
    let est = |k: usize, offset: f64| {
        Estimated::new(offset + w[k], last.sigma[idx::WATER + k], prior_sigma[k])
    };
    WaterReport {
        eml_scale_factor: est(0, 1.0),
        current_m_s: [est(1, 0.0), est(2, 0.0)],
    }
}

/// The z gyro's scale factor (about 1: it reads this times the true rate) from the last
/// forward solution, with its prior sigma.
pub fn gyro_scale_report(last: &Solution, prior_sigma: f64) -> Estimated {
    Estimated::new(
        1.0 + last.point.gyro_scale_z,
        last.sigma[idx::GYRO_SCALE_Z],
        prior_sigma,
    )
}

/// The speed of sound's scale (about 1: the true speed over the one the acoustic ranges were
/// converted with) from the last forward solution, with its prior sigma.
pub fn sound_speed_report(last: &Solution, prior_sigma: f64) -> Estimated {
    Estimated::new(
        1.0 + last.point.sound_speed_scale,
        last.sigma[idx::SOUND_SPEED_SCALE],
        prior_sigma,
    )
}

/// The report from the last forward solution, with the prior sigmas (scale, pitch and heading
/// rad, bias m/s per axis).
pub fn report(last: &Solution, prior_sigma: &[f64; 6]) -> DvlCalibrationReport {
    let cal = &last.point.dvl;
    let sigma = |k: usize| last.sigma[idx::DVL + k];
    let est = |k: usize, unit: f64, offset: f64| {
        Estimated::new(
            offset + cal[k] * unit,
            sigma(k) * unit,
            prior_sigma[k] * unit,
        )
    };
    let deg = 1f64.to_degrees();
    DvlCalibrationReport {
        scale_factor: est(0, 1.0, 1.0),
        bias_m_s: [est(3, 1.0, 0.0), est(4, 1.0, 0.0), est(5, 1.0, 0.0)],
        misalignment_deg: Misalignment {
            pitch: est(1, deg, 0.0),
            heading: est(2, deg, 0.0),
        },
    }
}
