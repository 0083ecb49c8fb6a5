//! Identification of hydrodynamic coefficients from sea-trial logs (`hindsight identify`):
//! seed 004's augmented-state EKF, then an output-error refinement over the whole record.
//!
//! - [`record`]: the measurements a log gives (q, theta, w, depth, plane, speed), with the
//!   checks that make identification possible (input present, a manoeuvre, long enough).
//! - [`ekf`]: the first stage, the continuous-discrete augmented EKF.
//! - [`settings`]: constants, sensor noise, tuning, thresholds; [`config`]: the same from a
//!   TOML file.
//! - [`output_error`]: the second stage; [`learn_noise`] alternates it with estimating each
//!   channel's noise from its residuals.

pub mod config;
pub mod design;
pub mod ekf;
pub mod identifiability;
pub mod levenberg;
pub mod output_error;
pub mod record;
pub mod settings;
pub mod six_dof;

use crate::vehicle::heave_pitch::Coefficients;

/// `c` with every coefficient moved by `fraction` of itself, alternately up and down
/// (`Z_w` up, `Z_wdot` down, ...): the start of the "20 % off" tests and of `--perturb`.
pub fn perturbed(c: &Coefficients, fraction: f64) -> Coefficients {
    Coefficients::from_fn(|i, _| c[i] * (1.0 + if i % 2 == 0 { fraction } else { -fraction }))
}

use crate::vehicle::heave_pitch::State;
use identifiability::Determination;
use output_error::Refined;
use record::Record;
use settings::{Settings, Sigmas, Thresholds};

/// How well the identified model reproduces one channel of one log.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ChannelFit {
    /// RMS of measured minus re-simulated, over the sensor's sigma (about 1: the model
    /// fits to the noise).
    pub normalised_rms: f64,
    /// `100 (1 - |y - y_sim| / |y - mean(y)|)`, percent (100: perfect).
    pub fit_percent: f64,
    /// Correlation of each residual with the next: about 0 (within `2 / sqrt(samples)`)
    /// when the model fits and the noise is white; near 1 when the residual is a slow
    /// misfit (a wrong structure) or the sensor's noise is coloured (its sigmas are then
    /// too small).
    pub lag1_correlation: f64,
    pub samples: usize,
}

/// One log re-simulated with the identified model.
#[derive(Debug, Clone, PartialEq)]
pub struct LogFit {
    pub simulated: Vec<State>,
    /// q, theta, w, depth.
    pub channels: [ChannelFit; 4],
}

/// The whole identification: both stages, the assessment, and the fits.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    pub start: Coefficients,
    /// The EKF's answer could not be simulated (the refinement started from `start`).
    pub ekf_diverged: bool,
    pub ekf: ekf::EkfResult,
    pub refined: Refined,
    pub assessment: Vec<Determination>,
    pub fits: Vec<LogFit>,
    /// The sensor noise the refinement used: learnt from its residuals, or as given.
    pub noise: LearntNoise,
}

/// The channel names of [`ChannelFit`]s, in order.
pub const CHANNELS: [&str; 4] = ["q", "theta", "w", "depth"];

/// Runs both stages over the logs from `start`, then assesses and re-simulates.
pub fn identify(records: &[Record], start: &Coefficients, settings: &Settings) -> Identification {
    let ekf = ekf::run(records, start, settings);
    // The EKF can run away (e.g. when a fixed coefficient makes the model wrong): the
    // refinement then starts from the starting values instead.
    let ekf_diverged = !ekf.coefficients.iter().all(|v| v.is_finite())
        || !output_error::simulates(records, &ekf.coefficients, settings);
    let lm_start = if ekf_diverged {
        settings.with_fixed(start)
    } else {
        ekf.coefficients
    };
    let (refined, noise) = learn_noise(records, &lm_start, settings);
    let assessment = identifiability::assess(
        &refined.coefficients,
        &refined.covariance,
        &settings.fixed,
        &settings.thresholds,
    );
    let fits = records
        .iter()
        .zip(&refined.initial_states)
        .map(|(r, x0)| {
            let model = ekf::model_for(r, &settings.constants);
            let simulated = output_error::simulate(&model, r, x0, &refined.coefficients);
            let sigma = noise.sigma.by_channel();
            let pairs: [Vec<(f64, f64)>; 4] = [
                r.q_rad_s
                    .iter()
                    .zip(&simulated)
                    .map(|(m, s)| (*m, s[2]))
                    .collect(),
                r.theta_rad
                    .iter()
                    .zip(&simulated)
                    .map(|(m, s)| (*m, s[1]))
                    .collect(),
                r.w_m_s
                    .iter()
                    .map(|(k, m)| (*m, simulated[*k][0]))
                    .collect(),
                r.depth_m
                    .iter()
                    .map(|(k, m)| (*m, simulated[*k][3]))
                    .collect(),
            ];
            let channels = std::array::from_fn(|ch| channel_fit(&pairs[ch], sigma[ch]));
            LogFit {
                simulated,
                channels,
            }
        })
        .collect();
    Identification {
        start: settings.with_fixed(start),
        ekf_diverged,
        ekf,
        refined,
        assessment,
        fits,
        noise,
    }
}

impl Identification {
    /// What makes the fit doubtful, in words: a poor fit (residuals correlated from sample to
    /// sample, or, with the noise given, larger than it), a refinement that did not converge,
    /// and learnt noise far above the given figures.
    pub fn fit_warnings(&self, settings: &Settings) -> Vec<String> {
        let t = &settings.thresholds;
        let mut warnings = Vec::new();
        let channels = || {
            self.fits.iter().flat_map(|f| {
                CHANNELS
                    .iter()
                    .zip(&f.channels)
                    .filter(|(_, c)| c.samples > 0)
            })
        };
        let worst_rms = channels()
            .map(|(_, c)| c.normalised_rms)
            .fold(
                0.0,
                |a: f64, b| if b.is_nan() { f64::INFINITY } else { a.max(b) },
            );
        warnings.extend(residual_warning(channels().map(|(n, c)| (*n, c)), t));
        if !self.noise.learnt && worst_rms > t.max_normalised_rms {
            warnings.push(format!(
                "POOR FIT: residuals up to {worst_rms:.1} times the sensor noise: the model's \
                 structure (or a fixed coefficient, or the noise figures) does not match the \
                 data; do not trust these coefficients"
            ));
        }
        if !self.refined.converged {
            warnings.push(NOT_CONVERGED.to_string());
        }
        if self.noise.learnt {
            let given = settings.sigma.by_channel();
            let learnt = self.noise.sigma.by_channel();
            for (ch, name) in CHANNELS.iter().enumerate() {
                let ratio = learnt[ch] / given[ch];
                if ratio > t.max_noise_ratio {
                    warnings.push(format!(
                        "the {name} residuals are {ratio:.1} times the given sensor noise: \
                         a noisier sensor than stated, or a misfit"
                    ));
                }
            }
        }
        warnings
    }
}

/// The warning for a refinement that did not converge.
pub const NOT_CONVERGED: &str =
    "POOR FIT: the refinement did not converge; do not trust these coefficients";

/// POOR FIT when the worst channel's residuals are correlated from one sample to the next
/// above the threshold (a NaN, from a simulation that blew up, counts as the worst).
pub fn residual_warning<'a>(
    channels: impl Iterator<Item = (&'a str, &'a ChannelFit)>,
    thresholds: &Thresholds,
) -> Option<String> {
    let (name, r) = channels
        .filter(|(_, c)| c.samples > 0)
        .map(|(n, c)| (n, c.lag1_correlation))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (r.is_nan() || r > thresholds.max_residual_lag1).then(|| {
        format!(
            "POOR FIT: the {name} residuals are correlated from one sample to the next \
             ({r:.2}; white noise gives about 0): the model's structure (or a fixed \
             coefficient) does not match the data, or the sensor's noise is not white and \
             the sigmas are too small; do not trust these coefficients"
        )
    })
}

/// The sensor noise the refinement ended with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearntNoise {
    pub sigma: Sigmas,
    /// Learnt from the residuals (else as given).
    pub learnt: bool,
    /// Refinements run.
    pub rounds: usize,
}

/// The output-error refinement with each channel's noise learnt from its own residuals.
///
/// For a given model, the maximum-likelihood variance of a channel's white noise is the mean
/// square of its residuals; for given variances, the refinement finds the model. The two
/// are alternated until every channel's normalised residual RMS is within 1 % of one (the
/// coefficients hardly move after the first round, so two or three rounds do). The
/// coefficients' covariance is then the inverse Fisher information at the learnt noise,
/// instead of at figures that may not be the sensors'. A channel without readings keeps
/// its given sigma. With `settings.learn_noise` off, one refinement at the given noise.
pub fn learn_noise(
    records: &[Record],
    start: &Coefficients,
    settings: &Settings,
) -> (Refined, LearntNoise) {
    let mut at = *settings;
    let mut refined = output_error::refine(records, start, &at);
    let mut rounds = 1;
    while settings.learn_noise && rounds < settings.noise_rounds.max(1) {
        let ratios = refined.normalised_rms;
        if !ratios.iter().all(|r| r.is_finite())
            || ratios.iter().all(|r| *r == 0.0 || (r - 1.0).abs() < 0.01)
        {
            break;
        }
        at.sigma = at.sigma.scaled(&ratios);
        refined = output_error::refine(records, &refined.coefficients, &at);
        rounds += 1;
    }
    let noise = LearntNoise {
        sigma: at.sigma,
        learnt: settings.learn_noise,
        rounds,
    };
    (refined, noise)
}

pub(crate) fn channel_fit(pairs: &[(f64, f64)], sigma: f64) -> ChannelFit {
    let n = pairs.len().max(1) as f64;
    // A simulation that blew up fits nothing.
    if pairs.iter().any(|(_, s)| !s.is_finite()) {
        return ChannelFit {
            normalised_rms: f64::INFINITY,
            fit_percent: f64::NEG_INFINITY,
            lag1_correlation: f64::NAN,
            samples: pairs.len(),
        };
    }
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let residual = pairs.iter().map(|(m, s)| (m - s).powi(2)).sum::<f64>();
    let spread = pairs.iter().map(|(m, _)| (m - mean).powi(2)).sum::<f64>();
    ChannelFit {
        normalised_rms: (residual / n).sqrt() / sigma,
        fit_percent: 100.0 * (1.0 - (residual / spread.max(f64::MIN_POSITIVE)).sqrt()),
        lag1_correlation: lag1_correlation(pairs),
        samples: pairs.len(),
    }
}

/// Lag-one correlation of the residuals `measured - simulated` (0 with fewer than three).
fn lag1_correlation(pairs: &[(f64, f64)]) -> f64 {
    if pairs.len() < 3 {
        return 0.0;
    }
    let r: Vec<f64> = pairs.iter().map(|(m, s)| m - s).collect();
    let mean = r.iter().sum::<f64>() / r.len() as f64;
    let variance = r.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    if variance == 0.0 {
        return 0.0;
    }
    let lagged = r
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum::<f64>();
    lagged / variance
}
