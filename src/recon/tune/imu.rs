//! The IMU's noise by maximum likelihood of the filter's innovations.
//!
//! Each candidate noise model runs the forward filter over the same span of the log; its
//! score is the log-likelihood of the innovations (`ForwardRun::log_likelihood_of`: from
//! `[tune] settle_s` into the span when the start heading was found in motion). The
//! candidates are first the grades (navigation to MEMS, and MEMS 10 and 100 times worse
//! unless the MEMS grade fell far below the best: [`loud_rungs_left_out`]), then, from the
//! best, the gyro's and the accelerometer's figures each scaled by 3 up and
//! down while the likelihood improves. An IMU whose data sheet nobody gave is thus learnt
//! from how well each noise model predicts the aiding sensors.
//!
//! When the IMU's white noise was measured from its own data, the candidates are compared by
//! their likelihood plus a prior on their biases ([`bias_prior`]): centred on the biases the
//! grades pair with that white noise, one decade wide; one-sided (biases below the pair are
//! not penalised) when it is the moving samples' upper bound, which a hull's vibration
//! inflates 10-90 times on a fibre-optic IMU. Where the innovations cannot tell two
//! models apart (a fibre-optic gyro's 0.01 deg/h moves a 400 s heading by 0.001 deg) the
//! IMU's own noise decides; where they can, they outweigh it.

use super::ImuWhite;
use crate::filters::ins::aid_table::Sensor;
use crate::ingest::Mission;
use crate::recon::alignment::heading::HeadingSource;
use crate::recon::alignment::start::{InitError, Initialisation};
use crate::recon::config::{Config, ImuConfig, ImuGrade, ImuSpec};
use crate::recon::{forward_pass, Prepared, ReconError, Streams};
use rayon::prelude::*;
use serde::Serialize;

/// Scale of one refinement step.
const STEP: f64 = 3.0;
/// Refinement rounds at most: the search goes on while the likelihood rises, up to factors of
/// 3^8 (6561) either way of the best grade, beyond any IMU.
const MAX_ROUNDS: usize = 8;
/// Least log-likelihood gain for a refinement step to be taken (below it the data cannot
/// tell the two apart).
const MIN_GAIN: f64 = 0.5;

/// A noise model: a grade's figures with the gyro's and the accelerometer's scaled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Candidate {
    /// The gyro's grade (and the model's, for what follows from a grade) ...
    pub grade: ImuGrade,
    /// ... and the accelerometer's: the same, unless the ladder's second stage paired a finer
    /// gyro with the best grade's accelerometer ([`finer_gyros`]).
    pub accel_grade: ImuGrade,
    pub gyro_factor: f64,
    pub accel_factor: f64,
    /// The gyro's white noise (ARW) scaled apart from its biases: a grade ties them, and an
    /// IMU need not follow it (a MEMS gyro of 1000 deg/h whose white noise is 2 deg/sqrt(h)
    /// is no grade's 1000/30).
    pub gyro_white_factor: f64,
}

impl Candidate {
    fn of(grade: ImuGrade, factor: f64) -> Self {
        Candidate {
            grade,
            accel_grade: grade,
            gyro_factor: factor,
            accel_factor: factor,
            gyro_white_factor: 1.0,
        }
    }

    /// The figures of this model.
    pub fn spec(&self) -> ImuSpec {
        let g = self.grade.spec();
        let a = self.accel_grade.spec();
        ImuSpec {
            gyro_bias_deg_h: g.gyro_bias_deg_h * self.gyro_factor,
            gyro_bias_instability_deg_h: g.gyro_bias_instability_deg_h * self.gyro_factor,
            gyro_arw_deg_rt_h: g.gyro_arw_deg_rt_h * self.gyro_factor * self.gyro_white_factor,
            accel_bias_ug: a.accel_bias_ug * self.accel_factor,
            accel_bias_instability_ug: a.accel_bias_instability_ug * self.accel_factor,
            accel_vrw_ug_rt_hz: a.accel_vrw_ug_rt_hz * self.accel_factor,
            bias_correlation_s: g.bias_correlation_s,
            gyro_scale_ppm: g.gyro_scale_ppm,
        }
    }

    /// The figures with the white noise measured from the IMU's own data, when it was.
    pub fn spec_with(&self, white: Option<&ImuWhite>) -> ImuSpec {
        let mut s = self.spec();
        if let Some(w) = white.filter(|w| w.is_measured()) {
            s.gyro_arw_deg_rt_h = w.gyro_arw_deg_rt_h;
            s.accel_vrw_ug_rt_hz = w.accel_vrw_ug_rt_hz;
        }
        s
    }

    /// "tactical", "mems x100", "navigation, gyro x3, accel x0.33", "navigation gyro,
    /// tactical accel".
    pub fn label(&self) -> String {
        let name = |g: ImuGrade| {
            serde_json::to_value(g)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default()
        };
        let grade = if self.accel_grade == self.grade {
            name(self.grade)
        } else {
            format!(
                "{} gyro, {} accel",
                name(self.grade),
                name(self.accel_grade)
            )
        };
        let factor = |f: f64| {
            if f >= 1.0 {
                format!("x{f:.0}")
            } else {
                format!("x{f:.2}")
            }
        };
        let label = if self.gyro_factor == self.accel_factor {
            if self.gyro_factor == 1.0 {
                grade
            } else {
                format!("{grade} {}", factor(self.gyro_factor))
            }
        } else {
            format!(
                "{grade}, gyro {}, accel {}",
                factor(self.gyro_factor),
                factor(self.accel_factor)
            )
        };
        if (self.gyro_white_factor - 1.0).abs() < 1e-9 {
            label
        } else {
            format!("{label}, gyro ARW {}", factor(self.gyro_white_factor))
        }
    }

    /// The same model (factors equal to rounding).
    fn same_as(&self, other: &Candidate) -> bool {
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-6;
        self.grade == other.grade
            && self.accel_grade == other.accel_grade
            && close(self.gyro_factor, other.gyro_factor)
            && close(self.accel_factor, other.accel_factor)
            && close(self.gyro_white_factor, other.gyro_white_factor)
    }

    fn scaled(&self, gyro: f64, accel: f64) -> Self {
        Candidate {
            gyro_factor: self.gyro_factor * gyro,
            accel_factor: self.accel_factor * accel,
            ..*self
        }
    }

    /// The gyro's white noise alone scaled.
    fn white_scaled(&self, gyro_white: f64) -> Self {
        Candidate {
            gyro_white_factor: self.gyro_white_factor * gyro_white,
            ..*self
        }
    }
}

/// A candidate with its score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scored {
    pub label: String,
    #[serde(flatten)]
    pub candidate: Candidate,
    /// `None` when its forward pass failed.
    pub log_likelihood: Option<f64>,
    /// The log of its prior ([`bias_prior`]; 0 without a measured white noise).
    pub log_prior: f64,
}

/// The outcome of the search.
#[derive(Debug, Clone, PartialEq)]
pub struct Search {
    /// The most likely model; `None` when no pass succeeded.
    pub best: Option<Candidate>,
    /// The DVL bias's drift the IMU was scored with (`None`: the configuration's, kept).
    pub dvl_bias_walk: Option<DvlDrift>,
    /// Every model tried, in the order tried.
    pub tried: Vec<Scored>,
    /// The ladder's rungs left out, and why ([`loud_rungs_left_out`]).
    pub left_out: Option<String>,
    pub warning: Option<super::TuningWarning>,
}

/// The DVL bias walks tried, m/s/sqrt(h): a 1 cm/s error correlated over a minute is about
/// 0.1 (`sigma sqrt(2 / T)`).
const DVL_WALKS: [f64; 3] = [0.03, 0.1, 0.3];

/// The correlation times tried with the chosen walk, s: a DVL's error that follows the
/// bottom's type or the beams' geometry holds for tens of seconds to minutes, and bounded,
/// it tells the heading and the position more than a walk that may wander off.
const DVL_CORRELATIONS_S: [f64; 3] = [30.0, 120.0, 600.0];

/// The DVL bias's drift chosen by the likelihood: a random walk, first-order Gauss-Markov
/// when a correlation time makes the innovations more likely still.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DvlDrift {
    /// Driving noise, m/s/sqrt(h) (0: a constant bias).
    pub walk_m_s_rt_h: f64,
    /// Correlation time, s (0: a random walk).
    pub correlation_s: f64,
    /// Log-likelihood gain of the walk over none.
    pub walk_gain: f64,
    /// Log-likelihood gain of the correlation time over the plain walk.
    pub correlation_gain: f64,
}

/// The walk the fine grades are scored with in the ladder (see [`fine_grades_with_walk`]).
const LADDER_WALK: f64 = DVL_WALKS[1];

/// Whether a grade is fine enough for a DVL bias walk under `auto`: its own unmodelled errors
/// are small next to a DVL's correlated error (a tactical or MEMS IMU's, its misalignment
/// above all, would be soaked up by the walk: honest sigmas, larger errors).
fn fine(grade: ImuGrade) -> bool {
    matches!(grade, ImuGrade::Navigation | ImuGrade::Intermediate)
}

/// Whether the DVL bias's walk is left to the tuning with the IMU graded `best`: no `[dvl]
/// bias_walk_m_s_rt_h` given, and `[tune] dvl_bias_walk` on, or `auto` with a [`fine`] grade.
fn dvl_walk_unset(config: &Config, best: &Candidate) -> bool {
    config
        .tune
        .dvl_bias_walk
        .given()
        .unwrap_or(fine(best.grade))
        && config.dvl.enabled
        && !config.fixed.contains("dvl.bias_walk_m_s_rt_h")
}

/// The fine grades scored with a DVL bias walk, when the walk is the tuning's to choose (an
/// empty list otherwise): a fibre-optic IMU whose DVL's error drifts would otherwise lose
/// the ladder to a noisy model that absorbs that error. Without a settled start each starts
/// from the alignment its grade found in the ladder (`ladder`: the ladder's candidates with
/// their starts): one alignment per grade.
fn fine_grades_with_walk(
    scorer: Scorer<'_>,
    config: &Config,
    ladder: &[(Candidate, Option<&Initialisation>)],
) -> Vec<Scored> {
    let candidates: Vec<(Candidate, Option<&Initialisation>)> = ladder
        .iter()
        .copied()
        .filter(|(c, _)| fine(c.grade) && c.accel_grade == c.grade)
        .collect();
    if !candidates.iter().any(|(c, _)| dvl_walk_unset(config, c)) {
        return Vec::new();
    }
    let walked = with_dvl_walk(config, LADDER_WALK, config.dvl.bias_correlation_s);
    candidates
        .par_iter()
        .map(|&(c, start)| {
            let mut scored = scorer.starting_at(start).scored(&walked, &c);
            scored.label = format!("{}, dvl bias walk {LADDER_WALK}", scored.label);
            scored
        })
        .collect()
}

fn with_dvl_walk(config: &Config, walk: f64, correlation_s: f64) -> Config {
    let mut c = config.clone();
    c.dvl.bias_walk_m_s_rt_h = walk;
    c.dvl.bias_correlation_s = correlation_s;
    c
}

/// The DVL bias's drift that makes the innovations most likely with the IMU model `best`
/// (posterior `best_ll` with the configuration's): the walk of [`DVL_WALKS`] that gains more
/// than [`MIN_GAIN`] over the configuration's, then, with it and when `[tune]
/// dvl_bias_correlation` asks, the correlation time of [`DVL_CORRELATIONS_S`] that gains more
/// than that over the plain walk (unless the configuration gives one). Returns the drift and
/// the posterior with it. `walked` are the fine grades already scored with [`LADDER_WALK`] and
/// the configured correlation, from the start `scorer` has: that pass is not run again.
fn dvl_bias_drift(
    scorer: Scorer<'_>,
    config: &Config,
    (best, best_ll): (&Candidate, f64),
    walked: &[Scored],
) -> (DvlDrift, f64) {
    let prior = bias_prior(best, scorer.white);
    let given_correlation = config.dvl.bias_correlation_s;
    let already = |walk: f64, correlation_s: f64| {
        if walk != LADDER_WALK || correlation_s != given_correlation {
            return None;
        }
        walked
            .iter()
            .find(|s| s.candidate.same_as(best))
            .and_then(|s| s.log_likelihood)
    };
    // The (walk, correlation time) of `tries` most likely, by more than MIN_GAIN over `over`.
    let most_likely = |tries: Vec<(f64, f64)>, over: f64| {
        let scored: Vec<((f64, f64), f64)> = tries
            .par_iter()
            .filter_map(|&(walk, correlation_s)| {
                let ll = already(walk, correlation_s).or_else(|| {
                    let c = with_dvl_walk(config, walk, correlation_s);
                    scorer.score(&c, best).map(|(ll, _)| ll)
                });
                ll.map(|ll| ((walk, correlation_s), ll + prior))
            })
            .collect();
        scored
            .into_iter()
            .filter(|&(_, ll)| ll > over + MIN_GAIN)
            .max_by(|a, b| a.1.total_cmp(&b.1))
    };
    let walks = DVL_WALKS.iter().map(|&w| (w, given_correlation)).collect();
    let Some(((walk, _), walk_ll)) = most_likely(walks, best_ll) else {
        let kept = DvlDrift {
            walk_m_s_rt_h: config.dvl.bias_walk_m_s_rt_h,
            correlation_s: given_correlation,
            walk_gain: 0.0,
            correlation_gain: 0.0,
        };
        return (kept, best_ll);
    };
    let mut drift = DvlDrift {
        walk_m_s_rt_h: walk,
        correlation_s: given_correlation,
        walk_gain: walk_ll - best_ll,
        correlation_gain: 0.0,
    };
    if !config.tune.dvl_bias_correlation || config.fixed.contains("dvl.bias_correlation_s") {
        return (drift, walk_ll);
    }
    let correlations = DVL_CORRELATIONS_S.iter().map(|&t| (walk, t)).collect();
    match most_likely(correlations, walk_ll) {
        Some(((_, correlation_s), ll)) => {
            drift.correlation_s = correlation_s;
            drift.correlation_gain = ll - walk_ll;
            (drift, ll)
        }
        None => (drift, walk_ll),
    }
}

/// Steps the gyro's and the accelerometer's factors of the best model by [`STEP`] either way
/// while the likelihood rises by more than [`MIN_GAIN`], for at most [`MAX_ROUNDS`]; the
/// steps scored join `tried`. Returns whether the search settled (a round gained nothing).
/// (Steps of sqrt(3) after it were tried on `auv-at-sea` seeds 1-10: they moved only the
/// accelerometer, never the gyro's 3.3 times the truth.)
fn climb(
    scorer: Scorer<'_>,
    config: &Config,
    (best, best_ll): (&mut Candidate, &mut f64),
    tried: &mut Vec<Scored>,
) -> bool {
    for _ in 0..MAX_ROUNDS {
        let steps: Vec<Candidate> = [
            best.scaled(STEP, 1.0),
            best.scaled(1.0 / STEP, 1.0),
            best.scaled(1.0, STEP),
            best.scaled(1.0, 1.0 / STEP),
            best.white_scaled(STEP),
            best.white_scaled(1.0 / STEP),
        ]
        .into_iter()
        .filter(|c| !tried.iter().any(|t| t.candidate.same_as(c)))
        .collect();
        let round: Vec<Scored> = scorer
            .score_all(config, &steps)
            .into_iter()
            .map(|(scored, _)| scored)
            .collect();
        let next = best_of(&round);
        tried.extend(round);
        match next {
            Some((c, ll)) if ll > *best_ll + MIN_GAIN => {
                *best = c;
                *best_ll = ll;
            }
            _ => return true,
        }
    }
    false
}

/// The grades first tried, quietest first.
fn ladder() -> Vec<Candidate> {
    GRADES.iter().map(|&g| Candidate::of(g, 1.0)).collect()
}

/// The ladder's rungs noisier than MEMS, scored after the grades unless
/// [`loud_rungs_left_out`] says why not.
///
/// Their gyro's white noise is held at the IMU's own high-frequency content when the grade's
/// would exceed it: a gyro biased by 100 or 1000 deg/h need not be as noisy as a grade 10 or
/// 100 times a MEMS's (`pool-mems-host`: 1000 deg/h, 1.8 deg/sqrt(h)); the refinements raise
/// it again where the likelihood asks (the real pool runs).
fn loud_rungs(white: Option<&ImuWhite>) -> Vec<Candidate> {
    [10.0, 100.0]
        .map(|f| {
            let c = Candidate::of(ImuGrade::Mems, f);
            let grade_white = c.spec().gyro_arw_deg_rt_h;
            match white {
                Some(w) if w.gyro_arw_deg_rt_h < 0.9 * grade_white => {
                    c.white_scaled(w.gyro_arw_deg_rt_h / grade_white)
                }
                _ => c,
            }
        })
        .to_vec()
}

/// The ladder's second stage: the gyros finer than the best grade's, each with the best
/// grade's accelerometer, with its own white noise and with the best grade's. A grade pairs
/// a gyro with an accelerometer, and a bias with a white noise, and an IMU need not: a
/// fibre-optic gyro beside a tactical accelerometer loses the first stage to the tactical
/// grade, whose accelerometer the data want, and whose gyro then lets the heading wander; a
/// gyro whose bias is a navigation grade's may be as noisy as an intermediate one
/// (`auv-at-sea-straight` seed 1: 0.01 deg/h with 0.0125 deg/sqrt(h) chosen, where the truth
/// is 0.01 with 0.005; the navigation grade's 0.002 scores 5 below it).
fn finer_gyros(best: &Candidate) -> Vec<Candidate> {
    let best_white = best.spec().gyro_arw_deg_rt_h;
    GRADES
        .iter()
        .take_while(|&&g| g != best.grade)
        .flat_map(|&g| {
            let finer = Candidate {
                grade: g,
                accel_grade: best.grade,
                ..Candidate::of(g, 1.0)
            };
            let own_white = finer.spec().gyro_arw_deg_rt_h;
            [finer, finer.white_scaled(best_white / own_white)]
        })
        .collect()
}

/// How far below the best grade the MEMS rung's posterior must fall (nats) for the noisier
/// rungs to be left out. On the noisy side of the likelihood's peak a model only loosens
/// further. On 38 simulated logs (pool, survey, trench, dive, at-sea and the 5.5 h
/// missions) where MEMS fell below the best grade, the noisier rungs rose past it by at most
/// 42 % of its deficit, and where it fell by more than this margin they stayed at least
/// 2067 nats below the best.
const LOUD_RUNGS_MARGIN: f64 = 500.0;

/// Why the rungs noisier than MEMS are not scored, given the grades' scores (quietest first,
/// MEMS last), or `None` when they are. They are left out when the MEMS rung could not run
/// (its bank of start headings could not decide: a noisier model decides less) or scored more
/// than [`LOUD_RUNGS_MARGIN`] below the best grade, while some grade did score: they cost as
/// much as the grades, and on a fine IMU they are the tuning's most expensive passes for
/// nothing.
fn loud_rungs_left_out(grades: &[Scored], white: Option<&ImuWhite>) -> Option<String> {
    if white.is_some_and(may_be_louder_than_mems) {
        return None;
    }
    let (best, best_posterior) = best_of(grades)?;
    let mems = grades
        .iter()
        .find(|s| s.candidate.same_as(&Candidate::of(ImuGrade::Mems, 1.0)))?;
    let posterior = mems.log_likelihood.map(|l| l + mems.log_prior);
    let why = match posterior {
        None => "mems could not run over the span".to_string(),
        Some(p) if p < best_posterior - LOUD_RUNGS_MARGIN => format!(
            "mems scored {:.0} below {} (more than {LOUD_RUNGS_MARGIN:.0})",
            best_posterior - p,
            best.label()
        ),
        Some(_) => return None,
    };
    Some(format!("mems x10 and x100 not scored: {why}"))
}

/// Whether the IMU's own white noise (measured, or its upper bound while moving) leaves room
/// for an IMU noisier than the MEMS grade: then the noisier rungs are scored whatever the
/// grades scored (a model far too tight rejects most readings, and its score says little).
fn may_be_louder_than_mems(white: &ImuWhite) -> bool {
    let mems = ImuGrade::Mems.spec();
    white.gyro_arw_deg_rt_h >= mems.gyro_arw_deg_rt_h
        || white.accel_vrw_ug_rt_hz >= mems.accel_vrw_ug_rt_hz
}

/// The configuration with a candidate's figures, every one given.
pub fn with_candidate(config: &Config, c: &Candidate, white: Option<&ImuWhite>) -> Config {
    let s = c.spec_with(white);
    Config {
        imu: ImuConfig {
            grade: c.grade,
            gyro_bias_deg_h: Some(s.gyro_bias_deg_h),
            gyro_bias_instability_deg_h: Some(s.gyro_bias_instability_deg_h),
            gyro_arw_deg_rt_h: Some(s.gyro_arw_deg_rt_h),
            accel_bias_ug: Some(s.accel_bias_ug),
            accel_bias_instability_ug: Some(s.accel_bias_instability_ug),
            accel_vrw_ug_rt_hz: Some(s.accel_vrw_ug_rt_hz),
            bias_correlation_s: Some(s.bias_correlation_s),
            gyro_scale_ppm: config.imu.gyro_scale_ppm,
            estimate_biases: config.imu.estimate_biases,
        },
        ..config.clone()
    }
}

/// Where the score of a pass whose start heading the in-motion alignment found starts:
/// `settle_s` into the span, at most a third of it. That heading was found from the span's
/// own first minutes (with a floor of a few degrees on its sigma), so the innovations there
/// re-fit it rather than tell the IMU's noise, which would otherwise be inflated to absorb
/// them. A heading from another source (a magnetometer, a gyrocompass at rest, GNSS) is
/// independent of them, and the span is scored whole: on a MEMS IMU the first minutes are
/// where its gyro shows most.
fn scored_from_ns(streams: &Streams<'_>, tune: &crate::recon::config::TuneConfig) -> i64 {
    let (Some(first), Some(last)) = (streams.imu.first(), streams.imu.last()) else {
        return i64::MIN;
    };
    let span_s = (last.stamp_ns - first.stamp_ns) as f64 * 1e-9;
    first.stamp_ns + (tune.settle_s.min(span_s / 3.0) * 1e9) as i64
}

/// What every candidate is scored against: the log, its mission, the IMU's measured white
/// noise, and the prepared start and magnetometer.
#[derive(Clone, Copy)]
struct Scorer<'s> {
    streams: &'s Streams<'s>,
    mission: &'s Mission,
    white: Option<&'s ImuWhite>,
    from: Prepared<'s>,
}

impl Scorer<'_> {
    /// The log-likelihood of one model over the span, with the start its pass took; `None` when
    /// the pass fails. Every candidate starts from the settled heading when there is one; else
    /// the in-motion alignment is skipped while the log has a heading source (every candidate
    /// then starts from the same heading), and used only when it has none.
    fn score(&self, config: &Config, c: &Candidate) -> Option<(f64, Initialisation)> {
        let Scorer {
            streams,
            mission,
            white,
            from,
        } = *self;
        let mut cfg = with_candidate(config, c, white);
        cfg.alignment.enabled = false;
        let pass = |cfg: &Config| forward_pass(streams, mission, cfg, from.scored());
        let pass = match pass(&cfg) {
            Err(ReconError::Init(InitError::NoHeading(_))) if config.alignment.enabled => {
                cfg.alignment.enabled = true;
                pass(&cfg)
            }
            other => other,
        };
        // A magnetometer whose deviation is unknown (its hard iron could not be calibrated) has
        // errors no model here describes: its innovations would be blamed on the gyro. It still
        // aids the passes; it is not scored.
        let mag_scored = !from.mag.is_some_and(|m| m.deviation_unknown);
        pass.ok()
            .map(|p| {
                // A start heading from such a magnetometer is no better than one found in
                // motion: its first minutes re-fit it too.
                let refit = match p.init.heading {
                    HeadingSource::InMotion => true,
                    HeadingSource::Magnetometer => !mag_scored,
                    _ => false,
                };
                let from_ns = if refit {
                    scored_from_ns(streams, &config.tune)
                } else {
                    i64::MIN
                };
                let counted = |s: Sensor| s != Sensor::Magnetometer || mag_scored;
                (p.run.log_likelihood_of(from_ns, counted), p.init)
            })
            .filter(|(l, _)| l.is_finite())
    }

    /// The scorer with `start` as its start when it has none settled (a start found for the
    /// same grade).
    fn starting_at<'t>(&self, start: Option<&'t Initialisation>) -> Scorer<'t>
    where
        Self: 't,
    {
        Scorer {
            from: Prepared {
                start: self.from.start.or(start),
                ..self.from
            },
            ..*self
        }
    }

    /// One candidate scored, with the start its pass took.
    fn scored_with_start(
        &self,
        config: &Config,
        c: &Candidate,
    ) -> (Scored, Option<Initialisation>) {
        let (log_likelihood, start) = self
            .score(config, c)
            .map_or((None, None), |(l, i)| (Some(l), Some(i)));
        let scored = Scored {
            label: c.label(),
            candidate: *c,
            log_likelihood,
            log_prior: bias_prior(c, self.white),
        };
        (scored, start)
    }

    /// One candidate scored.
    fn scored(&self, config: &Config, c: &Candidate) -> Scored {
        self.scored_with_start(config, c).0
    }

    /// Scores the candidates in parallel; each with the start its pass took.
    fn score_all(
        &self,
        config: &Config,
        candidates: &[Candidate],
    ) -> Vec<(Scored, Option<Initialisation>)> {
        candidates
            .par_iter()
            .map(|c| self.scored_with_start(config, c))
            .collect()
    }
}

/// The candidate of highest posterior (likelihood times prior) and its log.
fn best_of(scored: &[Scored]) -> Option<(Candidate, f64)> {
    scored
        .iter()
        .filter_map(|s| s.log_likelihood.map(|l| (s.candidate, l + s.log_prior)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Width of the bias prior: one decade, 1-sigma, in log scale.
const PRIOR_DECADES: f64 = 1.0;

/// The grades, in order of noise.
const GRADES: [ImuGrade; 4] = [
    ImuGrade::Navigation,
    ImuGrade::Intermediate,
    ImuGrade::Tactical,
    ImuGrade::Mems,
];

/// The bias the grades pair with a white noise: interpolated between them in log scale
/// (extended past the ends along the nearest two).
fn paired_bias(pairs: &[[f64; 2]], white: f64) -> f64 {
    let i = pairs
        .windows(2)
        .position(|w| white <= w[1][0])
        .unwrap_or(pairs.len() - 2);
    let ([x0, y0], [x1, y1]) = (pairs[i], pairs[i + 1]);
    let t = (white / x0).ln() / (x1 / x0).ln();
    (y0.ln() + t * (y1 / y0).ln()).exp()
}

/// The log prior of a candidate's gyro and accelerometer biases given the white noise the
/// IMU's own data showed: log-normal about the biases the grades pair with that noise.
pub fn bias_prior(c: &Candidate, white: Option<&ImuWhite>) -> f64 {
    let Some(w) = white else {
        return 0.0;
    };
    // The grades' (white noise, bias) pairs: gyro (deg/sqrt(h), deg/h), accelerometer
    // (ug/sqrt(Hz), ug).
    let gyro = GRADES.map(|g| [g.spec().gyro_arw_deg_rt_h, g.spec().gyro_bias_deg_h]);
    let accel = GRADES.map(|g| [g.spec().accel_vrw_ug_rt_hz, g.spec().accel_bias_ug]);
    let s = c.spec();
    // A white noise measured while moving bounds the sensor's from above only: biases above
    // the paired one are penalised, those below are not.
    let one_sided = !w.is_measured();
    let term = |bias: f64, paired: f64| {
        let decades = (bias / paired).log10() / PRIOR_DECADES;
        if one_sided && decades < 0.0 {
            return 0.0;
        }
        -0.5 * decades * decades
    };
    term(s.gyro_bias_deg_h, paired_bias(&gyro, w.gyro_arw_deg_rt_h))
        + term(s.accel_bias_ug, paired_bias(&accel, w.accel_vrw_ug_rt_hz))
}

/// The most likely IMU noise model for the streams (already cut to the tuning span).
///
/// With `white` measured on a still stretch, every model takes its angle and velocity random
/// walks from it and the search finds the biases alone; measured while moving, it is an
/// upper bound: each model keeps its grade's, refined apart from the biases.
/// When the refinement has not settled after [`MAX_ROUNDS`], the best model scored is still
/// the answer (with a warning): it is the most likely of all tried.
pub fn search(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    white: Option<&ImuWhite>,
    from: Prepared<'_>,
) -> Search {
    let scorer = Scorer {
        streams,
        mission,
        white,
        from,
    };
    let (mut tried, mut starts): (Vec<Scored>, Vec<Option<Initialisation>>) =
        scorer.score_all(config, &ladder()).into_iter().unzip();
    let loud_left_out = loud_rungs_left_out(&tried, white);
    if loud_left_out.is_none() {
        let (loud, loud_starts): (Vec<Scored>, Vec<Option<Initialisation>>) = scorer
            .score_all(config, &loud_rungs(white))
            .into_iter()
            .unzip();
        tried.extend(loud);
        starts.extend(loud_starts);
    }
    if let Some((first, _)) = best_of(&tried) {
        let (finer, finer_starts): (Vec<Scored>, Vec<Option<Initialisation>>) = scorer
            .score_all(config, &finer_gyros(&first))
            .into_iter()
            .unzip();
        tried.extend(finer);
        starts.extend(finer_starts);
    }
    let Some((mut best, mut best_ll)) = best_of(&tried) else {
        return Search {
            best: None,
            tried,
            dvl_bias_walk: None,
            left_out: loud_left_out,
            warning: Some(super::TuningWarning::NoNoiseModelRan),
        };
    };
    // The fine grades with a walk start where their grade's ladder pass started.
    // The better of them, when it beats the ladder's best, becomes the best, with its
    // posterior without the walk (the walk's own search below then takes it up).
    let ladder_starts: Vec<(Candidate, Option<&Initialisation>)> = tried
        .iter()
        .zip(&starts)
        .map(|(t, s)| (t.candidate, s.as_ref()))
        .collect();
    let with_walk = fine_grades_with_walk(scorer, config, &ladder_starts);
    if let Some((c, ll)) = best_of(&with_walk).filter(|&(_, ll)| ll > best_ll + MIN_GAIN) {
        let without_walk = tried
            .iter()
            .find(|t| t.candidate.same_as(&c))
            .and_then(|t| t.log_likelihood.map(|l| l + t.log_prior));
        best = c;
        best_ll = without_walk.unwrap_or(ll);
    }
    tried.extend(with_walk.iter().cloned());
    // Without a settled start each grade aligned itself: the refinements, near the best
    // grade, start from the start the best grade found (one alignment per grade, not per
    // candidate).
    let best_start = ladder_starts
        .iter()
        .find(|(c, _)| c.same_as(&best))
        .and_then(|(_, s)| *s);
    let scorer = scorer.starting_at(best_start);
    // The DVL's error correlated in time is modelled before the refinements, so that they
    // do not blame it on the IMU.
    let dvl_bias_walk = dvl_walk_unset(config, &best).then(|| {
        let (drift, ll) = dvl_bias_drift(scorer, config, (&best, best_ll), &with_walk);
        best_ll = ll;
        drift
    });
    let walked = dvl_bias_walk
        .filter(|d| d.walk_m_s_rt_h > 0.0)
        .map(|d| with_dvl_walk(config, d.walk_m_s_rt_h, d.correlation_s));
    let config = walked.as_ref().unwrap_or(config);
    let settled = climb(scorer, config, (&mut best, &mut best_ll), &mut tried);
    let warning = (!settled).then(|| super::TuningWarning::NoiseStillRising {
        rounds: MAX_ROUNDS,
        model: best.label(),
    });
    Search {
        best: Some(best),
        dvl_bias_walk,
        tried,
        left_out: loud_left_out,
        warning,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::Imu;

    fn imu_over(span_s: i64) -> Vec<Imu> {
        (0..=span_s)
            .map(|k| Imu {
                stamp_ns: 5_000_000_000 + k * 1_000_000_000,
                angular_velocity: [0.0; 3],
                specific_force: [0.0, 0.0, -9.8],
            })
            .collect()
    }

    #[test]
    fn the_score_starts_after_the_settle_span_and_at_most_a_third_in() {
        let tune = crate::recon::config::TuneConfig::default();
        assert_eq!(tune.settle_s, 300.0);
        let long = imu_over(1800);
        let streams = Streams {
            imu: &long,
            ..Streams::default()
        };
        assert_eq!(
            scored_from_ns(&streams, &tune),
            5_000_000_000 + 300_000_000_000
        );
        // A 6-minute log: a third of it (120 s), not 300 s.
        let short = imu_over(360);
        let streams = Streams {
            imu: &short,
            ..Streams::default()
        };
        assert_eq!(
            scored_from_ns(&streams, &tune),
            5_000_000_000 + 120_000_000_000
        );
        assert_eq!(scored_from_ns(&Streams::default(), &tune), i64::MIN);
    }

    fn grades_scored(posteriors: [Option<f64>; 4]) -> Vec<Scored> {
        GRADES
            .iter()
            .zip(posteriors)
            .map(|(&g, p)| {
                let candidate = Candidate::of(g, 1.0);
                Scored {
                    label: candidate.label(),
                    candidate,
                    log_likelihood: p.map(|p| p + 1.0),
                    log_prior: -1.0,
                }
            })
            .collect()
    }

    #[test]
    fn the_noisier_rungs_are_left_out_only_when_mems_falls_far_below_or_cannot_run() {
        let near = grades_scored([Some(-700.0), Some(-720.0), Some(-790.0), Some(-1199.0)]);
        assert_eq!(loud_rungs_left_out(&near, None), None);
        // The pool's MEMS IMUs: the likelihood climbs through MEMS.
        let rising = grades_scored([Some(4316.0), Some(3701.0), Some(3066.0), Some(17101.0)]);
        assert_eq!(loud_rungs_left_out(&rising, None), None);
        let far = grades_scored([Some(-704.4), Some(-719.9), Some(-787.9), Some(-3143.4)]);
        assert_eq!(
            loud_rungs_left_out(&far, None).as_deref(),
            Some("mems x10 and x100 not scored: mems scored 2439 below navigation (more than 500)")
        );
        let failed = grades_scored([Some(72068.8), Some(72091.9), Some(57317.5), None]);
        assert_eq!(
            loud_rungs_left_out(&failed, None).as_deref(),
            Some("mems x10 and x100 not scored: mems could not run over the span")
        );
        // An IMU whose own high-frequency content is as loud as a MEMS's: scored anyway.
        let loud = ImuWhite {
            gyro_arw_deg_rt_h: 30.0,
            accel_vrw_ug_rt_hz: 10_000.0,
            from: super::super::WhiteFrom::Moving,
        };
        assert_eq!(loud_rungs_left_out(&far, Some(&loud)), None);
        let quiet = ImuWhite {
            gyro_arw_deg_rt_h: 0.13,
            accel_vrw_ug_rt_hz: 90.0,
            ..loud
        };
        assert!(loud_rungs_left_out(&far, Some(&quiet)).is_some());
        // No grade scored: every rung is tried.
        assert_eq!(loud_rungs_left_out(&grades_scored([None; 4]), None), None);
    }

    #[test]
    fn candidates_scale_their_grade() {
        let c = Candidate::of(ImuGrade::Mems, 100.0).scaled(1.0, 1.0 / 3.0);
        let s = c.spec();
        let m = ImuGrade::Mems.spec();
        assert!((s.gyro_arw_deg_rt_h / m.gyro_arw_deg_rt_h - 100.0).abs() < 1e-9);
        assert!((s.accel_vrw_ug_rt_hz / m.accel_vrw_ug_rt_hz - 100.0 / 3.0).abs() < 1e-9);
        assert_eq!(c.label(), "mems, gyro x100, accel x33");
        assert_eq!(Candidate::of(ImuGrade::Tactical, 1.0).label(), "tactical");
        let cfg = with_candidate(&Config::default(), &c, None);
        assert_eq!(cfg.imu.spec(), s);
    }
}
