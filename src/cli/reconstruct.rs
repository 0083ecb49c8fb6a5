//! `hindsight reconstruct LOG --out DIR`: the arguments, the console and its hints around
//! the library's one entry ([`hindsight::reconstruct`]).

use super::choices::{HeadingChoice, ImuGrade};
use super::console;
use super::console::{out, say};
use super::{LogArgs, PolicyArgs};
use anyhow::{Context, Result};
use hindsight::config::Section;
use hindsight::recon::config::Config;
use hindsight::recon::pipeline::{self, Stage};
use hindsight::recon::stats::RunWarning;
use hindsight::reconstruction::summary::{dvl_calibration_line, estimated_text, Summary};
use hindsight::reconstruction::{Job, Note, Observer, Warning};
use std::path::{Path, PathBuf};

/// Reconstruct the trajectory: strapdown INS, 26-state error-state filter (with self-tuned noise), RTS smoother.
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
/// missions. The 27 h `survey-27h` scenario (100 Hz IMU) stays under 1 GB resident
/// (docs/results/speed.md).
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
            Some(path) => super::config_command::read(path, None)?,
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
            config.model_velocity.enabled = hindsight::recon::on_off_auto::Switch::On;
            read_vehicle_file(&mut config).context("--vehicle")?;
        } else if config.model_velocity.enabled != hindsight::recon::on_off_auto::Switch::Off {
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

/// The configuration's topic roles and ROS 2 conversions, the command line's over them.
fn ingest_options(args: &ReconstructArgs, config: &Config) -> hindsight::ingest::IngestOptions {
    let mut options = args.policy.ingest_options(&Default::default());
    options.topics = config.topics.clone();
    options.frame_conventions = config.frames.clone();
    options.ros2 = config.ros2;
    options.keep_log_times = false;
    args.log.source.apply(&mut options);
    options
}

pub fn run(args: ReconstructArgs) -> Result<()> {
    let config = args.config()?;
    let job = Job {
        ingest: ingest_options(&args, &config),
        offsets: args.log.offsets.clone(),
        mission_defaults: args.log.source.mission_defaults(config.mission.clone()),
        ..Job::new(&args.log.log, config)
    };
    reconstruct(&job, &args.out)
}

/// The console's view of the reconstruction: the reading's bar, a spinner for each stage,
/// bars for the passes, and what the library notes said once.
#[derive(Default)]
struct StageConsole {
    /// The reading's bar and the log's size in bytes.
    reading: std::sync::Mutex<Option<(indicatif::ProgressBar, u64)>>,
    spinner: std::sync::Mutex<Option<indicatif::ProgressBar>>,
    forward: std::sync::OnceLock<indicatif::ProgressBar>,
    smoother: std::sync::OnceLock<indicatif::ProgressBar>,
}

impl StageConsole {
    fn on_note(&self, note: Note<'_>) {
        match note {
            Note::Reading { bytes } => {
                let bar = match bytes {
                    // A database is read by SQLite, not streamed: a spinner, not a byte bar.
                    None => console::spinner("reading the bag"),
                    Some(size) => console::bytes_bar(size, "reading the log"),
                };
                if let Ok(mut r) = self.reading.lock() {
                    *r = Some((bar, bytes.unwrap_or(0)));
                }
            }
            Note::ReadWarning(w) => say!("warning: {w}"),
            Note::MissionWarning(w) => say!("warning: {w} (--origin LAT,LON)"),
            Note::Read { log, seconds } => {
                if let Some((bar, _)) = self.reading.lock().ok().and_then(|mut r| r.take()) {
                    bar.finish_and_clear();
                }
                say_read(log, seconds);
            }
            Note::Forward(f) => say_forward(f),
            Note::Smoothed { seconds } => say!("smoother {seconds:.1} s"),
        }
    }

    fn read_progress(&self, f: f64) {
        if let Some((bar, size)) = self.reading.lock().ok().as_deref().and_then(Option::as_ref) {
            bar.set_position((f * *size as f64).round() as u64);
        }
    }

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
        if let Some((bar, _)) = self.reading.lock().ok().and_then(|mut r| r.take()) {
            bar.finish_and_clear();
        }
        for b in [self.forward.get(), self.smoother.get()]
            .into_iter()
            .flatten()
        {
            b.finish_and_clear();
        }
    }
}

/// Reads the log, runs the pipeline, writes the outputs into `out`, saying what happens.
pub fn reconstruct(job: &Job, out: &Path) -> Result<()> {
    let view = StageConsole::default();
    let (on_stage, read_bar, fwd_bar, smo_bar) = (
        |s: Stage| view.on_stage(s),
        |f: f64| view.read_progress(f),
        |f: f64| view.forward_progress(f),
        |f: f64| view.smoother_progress(f),
    );
    let on_note = |n: Note<'_>| view.on_note(n);
    let observer = Observer {
        on_note: Some(&on_note),
        on_stage: Some(&on_stage),
        read_progress: Some(&read_bar),
        forward_progress: Some(&fwd_bar),
        smoother_progress: Some(&smo_bar),
    };
    let done = hindsight::reconstruct(job, observer);
    view.finish();
    super::memory::give_back();
    let mut r = done.map_err(anyhow::Error::from)?;
    let written = r.write(out).map_err(anyhow::Error::from)?;
    print_report(&r.summary);
    for p in written {
        out!("wrote {}", p.display());
    }
    Ok(())
}

/// What the run read, said once.
fn say_read(log: &hindsight::ingest::Log, ingest_s: f64) {
    super::print_roles(log);
    let streams = hindsight::recon::Streams::of(log);
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
    let Warning::Pipeline(p) = w else {
        return w.to_string();
    };
    match p {
        pipeline::Warning::DvlClock {
            suggestion: Some(s),
            ..
        } => format!(
            "{w}: rerun with --offset /dvl={:.1} if the DVL's clock is off",
            s.offset_s
        ),
        pipeline::Warning::Run(RunWarning::InnovationsTooLarge(x)) => {
            format!(
                "{w} (a clock offset is given with --offset /{}=SECONDS)",
                x.sensor
            )
        }
        pipeline::Warning::Run(RunWarning::DeclinationUnknown) => {
            format!("{w}: pass --declination DEG")
        }
        pipeline::Warning::ForcedOnRefused { .. } => {
            format!("{w} (the rest runs; leave its `use` at \"auto\" to let the log decide)")
        }
        _ => w.to_string(),
    }
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
    if let Some(c) = &s.sound_speed_scale {
        out!(
            "speed of sound: the acoustic ranges' times {}",
            estimated_text(c, 1.0, 5, "")
        );
    }
    out!("{}", s.consistency.verdict_line());
    for w in &s.warnings {
        say!("warning: {}", render_warning(w));
    }
}
