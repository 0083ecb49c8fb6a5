//! In-motion alignment: the heading the log's aiding supports, found from any start and
//! carried back to the start.
//!
//! A bank of heading hypotheses, as a Gaussian sum: the full forward filter is run over the
//! first `span_s` of the mission from `hypotheses` headings spread evenly over 360 deg (the
//! first at the initial heading with its own sigma, the others with half their spacing as
//! sigma, so that each filter's linearisation holds), each scored by the likelihood of its
//! innovations (every measurement counted, a gated-out one at the gate's value, so a filter
//! cannot win by rejecting what contradicts it). The prior weights trust the initial heading
//! except with `hint_outlier_probability`; without any heading source they are equal.
//!
//! When one hypothesis and its two neighbours hold at least `decisive_weight` of the
//! posterior (the neighbours of the right heading converge to it too): if the initial heading
//! is among them, nothing changes; otherwise the winner's run over the span is smoothed (the RTS
//! smoother, a backward pass) and the start gets the smoothed heading and its sigma. When no
//! hypothesis is decisive, the span grows (three times, up to the whole log) before the
//! initial heading is kept (or, without one, the run is refused).
//!
//! The forward pass then starts from that heading: it is no longer strictly causal at its
//! start (the heading was found later in the log), which is what a post-processor wants and
//! what commercial ones do (forward and backward passes, or the log processed several times).

use super::heading::HeadingSource;
use super::start::Initialisation;
use crate::angle::wrap_pi;
use crate::filters::ins::driver::{run_forward, Inputs, Keep, Residual, Settings};
use crate::filters::ins::error_state::idx;
use crate::filters::kalman::chi_square_quantile;
use crate::recon::config::AlignmentConfig;
use crate::smooth::rts::smooth;
use rayon::prelude::*;
use serde::Serialize;

/// One heading hypothesis and its score.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Hypothesis {
    /// Start heading, degrees in [0, 360).
    pub heading_deg: f64,
    pub sigma_deg: f64,
    pub log_likelihood: f64,
    /// Posterior weight (prior times likelihood, normalised).
    pub weight: f64,
}

/// What the alignment found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InMotion {
    /// Seconds of the mission the deciding bank ran over.
    pub span_s: f64,
    pub hypotheses: Vec<Hypothesis>,
    /// Whether one hypothesis and its neighbours held `decisive_weight` of the posterior.
    pub decisive: bool,
    /// The winning hypothesis (index into `hypotheses`; 0 is the initial heading).
    pub best: usize,
    /// The start heading found (rad) and its 1-sigma (deg), when it replaces the initial one.
    #[serde(skip)]
    pub found: Option<(f64, f64)>,
    /// Found heading, degrees in [0, 360), for the summary.
    pub heading_deg: Option<f64>,
    pub sigma_deg: Option<f64>,
    /// A gyrocompassed initial heading confirmed by the bank and refined over the span:
    /// heading (rad) and 1-sigma (deg).
    #[serde(skip)]
    pub refined: Option<(f64, f64)>,
    /// The refined heading, degrees in [0, 360), and its sigma, for the summary.
    pub refined_heading_deg: Option<f64>,
    pub refined_sigma_deg: Option<f64>,
}

/// The inputs up to `end_ns` (the output stamps left out: the bank needs no output rows).
/// Cutting the IMU is enough: a reading is applied at an IMU tick at or after its stamp.
fn inputs_until<'a>(inputs: &Inputs<'a>, end_ns: i64) -> Inputs<'a> {
    Inputs {
        imu: &inputs.imu[..inputs.imu.partition_point(|m| m.stamp_ns <= end_ns)],
        output_stamps_ns: &[],
        progress: None,
        ..*inputs
    }
}

/// Log-likelihood of a run's innovations: `-0.5 (min(NIS, cap) + ln det S)` per measurement
/// (`S` taken as its diagonal), the cap being the gate's quantile of the measurement's size.
fn log_likelihood(residuals: &[Residual], gate_probability: f64) -> f64 {
    let caps: Vec<f64> = (1..=3)
        .map(|m| chi_square_quantile(m, gate_probability))
        .collect();
    residuals
        .iter()
        .map(|r| {
            let ln_det: f64 = r.sigma[..usize::from(r.dims)]
                .iter()
                .map(|s| (s * s).max(1e-300).ln())
                .sum();
            -0.5 * (r.nis.min(caps[usize::from(r.dims) - 1]) + ln_det)
        })
        .sum()
}

/// A heading hypothesis of the bank: yaw (rad), its sigma (deg) and its prior weight.
type HypothesisPrior = (f64, f64, f64);

/// The bank's hypotheses, spread over 360 deg from the start's heading: a known start
/// heading gets its own sigma and the prior that it is right.
fn hypotheses(init: &Initialisation, cfg: &AlignmentConfig) -> Vec<HypothesisPrior> {
    let k = cfg.hypotheses.max(2);
    let spacing_deg = 360.0 / k as f64;
    let known = init.heading != super::heading::HeadingSource::Unknown;
    let (_, _, yaw0) = init.estimate.nav.ned_from_body.euler_angles();
    (0..k)
        .map(|i| {
            let yaw = wrap_pi(yaw0 + (i as f64 * spacing_deg).to_radians());
            let (sigma, prior) = match (known, i) {
                (true, 0) => (
                    init.heading_sigma_deg.min(spacing_deg * 0.5),
                    1.0 - cfg.hint_outlier_probability + cfg.hint_outlier_probability / k as f64,
                ),
                (true, _) => (spacing_deg * 0.5, cfg.hint_outlier_probability / k as f64),
                (false, _) => (spacing_deg * 0.5, 1.0 / k as f64),
            };
            (yaw, sigma, prior)
        })
        .collect()
}

/// Each hypothesis's log-likelihood over the span and its posterior weight.
fn score_bank(
    settings: &Settings,
    cut: &Inputs<'_>,
    init: &Initialisation,
    hypotheses: &[HypothesisPrior],
) -> (Vec<f64>, Vec<f64>) {
    let gate_p = settings.aiding.gate_probability.unwrap_or(0.999);
    // Only the residuals are scored.
    let cut = &Inputs {
        keep: Keep::Nothing,
        ..*cut
    };
    let scores: Vec<f64> = hypotheses
        .par_iter()
        .map(|&(yaw, sigma, _)| {
            let run = run_forward(settings, cut, init.estimate_with_heading(yaw, sigma));
            log_likelihood(&run.residuals, gate_p)
        })
        .collect();
    let ln_post: Vec<f64> = scores
        .iter()
        .zip(hypotheses)
        .map(|(ll, h)| ll + h.2.ln())
        .collect();
    let top = ln_post.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let total: f64 = ln_post.iter().map(|l| (l - top).exp()).sum();
    let weights = ln_post.iter().map(|l| (l - top).exp() / total).collect();
    (scores, weights)
}

/// Runs the bank over growing spans until it is decisive or covers the log.
pub fn align(
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    cfg: &AlignmentConfig,
) -> Option<InMotion> {
    let (Some(first), Some(last)) = (inputs.imu.first(), inputs.imu.last()) else {
        return None;
    };
    let hypotheses = hypotheses(init, cfg);
    let k = hypotheses.len();
    let whole_s = (last.stamp_ns - first.stamp_ns) as f64 * 1e-9;
    let mut span_s = cfg.first_span_s.min(whole_s);
    loop {
        let end_ns = first.stamp_ns + (span_s * 1e9) as i64;
        let cut = inputs_until(inputs, end_ns);
        let (scores, weights) = score_bank(settings, &cut, init, &hypotheses);
        let best = (0..k)
            .max_by(|&a, &b| weights[a].total_cmp(&weights[b]))
            .unwrap_or(0);
        // Neighbours of the right heading converge to it as well: the decision is the
        // weight of the best and its two neighbours.
        let cluster = [(best + k - 1) % k, best, (best + 1) % k];
        let decisive = cluster.iter().map(|&i| weights[i]).sum::<f64>() >= cfg.decisive_weight;
        if decisive || span_s >= whole_s {
            let decided = Decided {
                settings,
                cut: &cut,
                init,
                hypotheses: &hypotheses,
                best,
                decisive,
            };
            let (found, refined) = (decided.found(cfg), decided.refined());
            return Some(InMotion {
                span_s,
                hypotheses: hypotheses
                    .iter()
                    .zip(scores.iter().zip(&weights))
                    .map(|(h, (ll, w))| Hypothesis {
                        heading_deg: h.0.to_degrees().rem_euclid(360.0),
                        sigma_deg: h.1,
                        log_likelihood: *ll,
                        weight: *w,
                    })
                    .collect(),
                decisive,
                best,
                heading_deg: found.map(|f| f.0.to_degrees().rem_euclid(360.0)),
                sigma_deg: found.map(|f| f.1),
                found,
                refined_heading_deg: refined.map(|f| f.0.to_degrees().rem_euclid(360.0)),
                refined_sigma_deg: refined.map(|f| f.1),
                refined,
            });
        }
        span_s = (span_s * 3.0).min(whole_s);
    }
}

/// The bank's last span, decided (or covering the log).
struct Decided<'a> {
    settings: &'a Settings,
    cut: &'a Inputs<'a>,
    init: &'a Initialisation,
    hypotheses: &'a [HypothesisPrior],
    best: usize,
    decisive: bool,
}

impl Decided<'_> {
    /// The heading found (yaw rad, sigma deg): a decisive winner other than a known start
    /// heading, refined over the span.
    fn found(&self, cfg: &AlignmentConfig) -> Option<(f64, f64)> {
        let known = self.init.heading != super::heading::HeadingSource::Unknown;
        if !(self.decisive && (self.best != 0 || !known)) {
            return None;
        }
        let (yaw, sigma, _) = self.hypotheses[self.best];
        let floor = if sees_earth_rate(self.init) {
            0.0
        } else {
            cfg.found_sigma_floor_deg
        };
        let (yaw, sigma) = for_another_pass(refine(self.settings, self.cut, self.init, yaw, sigma));
        Some((yaw, sigma.max(floor)))
    }

    /// A gyrocompassed heading the bank confirms: the filter over the span sees the Earth's
    /// rate with the DVL's velocity (gyrocompassing in motion), far better than the still
    /// gyrocompass's window. It must agree with the gyrocompass (within 3 sigmas of their
    /// difference): a span whose aiding misleads the filter would otherwise replace a sound
    /// heading with a confident wrong one.
    fn refined(&self) -> Option<(f64, f64)> {
        if !(self.decisive && self.best == 0 && self.init.heading == HeadingSource::Gyrocompass) {
            return None;
        }
        let (yaw, sigma, _) = self.hypotheses[0];
        let (refined_yaw, refined_sigma) =
            for_another_pass(refine(self.settings, self.cut, self.init, yaw, sigma));
        let apart_deg = wrap_pi(refined_yaw - yaw).to_degrees().abs();
        (apart_deg <= 3.0 * sigma.hypot(refined_sigma)).then_some((refined_yaw, refined_sigma))
    }
}

/// A gyro's bias over the horizontal Earth rate, as a heading error, at most this: its
/// filter sees the Earth's rate (the same bar as the gyrocompass at rest).
const EARTH_RATE_HEADING_DEG: f64 = 1.0;

/// Whether the start's gyro sees the Earth's rate: its horizontal bias sigma, as the heading
/// error it would make a gyrocompass, is at most [`EARTH_RATE_HEADING_DEG`].
fn sees_earth_rate(init: &Initialisation) -> bool {
    let bias_rad_s = init.estimate.cov[(idx::GYRO_BIAS, idx::GYRO_BIAS)].sqrt();
    let horizontal =
        crate::recon::alignment::at_rest::horizontal_earth_rate(init.estimate.nav.lat_rad);
    (bias_rad_s / horizontal).to_degrees() <= EARTH_RATE_HEADING_DEG
}

/// A prior heading sigma small enough for the error state to stay linear, deg: a filter
/// started within it corrects its heading by a small angle.
const LINEAR_SIGMA_DEG: f64 = 5.0;

/// How much wider than the last pass's smoothed sigma the next pass starts: the span's data
/// then outweigh the prior nine to one, and are not counted twice over.
const WIDENED: f64 = 3.0;

/// Passes of [`refine`] at most.
const REFINE_PASSES: usize = 5;

/// A pass of [`refine`] whose heading moved less than this share of its sigma has settled.
const SETTLED_SHARE: f64 = 0.1;

/// A pass of [`refine`] that moves the heading by more than this share of the move before
/// it is not converging: the linearisation is no longer what moves it, the model's mismatch
/// with the data is (untuned figures on a MEMS IMU, `TEST_PISCINE_20160305_CIRCLE`: 13.5,
/// 12.9, 12.4, 20.0 deg with a sigma of 0.14), and the answer before it is kept.
const CONTRACTION: f64 = 0.9;

/// The winner's run over the span, smoothed: its start heading (rad) and 1-sigma (deg).
/// Again from each answer, so that the linearisation is about the answer, until a pass moves
/// the heading by less than [`SETTLED_SHARE`] of its sigma (at most [`REFINE_PASSES`], and
/// while the moves contract, [`CONTRACTION`]).
///
/// Each pass after the first starts with the prior's sigma when that is within
/// [`LINEAR_SIGMA_DEG`]: started with the smoothed one it would count the span's data twice,
/// and follow whatever misled them twice as far (a DVL's correlated error read as heading:
/// 0.3 deg on `auv-at-sea`, reported as 0.11). A wider prior (a bank's hypothesis, 15 deg)
/// would make the next pass's first corrections large and non-linear again: it starts with
/// [`LINEAR_SIGMA_DEG`] (or [`WIDENED`] times the smoothed sigma, when wider). Two passes, the
/// second started with the smoothed sigma, left the first's linearisation error in the answer
/// with a sigma that did not cover it: on `auv-at-sea-straight` seeds 1, 2 and 5 the start
/// was 1.4-1.5 deg off with a reported 0.39-0.47 deg; now 0.3-0.5 deg with 0.59-0.68 deg
/// before the tuning, and 0.1-0.2 deg after it.
fn refine(
    settings: &Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    yaw: f64,
    prior_sigma_deg: f64,
) -> (f64, f64) {
    // The smoother needs the records, whatever the caller keeps (a scoring pass keeps none).
    let inputs = &Inputs {
        keep: Keep::Records,
        ..*inputs
    };
    let mut answer = (yaw, prior_sigma_deg);
    let mut start_sigma_deg = prior_sigma_deg;
    let mut last_move_deg = f64::INFINITY;
    for _ in 0..REFINE_PASSES {
        let run = run_forward(
            settings,
            inputs,
            init.estimate_with_heading(answer.0, start_sigma_deg),
        );
        let Some(start) = smooth(&run.records).ok().and_then(|s| s.first().copied()) else {
            break;
        };
        let found = (start.euler_rad()[2], start.sigma[idx::ATT + 2].to_degrees());
        let moved_deg = wrap_pi(found.0 - answer.0).to_degrees().abs();
        if moved_deg > CONTRACTION * last_move_deg {
            break;
        }
        answer = found;
        if moved_deg < SETTLED_SHARE * found.1 {
            break;
        }
        last_move_deg = moved_deg;
        start_sigma_deg = if prior_sigma_deg <= LINEAR_SIGMA_DEG {
            prior_sigma_deg
        } else {
            LINEAR_SIGMA_DEG.max(WIDENED * found.1)
        };
    }
    answer
}

/// The sigma a forward pass over the span's data again starts a heading found from them
/// with. Started with the smoothed sigma, it would hold twice their information by the span's
/// end (sigma 0.71 times the error's); started with sqrt(2) times it, it is 1.41 times the
/// error's at the start and 0.82 at the span's end: off by the same factor either way.
fn for_another_pass(found: (f64, f64)) -> (f64, f64) {
    (found.0, std::f64::consts::SQRT_2 * found.1)
}
