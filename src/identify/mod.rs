//! Identification of hydrodynamic coefficients from sea-trial logs (`hindsight identify`):
//! seed 004's augmented-state EKF, then an output-error refinement over the whole record.
//!
//! - [`record`]: the measurements a log gives (q, theta, w, depth, plane, speed), with the
//!   checks that make identification possible (input present, a manoeuvre, long enough).
//! - [`ekf`]: the first stage, the continuous-discrete augmented EKF.
//! - [`settings`]: constants, sensor noise, tuning.

pub mod ekf;
pub mod identifiability;
pub mod output_error;
pub mod record;
pub mod settings;

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
use settings::Settings;

/// How well the identified model reproduces one channel of one log.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ChannelFit {
    /// RMS of measured minus re-simulated, over the sensor's sigma (about 1: the model
    /// fits to the noise).
    pub normalised_rms: f64,
    /// `100 (1 - |y - y_sim| / |y - mean(y)|)`, percent (100: perfect).
    pub fit_percent: f64,
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
    let refined = output_error::refine(records, &lm_start, settings);
    let assessment =
        identifiability::assess(&refined.coefficients, &refined.covariance, &settings.fixed);
    let fits = records
        .iter()
        .zip(&refined.initial_states)
        .map(|(r, x0)| {
            let model = ekf::model_for(r, &settings.constants);
            let simulated = output_error::simulate(&model, r, x0, &refined.coefficients);
            let sigma = [
                settings.sigma.q_rad_s,
                settings.sigma.theta_rad,
                settings.sigma.w_m_s,
                settings.sigma.depth_m,
            ];
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
    }
}

fn channel_fit(pairs: &[(f64, f64)], sigma: f64) -> ChannelFit {
    let n = pairs.len().max(1) as f64;
    // A simulation that blew up fits nothing.
    if pairs.iter().any(|(_, s)| !s.is_finite()) {
        return ChannelFit {
            normalised_rms: f64::INFINITY,
            fit_percent: f64::NEG_INFINITY,
            samples: pairs.len(),
        };
    }
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let residual = pairs.iter().map(|(m, s)| (m - s).powi(2)).sum::<f64>();
    let spread = pairs.iter().map(|(m, _)| (m - mean).powi(2)).sum::<f64>();
    ChannelFit {
        normalised_rms: (residual / n).sqrt() / sigma,
        fit_percent: 100.0 * (1.0 - (residual / spread.max(f64::MIN_POSITIVE)).sqrt()),
        samples: pairs.len(),
    }
}
