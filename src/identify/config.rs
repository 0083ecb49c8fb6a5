//! Settings of `hindsight identify` (the section `identify` of the one configuration system,
//! [`crate::config`]), with a default for every key; `hindsight config identify` prints
//! [`DEFAULT_TOML`]. Angles are in degrees here and in radians in [`Settings`].

use super::design::DesignSettings;
use super::settings::{ProcessNoise, Settings, Sigmas, Thresholds};
use crate::config::keyed;
use crate::config::{all, check_ranges, ConfigError, Range, Section};
use serde::{Deserialize, Serialize};

/// The documented defaults (a test parses it back to [`IdentifyConfig::default`]).
pub const DEFAULT_TOML: &str = r#"# hindsight identify: configuration (every key optional; these are the defaults).

[noise]
# Each channel's white measurement noise, 1 sigma. With learn = true (the default) these
# are where the learning starts, and the learnt figures are compared with them: the
# refinement is alternated with re-estimating each channel's noise from its own residuals
# until they agree (summary.json: noise). With learn = false they are used as they are.
learn = true
max_rounds = 8               # refinements at most while learning
q_deg_s = 0.01               # pitch rate, from the gyro
theta_deg = 0.02             # pitch, from /attitude
w_m_s = 0.003                # heave velocity, from the DVL
depth_m = 0.01               # depth sensor

[ekf]
# The first stage: seed 004's continuous-discrete EKF with the coefficients as states.
initial_coefficient_sigma = 0.5      # 1 sigma of each starting coefficient, fraction of it
w_accel_m_s2_rt_s = 1e-5             # process noise on the heave equation
q_accel_rad_s2_rt_s = 1e-6           # process noise on the pitch equation
history_interval_s = 0.1             # interval of coefficient_history.parquet

[refinement]
# The second stage: output-error maximum likelihood (Levenberg-Marquardt).
max_iterations = 50
substeps = 1                 # RK4 steps per sample interval in the simulation

[thresholds]
max_relative_sigma = 0.05    # a coefficient with a larger 1-sigma (fraction) is poorly determined
max_correlation = 0.95       # a coefficient correlated more than this with another: noted as determined together
max_residual_lag1 = 0.3      # residuals correlated more from sample to sample: POOR FIT
max_noise_ratio = 3.0        # learnt noise more than this times the given figure: a warning
max_normalised_rms = 2.0     # with learn = false: residuals more than this times the noise: POOR FIT

[design]
# identify's suggestions: the candidate manoeuvres whose Fisher information is predicted (a
# zig-zag flown as the simulator's scenario `zigzag-PLANE-TRIGGER` flies it).
plane_deg = 10.0             # plane deflection of the candidate zig-zags
trigger_deg = 5.0            # pitch that reverses the plane
duration_s = 200.0
plane_rate_deg_s = 10.0      # the plane's rate limit
speed_factors = [0.5, 1.5]   # other speeds to try, as multiples of the logs' mean speed
ballast_fraction = 0.0005    # a known ballast change to try: (W - B) / W, positive heavy; 0: none
"#;

/// Everything `hindsight identify` can be told from a file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifyConfig {
    pub noise: NoiseConfig,
    pub ekf: EkfConfig,
    pub refinement: RefinementConfig,
    pub thresholds: Thresholds,
    pub design: DesignSettings,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseConfig {
    pub learn: bool,
    pub max_rounds: usize,
    pub q_deg_s: f64,
    pub theta_deg: f64,
    pub w_m_s: f64,
    pub depth_m: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EkfConfig {
    pub initial_coefficient_sigma: f64,
    pub w_accel_m_s2_rt_s: f64,
    pub q_accel_rad_s2_rt_s: f64,
    pub history_interval_s: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RefinementConfig {
    pub max_iterations: usize,
    pub substeps: usize,
}

impl Default for IdentifyConfig {
    /// The figures of [`Settings::default`], angles in degrees as given there.
    fn default() -> Self {
        let d = Settings::default();
        IdentifyConfig {
            noise: NoiseConfig {
                learn: d.learn_noise,
                max_rounds: d.noise_rounds,
                q_deg_s: 0.01,
                theta_deg: 0.02,
                w_m_s: d.sigma.w_m_s,
                depth_m: d.sigma.depth_m,
            },
            ekf: EkfConfig {
                initial_coefficient_sigma: d.initial_coefficient_sigma,
                w_accel_m_s2_rt_s: d.process_noise.w_accel_m_s2_rt_s,
                q_accel_rad_s2_rt_s: d.process_noise.q_accel_rad_s2_rt_s,
                history_interval_s: d.history_interval_s,
            },
            refinement: RefinementConfig {
                max_iterations: d.max_iterations,
                substeps: d.substeps,
            },
            thresholds: d.thresholds,
            design: DesignSettings::default(),
        }
    }
}

/// A section left out of a file, or a key left out of a section, takes the default of
/// [`IdentifyConfig::default`].
macro_rules! section_defaults {
    ($($section:ident: $type:ty),*) => {
        $(impl Default for $type {
            fn default() -> Self {
                IdentifyConfig::default().$section
            }
        })*
    };
}
section_defaults!(noise: NoiseConfig, ekf: EkfConfig, refinement: RefinementConfig);

impl Section for IdentifyConfig {
    const NAME: &'static str = "identify";
    const DEFAULT_TOML: &'static str = DEFAULT_TOML;

    fn check(&self) -> Result<(), ConfigError> {
        self.settings()?;
        self.design()?;
        Ok(())
    }
}

impl IdentifyConfig {
    /// The identification's settings (no coefficient fixed).
    pub fn settings(&self) -> Result<Settings, ConfigError> {
        let (n, e, r, t) = (&self.noise, &self.ekf, &self.refinement, &self.thresholds);
        let positive = all(
            Range::Positive,
            keyed!(n => noise; q_deg_s, theta_deg, w_m_s, depth_m),
        )
        .chain(all(
            Range::Positive,
            keyed!(e => ekf; initial_coefficient_sigma, history_interval_s),
        ))
        .chain(all(
            Range::Positive,
            keyed!(t => thresholds;
                max_relative_sigma, max_correlation, max_residual_lag1, max_noise_ratio,
                max_normalised_rms),
        ));
        let non_negative = all(
            Range::NonNegative,
            keyed!(e => ekf; w_accel_m_s2_rt_s, q_accel_rad_s2_rt_s),
        );
        let counts = all(
            Range::AtLeast(1.0, "must be at least 1"),
            [
                ("noise.max_rounds", n.max_rounds as f64),
                ("refinement.max_iterations", r.max_iterations as f64),
                ("refinement.substeps", r.substeps as f64),
            ],
        );
        check_ranges(positive.chain(non_negative).chain(counts))?;
        Ok(Settings {
            sigma: Sigmas {
                q_rad_s: n.q_deg_s.to_radians(),
                theta_rad: n.theta_deg.to_radians(),
                w_m_s: n.w_m_s,
                depth_m: n.depth_m,
            },
            process_noise: ProcessNoise {
                w_accel_m_s2_rt_s: e.w_accel_m_s2_rt_s,
                q_accel_rad_s2_rt_s: e.q_accel_rad_s2_rt_s,
            },
            initial_coefficient_sigma: e.initial_coefficient_sigma,
            history_interval_s: e.history_interval_s,
            substeps: r.substeps,
            max_iterations: r.max_iterations,
            learn_noise: n.learn,
            noise_rounds: n.max_rounds,
            thresholds: *t,
            ..Settings::default()
        })
    }
}

impl IdentifyConfig {
    /// The candidates of `identify --suggest`.
    pub fn design(&self) -> Result<DesignSettings, ConfigError> {
        let d = &self.design;
        check_ranges(all(
            Range::Positive,
            keyed!(d => design; plane_deg, trigger_deg, duration_s, plane_rate_deg_s),
        ))?;
        if let Some(f) = d
            .speed_factors
            .iter()
            .find(|f| !(f.is_finite() && **f > 0.0))
        {
            return Err(ConfigError::bad(
                "design.speed_factors",
                f,
                "every factor must be a positive number",
            ));
        }
        check_ranges([(
            "design.ballast_fraction",
            d.ballast_fraction,
            Range::Within(
                -0.1,
                0.1,
                "must be a fraction of the weight, between -0.1 and 0.1",
            ),
        )])?;
        Ok(d.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_defaults_are_the_settings_defaults() {
        let documented = IdentifyConfig::from_toml(DEFAULT_TOML).unwrap();
        assert_eq!(documented.settings().unwrap(), Settings::default());
        assert_eq!(documented.design().unwrap(), DesignSettings::default());
    }

    #[test]
    fn a_file_sets_what_it_names() {
        let c = IdentifyConfig::from_toml("[noise]\nlearn = false\ndepth_m = 0.02").unwrap();
        let s = c.settings().unwrap();
        assert!(!s.learn_noise);
        assert_eq!(s.sigma.depth_m, 0.02);
        assert_eq!(s.sigma.w_m_s, Settings::default().sigma.w_m_s);
    }

    #[test]
    fn bad_values_name_their_key() {
        for (text, key) in [
            ("[noise]\ndepth_m = 0.0", "noise.depth_m"),
            (
                "[thresholds]\nmax_residual_lag1 = -1.0",
                "thresholds.max_residual_lag1",
            ),
            ("[refinement]\nsubsteps = 0", "refinement.substeps"),
            (
                "[design]\nspeed_factors = [1.5, -1.0]",
                "design.speed_factors",
            ),
            (
                "[design]\nballast_fraction = 0.5",
                "design.ballast_fraction",
            ),
        ] {
            let e = IdentifyConfig::from_toml(text).unwrap_err().to_string();
            assert!(e.starts_with(&format!("`{key}`")), "{e}");
        }
    }
}
