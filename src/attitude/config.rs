//! Settings of `hindsight attitude` (the section `attitude` of the one configuration system,
//! [`crate::config`]), with a default for every key: seed 001's parameters for its three
//! filters, hindsight's MEKF densities, the DVL's mounting and the magnetometer checks.
//! `hindsight config attitude` prints [`DEFAULT_TOML`].
//!
//! A [`Preset`] is the base a configuration file is laid over: hindsight's defaults, or
//! seed 001's matrices as printed (`Preset::Seed001`, for reproducing the paper; its
//! measurement covariances are indefinite and are raised to a floor, with a message).

use super::cf::CfSettings;
use super::ekf::{matrix, Ekf, EkfSettings};
use super::euler::positive_definite;
use super::mekf::MekfSettings;
use super::ukf::{Ukf, UkfSettings};
use crate::config::keyed;
use crate::config::{all, check_ranges, ConfigError, Range, Section};
use crate::filters::ins::forward::DvlMounting;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The documented defaults (a test parses it back to [`AttitudeConfig::default`]).
pub const DEFAULT_TOML: &str = r#"# hindsight attitude: configuration (every key optional; these are the defaults).
#
# Covariances are 3x3, rows and columns [roll, pitch, yaw], rad^2, per filter step (one
# step per IMU sample), as seed 001 gives them. NOTE: seed 001 calls the process noise R
# and the measurement noise Q, the reverse of the usual convention. Here process_noise is
# the paper's R and measurement_noise the paper's Q.
#
# The paper's printed measurement covariances are not positive definite; these defaults
# keep their diagonals. The preset `seed001` takes the paper's matrices as printed (raised to
# checks.covariance_floor_rad2 where they must be, with a note), for reproducing it.

[ekf]                  # seed 001 Table 1, parameters of its Table 6
initial_cov = [[0.15, 0.0, 0.0], [0.0, 0.15, 0.0], [0.0, 0.0, 0.15]]
process_noise = [[0.1, 0.08, 0.08], [0.08, 0.1, 0.08], [0.08, 0.08, 0.1]]
measurement_noise = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.2]]

[ukf]                  # seed 001 Table 2, parameters of its Table 7
kappa = 1.7
initial_cov = [[0.15, 0.0, 0.0], [0.0, 0.15, 0.0], [0.0, 0.0, 0.15]]
process_noise = [[0.2, 0.02, 0.02], [0.02, 0.2, 0.02], [0.02, 0.02, 0.15]]
measurement_noise = [[0.07, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.02]]

[cf]                   # seed 001 Table 3, gains of its Table 8
kp = 6.151828996322964 # 4.35 sqrt(2), 1/s
ki = 0.415             # 1/s^2

[mekf]                 # hindsight's quaternion filter (densities, one sigma)
gyro_noise_rad_s_rt_hz = 0.002
gyro_bias_walk_rad_s_rt_s = 1e-5
gyro_bias_sigma_rad_s = 0.01
accel_noise_m_s2_rt_s = 0.003   # gravity sensor at rest
accel_sigma_growth = 2.0        # added sigma per m/s^2 of | |f| - g |
heading_noise_rad_rt_s = 0.03
max_field_change = 0.1          # readings whose magnitude departs more (fraction) are skipped
max_dip_change_rad = 0.1        # ... or whose dip departs more
gate_probability = 0.9999

[checks]
# A covariance above that is not positive definite (seed 001's printed measurement
# covariances are not) has its eigenvalues raised to this floor, with a message.
covariance_floor_rad2 = 1e-4

[dvl]
lever_arm_m = [0.0, 0.0, 0.0]     # DVL position from the AHRS, body FRD
rotation_deg = [0.0, 0.0, 0.0]    # DVL axes from body axes: roll, pitch, yaw (Z-Y-X)
# A stretch without a valid reading (no bottom lock, or no readings) up to this long is
# bridged with the last velocity; a longer one is not (the track holds its position
# through it) and is reported.
max_gap_s = 5.0

[magnetometer]
# A reading with an axis at that axis's extreme value of the whole log, repeated in at
# least this many consecutive readings, is taken as saturated: flagged and not used.
saturation_repeats = 3
"#;

/// Everything `hindsight attitude` can be told.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AttitudeConfig {
    pub ekf: EkfSettings,
    pub ukf: UkfSettings,
    pub cf: CfSettings,
    pub mekf: MekfSettings,
    pub checks: Checks,
    pub dvl: DvlSettings,
    pub magnetometer: MagnetometerChecks,
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct Checks {
        pub covariance_floor_rad2: f64 = 1e-4,
    }
}

crate::config::with_defaults! {
    /// The DVL's mounting and how long a stretch without it the dead reckoning bridges.
    #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct DvlSettings {
        pub lever_arm_m: [f64; 3] = [0.0; 3],
        pub rotation_deg: [f64; 3] = [0.0; 3],
        pub max_gap_s: f64 = 5.0,
    }
}

impl DvlSettings {
    pub fn mounting(&self) -> DvlMounting {
        DvlMounting::from_config(self.lever_arm_m, self.rotation_deg)
    }
}

/// The base a configuration file is laid over.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Preset {
    /// hindsight's defaults (every covariance positive definite).
    #[default]
    Hindsight,
    /// Seed 001's EKF and UKF matrices exactly as printed (Tables 6-7), for reproducing
    /// the paper.
    Seed001,
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct MagnetometerChecks {
        pub saturation_repeats: usize = 3,
    }
}

/// A covariance that had to be changed to be used, for the console.
#[derive(Debug, Clone, PartialEq)]
pub struct Adjustment {
    pub key: &'static str,
    pub eigenvalues: [f64; 3],
    pub floor: f64,
}

impl std::fmt::Display for Adjustment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c] = self.eigenvalues;
        write!(
            f,
            "`{}` is not positive definite (eigenvalues {a:.4}, {b:.4}, {c:.4} rad^2): \
             eigenvalues raised to {:e} rad^2",
            self.key, self.floor
        )
    }
}

/// The filters built from a configuration, and what had to be adjusted.
#[derive(Debug, Clone, PartialEq)]
pub struct Filters {
    pub ekf: Ekf,
    pub ukf: Ukf,
    pub cf: CfSettings,
    pub mekf: MekfSettings,
    pub adjustments: Vec<Adjustment>,
}

impl AttitudeConfig {
    /// A preset's settings.
    pub fn preset(preset: Preset) -> AttitudeConfig {
        match preset {
            Preset::Hindsight => AttitudeConfig::default(),
            Preset::Seed001 => AttitudeConfig {
                ekf: EkfSettings::seed001(),
                ukf: UkfSettings::seed001(),
                ..AttitudeConfig::default()
            },
        }
    }

    /// The filters, every covariance made positive definite (reported in `adjustments`).
    pub fn filters(&self) -> Result<Filters, ConfigError> {
        self.check_scalars()?;
        let floor = self.checks.covariance_floor_rad2;
        let mut adjustments = Vec::new();
        let mut checked = |key: &'static str, m: &[[f64; 3]; 3]| {
            if m.iter().flatten().any(|v| !v.is_finite()) {
                return Err(ConfigError::bad_key(
                    key,
                    "every element must be a finite number",
                ));
            }
            let (fixed, found) = positive_definite(&matrix(m), floor);
            if let Some(e) = found {
                let mut eigenvalues = [e[0], e[1], e[2]];
                eigenvalues.sort_by(f64::total_cmp);
                adjustments.push(Adjustment {
                    key,
                    eigenvalues,
                    floor,
                });
            }
            Ok::<Matrix3<f64>, ConfigError>(fixed)
        };
        let ekf = Ekf {
            initial_cov: checked("ekf.initial_cov", &self.ekf.initial_cov)?,
            process_noise: checked("ekf.process_noise", &self.ekf.process_noise)?,
            measurement_noise: checked("ekf.measurement_noise", &self.ekf.measurement_noise)?,
        };
        let ukf = Ukf {
            kappa: self.ukf.kappa,
            initial_cov: checked("ukf.initial_cov", &self.ukf.initial_cov)?,
            process_noise: checked("ukf.process_noise", &self.ukf.process_noise)?,
            measurement_noise: checked("ukf.measurement_noise", &self.ukf.measurement_noise)?,
        };
        Ok(Filters {
            ekf,
            ukf,
            cf: self.cf,
            mekf: self.mekf,
            adjustments,
        })
    }

    /// Every setting that is one number, against its range.
    fn check_scalars(&self) -> Result<(), ConfigError> {
        let kappa = Range::Above(-3.0, "must be a number above -3 (n + kappa > 0)");
        let repeats = self.magnetometer.saturation_repeats as f64;
        let at_least_two = Range::AtLeast(2.0, "must be 2 or more");
        check_ranges(
            all(
                Range::Positive,
                keyed!(self.checks => checks; covariance_floor_rad2),
            )
            .chain(all(kappa, keyed!(self.ukf => ukf; kappa)))
            .chain(all(Range::NonNegative, keyed!(self.cf => cf; kp, ki)))
            .chain(all(
                Range::Positive,
                keyed!(self.mekf => mekf;
                    gyro_noise_rad_s_rt_hz, gyro_bias_sigma_rad_s, accel_noise_m_s2_rt_s,
                    heading_noise_rad_rt_s, max_field_change, max_dip_change_rad),
            ))
            .chain(all(
                Range::OpenProbability,
                keyed!(self.mekf => mekf; gate_probability),
            ))
            .chain(all(Range::NonNegative, keyed!(self.dvl => dvl; max_gap_s)))
            .chain([("magnetometer.saturation_repeats", repeats, at_least_two)]),
        )
    }
}

impl Section for AttitudeConfig {
    const NAME: &'static str = "attitude";
    const DEFAULT_TOML: &'static str = DEFAULT_TOML;

    fn check(&self) -> Result<(), ConfigError> {
        self.filters().map(|_| ())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::load_over;

    /// The defaults need no adjustment.
    #[test]
    fn the_defaults_are_positive_definite() {
        let filters = AttitudeConfig::default().filters().unwrap();
        assert!(filters.adjustments.is_empty(), "{:?}", filters.adjustments);
    }

    /// A file laid over the seed 001 preset keeps the preset's other keys.
    #[test]
    fn a_file_is_laid_over_the_preset() {
        let seed001 = AttitudeConfig::preset(Preset::Seed001);
        let c = load_over(
            &seed001,
            "[ekf]\nprocess_noise = \
            [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]]\n[dvl]\nmax_gap_s = 1.0",
        )
        .unwrap();
        assert_eq!(c.ekf.process_noise[0][0], 0.2);
        assert_eq!(
            c.ekf.measurement_noise,
            EkfSettings::seed001().measurement_noise
        );
        assert_eq!(c.ukf, UkfSettings::seed001());
        assert_eq!(c.dvl.max_gap_s, 1.0);
        let e = load_over(&seed001, "[dvl]\nmax_gap = 1.0").unwrap_err();
        assert!(e.to_string().contains("max_gap"), "{e}");
    }

    /// Seed 001's printed measurement covariances are indefinite: both are adjusted and
    /// reported, nothing else is.
    #[test]
    fn the_papers_measurement_covariances_are_adjusted() {
        let filters = AttitudeConfig::preset(Preset::Seed001).filters().unwrap();
        let keys: Vec<_> = filters.adjustments.iter().map(|a| a.key).collect();
        assert_eq!(keys, ["ekf.measurement_noise", "ukf.measurement_noise"]);
        for a in &filters.adjustments {
            assert!(a.eigenvalues[0] < 0.0, "{a}");
        }
        assert!(filters.ekf.measurement_noise.cholesky().is_some());
        assert!(filters.ukf.measurement_noise.cholesky().is_some());
    }

    #[test]
    fn kappa_keeps_the_sigma_points_real() {
        let e = AttitudeConfig::from_toml("[ukf]\nkappa = -5.0").unwrap_err();
        assert!(e.to_string().contains("ukf.kappa"), "{e}");
        assert!(AttitudeConfig::from_toml("[ukf]\nkappa = -3.0").is_err());
        assert!(AttitudeConfig::from_toml("[ukf]\nkappa = -2.5").is_ok());
    }
}
