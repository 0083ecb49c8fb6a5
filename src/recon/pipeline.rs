//! The reconstruction workflow, in one place: inspect the log, decide the plan, prepare the
//! magnetometer, settle the start heading, tune, check the heading with the tuned figures
//! (and tune again from it when it moved), run the forward pass with every aid of the plan,
//! look for a DVL clock offset when its innovations say so, smooth.
//!
//! [`run`] does it all. A caller that must free the log before the smoother (a day-long
//! mission's log and its records would not fit together) calls [`forward`], then
//! [`Forward::smooth`]. The CLI's `reconstruct` and `batch`, `study` and the library's
//! [`super::reconstruct`] all go through here.

use super::alignment::heading::HeadingSource;
use super::alignment::start::Initialisation;
use super::clock::{self, OffsetSuggestion};
use super::config::Config;
use super::magnetometer::{self, PreparedMag};
use super::plan::{LogFacts, Part, Plan};
use super::stats::{self, SensorStats};
use super::tune::{self, Tuning};
use super::{
    finish, forward_pass, settled_start, settled_start_from_sources, AttitudeTrack, ForwardPass,
    MagInput, PassOptions, Prepared, ReconError, Reconstruction, Streams,
};
use crate::angle::wrap_pi;
use crate::contract::{Dvl, MagneticField};
use crate::filters::ins::aid_table::Sensor;
use crate::filters::ins::driver::Keep;
use crate::ingest::Mission;
use crate::progress::Progress;
use serde::Serialize;
use std::fmt;
use std::time::{Duration, Instant};

/// A stage of the pipeline, told to [`Options::on_stage`] as it starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Plan,
    Magnetometer,
    Align,
    Tune,
    CheckAlignment,
    Retune,
    AcousticDelay,
    Forward,
    ClockSearch,
    Smooth,
}

impl Stage {
    pub fn describe(self) -> &'static str {
        match self {
            Stage::Plan => "deciding the plan from the log",
            Stage::Magnetometer => "preparing the magnetometer",
            Stage::Align => "settling the start heading",
            Stage::Tune => "self-tuning the noise figures",
            Stage::CheckAlignment => "checking the start heading with the tuned figures",
            Stage::Retune => "self-tuning again from the corrected heading",
            Stage::AcousticDelay => {
                "finding the acoustic fixes' receipt delay (a forward pass without them)"
            }
            Stage::Forward => "forward filter",
            Stage::ClockSearch => {
                "the DVL's innovations are too large: searching for a clock offset"
            }
            Stage::Smooth => "smoother",
        }
    }
}

/// How the pipeline reports and what it is handed beyond the log.
pub(crate) struct Options<'a> {
    /// Told how far the forward pass has come.
    pub forward_progress: Progress<'a>,
    /// Told as each stage starts.
    pub on_stage: Option<&'a dyn Fn(Stage)>,
    /// The magnetometer's readings moved out of the log (a day's would be held twice),
    /// used instead of `streams.mag`.
    pub mag: Option<Vec<MagneticField>>,
    /// The attitude the model aid is driven by, from a run of the same log (a study's
    /// solutions share it).
    pub shared_attitude: Option<AttitudeTrack>,
}

/// What a user should know of the run, with its data; rendered by [`fmt::Display`] and,
/// with the command's own hints, by the CLI.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Warning {
    /// A part the configuration switched on cannot run on this log.
    ForcedOnRefused {
        part: &'static str,
        #[serde(flatten)]
        why: super::plan::Why,
    },
    /// An aid refused itself when it ran.
    AidRefused { sensor: Sensor, why: String },
    /// An aid left some of its readings out, and used the others.
    AidLeftOut { sensor: Sensor, why: String },
    /// The checked start heading moved from the one tuning started from: tuned again.
    Retuned {
        tuned_from_deg: f64,
        checked_deg: f64,
    },
    /// The DVL's innovations are too large; a clock offset fits better (or none does).
    DvlClock {
        mean_nis: f64,
        suggestion: Option<OffsetSuggestion>,
    },
    /// From self-tuning.
    Tuning(tune::TuningWarning),
    /// From the forward pass's statistics and the initialisation.
    Run(stats::RunWarning),
    /// Magnetometer readings with an axis stuck at its extreme, left out.
    MagSaturated {
        from_ns: i64,
        to_ns: i64,
        readings: usize,
    },
    /// The magnetometer could not be calibrated (`why`) and its field magnitude varies over
    /// the headings flown: its heading updates are taken as correlated over `correlation_s`.
    MagNotCalibrated {
        why: String,
        magnitude_variation: f64,
        correlation_s: f64,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::ForcedOnRefused { part, why } => {
                write!(f, "{part}: switched on, but not used: {why}")
            }
            Warning::AidRefused { sensor, why } => write!(f, "{sensor}: not used: {why}"),
            Warning::AidLeftOut { sensor, why } => write!(f, "{sensor}: {why}"),
            Warning::Retuned {
                tuned_from_deg,
                checked_deg,
            } => write!(
                f,
                "self-tuning started from a heading of {tuned_from_deg:.1} deg, which the \
                 alignment with the tuned figures moved to {checked_deg:.1} deg: tuned again \
                 from there"
            ),
            Warning::DvlClock {
                mean_nis,
                suggestion: Some(s),
            } => write!(
                f,
                "dvl: mean NIS {mean_nis:.1}; its innovations are smallest with its stamps moved \
                 by {:.1} s (mean NIS {:.1} against {:.1} without, first 10 min): its clock may \
                 be off by that much",
                s.offset_s, s.mean_nis, s.mean_nis_unshifted
            ),
            Warning::DvlClock {
                mean_nis,
                suggestion: None,
            } => write!(
                f,
                "dvl: mean NIS {mean_nis:.1}, and no clock offset within +-{:.0} s fits clearly \
                 better: the DVL's clock is not the cause",
                clock::COARSE_SPAN_S
            ),
            Warning::Run(w) => write!(f, "{w}"),
            Warning::Tuning(w) => write!(f, "{w}"),
            Warning::MagSaturated {
                from_ns,
                to_ns,
                readings,
            } => write!(
                f,
                "mag: saturated from {} to {} ({readings} readings: an axis stuck at its \
                 extreme), left out",
                crate::time::format_utc(*from_ns),
                crate::time::format_utc(*to_ns),
            ),
            Warning::MagNotCalibrated {
                why,
                magnitude_variation,
                correlation_s,
            } => write!(
                f,
                "mag: not calibrated ({why}), and the field magnitude varies by {:.1} % over \
                 the headings flown: the heading carries a deviation of a few degrees that \
                 changes with the heading, so its updates are taken as correlated over \
                 {correlation_s:.0} s (a full circle in the dive would let it be calibrated)",
                magnitude_variation * 100.0
            ),
        }
    }
}

/// Wall time of each stage.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct StageTimes {
    pub plan_s: f64,
    pub magnetometer_s: f64,
    pub align_s: f64,
    pub tune_s: f64,
    pub forward_s: f64,
    pub clock_search_s: f64,
    pub smoother_s: f64,
}

/// The pipeline up to the forward pass: what [`Forward::smooth`] finishes.
#[derive(Debug)]
pub struct Forward {
    pub facts: LogFacts,
    pub plan: Plan,
    /// The configuration the final pass ran with (the plan's switches, the tuned figures).
    pub config: Config,
    pub tuning: Option<Tuning>,
    pub pass: ForwardPass,
    /// Innovation statistics of the final pass, per sensor.
    pub sensors: Vec<SensorStats>,
    pub warnings: Vec<Warning>,
    pub times: StageTimes,
}

/// A whole reconstruction and how it was made.
#[derive(Debug)]
pub(crate) struct Outcome {
    pub plan: Plan,
    pub config: Config,
    pub tuning: Option<Tuning>,
    pub reconstruction: Reconstruction,
    /// The attitude the model aid was driven by, to share with a run of the same log.
    pub model_attitude: Option<AttitudeTrack>,
    pub sensors: Vec<SensorStats>,
    pub warnings: Vec<Warning>,
    pub times: StageTimes,
}

/// A timer of stages that tells the caller as each starts.
struct Stages<'a> {
    on_stage: Option<&'a dyn Fn(Stage)>,
    at: Instant,
}

impl Stages<'_> {
    /// Tells the stage's start; returns the seconds since the last call.
    fn start(&mut self, stage: Stage) -> f64 {
        if let Some(tell) = self.on_stage {
            tell(stage);
        }
        self.lap()
    }

    fn lap(&mut self) -> f64 {
        let s = self.at.elapsed().as_secs_f64();
        self.at = Instant::now();
        s
    }
}

/// The pipeline up to and including the forward pass.
pub(crate) fn forward(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    options: Options<'_>,
) -> Result<Forward, ReconError> {
    let mut stages = Stages {
        on_stage: options.on_stage,
        at: Instant::now(),
    };
    let mut times = StageTimes::default();
    stages.start(Stage::Plan);
    let with_mag = Streams {
        mag: options.mag.as_deref().unwrap_or(streams.mag),
        ..*streams
    };
    let facts = LogFacts::of(&with_mag, mission, config);
    let mut plan = Plan::decide(&facts, config);
    let planned = plan.apply(config);
    let shifted_dvl = delayed_dvl(streams.dvl, planned.dvl.stamp_delay_s);
    let streams = &Streams {
        dvl: shifted_dvl.as_deref().unwrap_or(streams.dvl),
        ..*streams
    };
    let mut warnings: Vec<Warning> = plan
        .overruled()
        .map(|d| Warning::ForcedOnRefused {
            part: d.name,
            why: d.why.clone(),
        })
        .collect();
    times.plan_s = stages.start(Stage::Magnetometer);
    let mag = prepare_mag(streams, &planned, options.mag);
    times.magnetometer_s = stages.start(Stage::Align);
    let ready = (streams, mission, &mag);
    let settled = settle_and_place_fixes(ready, &planned, &mut plan, &mut stages, &mut times)?;
    warnings.extend(settled.warnings);
    let Settled {
        config,
        mut tuning,
        start,
        ..
    } = settled;
    if let Some(t) = tuning.as_mut() {
        add_plan_figures(t, &plan, &config, planned.dvl.stamp_delay_s);
    }
    times.align_s += stages.start(Stage::Forward);
    let pass = forward_pass(
        streams,
        mission,
        &config,
        PassOptions {
            shared_attitude: options.shared_attitude,
            progress: options.forward_progress,
            mag: MagInput::Owned(Box::new(mag)),
            start: Some(&start),
            keep: Keep::Records,
        },
    )?;
    times.forward_s = stages.lap();
    for note in pass.aid_notes.iter().filter(|n| n.refused) {
        plan.refuse(Part::Aid(note.sensor), note.to_string());
    }
    let sensors = stats::sensor_stats(&pass.run.residuals);
    warnings.extend(pass_warnings(&pass, &sensors, &config, tuning.as_ref()));
    if let Some(dvl) = sensors
        .iter()
        .find(|s| s.sensor == Sensor::Dvl && stats::innovations_too_large(s))
    {
        stages.start(Stage::ClockSearch);
        let streams = Streams {
            mag: &pass.mag.readings,
            ..*streams
        };
        let from = Prepared {
            start: Some(&start),
            mag: Some(&pass.mag),
        };
        warnings.push(Warning::DvlClock {
            mean_nis: dvl.mean_nis,
            suggestion: clock::suggest_dvl_offset(&streams, mission, &config, from),
        });
        times.clock_search_s = stages.lap();
    }
    Ok(Forward {
        facts,
        plan,
        config,
        tuning,
        pass,
        sensors,
        warnings,
        times,
    })
}

impl Forward {
    /// Smooths the forward pass (its records are turned into solutions and freed).
    pub(crate) fn smooth(
        self,
        progress: Progress<'_>,
        on_stage: Option<&dyn Fn(Stage)>,
    ) -> Result<Outcome, ReconError> {
        if let Some(tell) = on_stage {
            tell(Stage::Smooth);
        }
        let started = Instant::now();
        let depth_used = self.plan.uses(Part::Aid(Sensor::Depth));
        let model_attitude = self.pass.model_attitude.clone();
        let reconstruction = finish(self.pass, &self.config, depth_used, progress)?;
        let mut times = self.times;
        times.smoother_s = started.elapsed().as_secs_f64();
        Ok(Outcome {
            plan: self.plan,
            config: self.config,
            tuning: self.tuning,
            reconstruction,
            model_attitude,
            sensors: self.sensors,
            warnings: self.warnings,
            times,
        })
    }

    /// Seconds the forward pass took.
    pub fn forward_time(&self) -> Duration {
        self.pass.time
    }
}

/// [`settle_and_tune`], then the acoustic fixes' receipt delay when it is to be estimated
/// (into the plan and the configuration). Fixes whose time of validity is still to be found
/// would mislead the alignment and the tuning: those run without them.
fn settle_and_place_fixes(
    (streams, mission, mag): (&Streams<'_>, &Mission, &PreparedMag),
    planned: &Config,
    plan: &mut Plan,
    stages: &mut Stages<'_>,
    times: &mut StageTimes,
) -> Result<Settled, ReconError> {
    let delay_unknown = plan.acoustic_delay_to_estimate();
    let settling = if delay_unknown {
        let without_fixes = Sensor::AcousticFix.left_out_of(*streams);
        Sensor::Usbl.left_out_of(without_fixes)
    } else {
        *streams
    };
    let mut settled = settle_and_tune(&settling, mission, planned, mag, stages, times)?;
    if delay_unknown {
        times.align_s += stages.start(Stage::AcousticDelay);
        let estimate = acoustic_delay(
            &settling,
            streams,
            mission,
            &settled.config,
            &settled.start,
            mag,
        )?;
        plan.estimated_acoustic_delay(estimate.as_ref());
    }
    settled.config.acoustic_fix.receipt_delay_s = plan.acoustic_delay_s();
    settled.config.acoustic_delay_placed = true;
    Ok(settled)
}

/// The receipt delay of the acoustic fixes that carry none: their positions against the
/// track of a forward pass without them (`None`: no such track).
fn acoustic_delay(
    without_fixes: &Streams<'_>,
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    start: &Initialisation,
    mag: &PreparedMag,
) -> Result<Option<super::acoustic_delay::ReceiptDelay>, ReconError> {
    let mut unaided = config.clone();
    unaided.model_velocity.enabled = super::on_off_auto::Switch::Off;
    // Dead reckoning alone: an absolute position's update would jump the track, which no
    // window's drift takes up.
    let smooth = [Sensor::Gnss, Sensor::PositionFix]
        .into_iter()
        .fold(*without_fixes, |kept, s| s.left_out_of(kept));
    let pass = forward_pass(
        &smooth,
        mission,
        &unaided,
        PassOptions {
            mag: MagInput::Shared(mag),
            start: Some(start),
            keep: Keep::Navigation,
            ..PassOptions::default()
        },
    )?;
    let (fixes, usbl) = (
        config.acoustic_fix.aid(),
        config.usbl.aid(&config.acoustic_fix, true),
    );
    let readings = super::acoustic_delay::Delayed {
        fixes: fixes.as_ref().map(|a| (streams.acoustic_fixes, a)),
        usbl: usbl.as_ref().map(|a| (streams.usbl, a)),
        ship: streams.ship,
        lever_arm_body_m: config.acoustic_fix.lever_arm_m,
    };
    let Some(first) = super::acoustic_delay::estimate(&readings, &pass.run.navigation) else {
        return Ok(None);
    };
    if !first.is_clear() {
        return Ok(Some(first));
    }
    let from = Prepared {
        start: Some(start),
        mag: Some(mag),
    };
    let log_likelihood = |delay_s: f64| {
        let mut trial = unaided.clone();
        trial.acoustic_fix.receipt_delay_s = delay_s;
        trial.acoustic_delay_placed = true;
        forward_pass(streams, mission, &trial, from.scored()).map_or(f64::NEG_INFINITY, |p| {
            p.run.log_likelihood_of(i64::MIN, |s| {
                matches!(s, Sensor::AcousticFix | Sensor::Usbl)
            })
        })
    };
    Ok(Some(super::acoustic_delay::refine(&first, &log_likelihood)))
}

/// What the plan estimated from the log, given back with the tuned figures: a DVL stamp
/// delay the plan took out (tuned.toml then corrects the stamps the same way on a rerun), and
/// the DVL lever arm used.
fn add_plan_figures(tuning: &mut Tuning, plan: &Plan, config: &Config, stamp_delay_s: f64) {
    if plan.uses(Part::DvlStampDelay) && !config.fixed.contains("dvl.stamp_delay_s") {
        tuning.sensors.push(super::tune::SensorNoise {
            key: "dvl.stamp_delay_s",
            value: stamp_delay_s,
            source: super::tune::Source::Estimated,
            differences: None,
        });
    }
    tuning.dvl_lever_arm_m = plan.dvl_lever_arm_m();
    let estimated = plan.decisions.iter().any(|d| {
        d.part == Part::AcousticFixDelay
            && d.used
            && matches!(d.why, super::plan::Why::EstimatedReceiptDelay { .. })
    });
    if estimated {
        tuning.sensors.push(super::tune::SensorNoise {
            key: super::plan::ACOUSTIC_DELAY_KEY,
            value: config.acoustic_fix.receipt_delay_s,
            source: super::tune::Source::Estimated,
            differences: None,
        });
    }
}

/// The warnings of the final pass: aids that refused themselves, its statistics and start,
/// the magnetometer's, and the tuning's.
fn pass_warnings(
    pass: &ForwardPass,
    sensors: &[SensorStats],
    config: &Config,
    tuning: Option<&Tuning>,
) -> Vec<Warning> {
    let refused = pass.aid_notes.iter().map(|note| {
        let (sensor, why) = (note.sensor, note.why.clone());
        match note.refused {
            true => Warning::AidRefused { sensor, why },
            false => Warning::AidLeftOut { sensor, why },
        }
    });
    let run = stats::warnings(&pass.run, &pass.init, sensors)
        .into_iter()
        .map(Warning::Run);
    let mag = magnetometer_warnings(&pass.mag, &config.mag);
    let tuned = tuning
        .into_iter()
        .flat_map(|t| t.warnings.iter())
        .cloned()
        .map(Warning::Tuning);
    refused.chain(run).chain(mag).chain(tuned).collect()
}

/// What a user should know of the magnetometer's readings: saturated spans left out, and a
/// deviation that could not be calibrated.
fn magnetometer_warnings(mag: &PreparedMag, cfg: &super::config::MagConfig) -> Vec<Warning> {
    let saturated = mag.saturated.iter().map(|s| Warning::MagSaturated {
        from_ns: s.from_ns,
        to_ns: s.to_ns,
        readings: s.readings,
    });
    let deviation = mag.deviation_unknown.then(|| Warning::MagNotCalibrated {
        why: (mag.calibration_skipped.as_deref())
            .unwrap_or("no reason recorded")
            .to_string(),
        magnitude_variation: mag.magnitude_variation,
        correlation_s: cfg.uncalibrated_correlation_s,
    });
    saturated.chain(deviation).collect()
}

/// The DVL's readings stamped when they were measured (`None`: no delay to take out).
fn delayed_dvl(dvl: &[Dvl], delay_s: f64) -> Option<Vec<Dvl>> {
    let delay_ns = (delay_s * 1e9).round() as i64;
    (delay_ns != 0).then(|| {
        dvl.iter()
            .map(|d| Dvl {
                stamp_ns: d.stamp_ns - delay_ns,
                ..d.clone()
            })
            .collect()
    })
}

/// The magnetometer's readings prepared once (moved in, or copied from the streams).
fn prepare_mag(
    streams: &Streams<'_>,
    config: &Config,
    owned: Option<Vec<MagneticField>>,
) -> PreparedMag {
    if !config.mag.enabled {
        return PreparedMag::default();
    }
    match owned {
        Some(readings) => magnetometer::prepare_owned(readings, &config.mag),
        None => magnetometer::prepare(streams.mag, &config.mag),
    }
}

/// The start and the figures the final pass runs with.
struct Settled {
    config: Config,
    tuning: Option<Tuning>,
    start: Initialisation,
    warnings: Vec<Warning>,
}

/// Settles the start heading, tunes from it, checks the heading with the tuned figures and,
/// when the check moved it beyond the two sigmas, tunes again from the checked heading.
///
/// The first heading is settled with the configured (or default) figures; when those cannot
/// settle it, or the log has no heading source for the alignment to check, tuning scores each
/// candidate with its own alignment instead.
fn settle_and_tune(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    mag: &PreparedMag,
    stages: &mut Stages<'_>,
    times: &mut StageTimes,
) -> Result<Settled, ReconError> {
    if !config.tune.enabled {
        let start = settled_start(streams, mission, config, mag)?;
        return Ok(Settled {
            config: config.clone(),
            tuning: None,
            start,
            warnings: Vec::new(),
        });
    }
    // A heading the alignment found from nothing (no source at all) rests on the untuned
    // figures, which may be far off: the candidates then align themselves, each with its own
    // figures (the right model finds the right heading and scores best).
    let first = settled_start_from_sources(streams, mission, config, mag)
        .ok()
        .flatten();
    times.align_s += stages.start(Stage::Tune);
    // The candidates are scored without the model aid: it would cost each a pass more, and
    // the IMU's noise is to be learnt from the sensors, not from the model's errors.
    let mut scoring = config.clone();
    scoring.model_velocity.enabled = super::on_off_auto::Switch::Off;
    let tune_from = |start: Option<&Initialisation>| {
        let from = Prepared {
            start,
            mag: Some(mag),
        };
        let (mut tuned, tuning) = tune::tune_from(streams, mission, &scoring, from);
        tuned.model_velocity = config.model_velocity.clone();
        (tuned, tuning)
    };
    let (tuned, tuning) = tune_from(first.as_ref());
    times.tune_s += stages.start(Stage::CheckAlignment);
    let checked = settled_start(streams, mission, &tuned, mag)?;
    let moved = first
        .as_ref()
        .and_then(|first| heading_moved(first, &checked));
    let Some((tuned_from_deg, checked_deg)) = moved else {
        return Ok(Settled {
            config: tuned,
            tuning,
            start: checked,
            warnings: Vec::new(),
        });
    };
    times.align_s += stages.start(Stage::Retune);
    let (tuned, tuning) = tune_from(Some(&checked));
    times.tune_s += stages.start(Stage::CheckAlignment);
    let start = settled_start(streams, mission, &tuned, mag)?;
    Ok(Settled {
        config: tuned,
        tuning,
        start,
        warnings: vec![Warning::Retuned {
            tuned_from_deg,
            checked_deg,
        }],
    })
}

/// The two headings (deg, [0, 360)) when the second is off the first by more than twice
/// their combined sigma and came from the in-motion alignment.
fn heading_moved(first: &Initialisation, checked: &Initialisation) -> Option<(f64, f64)> {
    let yaw = |i: &Initialisation| i.estimate.nav.ned_from_body.euler_angles().2;
    let difference_deg = wrap_pi(yaw(checked) - yaw(first)).to_degrees().abs();
    let sigma_deg = first.heading_sigma_deg.hypot(checked.heading_sigma_deg);
    let deg = |i: &Initialisation| yaw(i).to_degrees().rem_euclid(360.0);
    (checked.heading == HeadingSource::InMotion && difference_deg > 2.0 * sigma_deg)
        .then(|| (deg(first), deg(checked)))
}
