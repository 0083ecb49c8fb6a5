//! `hindsight reconstruct LOG --out DIR`: the best trajectory the log supports.

use super::console::{out, say};
mod report;
mod tables;
use tables::Tables;

use super::choices::{HeadingChoice, ImuGrade};
use super::console;
use super::{LogArgs, OutputFailed, PolicyArgs};
use anyhow::{Context, Result};
use hindsight::config::Section;
use hindsight::contract::Truth;
use hindsight::filters::ins::aiding::Sensor;
use hindsight::filters::ins::record::Solution;
use hindsight::output::atomic::Staging;
use hindsight::output::recon_tables;
use hindsight::recon::calibration::{self, DvlCalibrationReport, WaterReport};
use hindsight::recon::config::Config;
use hindsight::recon::consistency::{self, Consistency};
use hindsight::recon::pipeline::{self, Stage, Warning};
use hindsight::recon::plan::{Part, Plan};
use hindsight::recon::score::{self, Scores};
use hindsight::recon::stats::RunWarning;
use hindsight::recon::stats::SensorStats;
use hindsight::recon::tune::Tuning;
use hindsight::recon::{Reconstruction, Streams};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Reconstruct the trajectory: strapdown INS, 25-state error-state filter (with self-tuned noise), RTS smoother.
///
/// Reads the log and decides from it what to use (the plan, printed and kept in summary.json:
/// every aid, calibration state and stage, used or not and why: the propeller's velocity
/// filter when /rpm exists and the DVL has gaps, the vehicle model's when /fins, /rpm and a
/// vehicle are there, the DVL's scale and misalignment when fixes far apart make them
/// observable, the DVL's stamp delay when the IMU and the DVL show it clearly). Initialises
/// from the log (position from GNSS, a `start` fix or the mission origin; levelling; heading
/// by gyrocompass, magnetometer, the mission's initial_yaw_rad or --initial-yaw, checked by
/// the in-motion alignment, which also refines a gyrocompass heading while the vehicle
/// moves; the sources are printed), self-tunes the noise from that start, checks the heading
/// again with the tuned figures, runs the forward filter at the IMU rate with every aid of
/// the plan behind a chi-square gate, then smooths the whole mission. Writes to DIR, atomically:
///
///   trajectory.parquet  forward and smoothed solutions at --output-rate: position (lat/lon
///                       and north/east/down in the mission frame), NED velocity,
///                       roll/pitch/yaw, their 1-sigma, gyro and accelerometer biases
///   trajectory.mcap     the same rows for Foxglove: LocationFix (map panel) and PoseInFrame
///                       (3-D panel, `map` = east/north/up from the origin) on
///                       /hindsight/{forward,smoothed}/{fix,pose}, as ROS 2 messages
///                       (foxglove_msgs, CDR)
///   residuals.parquet   every aiding measurement: innovation, predicted sigma, NIS, accepted
///   summary.json        the plan, inputs, initialisation, tuning, counts, rejections, NIS
///                       per sensor, distance, final 1-sigma, run time per stage, and truth
///                       scores when /truth exists
///   errors.parquet      (logs with /truth) both solutions minus the truth, with 1-sigma, NEES
///
/// Noise and every other setting: a TOML file (--config; `hindsight config` prints the
/// defaults with each key explained); the options below override it.
///
/// Memory: what grows with the mission (the smoother's records, both solutions, the truth)
/// waits on temporary files in TMPDIR, about 6.3 kB per filter epoch (6.2 GB for 27 h at
/// 10 Hz), deleted as the run ends; point TMPDIR at a disk, not a RAM-backed /tmp, for long
/// missions. The 27 h `survey-27h` scenario (100 Hz IMU) peaks at 949 MB resident.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct ReconstructArgs {
    #[command(flatten)]
    pub log: LogArgs,

    #[command(flatten)]
    pub policy: PolicyArgs,

    /// Output folder (created if missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Settings file (TOML); see `hindsight config` for every key and its default.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// IMU grade, for its noise and bias figures [default: the config's, else tactical].
    #[arg(long, value_enum, value_name = "GRADE")]
    pub imu_grade: Option<ImuGrade>,

    /// Where the initial heading comes from [default: auto: every source available
    /// (gyrocompass if the IMU is good enough, magnetometer, the mission's initial_yaw_rad,
    /// --initial-yaw) combined by their sigmas]. A forced source is used alone. Either way the
    /// in-motion alignment checks it against the log and replaces it when the log decides
    /// otherwise (a warning says so); without any source it finds the heading itself.
    #[arg(long, value_enum, value_name = "SOURCE")]
    pub heading: Option<HeadingChoice>,

    /// Initial heading, degrees from north (combined with the other sources, or alone with
    /// --heading given).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub initial_yaw: Option<f64>,

    /// Magnetic declination at the site, degrees, east positive, -180 to 180 [default: the
    /// mission's magnetic_declination_deg, else the World Magnetic Model (2020-2029) or IGRF-14
    /// (1900-2030) at the start's place and date].
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub declination: Option<f64>,

    /// Do not use the magnetometer (neither for the initial heading nor as an aid).
    #[arg(long)]
    pub no_mag: bool,

    /// Self-tuning: estimate from the log the noise figures the configuration does not give
    /// (the IMU's by the likelihood of the filter's innovations, the DVL's, depth sensor's
    /// and EM log's from the scatter of their readings). The estimates are printed, kept in
    /// summary.json and written to tuned.toml for reuse with --config. `off` uses the
    /// configuration's figures and the built-in defaults [default: the config's, else on].
    #[arg(long, value_enum, value_name = "ON_OFF")]
    pub tune: Option<Toggle>,

    /// Trajectory rows per second, per solution [default: 10].
    #[arg(long, value_name = "HZ")]
    pub output_rate: Option<f64>,

    /// Also write a trajectory row at every aiding measurement's epoch.
    #[arg(long)]
    pub aiding_epochs: bool,

    /// The vehicle's 6-DOF model for seed 000's model-aided velocity filter: a built-in
    /// vehicle (nps-auv-ii, remus-100) or a vehicle file (JSON, see `hindsight vehicle
    /// check`). Turns the filter on ([model_velocity] use): driven by /fins, /rpm and the
    /// navigation's attitude, it bridges DVL outages. Without it, [model_velocity] vehicle,
    /// else the mission's vehicle when built in.
    #[arg(long, value_name = "NAME_OR_FILE")]
    pub vehicle: Option<String>,
}

/// Reads the vehicle file `[model_velocity] vehicle` names (a built-in vehicle needs none)
/// into the configuration, and checks that its model can be made: the library reads no
/// files.
pub fn read_vehicle_file(config: &mut Config) -> Result<()> {
    use hindsight::recon::model_velocity::{parse_vehicle_file, vehicle_model, VehicleError};
    use hindsight::vehicle::six_dof::description::Vehicle;
    let name = config.model_velocity.vehicle.clone();
    if name.is_empty() {
        return Ok(());
    }
    if Vehicle::built_in(&name).is_none() {
        let text = std::fs::read_to_string(&name).map_err(|e| VehicleError {
            name: name.clone(),
            reason: format!(
                "neither a built-in vehicle ({}) nor a readable vehicle file ({e})",
                hindsight::recon::model_velocity::built_in_names()
            ),
        })?;
        config.model_velocity.vehicle_file = Some(parse_vehicle_file(&name, &text)?);
    }
    vehicle_model(&name, config.model_velocity.vehicle_file.as_ref())?;
    Ok(())
}

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Toggle {
    On,
    Off,
}

impl ReconstructArgs {
    fn config(&self) -> Result<Config> {
        let mut config = match &self.config {
            Some(path) => super::config::read(path, None)?,
            None => Config::default(),
        };
        if let Some(g) = self.imu_grade {
            config.imu.grade = g.into();
            config.fixed.insert("imu.grade".into());
        }
        if let Some(t) = self.tune {
            config.tune.enabled = t == Toggle::On;
        }
        if let Some(h) = self.heading {
            config.initial.heading = h.into();
        }
        if let Some(y) = self.initial_yaw {
            config.initial.yaw_deg = Some(y);
        }
        if let Some(v) = &self.vehicle {
            config.model_velocity.vehicle = v.clone();
            config.model_velocity.enabled = hindsight::recon::switch::Switch::On;
            read_vehicle_file(&mut config).context("--vehicle")?;
        } else if config.model_velocity.enabled != hindsight::recon::switch::Switch::Off {
            read_vehicle_file(&mut config).context("[model_velocity] vehicle")?;
        }
        if let Some(d) = self.declination {
            config.initial.declination_deg = Some(d);
        }
        if self.no_mag {
            config.mag.enabled = false;
        }
        if let Some(r) = self.output_rate {
            config.output.rate_hz = r;
        }
        config.output.aiding_epochs |= self.aiding_epochs;
        // A clock offset given for the DVL's topic replaces the estimate of its delay.
        let dvl_topic = (self.log.source.topics.iter().rev())
            .find(|(role, _)| role == "dvl")
            .map(|(_, topic)| topic.as_str())
            .or(config.topics.get("dvl").map(String::as_str))
            .unwrap_or("/dvl");
        if self.log.offsets.iter().any(|o| o.topic == dvl_topic) {
            config
                .fixed
                .insert(hindsight::recon::plan::DVL_DELAY_KEY.into());
        }
        config.check().context("command-line options")?;
        Ok(config)
    }
}

#[derive(Debug, Serialize)]
struct Summary {
    hindsight_version: &'static str,
    log: String,
    mission: MissionSummary,
    inputs: Vec<InputCount>,
    initialisation: InitSummary,
    /// Self-tuning's estimates (absent with tuning off).
    tuning: Option<Tuning>,
    /// What was used and why: every aid, calibration state and stage.
    plan: Plan,
    magnetometer: MagSummary,
    epochs: usize,
    trajectory_rows_per_solution: usize,
    residuals: usize,
    rejected: usize,
    dvl_out_of_range: usize,
    /// The DVL's scale factor, bias and misalignment as estimated (absent without DVL).
    dvl_calibration: Option<DvlCalibrationReport>,
    /// The EM log's scale factor and the water current (absent without EM log).
    water: Option<WaterReport>,
    /// The z gyro's scale factor as estimated (it reads this times the true rate).
    gyro_scale_factor_z: Option<calibration::Estimated>,
    depth_skipped_by_interval: usize,
    eml_too_slow: usize,
    gate_resets: usize,
    imu_gaps: Vec<GapSummary>,
    sensors: Vec<SensorStats>,
    duration_s: f64,
    distance_travelled_m: f64,
    final_sigma: FinalSigma,
    truth: Option<TruthSummary>,
    /// Whether the innovations and (with truth) the NEES look consistent.
    consistency: Consistency,
    warnings: Vec<String>,
    run_time_s: RunTime,
    config: Config,
}

#[derive(Debug, Clone, Serialize)]
struct InputCount {
    /// The role's contract topic.
    topic: &'static str,
    /// The log's topic that played it (a ROS 2 recording's `/vehicle/imu/data`).
    log_topic: Option<String>,
    messages: usize,
    used: bool,
}

/// The mission the run used (from the log's record, or standing in for it).
#[derive(Debug, Serialize)]
struct MissionSummary {
    origin_latitude_deg: f64,
    origin_longitude_deg: f64,
    vehicle: String,
    description: String,
}

#[derive(Debug, Serialize)]
struct InitSummary {
    position_source: &'static str,
    position_sigma_m: f64,
    velocity_source: &'static str,
    velocity_sigma_m_s: f64,
    heading_source: &'static str,
    heading_sigma_deg: f64,
    tilt_sigma_deg: f64,
    latitude_deg: f64,
    longitude_deg: f64,
    depth_m: f64,
    roll_deg: f64,
    pitch_deg: f64,
    yaw_deg: f64,
    /// Every heading source: value, sigma, whether it was used.
    heading_sources: Vec<hindsight::recon::heading::HeadingCandidate>,
    heading_unavailable: Vec<String>,
    declination: Option<hindsight::recon::heading::DeclinationUsed>,
    in_motion_alignment: Option<hindsight::recon::in_motion::InMotion>,
}

/// What was done with the magnetometer's readings.
#[derive(Debug, Serialize)]
struct MagSummary {
    readings_used: usize,
    saturated_spans: Vec<hindsight::attitude::mag_checks::SaturatedSpan>,
    calibrated: bool,
    calibration_skipped: Option<String>,
    /// The field magnitude's rms variation beyond the noise, percent of the magnitude.
    magnitude_variation_pct: f64,
    /// Not calibrated, with a varying magnitude: heading updates held correlated longer.
    deviation_unknown: bool,
    reference_field_nt: f64,
    skipped_by_interval: usize,
    disturbed: usize,
}

#[derive(Debug, Serialize)]
struct GapSummary {
    from_ns: i64,
    to_ns: i64,
    seconds: f64,
}

#[derive(Debug, Serialize)]
struct Sigma {
    horizontal_m: f64,
    down_m: f64,
    yaw_deg: f64,
}

#[derive(Debug, Serialize)]
struct FinalSigma {
    forward: Option<Sigma>,
    smoothed: Option<Sigma>,
}

#[derive(Debug, Serialize)]
struct TruthSummary {
    forward: Option<Scores>,
    smoothed: Option<Scores>,
    nees_horizontal_bounds_95: (f64, f64),
    nees_position_bounds_95: (f64, f64),
}

#[derive(Debug, Serialize)]
struct RunTime {
    ingest: f64,
    /// The pipeline's stages before the forward pass.
    plan: f64,
    magnetometer: f64,
    /// Settling and checking the start heading.
    align: f64,
    tune: f64,
    forward: f64,
    /// The DVL clock-offset search (when its innovations asked for it).
    clock_search: f64,
    smoother: f64,
    outputs: f64,
    /// Drawing report.html and its PNGs (part of `outputs`).
    report: f64,
    total: f64,
}

fn final_sigma(s: Option<&Solution>) -> Option<Sigma> {
    s.map(|s| Sigma {
        horizontal_m: s.sigma[0].hypot(s.sigma[1]),
        down_m: s.sigma[2],
        yaw_deg: s.euler_sigma_rad()[2].to_degrees(),
    })
}

/// The configuration's topic roles and ROS 2 conversions, the command line's over them.
fn ingest_options(args: &ReconstructArgs, config: &Config) -> hindsight::ingest::IngestOptions {
    ingest_for(&args.policy, &args.log.source, config)
}

fn ingest_for(
    policy: &super::PolicyArgs,
    source: &super::source::SourceArgs,
    config: &Config,
) -> hindsight::ingest::IngestOptions {
    let mut options = policy.ingest_options(&Default::default());
    options.topics = config.topics.clone();
    options.frame_conventions = config.frames.clone();
    options.ros2 = config.ros2;
    options.keep_log_times = false;
    source.apply(&mut options);
    options
}

pub fn run(args: ReconstructArgs) -> Result<()> {
    let config = args.config()?;
    let job = Job {
        log: args.log.log.clone(),
        out: args.out.clone(),
        ingest: ingest_options(&args, &config),
        offsets: args.log.offsets.clone(),
        mission_defaults: args.log.source.mission_defaults(config.mission.clone()),
        config,
    };
    reconstruct(&job)
}

/// One mission to reconstruct: what `reconstruct` parsed, or what `batch` made for each log.
pub struct Job {
    pub log: PathBuf,
    pub out: PathBuf,
    pub config: Config,
    pub ingest: hindsight::ingest::IngestOptions,
    pub offsets: Vec<hindsight::align::ClockOffset>,
    pub mission_defaults: hindsight::ingest::MissionDefaults,
}

impl Job {
    /// A log reconstructed as `hindsight reconstruct LOG --out DIR [--config FILE]` would.
    pub fn plain(log: &std::path::Path, out: &std::path::Path, config: Config) -> Job {
        let source = super::source::SourceArgs::default();
        Job {
            log: log.to_path_buf(),
            out: out.to_path_buf(),
            mission_defaults: source.mission_defaults(config.mission.clone()),
            ingest: ingest_for(&super::PolicyArgs::default(), &source, &config),
            offsets: Vec::new(),
            config,
        }
    }
}

/// The console's view of the pipeline's stages: a spinner for each, bars for the passes.
#[derive(Default)]
struct StageConsole {
    spinner: std::sync::Mutex<Option<indicatif::ProgressBar>>,
    forward: std::sync::OnceLock<indicatif::ProgressBar>,
    smoother: std::sync::OnceLock<indicatif::ProgressBar>,
}

impl StageConsole {
    fn on_stage(&self, stage: Stage) {
        // What the stage before freed goes back before the next one allocates.
        super::memory::give_back();
        if let Some(s) = self.spinner.lock().ok().and_then(|mut s| s.take()) {
            s.finish_and_clear();
        }
        match stage {
            Stage::Forward => {
                self.forward
                    .get_or_init(|| console::fraction_bar("forward filter"));
            }
            Stage::Smooth => {
                if let Some(b) = self.forward.get() {
                    b.finish_and_clear();
                }
                self.smoother
                    .get_or_init(|| console::fraction_bar("smoother"));
            }
            _ => {
                say!("{} ...", stage.describe());
                if let Ok(mut s) = self.spinner.lock() {
                    *s = Some(console::spinner(stage.describe()));
                }
            }
        }
    }

    fn forward_progress(&self, f: f64) {
        if let Some(b) = self.forward.get() {
            b.set_position((f * 100.0).round() as u64);
        }
    }

    fn smoother_progress(&self, f: f64) {
        if let Some(b) = self.smoother.get() {
            b.set_position((f * 100.0).round() as u64);
        }
    }

    fn finish(&self) {
        for b in [self.forward.get(), self.smoother.get()]
            .into_iter()
            .flatten()
        {
            b.finish_and_clear();
        }
    }
}

/// Reads the log, runs the pipeline, writes the outputs.
pub fn reconstruct(job: &Job) -> Result<()> {
    let started = Instant::now();
    let mut log = super::load(&job.log, &job.ingest, &job.offsets)?;
    let mission = super::settle_mission(&mut log, &job.mission_defaults, &job.log)?;
    super::print_roles(&log);
    let ingest_s = started.elapsed().as_secs_f64();
    say_read(&log, ingest_s);
    // What the filter does not need, or needs prepared, leaves the log: a day's truth waits
    // on disk, and its magnetometer is prepared in place (each would be 150 MB held twice).
    let parked_truth = park_truth(&mut log, &job.config);
    let mag = job
        .config
        .mag
        .enabled
        .then(|| log.take_role::<hindsight::contract::MagneticField>());
    let streams = Streams::of(&log);
    let view = StageConsole::default();
    let (on_stage, fwd_bar, smo_bar) = (
        |s: Stage| view.on_stage(s),
        |f: f64| view.forward_progress(f),
        |f: f64| view.smoother_progress(f),
    );
    let options = pipeline::Options {
        forward_progress: Some(&fwd_bar),
        on_stage: Some(&on_stage),
        mag,
        ..pipeline::Options::default()
    };
    let forward = pipeline::forward(&streams, &mission, &job.config, options)
        .with_context(|| format!("reconstructing {}", job.log.display()));
    let forward = forward.inspect_err(|_| view.finish())?;
    say_forward(&forward);
    let inputs = input_counts(&log, &streams, &forward.config);
    // What the outputs need from the log; the log itself is freed before smoothing.
    let origin = (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    );
    let from_log = report::FromLog::new(streams.gnss, streams.fixes, streams.dvl, origin);
    let log_truth = parked_truth.is_none().then(|| streams.truth.to_vec());
    drop(log);
    let records_failure = forward.pass.run.records.spill_failure();
    let outcome = forward.smooth(Some(&smo_bar), Some(&on_stage));
    view.finish();
    let outcome = outcome?;
    say!("smoother {:.1} s", outcome.times.smoother_s);
    let written = Written {
        job,
        mission: &mission,
        inputs,
        from_log,
        truth: (log_truth, parked_truth),
        records_failure,
        ingest_s,
        started,
    };
    written.write(outcome)
}

/// What the run read, said once.
fn say_read(log: &hindsight::ingest::Log, ingest_s: f64) {
    let streams = Streams::of(log);
    say!(
        "read {} messages in {ingest_s:.1} s; {} IMU samples over {:.0} s",
        log.message_count(),
        streams.imu.len(),
        match (streams.imu.first(), streams.imu.last()) {
            (Some(a), Some(b)) => (b.stamp_ns - a.stamp_ns) as f64 * 1e-9,
            _ => 0.0,
        }
    );
}

/// The plan, the tuning and the start, said once the forward pass is done.
fn say_forward(f: &pipeline::Forward) {
    say!(
        "plan (what is used and why):\n{}",
        indent(&f.plan.to_string())
    );
    if let Some(t) = &f.tuning {
        say!(
            "self-tuning {:.1} s:\n{}",
            f.times.tune_s,
            indent(&t.to_string())
        );
    }
    say!("initial state:\n{}", indent(&f.pass.init.to_string()));
    say!(
        "forward filter {:.1} s ({} epochs, {} measurements)",
        f.forward_time().as_secs_f64(),
        f.pass.run.records.len(),
        f.pass.run.residuals.len(),
    );
}

/// A warning as the command line says it: the library's text, with the option that acts on
/// it.
fn render_warning(w: &Warning) -> String {
    match w {
        Warning::DvlClock {
            suggestion: Some(s),
            ..
        } => format!(
            "{w}: rerun with --offset /dvl={:.1} if the DVL's clock is off",
            s.offset_s
        ),
        Warning::Run(RunWarning::InnovationsTooLarge(x)) => {
            format!(
                "{w} (a clock offset is given with --offset /{}=SECONDS)",
                x.sensor
            )
        }
        Warning::Run(RunWarning::DeclinationUnknown) => format!("{w}: pass --declination DEG"),
        Warning::ForcedOnRefused { .. } => {
            format!("{w} (the rest runs; leave its `use` at \"auto\" to let the log decide)")
        }
        _ => w.to_string(),
    }
}

/// What the outputs are written from, beyond the pipeline's outcome.
struct Written<'a> {
    job: &'a Job,
    mission: &'a hindsight::ingest::Mission,
    inputs: Vec<InputCount>,
    from_log: report::FromLog,
    truth: (Option<Vec<Truth>>, Option<hindsight::spill::Spilled<Truth>>),
    records_failure: Option<String>,
    ingest_s: f64,
    started: Instant,
}

/// A thread's result; its panic goes on.
fn joined<T>(thread: std::thread::ScopedJoinHandle<'_, T>) -> T {
    thread
        .join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// Where the scores' thread writes: the staging (tuned.toml and the report) and the list of
/// files written.
struct Outputs<'a> {
    staging: &'a mut Staging,
    written: &'a mut Vec<PathBuf>,
}

/// The rows the outputs hold: every output epoch (and every epoch with `aiding_epochs`).
fn kept_rows(r: &Reconstruction, config: &Config) -> Vec<usize> {
    (0..r.forward.len())
        .filter(|&k| r.output[k] || config.output.aiding_epochs)
        .collect()
}

impl Written<'_> {
    /// Every output, staged and then renamed together. The solutions are read back once
    /// ([`tables`]): the trajectory's tables are written beside the scores, and beside the
    /// summary, the errors table and the report made from them.
    fn write(self, outcome: pipeline::Outcome) -> Result<()> {
        let outputs_started = Instant::now();
        super::memory::give_back();
        let r = &outcome.reconstruction;
        let keep = kept_rows(r, &outcome.config);
        let job = self.job;
        std::fs::create_dir_all(&job.out).with_context(|| OutputFailed {
            path: job.out.clone(),
        })?;
        let mut staging = Staging::new();
        let origin = (
            self.mission.origin_latitude_deg.to_radians(),
            self.mission.origin_longitude_deg.to_radians(),
        );
        let tables = Tables::create(&mut staging, &job.out, self.has_truth())?;
        let mut written = tables.paths();
        let Tables {
            trajectory,
            foxglove,
            residuals,
            errors,
        } = tables;
        let (to_parquet, parquet_blocks) = tables::channel();
        let (to_mcap, mcap_blocks) = tables::channel();
        let (to_scores, score_blocks) = tables::channel();
        let (to_errors, block_errors) = std::sync::mpsc::sync_channel(1);
        let to_errors = errors.is_some().then_some(to_errors);
        let outputs = Outputs {
            staging: &mut staging,
            written: &mut written,
        };
        // The writers' threads use no rayon: the report, which does, is made on this thread
        // (a rayon worker's, in a batch), so that no thread waits on the pool from outside it.
        let (read, parquet, mcap, errors_table, scored) = std::thread::scope(|s| {
            let parquet = s.spawn(|| -> Result<()> {
                tables::trajectory_parquet(trajectory, parquet_blocks, origin)?;
                tables::write_chunks(residuals, &r.run.residuals, recon_tables::residuals_batch)
            });
            let mcap = s.spawn(|| tables::trajectory_mcap(foxglove, mcap_blocks, origin));
            let errors_table = s.spawn(|| match errors {
                Some(file) => tables::errors_parquet(file, block_errors),
                None => Ok(()),
            });
            let scores = s.spawn(|| -> Result<_> {
                let truth = self.truth_back()?;
                let from_log = self.from_log.clone().with_truth(&truth);
                let sample_rows = tables::sample_rows(&keep);
                let scored = tables::score(score_blocks, &truth, &sample_rows, to_errors);
                Ok((scored, from_log))
            });
            let read = tables::read_blocks(r, &keep, vec![to_parquet, to_mcap, to_scores]);
            let scored = joined(scores).and_then(|(scored, from_log)| {
                let report_inputs = (&keep[..], origin, &from_log);
                self.summary_and_report(&outcome, scored, outputs, report_inputs)
            });
            (
                read,
                joined(parquet),
                joined(mcap),
                joined(errors_table),
                scored,
            )
        });
        // A writer's own failure first: it is why the reading stopped.
        parquet?;
        mcap?;
        errors_table?;
        let mut summary = scored?;
        read?;
        summary.run_time_s.outputs = outputs_started.elapsed().as_secs_f64();
        summary.run_time_s.total = self.started.elapsed().as_secs_f64();
        let path = job.out.join("summary.json");
        super::write_json(&mut staging, &path, &summary)?;
        written.push(path);
        staging.commit().with_context(|| OutputFailed {
            path: job.out.clone(),
        })?;
        print_report(&summary);
        for p in written {
            out!("wrote {}", p.display());
        }
        Ok(())
    }

    /// The summary from the scores, then errors.parquet, tuned.toml and the report.
    fn summary_and_report(
        &self,
        outcome: &pipeline::Outcome,
        scored: tables::Scored,
        out: Outputs<'_>,
        (keep, origin_rad, from_log): (&[usize], (f64, f64), &report::FromLog),
    ) -> Result<Summary> {
        let mut summary = self.summary(outcome, keep, &scored)?;
        if let Some(t) = &summary.tuning {
            let path = self.job.out.join("tuned.toml");
            let mut file = out
                .staging
                .create(&path)
                .with_context(|| OutputFailed { path: path.clone() })?;
            std::io::Write::write_all(&mut file, t.as_toml().as_bytes())
                .with_context(|| OutputFailed { path: path.clone() })?;
            out.written.push(path);
        }
        let started = Instant::now();
        let r = &outcome.reconstruction;
        let page = report::build(&report::Inputs {
            summary: &summary,
            r,
            samples: &scored.samples,
            origin_rad,
            from_log,
            truth_errors: scored
                .errors
                .as_ref()
                .map(|(f, s)| (&f.points[..], &s.points[..])),
            init_text: r.init.to_string(),
        });
        super::write_report(out.staging, &self.job.out, &page, out.written)?;
        summary.run_time_s.report = started.elapsed().as_secs_f64();
        Ok(summary)
    }

    /// Whether the log has a truth to score against (its errors table is then written).
    fn has_truth(&self) -> bool {
        match &self.truth {
            (Some(truth), _) => !truth.is_empty(),
            (None, Some(parked)) => !parked.is_empty(),
            (None, None) => false,
        }
    }

    /// The truth read back (it waited on its temporary file through the smoother; held only
    /// while the errors are taken: a day of it is 140 MB).
    fn truth_back(&self) -> Result<Vec<Truth>> {
        Ok(match &self.truth {
            (Some(truth), _) => truth.clone(),
            (None, Some(parked)) => parked.to_vec().context("reading the truth back")?,
            (None, None) => Vec::new(),
        })
    }

    /// summary.json, but the outputs' and the report's times and the whole run's (filled once
    /// the files are written).
    fn summary(
        &self,
        outcome: &pipeline::Outcome,
        keep: &[usize],
        against: &tables::Scored,
    ) -> Result<Summary> {
        let r = &outcome.reconstruction;
        let config = &outcome.config;
        let mut warnings: Vec<String> = outcome.warnings.iter().map(render_warning).collect();
        // A full disk is no reason to fail: the run held in memory what it meant to spill.
        for why in self
            .records_failure
            .clone()
            .into_iter()
            .chain(r.forward.spill_failure())
            .chain(r.smoothed.spill_failure())
            .take(1)
        {
            warnings.push(format!(
                "memory: the epoch records or solutions could not go to a temporary file \
                 ({why}); they were held in memory instead (set TMPDIR to a disk with room)"
            ));
        }
        let truth = against.errors.as_ref().map(|(fwd, smo)| TruthSummary {
            forward: fwd.sums.scores(),
            smoothed: smo.sums.scores(),
            nees_horizontal_bounds_95: score::bounds_95(2),
            nees_position_bounds_95: score::bounds_95(3),
        });
        let consistency = consistency::assess(
            &outcome.sensors,
            truth.as_ref().and_then(|t| t.forward.as_ref()),
            truth.as_ref().and_then(|t| t.smoothed.as_ref()),
        );
        warnings.extend(consistency.warnings());
        let (first_forward, last_forward) = (r.forward.first()?, r.forward.last()?);
        let last_smoothed = r.smoothed.last()?;
        let times = &outcome.times;
        let mission = self.mission;
        Ok(Summary {
            hindsight_version: env!("CARGO_PKG_VERSION"),
            log: self.job.log.display().to_string(),
            mission: MissionSummary {
                origin_latitude_deg: mission.origin_latitude_deg,
                origin_longitude_deg: mission.origin_longitude_deg,
                vehicle: mission.vehicle.clone(),
                description: mission.description.clone(),
            },
            inputs: self.inputs.clone(),
            tuning: outcome.tuning.clone(),
            plan: outcome.plan.clone(),
            initialisation: init_summary(&r.init),
            magnetometer: mag_summary(r),
            epochs: r.forward.len(),
            trajectory_rows_per_solution: keep.len(),
            residuals: r.run.residuals.len(),
            rejected: r.run.residuals.iter().filter(|x| !x.accepted).count(),
            dvl_out_of_range: r.run.unused[Sensor::Dvl],
            dvl_calibration: outcome
                .plan
                .uses(Part::Aid(Sensor::Dvl))
                .then_some(last_forward.as_ref())
                .flatten()
                .map(|last| calibration::report(last, &config.dvl.calibration_sigma())),
            water: water_summary(r, config, last_forward.as_ref()),
            gyro_scale_factor_z: last_forward
                .as_ref()
                .map(|last| calibration::gyro_scale_report(last, config.imu.spec().gyro_scale())),
            depth_skipped_by_interval: r.run.by_interval[Sensor::Depth],
            eml_too_slow: r.run.unused[Sensor::SpeedLog],
            gate_resets: r.run.gate_resets,
            imu_gaps: r
                .run
                .imu_gaps
                .iter()
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
            distance_travelled_m: against.distance_m,
            final_sigma: FinalSigma {
                forward: final_sigma(last_forward.as_ref()),
                smoothed: final_sigma(last_smoothed.as_ref()),
            },
            truth,
            consistency,
            warnings,
            run_time_s: RunTime {
                ingest: self.ingest_s,
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
                total: self.started.elapsed().as_secs_f64(),
            },
            config: config.clone(),
        })
    }
}

/// The initial state as summary.json has it.
fn init_summary(init: &hindsight::recon::init::Initialisation) -> InitSummary {
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
fn mag_summary(r: &Reconstruction) -> MagSummary {
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
fn water_summary(
    r: &Reconstruction,
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

fn indent(text: &str) -> String {
    text.lines()
        .map(|l| format!("  {l}\n"))
        .collect::<String>()
        .trim_end()
        .to_string()
}

fn print_report(s: &Summary) {
    out!(
        "{:.0} s, {:.0} m travelled (smoothed); {} epochs, {} measurements, {} rejected",
        s.duration_s,
        s.distance_travelled_m,
        s.epochs,
        s.residuals,
        s.rejected
    );
    out!(
        "{:<13} {:>8} {:>9} {:>9} {:>10} {:>10}",
        "sensor",
        "used",
        "rejected",
        "mean NIS",
        "norm mean",
        "norm var"
    );
    for x in &s.sensors {
        out!(
            "{:<13} {:>8} {:>9} {:>6.2}/{} {:>10.3} {:>10.3}",
            x.sensor,
            x.count - x.rejected,
            x.rejected,
            x.mean_nis,
            x.dims,
            x.normalised_mean,
            x.normalised_variance
        );
    }
    if s.dvl_out_of_range > 0 {
        out!(
            "DVL readings out of range (no bottom lock or too high): {}",
            s.dvl_out_of_range
        );
    }
    for (name, sigma) in [
        ("forward", &s.final_sigma.forward),
        ("smoothed", &s.final_sigma.smoothed),
    ] {
        if let Some(x) = sigma {
            out!(
                "final 1-sigma ({name}): horizontal {:.2} m, depth {:.2} m, yaw {:.3} deg",
                x.horizontal_m,
                x.down_m,
                x.yaw_deg
            );
        }
    }
    if let Some(t) = &s.truth {
        for (name, sc) in [("forward", &t.forward), ("smoothed", &t.smoothed)] {
            if let Some(x) = sc {
                out!(
                    "against /truth ({name}): horizontal RMS {:.2} m, max {:.2} m, final {:.2} m; \
                     yaw RMS {:.3} deg; NEES inside 95 % bounds: horizontal {:.1} %, 3-D {:.1} %",
                    x.horizontal_rms_m,
                    x.horizontal_max_m,
                    x.horizontal_final_m,
                    x.yaw_rms_deg,
                    100.0 * x.nees_horizontal_inside_95,
                    100.0 * x.nees_position_inside_95
                );
            }
        }
    }
    if let Some(d) = &s.dvl_calibration {
        out!("DVL calibration: {}", dvl_calibration_line(d));
    }
    if let Some(g) = &s.gyro_scale_factor_z {
        out!("z gyro scale factor: {}", estimated_text(g, 1.0, 6, ""));
    }
    out!("{}", s.consistency.verdict_line());
    for w in &s.warnings {
        say!("warning: {w}");
    }
}

/// The messages of each input, and whether the run used them.
fn input_counts(
    log: &hindsight::ingest::Log,
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

/// The log's truth moved to a temporary file (it is for the scores, after the filter), unless
/// the run starts from it.
fn park_truth(
    log: &mut hindsight::ingest::Log,
    config: &Config,
) -> Option<hindsight::spill::Spilled<Truth>> {
    if config.initial.from_truth {
        return None;
    }
    Some(log.take_role::<Truth>().into_iter().collect())
}

/// An estimate and its sigma (times `scale`), "(prior)" where the log did not tell it, "held"
/// where it was not estimated (a zero prior).
fn estimated_text(e: &calibration::Estimated, scale: f64, digits: usize, unit: &str) -> String {
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
fn dvl_calibration_line(d: &DvlCalibrationReport) -> String {
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
