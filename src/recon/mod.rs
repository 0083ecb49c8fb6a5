//! Post-dive reconstruction: a log and a configuration in, forward and smoothed solutions,
//! residuals and statistics out. Pure: the log is already read (`ingest`), the tables are
//! written elsewhere (`output`, `cli`).
//!
//! `config` (settings and their defaults) -> `init` (the initial estimate from the log) ->
//! `filters::ins::driver` (forward pass) -> `smooth::rts` -> `stats` (NIS per sensor,
//! distance) and, when the log carries `/truth`, `score`.

pub mod acoustic_delay;
pub mod alignment;
pub mod calibration;
pub mod clock;
pub mod config;
pub mod consistency;
pub mod dvl_delay;
pub mod held_dvl;
pub mod magnetometer;
pub mod model_velocity;
pub mod on_off_auto;
pub mod pipeline;
pub mod plan;
pub mod sanity;
pub mod score;
pub mod stats;
pub mod tune;

use crate::contract::Imu;
use crate::filters::ins::aid_table::{Aid, MagAiding, Sensor};
use crate::filters::ins::driver::{run_forward, ForwardRun, Inputs, Keep};
use crate::filters::ins::record::Solution;
use crate::filters::ins::solutions::Solutions;
use crate::filters::velocity::model_aided::{AttitudeAt, ModelAidedFilter};
use crate::ingest::Mission;
use crate::progress::Progress;
use crate::smooth::rts::{smooth_each, SmoothError};
use alignment::start::{InitError, InitSettings, Initialisation};
use alignment::{heading, in_motion, start as init};
use config::Config;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Why a reconstruction failed. The message carries the cause's text, so the cause is not
/// also a `source` (an error chain printed with `{:#}` would say it twice).
#[derive(Debug, thiserror::Error)]
pub enum ReconError {
    #[error("initialisation: {0}")]
    Init(InitError),
    #[error("smoother: {0}")]
    Smooth(SmoothError),
    #[error("model-aided velocity: {0}")]
    Vehicle(model_velocity::VehicleError),
}

impl From<InitError> for ReconError {
    fn from(e: InitError) -> Self {
        ReconError::Init(e)
    }
}

impl From<SmoothError> for ReconError {
    fn from(e: SmoothError) -> Self {
        ReconError::Smooth(e)
    }
}

/// What a reconstruction produced.
#[derive(Debug)]
pub struct Reconstruction {
    pub init: Initialisation,
    /// The magnetometer's readings as used (saturation, calibration).
    pub mag: magnetometer::PreparedMag,
    /// Residuals, counts and gaps of the forward pass (its records are turned into
    /// `forward` once smoothed, to free their memory).
    pub run: ForwardRun,
    /// What the aiding sources said (a source that could not be used, and why).
    pub aid_notes: Vec<AidNote>,
    /// One per filter epoch, on temporary files beyond a block (a long mission's would not
    /// fit in memory).
    pub forward: Solutions,
    pub smoothed: Solutions,
    /// Whether each solution falls on an output time (else only on a measurement).
    pub output: Vec<bool>,
    pub timing: Timing,
}

/// Wall time of each stage.
#[derive(Debug, Clone, Copy, Default)]
pub struct Timing {
    pub forward: Duration,
    pub smoother: Duration,
}

pub use crate::contract::Streams;

/// Output times: every `1 / rate_hz` from the first to the last IMU sample.
pub fn output_stamps(imu: &[Imu], rate_hz: f64) -> Vec<i64> {
    let (Some(first), Some(last)) = (imu.first(), imu.last()) else {
        return Vec::new();
    };
    let step = (1e9 / rate_hz).round().max(1.0) as i64;
    (0..)
        .map(|k| first.stamp_ns + k * step)
        .take_while(|&t| t <= last.stamp_ns)
        .collect()
}

/// Adds the depth sensor's constant offset, which nothing in the log can estimate (the depth
/// is the only vertical reference), to the depth uncertainty of a solution: a Schmidt
/// "consider" term. The estimate itself is unchanged; the offset's error is the same at
/// every epoch, so it adds `sigma^2` to the down variance.
pub(crate) fn consider_depth_bias(s: &mut Solution, bias_sigma_m: f64) {
    s.position_cov[(2, 2)] += bias_sigma_m * bias_sigma_m;
    s.sigma[2] = s.position_cov[(2, 2)].sqrt();
}

/// The DVL's held scale factor and heading misalignment, when the run used the DVL without
/// estimating them, took no absolute position, and the configuration gives them a sigma:
/// their share of the reported position sigma ([`held_dvl`]). An absolute position (GNSS, a
/// fix) bounds their error after it (and, smoothed, before it), which a displacement from the
/// start does not describe: there it is not added.
fn held_dvl_calibration(
    config: &Config,
    init: &Initialisation,
    run: &ForwardRun,
) -> Option<held_dvl::HeldDvlCalibration> {
    let d = &config.dvl;
    let took = |sensor: Sensor| {
        run.residuals
            .iter()
            .any(|r| r.sensor == sensor && r.accepted)
    };
    let dead_reckoned = took(Sensor::Dvl) && !took(Sensor::Gnss) && !took(Sensor::PositionFix);
    let sigma_given = d.scale_sigma > 0.0 || d.held_misalignment_sigma_deg > 0.0;
    (dead_reckoned && sigma_given && !d.scale_misalignment.is_on()).then(|| {
        held_dvl::HeldDvlCalibration {
            start_lat_rad: init.estimate.nav.lat_rad,
            start_lon_rad: init.estimate.nav.lon_rad,
            scale_sigma: d.scale_sigma,
            heading_sigma_rad: d.held_misalignment_sigma_deg.to_radians(),
        }
    })
}

/// What the forward pass started from and produced.
#[derive(Debug)]
pub struct ForwardPass {
    pub init: Initialisation,
    pub mag: magnetometer::PreparedMag,
    pub run: ForwardRun,
    /// What the aiding sources said (a source that could not be used, and why).
    pub aid_notes: Vec<AidNote>,
    pub time: Duration,
    /// The attitude the model-aided velocity was driven by (a pass without it), when it ran.
    pub model_attitude: Option<AttitudeTrack>,
}

/// What an aiding source said of itself: it could not be used, and why; or some of its
/// readings were left out, the others used.
#[derive(Debug, Clone, PartialEq)]
pub struct AidNote {
    pub sensor: Sensor,
    pub why: String,
    /// Whether the source as a whole could not be used.
    pub refused: bool,
}

impl std::fmt::Display for AidNote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.refused {
            true => write!(f, "{}: not used: {}", self.sensor, self.why),
            false => write!(f, "{}: {}", self.sensor, self.why),
        }
    }
}

/// The attitude of a forward pass without the model-aided velocity: what the model is
/// driven by. Shared between reconstructions of one log whose settings differ only in the
/// model aid's (a study's solutions), so that the pass is made once.
pub type AttitudeTrack = Arc<Vec<AttitudeAt>>;

/// The magnetometer's readings a pass uses.
#[derive(Default)]
pub(crate) enum MagInput<'a> {
    /// Prepared by the pass from `streams.mag` (and freed after it).
    #[default]
    FromStreams,
    /// Already prepared ([`magnetometer::prepare_owned`], moved out of the log so that a long
    /// mission's are not held twice): the pass keeps them in [`ForwardPass::mag`].
    Owned(Box<magnetometer::PreparedMag>),
    /// Already prepared and shared by several passes (the pipeline's tuning candidates).
    Shared(&'a magnetometer::PreparedMag),
}

/// How a forward pass is made, beyond its log and configuration.
#[derive(Default)]
pub(crate) struct PassOptions<'a> {
    /// The attitude the model-aided velocity is driven by: the [`ForwardPass::model_attitude`]
    /// of a pass over the same log whose settings differ only in `[model_velocity]`, instead
    /// of a pass of its own.
    pub shared_attitude: Option<AttitudeTrack>,
    /// Told how far the final pass has come.
    pub progress: Progress<'a>,
    pub mag: MagInput<'a>,
    /// What the pass keeps of its epochs: records for the smoother (the default), nothing (a
    /// pass that is only scored), or the navigation states (a track to compare with).
    pub keep: Keep,
    /// A start whose heading is already settled (the pipeline's alignment): its heading, its
    /// sources and its in-motion bank are taken instead of aligning again, unless the
    /// configuration's own sources give a sharper heading.
    pub start: Option<&'a Initialisation>,
}

/// What the pipeline has prepared once for the passes it scores (tuning candidates, clock
/// offsets): a start whose heading is settled, and the magnetometer's readings.
#[derive(Debug, Clone, Copy, Default)]
pub struct Prepared<'a> {
    pub start: Option<&'a Initialisation>,
    pub mag: Option<&'a magnetometer::PreparedMag>,
}

impl<'a> Prepared<'a> {
    /// The options of a pass that is only scored, from what is prepared.
    pub(crate) fn scored(self) -> PassOptions<'a> {
        PassOptions {
            keep: Keep::Nothing,
            start: self.start,
            mag: self.mag.map_or(MagInput::FromStreams, MagInput::Shared),
            ..PassOptions::default()
        }
    }
}

/// What an aid says of its readings: why it could not be used, and the readings it left out
/// (all of them: it could not be used either).
fn notes_of(aid: &dyn Aid) -> impl Iterator<Item = AidNote> {
    let sensor = aid.sensor();
    let none_left = aid.is_empty();
    let refused = aid.notes().into_iter().map(move |why| AidNote {
        sensor,
        why,
        refused: true,
    });
    let left_out = aid.left_out_notes().into_iter().map(move |why| AidNote {
        sensor,
        why,
        refused: none_left,
    });
    refused.chain(left_out)
}

/// Initialises from the log and runs the forward filter as `options` say.
pub(crate) fn forward_pass(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    options: PassOptions<'_>,
) -> Result<ForwardPass, ReconError> {
    let PassOptions {
        shared_attitude,
        progress,
        mag: mag_input,
        keep,
        start,
    } = options;
    let (mut owned, shared, keep_owned) = match mag_input {
        MagInput::Shared(m) => (None, config.mag.enabled.then_some(m), false),
        MagInput::Owned(m) => (config.mag.enabled.then_some(*m), None, true),
        MagInput::FromStreams => (
            config
                .mag
                .enabled
                .then(|| magnetometer::prepare(streams.mag, &config.mag)),
            None,
            false,
        ),
    };
    let mag: &magnetometer::PreparedMag = match shared {
        Some(m) => m,
        None => owned.get_or_insert_with(Default::default),
    };
    let streams = used_streams(streams, config, &mag.readings);
    let (settings, mut init) = initialise_for(&streams, mission, config, mag)?;
    let stamps = output_stamps(streams.imu, config.output.rate_hz);
    let aids = settings.aiding.table(&streams, mission_origin_rad(mission));
    let inputs = Inputs {
        imu: streams.imu,
        aids: &aids,
        output_stamps_ns: &stamps,
        progress: None,
        keep,
    };
    let started = Instant::now();
    take_start(start, config, &settings, &inputs, &mut init)?;
    let mut aid_notes: Vec<AidNote> = Vec::new();
    let inputs = Inputs { progress, ..inputs };
    let (run, model_note, attitude) = match with_model(config, mission)? {
        Ok(Some(model)) => {
            let beside = pass_with_model(
                &model,
                shared_attitude,
                &settings,
                &inputs,
                &init,
                (&streams, config),
            );
            (beside.run, beside.refused, Some(beside.attitude))
        }
        Ok(None) => (run_forward(&settings, &inputs, init.estimate), None, None),
        Err(note) => {
            aid_notes.push(note);
            (run_forward(&settings, &inputs, init.estimate), None, None)
        }
    };
    aid_notes.extend(aids.iter().flat_map(|aid| notes_of(aid.as_ref())));
    aid_notes.extend(model_note.map(|why| AidNote {
        sensor: Sensor::ModelVelocity,
        why,
        refused: true,
    }));
    // The table borrows the magnetometer's readings. Readings prepared here are a copy of
    // the log's: freed. Readings handed in are kept (the log no longer has them).
    drop(aids);
    let summary = (!keep_owned).then(|| mag.without_readings());
    let mag = match (owned, summary) {
        (_, Some(summary)) => summary,
        (Some(mag), None) => mag,
        (None, None) => magnetometer::PreparedMag::default(),
    };
    Ok(ForwardPass {
        init,
        mag,
        run,
        aid_notes,
        time: started.elapsed(),
        model_attitude: attitude,
    })
}

/// The pass's start heading: a start settled with other figures is taken unless this
/// configuration's own sources give a sharper heading (a gyrocompass its IMU figures allow);
/// without one (or from `/truth`), settled here.
fn take_start(
    start: Option<&Initialisation>,
    config: &Config,
    settings: &crate::filters::ins::driver::Settings,
    inputs: &Inputs<'_>,
    init: &mut Initialisation,
) -> Result<(), ReconError> {
    match start {
        Some(start) if !config.initial.from_truth => {
            let own_sharper = init.heading != heading::HeadingSource::Unknown
                && init.heading_sigma_deg < start.heading_sigma_deg;
            if !own_sharper {
                init.adopt_heading(start);
            }
            Ok(())
        }
        _ => settle_heading(settings, inputs, init, config),
    }
}

/// The vehicle model, when the configuration uses the model aid (seed 000). `Err` is the note
/// of a model that cannot be used.
fn with_model(
    config: &Config,
    mission: &Mission,
) -> Result<Result<Option<crate::vehicle::six_dof::model::SixDof>, AidNote>, ReconError> {
    if !config.uses(Sensor::ModelVelocity) {
        return Ok(Ok(None));
    }
    match model_velocity::model_for(&config.model_velocity, mission).map_err(ReconError::Vehicle)? {
        Ok(model) => Ok(Ok(Some(model))),
        Err(why) => Ok(Err(AidNote {
            sensor: Sensor::ModelVelocity,
            why: why.to_string(),
            refused: true,
        })),
    }
}

/// The streams a pass reads: a sensor the configuration leaves out is an empty stream, and
/// the magnetometer's are its prepared readings.
fn used_streams<'a>(
    streams: &Streams<'a>,
    config: &Config,
    mag: &'a [crate::contract::MagneticField],
) -> Streams<'a> {
    let streams = Sensor::ALL
        .into_iter()
        .filter(|&s| !config.uses(s))
        .fold(*streams, |kept, s| s.left_out_of(kept));
    Streams { mag, ..streams }
}

/// The mission origin, rad.
fn mission_origin_rad(mission: &Mission) -> (f64, f64) {
    (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    )
}

/// The filter's settings and the initial estimate from the log (or from `/truth`, as a study
/// asks), with the magnetometer's aiding set from the declination found.
fn initialise_for(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    mag: &magnetometer::PreparedMag,
) -> Result<(crate::filters::ins::driver::Settings, Initialisation), ReconError> {
    let mut settings = config.settings();
    let speed_of_rpm = rpm_speed(mission, config);
    let mut init = init::initialise(
        streams,
        mission,
        &InitSettings {
            initial: &config.initial,
            imu: config.imu.spec(),
            dvl_max_altitude_m: config.dvl.max_altitude_m,
            dvl_sigma_m_s: config.dvl.sigma_m_s,
            dvl_bias_walk_m_s_rt_s: config.dvl.bias_walk_m_s_rt_h / 60.0,
            dvl_mounting: config.dvl.mounting(),
            dvl_calibration_sigma: config.dvl.calibration_sigma(),
            water_sigma: [
                config.eml.scale_sigma,
                config.eml.current_sigma_m_s,
                config.eml.current_sigma_m_s,
            ],
            sound_speed_scale_sigma: config.lbl.sound_speed_sigma,
            depth_sigma_m: config.depth.sigma_m,
            speed_of_rpm: speed_of_rpm.as_ref().map(|f| f as &dyn Fn(f64) -> f64),
            acoustic: config.acoustic_fix.aid(),
            usbl: config
                .usbl
                .aid(&config.acoustic_fix, config.acoustic_delay_known()),
        },
    )?;
    if config.initial.from_truth {
        let truth = crate::align::latest_at(streams.truth, init.estimate_stamp_ns)
            .map(|(t, _)| t)
            .or(streams.truth.first())
            .ok_or(InitError::NoTruth)?;
        init::start_from_truth(&mut init, truth, &config.initial);
    }
    settings.aiding.mag = init
        .declination
        .filter(|_| config.mag.use_as_aid && !mag.readings.is_empty())
        .map(|d| MagAiding {
            declination_rad: d.declination_deg.to_radians(),
            sigma_rad: config.mag.update_sigma_rad(mag.deviation_unknown),
            min_interval_s: config.mag.min_interval_s,
            reference_norm_t: mag.reference_norm_t,
            max_norm_deviation: config.mag.max_field_deviation,
        });
    Ok((settings, init))
}

/// The start heading: checked by the in-motion alignment when it is on; without it, a start
/// with no heading source is refused.
fn settle_heading(
    settings: &crate::filters::ins::driver::Settings,
    inputs: &Inputs<'_>,
    init: &mut Initialisation,
    config: &Config,
) -> Result<(), ReconError> {
    if config.alignment.enabled && !config.initial.from_truth {
        align_in_motion(settings, inputs, init, config)
    } else if init.heading == heading::HeadingSource::Unknown {
        Err(InitError::NoHeading(init.heading_unavailable.join("; ")).into())
    } else {
        Ok(())
    }
}

/// The initial estimate with its heading settled (sources, then the in-motion alignment when
/// it is on), as a forward pass with this configuration would start: the pipeline's start.
pub(crate) fn settled_start(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    mag: &magnetometer::PreparedMag,
) -> Result<Initialisation, ReconError> {
    let (streams, settings, mut init) = unsettled_start(streams, mission, config, mag)?;
    settle_start(&streams, mission, &settings, &mut init, config)?;
    Ok(init)
}

/// [`settled_start`] when the log gives the heading a source, else `None` without settling
/// it (the in-motion alignment would then find it from nothing, on figures not yet tuned).
pub(crate) fn settled_start_from_sources(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
    mag: &magnetometer::PreparedMag,
) -> Result<Option<Initialisation>, ReconError> {
    let (streams, settings, mut init) = unsettled_start(streams, mission, config, mag)?;
    if init.heading_sources.is_empty() {
        return Ok(None);
    }
    settle_start(&streams, mission, &settings, &mut init, config)?;
    Ok(Some(init))
}

/// The streams a pass with this configuration uses, its settings and its initialisation,
/// the heading not yet settled.
fn unsettled_start<'a>(
    streams: &Streams<'a>,
    mission: &Mission,
    config: &Config,
    mag: &'a magnetometer::PreparedMag,
) -> Result<
    (
        Streams<'a>,
        crate::filters::ins::driver::Settings,
        Initialisation,
    ),
    ReconError,
> {
    let mag_readings = if config.mag.enabled {
        &mag.readings[..]
    } else {
        &[]
    };
    let streams = used_streams(streams, config, mag_readings);
    let (settings, init) = initialise_for(&streams, mission, config, mag)?;
    Ok((streams, settings, init))
}

/// Settles the start's heading over the aids of `streams`.
fn settle_start(
    streams: &Streams<'_>,
    mission: &Mission,
    settings: &crate::filters::ins::driver::Settings,
    init: &mut Initialisation,
    config: &Config,
) -> Result<(), ReconError> {
    let aids = settings.aiding.table(streams, mission_origin_rad(mission));
    let inputs = Inputs {
        imu: streams.imu,
        aids: &aids,
        output_stamps_ns: &[],
        progress: None,
        // The alignment smooths its winner back to the start: it needs the records.
        keep: Keep::Records,
    };
    settle_heading(settings, &inputs, init, config)
}

/// The navigation pass with the model's aid beside it ([`model_velocity::pass_beside_model`]).
fn pass_with_model(
    model: &crate::vehicle::six_dof::model::SixDof,
    shared_attitude: Option<AttitudeTrack>,
    settings: &crate::filters::ins::driver::Settings,
    inputs: &Inputs<'_>,
    init: &Initialisation,
    (streams, config): (&Streams<'_>, &Config),
) -> model_velocity::BesideModel {
    let dvl_in_range = settings.aiding.dvl(streams).in_range_body_velocities();
    let filter = model_filter(config);
    model_velocity::pass_beside_model(
        shared_attitude,
        settings,
        inputs,
        init,
        (&dvl_in_range, &config.model_velocity),
        |attitude, hand_on| {
            model_velocity::run_model(
                model,
                streams,
                attitude,
                &dvl_in_range,
                &config.model_velocity,
                &filter,
                hand_on,
            )
        },
    )
}

/// The model's filter's settings: the sensors' noise the configuration gives.
fn model_filter(config: &Config) -> ModelAidedFilter {
    ModelAidedFilter {
        depth_sigma_m: config.depth.sigma_m,
        eml_sigma_m_s: config.eml.sigma_m_s,
        dvl_sigma_m_s: config.dvl.sigma_m_s,
        ..ModelAidedFilter::default()
    }
}

/// The in-motion alignment: a decisive heading other than the initial one replaces it (with a
/// warning when a source had given one); without a source and without a decisive heading,
/// no reconstruction.
fn align_in_motion(
    settings: &crate::filters::ins::driver::Settings,
    inputs: &Inputs<'_>,
    init: &mut Initialisation,
    config: &Config,
) -> Result<(), ReconError> {
    let found = in_motion::align(settings, inputs, init, &config.alignment);
    let known = init.heading != heading::HeadingSource::Unknown;
    if let Some((yaw, sigma_deg)) = found.as_ref().and_then(|f| f.found) {
        if known {
            let (_, _, before) = init.estimate.nav.ned_from_body.euler_angles();
            init.heading_disagreements
                .push(heading::HeadingDisagreement::StartAndInMotion {
                    start: heading::SourceHeading {
                        source: init.heading,
                        heading_deg: before.to_degrees().rem_euclid(360.0),
                        sigma_deg: init.heading_sigma_deg,
                    },
                    in_motion: heading::SourceHeading {
                        source: heading::HeadingSource::InMotion,
                        heading_deg: yaw.to_degrees().rem_euclid(360.0),
                        sigma_deg,
                    },
                });
        }
        init.estimate = init.estimate_with_heading(yaw, sigma_deg);
        init.heading = heading::HeadingSource::InMotion;
        init.heading_sigma_deg = sigma_deg;
    } else if found.as_ref().is_some_and(|f| f.refined.is_some()) {
        // Confirmed: the forward pass starts from the gyrocompass's heading and sigma and
        // gyrocompasses in motion itself. Started from the refined heading it would read the
        // span's data twice: on `auv-at-sea` seeds 1-10 its heading NEES at 300 s was 2.7
        // (1.2 from the gyrocompass) and its RMS 1.9 m (1.6); the smoother gives the start
        // from all the data.
        init.heading = heading::HeadingSource::GyrocompassInMotion;
    } else if !known {
        init.in_motion = found;
        return Err(InitError::NoHeading(init.heading_unavailable.join("; ")).into());
    }
    init.in_motion = found;
    Ok(())
}

/// Forward speed for a propeller reading (rev/min): the configured gain, else the mission
/// vehicle's steady speed (built-in vehicles), else none.
fn rpm_speed(mission: &Mission, config: &Config) -> Option<Box<dyn Fn(f64) -> f64>> {
    if let Some(k) = config.initial.rpm_speed_m_s_per_rpm {
        return Some(Box::new(move |rpm| k * rpm));
    }
    let vehicle =
        crate::vehicle::six_dof::description::Vehicle::built_in(&mission.vehicle)?.ok()?;
    let model = crate::vehicle::six_dof::model::SixDof::new(vehicle)?;
    Some(Box::new(move |rpm: f64| {
        let n = rpm * std::f64::consts::TAU / 60.0;
        crate::vehicle::six_dof::properties::steady_speed(&model, n).unwrap_or(0.0)
    }))
}

/// Exactly the configuration given, without a plan or tuning: initialisation, forward
/// filter, smoother (a part left `auto` is off). For tests of one method and for studies of
/// hand-made configurations.
pub fn run_configured(
    streams: &Streams<'_>,
    mission: &Mission,
    config: &Config,
) -> Result<Reconstruction, ReconError> {
    let pass = forward_pass(streams, mission, config, PassOptions::default())?;
    let depth_used = config.depth.enabled && !streams.depth.is_empty();
    finish(pass, config, depth_used, None)
}

/// Smooths a forward run and turns its records into solutions (freeing the records), telling
/// `progress` how far the smoother has come. `depth_used`: the run had depth updates (their
/// offset is then added to the depth sigma).
pub(crate) fn finish(
    pass: ForwardPass,
    config: &Config,
    depth_used: bool,
    progress: Progress<'_>,
) -> Result<Reconstruction, ReconError> {
    let ForwardPass {
        init,
        mut mag,
        mut run,
        aid_notes,
        time: forward_time,
        model_attitude: _,
    } = pass;
    mag.readings = Vec::new();
    let started = Instant::now();
    let (mut forward, mut smoothed) = (Solutions::new(), Solutions::new());
    let mut output = Vec::with_capacity(run.records.len());
    let held_dvl = held_dvl_calibration(config, &init, &run);
    let considered = |mut s: Solution| {
        if depth_used {
            consider_depth_bias(&mut s, config.depth.bias_sigma_m);
        }
        if let Some(held) = &held_dvl {
            held.widen(&mut s);
        }
        s
    };
    smooth_each(&run.records, progress, |_, record, smooth| {
        forward.push_earlier(considered(Solution::forward(record)));
        smoothed.push_earlier(considered(smooth));
        output.push(record.output);
    })?;
    output.reverse();
    let smoother_time = started.elapsed();
    run.records = Default::default();
    Ok(Reconstruction {
        init,
        mag,
        run,
        aid_notes,
        forward,
        smoothed,
        output,
        timing: Timing {
            forward: forward_time,
            smoother: smoother_time,
        },
    })
}
