//! What a reconstruction holds, as `summary.json` has it: the plan, the inputs, the start,
//! the tuning, counts, rejections, NIS per sensor, the calibration, the final sigmas, the
//! truth's scores, the consistency verdict and the warnings.

use super::warning::Warning;
use crate::filters::ins::aid_table::Sensor;
use crate::filters::ins::record::Solution;
use crate::recon::calibration::{self, DvlCalibrationReport, WaterReport};
use crate::recon::config::Config;
use crate::recon::consistency::Consistency;
use crate::recon::plan::Plan;
use crate::recon::score::Scores;
use crate::recon::stats::SensorStats;
use crate::recon::tune::Tuning;
use crate::recon::{Reconstruction as Solved, Streams};
use serde::Serialize;

#[derive(Debug, Serialize)]
pub struct Summary {
    pub hindsight_version: &'static str,
    pub log: String,
    pub mission: MissionSummary,
    pub inputs: Vec<InputCount>,
    pub initialisation: InitSummary,
    /// Self-tuning's estimates (absent with tuning off).
    pub tuning: Option<Tuning>,
    /// What was used and why: every aid, calibration state and stage.
    pub plan: Plan,
    pub magnetometer: MagSummary,
    pub epochs: usize,
    pub trajectory_rows_per_solution: usize,
    pub residuals: usize,
    pub rejected: usize,
    pub dvl_out_of_range: usize,
    /// The DVL's scale factor, bias and misalignment as estimated (absent without DVL).
    pub dvl_calibration: Option<DvlCalibrationReport>,
    /// The EM log's scale factor and the water current (absent without EM log).
    pub water: Option<WaterReport>,
    /// The z gyro's scale factor as estimated (it reads this times the true rate).
    pub gyro_scale_factor_z: Option<calibration::Estimated>,
    /// The true speed of sound over the one the LBL ranges were converted with, as estimated
    /// (absent without LBL ranges).
    pub sound_speed_scale: Option<calibration::Estimated>,
    pub depth_skipped_by_interval: usize,
    pub eml_too_slow: usize,
    pub gate_resets: usize,
    pub imu_gaps: Vec<GapSummary>,
    pub sensors: Vec<SensorStats>,
    pub duration_s: f64,
    pub distance_travelled_m: f64,
    pub final_sigma: FinalSigma,
    pub truth: Option<TruthSummary>,
    /// Whether the innovations and (with truth) the NEES look consistent.
    pub consistency: Consistency,
    pub warnings: Vec<Warning>,
    pub run_time_s: RunTime,
    pub config: Config,
}

#[derive(Debug, Clone, Serialize)]
pub struct InputCount {
    /// The role's contract topic.
    pub topic: &'static str,
    /// The log's topic that played it (a ROS 2 recording's `/vehicle/imu/data`).
    pub log_topic: Option<String>,
    pub messages: usize,
    pub used: bool,
}

/// The mission the run used (from the log's record, or standing in for it).
#[derive(Debug, Serialize)]
pub struct MissionSummary {
    pub origin_latitude_deg: f64,
    pub origin_longitude_deg: f64,
    pub vehicle: String,
    pub description: String,
}

#[derive(Debug, Serialize)]
pub struct InitSummary {
    pub position_source: &'static str,
    pub position_sigma_m: f64,
    pub velocity_source: &'static str,
    pub velocity_sigma_m_s: f64,
    pub heading_source: &'static str,
    pub heading_sigma_deg: f64,
    pub tilt_sigma_deg: f64,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub depth_m: f64,
    pub roll_deg: f64,
    pub pitch_deg: f64,
    pub yaw_deg: f64,
    /// Every heading source: value, sigma, whether it was used.
    pub heading_sources: Vec<crate::recon::alignment::heading::HeadingCandidate>,
    pub heading_unavailable: Vec<String>,
    pub declination: Option<crate::recon::alignment::heading::DeclinationUsed>,
    pub in_motion_alignment: Option<crate::recon::alignment::in_motion::InMotion>,
}

/// What was done with the magnetometer's readings.
#[derive(Debug, Serialize)]
pub struct MagSummary {
    pub readings_used: usize,
    pub saturated_spans: Vec<crate::attitude::mag_checks::SaturatedSpan>,
    pub calibrated: bool,
    pub calibration_skipped: Option<String>,
    /// The field magnitude's rms variation beyond the noise, percent of the magnitude.
    pub magnitude_variation_pct: f64,
    /// Not calibrated, with a varying magnitude: heading updates held correlated longer.
    pub deviation_unknown: bool,
    pub reference_field_nt: f64,
    pub skipped_by_interval: usize,
    pub disturbed: usize,
}

#[derive(Debug, Serialize)]
pub struct GapSummary {
    pub from_ns: i64,
    pub to_ns: i64,
    pub seconds: f64,
}

#[derive(Debug, Serialize)]
pub struct Sigma {
    pub horizontal_m: f64,
    pub down_m: f64,
    pub yaw_deg: f64,
}

#[derive(Debug, Serialize)]
pub struct FinalSigma {
    pub forward: Option<Sigma>,
    pub smoothed: Option<Sigma>,
}

#[derive(Debug, Serialize)]
pub struct TruthSummary {
    pub forward: Option<Scores>,
    pub smoothed: Option<Scores>,
    pub nees_horizontal_bounds_95: (f64, f64),
    pub nees_position_bounds_95: (f64, f64),
}

#[derive(Debug, Serialize)]
pub struct RunTime {
    pub ingest: f64,
    /// The pipeline's stages before the forward pass.
    pub plan: f64,
    pub magnetometer: f64,
    /// Settling and checking the start heading.
    pub align: f64,
    pub tune: f64,
    pub forward: f64,
    /// The DVL clock-offset search (when its innovations asked for it).
    pub clock_search: f64,
    pub smoother: f64,
    pub outputs: f64,
    /// Drawing report.html and its PNGs (part of `outputs`).
    pub report: f64,
    pub total: f64,
}

pub(crate) fn final_sigma(s: Option<&Solution>) -> Option<Sigma> {
    s.map(|s| Sigma {
        horizontal_m: s.sigma[0].hypot(s.sigma[1]),
        down_m: s.sigma[2],
        yaw_deg: s.euler_sigma_rad()[2].to_degrees(),
    })
}

/// The initial state as summary.json has it.
pub(crate) fn init_summary(init: &crate::recon::alignment::start::Initialisation) -> InitSummary {
    let nav = init.estimate.nav;
    let (roll, pitch, yaw) = nav.ned_from_body.euler_angles();
    InitSummary {
        position_source: init.position.name(),
        position_sigma_m: init.position_sigma_m,
        velocity_source: init.velocity.name(),
        velocity_sigma_m_s: init.velocity_sigma_m_s,
        heading_source: init.heading.name(),
        heading_sigma_deg: init.heading_sigma_deg,
        tilt_sigma_deg: init.tilt_sigma_deg,
        latitude_deg: nav.lat_rad.to_degrees(),
        longitude_deg: nav.lon_rad.to_degrees(),
        depth_m: -nav.height_m,
        roll_deg: roll.to_degrees(),
        pitch_deg: pitch.to_degrees(),
        yaw_deg: yaw.to_degrees(),
        heading_sources: init.heading_sources.clone(),
        heading_unavailable: init.heading_unavailable.clone(),
        declination: init.declination,
        in_motion_alignment: init.in_motion.clone(),
    }
}

/// What was done with the magnetometer's readings.
pub(crate) fn mag_summary(r: &Solved) -> MagSummary {
    MagSummary {
        readings_used: r.mag.used,
        saturated_spans: r.mag.saturated.clone(),
        calibrated: r.mag.calibration.is_some(),
        calibration_skipped: r.mag.calibration_skipped.clone(),
        magnitude_variation_pct: r.mag.magnitude_variation * 100.0,
        deviation_unknown: r.mag.deviation_unknown,
        reference_field_nt: r.mag.reference_norm_t * 1e9,
        skipped_by_interval: r.run.by_interval[Sensor::Magnetometer],
        disturbed: r.run.disturbed[Sensor::Magnetometer],
    }
}

/// The EM log's scale and the water current, when the EM log was used.
pub(crate) fn water_summary(
    r: &Solved,
    config: &Config,
    last: Option<&Solution>,
) -> Option<WaterReport> {
    let used = config.eml.enabled && r.run.residuals.iter().any(|x| x.sensor == Sensor::SpeedLog);
    let sigma = [
        config.eml.scale_sigma,
        config.eml.current_sigma_m_s,
        config.eml.current_sigma_m_s,
    ];
    used.then_some(last)
        .flatten()
        .map(|last| calibration::water_report(last, &sigma))
}
/// The messages of each input, and whether the run used them.
pub(crate) fn input_counts(
    log: &crate::ingest::Log,
    streams: &Streams<'_>,
    config: &Config,
) -> Vec<InputCount> {
    let count = |topic: &'static str, messages, used: bool| InputCount {
        topic,
        log_topic: log
            .roles
            .iter()
            .find(|c| c.role == topic.trim_start_matches('/'))
            .map(|c| c.topic.clone()),
        messages,
        used: used && messages > 0,
    };
    std::iter::once(count("/imu", streams.imu.len(), true))
        .chain(
            Sensor::ALL
                .into_iter()
                .map(|s| count(s.topic(), s.readings(streams), config.uses(s))),
        )
        .chain([
            count("/altimeter", streams.altimeter.len(), true),
            count("/truth", streams.truth.len(), false),
        ])
        .collect()
}

/// An estimate and its sigma (times `scale`), "(prior)" where the log did not tell it, "held"
/// where it was not estimated (a zero prior).
pub fn estimated_text(e: &calibration::Estimated, scale: f64, digits: usize, unit: &str) -> String {
    if e.sigma == 0.0 {
        format!("{:.digits$}{unit} held", e.value * scale)
    } else {
        let told = if e.determined { "" } else { " (prior)" };
        format!(
            "{:.digits$} +- {:.digits$}{unit}{told}",
            e.value * scale,
            e.sigma * scale
        )
    }
}

/// One line of the DVL's calibration, each quantity as [`estimated_text`].
pub fn dvl_calibration_line(d: &DvlCalibrationReport) -> String {
    let show = estimated_text;
    let m = &d.misalignment_deg;
    let b = &d.bias_m_s;
    format!(
        "scale factor {}; misalignment heading {}, pitch {}; bias x {}, y {}, z {}",
        show(&d.scale_factor, 1.0, 4, ""),
        show(&m.heading, 1.0, 2, " deg"),
        show(&m.pitch, 1.0, 2, " deg"),
        show(&b[0], 1e3, 2, " mm/s"),
        show(&b[1], 1e3, 2, " mm/s"),
        show(&b[2], 1e3, 2, " mm/s"),
    )
}
/// What the summary is made from.
pub(crate) struct Parts<'a> {
    pub job: &'a super::Job,
    pub mission: &'a crate::ingest::Mission,
    pub run: &'a super::Solve,
    pub scored: &'a crate::output::recon_blocks::Scored,
    pub ingest_s: f64,
    pub started: std::time::Instant,
}

/// Every warning of the run: the pipeline's, a failed spill's, the consistency verdict's.
fn warnings(x: &Parts<'_>, consistency: &Consistency) -> Vec<Warning> {
    let r = &x.run.outcome.reconstruction;
    let pipeline = x
        .run
        .outcome
        .warnings
        .iter()
        .cloned()
        .map(Warning::Pipeline);
    // A full disk is no reason to fail: the run held in memory what it meant to spill.
    let held = (x.run.records_failure.clone().into_iter())
        .chain(r.forward.spill_failure())
        .chain(r.smoothed.spill_failure())
        .take(1)
        .map(|why| Warning::HeldInMemory { why });
    let over_confident = consistency
        .over_confident()
        .cloned()
        .map(Warning::OverConfident);
    pipeline.chain(held).chain(over_confident).collect()
}

/// The truth's scores and their bounds (logs with a truth).
fn truth_summary(scored: &crate::output::recon_blocks::Scored) -> Option<TruthSummary> {
    use crate::recon::score;
    scored.errors.as_ref().map(|(fwd, smo)| TruthSummary {
        forward: fwd.sums.scores(),
        smoothed: smo.sums.scores(),
        nees_horizontal_bounds_95: score::bounds_95(2),
        nees_position_bounds_95: score::bounds_95(3),
    })
}

/// The calibration the run estimated: the DVL's, the water's, the z gyro's scale.
fn calibration_of(
    x: &Parts<'_>,
    last: Option<&Solution>,
) -> (
    Option<DvlCalibrationReport>,
    Option<WaterReport>,
    Option<calibration::Estimated>,
) {
    use crate::recon::plan::Part;
    let (outcome, config) = (&x.run.outcome, &x.run.outcome.config);
    let dvl = (outcome.plan.uses(Part::Aid(Sensor::Dvl)))
        .then_some(last)
        .flatten()
        .map(|last| calibration::report(last, &config.dvl.calibration_sigma()));
    let water = water_summary(&outcome.reconstruction, config, last);
    let gyro =
        last.map(|last| calibration::gyro_scale_report(last, config.imu.spec().gyro_scale()));
    (dvl, water, gyro)
}

/// `summary.json`, but the outputs' and the report's times (filled once the files are
/// written).
pub(crate) fn build(x: &Parts<'_>) -> Result<Summary, super::Error> {
    let read_back = |source| super::Error::ReadBack {
        what: "reading the solutions back",
        source,
    };
    let (outcome, r) = (&x.run.outcome, &x.run.outcome.reconstruction);
    let config = &outcome.config;
    let truth = truth_summary(x.scored);
    let consistency = crate::recon::consistency::assess(
        &outcome.sensors,
        truth.as_ref().and_then(|t| t.forward.as_ref()),
        truth.as_ref().and_then(|t| t.smoothed.as_ref()),
    );
    let warnings = warnings(x, &consistency);
    let first_forward = r.forward.first().map_err(read_back)?;
    let last_forward = r.forward.last().map_err(read_back)?;
    let last_smoothed = r.smoothed.last().map_err(read_back)?;
    let (dvl_calibration, water, gyro_scale_factor_z) = calibration_of(x, last_forward.as_ref());
    let times = &outcome.times;
    let mission = x.mission;
    Ok(Summary {
        hindsight_version: env!("CARGO_PKG_VERSION"),
        log: x.job.log.name().display().to_string(),
        mission: MissionSummary {
            origin_latitude_deg: mission.origin_latitude_deg,
            origin_longitude_deg: mission.origin_longitude_deg,
            vehicle: mission.vehicle.clone(),
            description: mission.description.clone(),
        },
        inputs: x.run.inputs.clone(),
        tuning: outcome.tuning.clone(),
        plan: outcome.plan.clone(),
        initialisation: init_summary(&r.init),
        magnetometer: mag_summary(r),
        epochs: r.forward.len(),
        trajectory_rows_per_solution: x.run.kept_rows.len(),
        residuals: r.run.residuals.len(),
        rejected: r.run.residuals.iter().filter(|x| !x.accepted).count(),
        dvl_out_of_range: r.run.unused[Sensor::Dvl],
        dvl_calibration,
        water,
        gyro_scale_factor_z,
        sound_speed_scale: [Sensor::Lbl, Sensor::Usbl]
            .into_iter()
            .any(|s| outcome.plan.uses(crate::recon::plan::Part::Aid(s)))
            .then_some(last_forward.as_ref())
            .flatten()
            .map(|last| calibration::sound_speed_report(last, config.lbl.sound_speed_sigma)),
        depth_skipped_by_interval: r.run.by_interval[Sensor::Depth],
        eml_too_slow: r.run.unused[Sensor::SpeedLog],
        gate_resets: r.run.gate_resets,
        imu_gaps: (r.run.imu_gaps.iter())
            .map(|g| GapSummary {
                from_ns: g.from_ns,
                to_ns: g.to_ns,
                seconds: (g.to_ns - g.from_ns) as f64 * 1e-9,
            })
            .collect(),
        sensors: outcome.sensors.clone(),
        duration_s: match (&first_forward, &last_forward) {
            (Some(a), Some(b)) => (b.stamp_ns - a.stamp_ns) as f64 * 1e-9,
            _ => 0.0,
        },
        distance_travelled_m: x.scored.distance_m,
        final_sigma: FinalSigma {
            forward: final_sigma(last_forward.as_ref()),
            smoothed: final_sigma(last_smoothed.as_ref()),
        },
        truth,
        consistency,
        warnings,
        run_time_s: RunTime {
            ingest: x.ingest_s,
            plan: times.plan_s,
            magnetometer: times.magnetometer_s,
            align: times.align_s,
            tune: times.tune_s,
            forward: times.forward_s,
            clock_search: times.clock_search_s,
            smoother: times.smoother_s,
            outputs: 0.0,
            report: 0.0,
            // So far (the report shows it); the whole run's once the files are written.
            total: x.started.elapsed().as_secs_f64(),
        },
        config: config.clone(),
    })
}
