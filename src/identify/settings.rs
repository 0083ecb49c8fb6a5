//! Settings of `hindsight identify`: the model's constants, the sensors' noise, and the
//! filters' tuning.

use crate::vehicle::heave_pitch::Constants;

/// Measurement noise, 1 sigma, white.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmas {
    pub q_rad_s: f64,
    pub theta_rad: f64,
    pub w_m_s: f64,
    pub depth_m: f64,
}

impl Default for Sigmas {
    /// The realistic sensors: gyro 0.01 deg/s and pitch 0.02 deg at 100 Hz, DVL
    /// 0.003 m/s; depth 0.01 m.
    fn default() -> Self {
        Sigmas {
            q_rad_s: 0.01f64.to_radians(),
            theta_rad: 0.02f64.to_radians(),
            w_m_s: 0.003,
            depth_m: 0.01,
        }
    }
}

impl Sigmas {
    /// q, theta, w, depth: the order of [`crate::identify::CHANNELS`].
    pub fn by_channel(&self) -> [f64; 4] {
        [self.q_rad_s, self.theta_rad, self.w_m_s, self.depth_m]
    }

    /// Each channel's sigma times its factor (q, theta, w, depth); a factor that is not a
    /// positive number leaves its sigma as it is.
    pub fn scaled(&self, factors: &[f64; 4]) -> Sigmas {
        let s = self.by_channel();
        let f = |i: usize| {
            if factors[i].is_finite() && factors[i] > 0.0 {
                s[i] * factors[i]
            } else {
                s[i]
            }
        };
        Sigmas {
            q_rad_s: f(0),
            theta_rad: f(1),
            w_m_s: f(2),
            depth_m: f(3),
        }
    }
}

/// Process noise of the EKF's dynamic states (the model is taken as exact otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProcessNoise {
    pub w_accel_m_s2_rt_s: f64,
    pub q_accel_rad_s2_rt_s: f64,
}

crate::config::with_defaults! {
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Settings {
        pub constants: Constants = Constants::default(),
        pub sigma: Sigmas = Sigmas::default(),
        pub process_noise: ProcessNoise = ProcessNoise {
            w_accel_m_s2_rt_s: 1e-5,
            q_accel_rad_s2_rt_s: 1e-6,
        },
        /// Initial 1-sigma of each coefficient, as a fraction of its starting value.
        pub initial_coefficient_sigma: f64 = 0.5,
        /// Interval of the EKF's coefficient history, s.
        pub history_interval_s: f64 = 0.1,
        /// RK4 steps per sample interval in the output-error simulation.
        pub substeps: usize = 1,
        /// Levenberg-Marquardt iterations at most.
        pub max_iterations: usize = 50,
        /// Coefficients held at a given value (nondimensional) instead of estimated: known
        /// from elsewhere, or forced (e.g. to zero, to test a model structure).
        pub fixed: [Option<f64>; 10] = [None; 10],
        /// Learn each channel's noise from the refinement's residuals
        /// ([`crate::identify::learn_noise`]); `sigma` is then where the learning starts and
        /// what the result is compared with.
        pub learn_noise: bool = true,
        /// Rounds of refinement and noise re-estimation at most.
        pub noise_rounds: usize = 8,
        pub thresholds: Thresholds = Thresholds::default(),
    }
}

crate::config::with_defaults! {
    /// Where identify starts to warn (the `[thresholds]` section of its settings).
    #[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct Thresholds {
        /// Above this relative 1-sigma a coefficient is reported as poorly determined.
        pub max_relative_sigma: f64 = 0.05,
        /// Above this |correlation| with another, a coefficient is reported as poorly determined.
        pub max_correlation: f64 = 0.95,
        /// Above this lag-one correlation of a channel's residuals, the fit is poor: a slow
        /// misfit, or noise that is not white (white noise gives about `2 / sqrt(samples)`).
        pub max_residual_lag1: f64 = 0.3,
        /// Learnt noise above this multiple of the given figure is reported.
        pub max_noise_ratio: f64 = 3.0,
        /// With the noise not learnt: a normalised residual RMS above this is a poor fit.
        pub max_normalised_rms: f64 = 2.0,
    }
}

impl Settings {
    /// `c` with the fixed coefficients set to their values.
    pub fn with_fixed(
        &self,
        c: &crate::vehicle::heave_pitch::Coefficients,
    ) -> crate::vehicle::heave_pitch::Coefficients {
        crate::vehicle::heave_pitch::Coefficients::from_fn(|i, _| self.fixed[i].unwrap_or(c[i]))
    }
}
