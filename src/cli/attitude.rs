//! `hindsight attitude LOG --out DIR`: seed 001's attitude-method comparison on any log.

use super::choices::{self, Preset};
use super::config_command::{self, SectionChoice};
use super::console::{self, out, say};
use super::PolicyArgs;
use anyhow::{Context, Result};
use hindsight::attitude::compare::{self, Method, MethodRun, MethodScore, Reference};
use hindsight::attitude::config::AttitudeConfig;
use hindsight::attitude::dead_reckoning::gaps_longer_than;
use hindsight::attitude::mag_calibration;
use hindsight::attitude::mag_checks::without_saturation;
use hindsight::attitude::score::reference_from_truth;
use hindsight::attitude::{AhrsInputs, AttitudeSample};
use hindsight::contract::{Dvl, Imu, MagneticField, PositionFix, Truth};
use hindsight::output::attitude_tables;
use hindsight::output::files::Folder;
use hindsight::output::plots::{thin, Plot, Series};
use hindsight::output::report::{Block, Report, Section};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Compare attitude methods from a MEMS AHRS by the DVL dead reckoning each one gives.
///
/// Seed 001's comparison on any log: every method turns the same IMU and magnetometer
/// readings into an attitude; each attitude rotates the same DVL body velocity into NED
/// (lever arm and mounting rotation from the config), integrated from the `start` mark
/// (/position_fix labelled "start"; else the mission origin). Methods (--methods):
///
///   raw            seed 001 eq. 1-4: accelerometer roll/pitch, tilt-compensated magnetic yaw
///   ekf            seed 001 Table 1, parameters of Table 6
///   ukf            seed 001 Table 2, parameters of Table 7
///   cf             seed 001 Table 3 (complementary filter), gains of Table 8
///   mekf           quaternion error-state Kalman filter with gyro-bias states
///   mekf-smoothed  the MEKF smoothed forward-backward over the whole log
///
/// Seed 001 names the process noise R and the measurement noise Q; the config uses the usual
/// names (process_noise = the paper's R). Its printed measurement covariances are not
/// positive definite: they are raised to a floor, with a message.
///
/// Scores: the horizontal distance from each track's end to the `end` mark, in m and in % of
/// the path; with /truth, roll/pitch/yaw RMS and max errors and BROAD's
/// total/heading/inclination RMS (over the log's `broad.movement_intervals_ns` when it has
/// them). Without an `end` mark, the closest return of each track to its start when the run
/// comes back; without /truth, the angles are compared with the smoothed MEKF's. The table
/// says which. Without a magnetometer, raw, ekf, ukf and cf are skipped and the MEKF runs on
/// gravity alone (yaw from the gyro, from the mission's initial_yaw_rad).
///
/// The magnetometer is calibrated on the log itself (hard and soft iron) when the run turns
/// through enough headings; the declination is the mission's, else the World Magnetic
/// Model's at the mission origin and the log's date. A stretch without a valid DVL reading
/// longer than dvl.max_gap_s (5 s) is not bridged: the track holds its position, with a
/// warning.
///
/// Writes to DIR, atomically: attitude.parquet (stamp, method, roll/pitch/yaw, dead-reckoned
/// north/east/down), attitude_summary.parquet (one row per method), tracks_xy.png and
/// tracks_xz.png (when there is a DVL track).
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct AttitudeArgs {
    /// Recorded log.
    #[arg(required_unless_present = "print_config")]
    pub log: Option<PathBuf>,

    /// Clock offset of one topic, added to its stamps: TOPIC=SECONDS (repeatable).
    #[arg(long = "offset", value_name = "TOPIC=SECONDS")]
    pub offsets: Vec<hindsight::align::ClockOffset>,

    #[command(flatten)]
    pub policy: PolicyArgs,

    #[command(flatten)]
    pub source: super::source::SourceArgs,

    /// Output folder (created if missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR", required_unless_present = "print_config")]
    pub out: Option<PathBuf>,

    /// Methods to run, comma-separated [default: all].
    #[arg(long, value_enum, value_delimiter = ',', value_name = "METHOD,...")]
    pub methods: Vec<choices::Method>,

    /// Settings file (TOML); `hindsight config attitude` prints every key and its default.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// The same as `hindsight config attitude` (kept for old scripts).
    #[arg(long, hide = true)]
    pub print_config: bool,

    /// The settings a config file is laid over: hindsight's defaults, or seed 001's EKF and
    /// UKF matrices exactly as printed (for reproducing the paper; its measurement
    /// covariances are not positive definite and are raised to a floor, with a note).
    #[arg(long, value_enum, default_value_t = Preset::Hindsight, value_name = "PRESET")]
    pub preset: Preset,

    /// Magnetometer calibration: `auto` fits hard and soft iron to the log's own readings
    /// (an ellipsoid, or an ellipse when the run turns only about the vertical) and applies
    /// it to every method, when the readings cover enough headings (else a warning and the
    /// readings as they are); `none` uses the readings as they are.
    #[arg(long, value_enum, default_value_t = MagCalibration::Auto, value_name = "MODE")]
    pub mag_calibration: MagCalibration,

    /// Magnetic declination, deg east [default: the mission's magnetic_declination_deg,
    /// else the World Magnetic Model's (2020-2029) or IGRF-14's (1900-2030) at the mission
    /// origin on the log's date].
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub declination: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MagCalibration {
    Auto,
    #[value(alias = "off")]
    None,
}

pub fn run(args: AttitudeArgs) -> Result<()> {
    if args.print_config {
        print!("{}", config_command::default_toml(SectionChoice::Attitude));
        return Ok(());
    }
    let (Some(log_path), Some(out)) = (args.log.clone(), args.out.clone()) else {
        anyhow::bail!("a LOG and --out DIR are needed");
    };
    let config = match &args.config {
        Some(path) => {
            config_command::read(path, Some(&AttitudeConfig::preset(args.preset.into())))?
        }
        None => AttitudeConfig::preset(args.preset.into()),
    };
    let filters = config.filters()?;
    let mut said = console::Said::default();
    for a in &filters.adjustments {
        said.note(a.to_string());
    }
    let (log, mission) = read_log(&args, &log_path)?;
    let imu: &[Imu] = log.role();
    let raw_mag: &[MagneticField] = log.role();
    let dvl: &[Dvl] = log.role();
    let marks: &[PositionFix] = log.role();
    let truth: &[Truth] = log.role();

    // Times in messages: seconds into the log (from its first IMU sample).
    let into_log_s = |stamp_ns: i64| (stamp_ns - imu[0].stamp_ns) as f64 * 1e-9;
    let mag = prepared_mag(
        raw_mag,
        &config,
        args.mag_calibration,
        &into_log_s,
        &mut said,
    );
    let methods = chosen_methods(&args, mag.is_empty(), &mut said)
        .with_context(|| format!("attitude from {}", log_path.display()))?;
    let declination_rad =
        declination_deg(args.declination, &mission, imu[0].stamp_ns, &mut said).to_radians();
    let inputs = AhrsInputs {
        imu,
        mag: &mag,
        declination_rad,
        initial_yaw_rad: mission.initial_yaw_rad,
    };
    let filters_started = Instant::now();
    let runs = compare::run_methods(&methods, &inputs, &filters);
    let filters_s = filters_started.elapsed().as_secs_f64();

    // Scores.
    let mark = |label: &str| {
        marks
            .iter()
            .find(|m| m.label == label)
            .map(|m| Vector3::new(m.north_m, m.east_m, m.down_m.unwrap_or(0.0)))
    };
    let start = mark("start");
    let end = mark("end");
    dvl_notes(
        dvl,
        (start, end),
        config.dvl.max_gap_s,
        &into_log_s,
        &mut said,
    );
    let (reference_attitude, attitude_against) = reference_from(truth, &runs);
    let intervals = movement_intervals(&log);
    let scored =
        move |t: i64| intervals.is_empty() || intervals.iter().any(|[a, b]| (*a..=*b).contains(&t));
    let mounting = config.dvl.mounting();
    let reference = Reference {
        dvl,
        mounting: &mounting,
        max_gap_s: config.dvl.max_gap_s,
        start_ned_m: start.or(Some(Vector3::zeros())),
        end_ned_m: end,
        truth: &reference_attitude,
        scored: &scored,
    };
    let scores: Vec<MethodScore> = runs
        .par_iter()
        .map(|r| compare::score(r, &reference))
        .collect();

    let attitude_against = attitude_against.as_deref();
    let table = Table::new(&runs, &scores, attitude_against, end.is_some(), filters_s);
    let page = Page {
        log: &log_path,
        said: &said,
        table: &table,
        read: what_was_read(&log, mag.len()),
    };
    let against = attitude_against.map(|name| Against {
        name,
        attitude: &reference_attitude,
    });
    write_outputs(&out, &runs, &scores, against, start, end, &page)?;
    table.print();
    Ok(())
}

/// The log read, its mission settled and at least two IMU samples in it.
fn read_log(
    args: &AttitudeArgs,
    log_path: &std::path::Path,
) -> Result<(hindsight::ingest::Log, hindsight::ingest::Mission)> {
    let started = Instant::now();
    let ingest = args.policy.ingest_options(&args.source);
    let mut log = super::load(log_path, &ingest, &args.offsets)?;
    let defaults = args.source.mission_defaults(Default::default());
    let mission = super::settle_mission(&mut log, &defaults, log_path)?;
    super::print_roles(&log);
    let imu: &[Imu] = log.role();
    if imu.len() < 2 {
        return Err(compare::InputError::NoImu)
            .with_context(|| format!("attitude from {}", log_path.display()));
    }
    say!(
        "read {} in {:.1} s: {} IMU, {} magnetometer, {} DVL readings",
        log_path.display(),
        started.elapsed().as_secs_f64(),
        imu.len(),
        log.role::<MagneticField>().len(),
        log.role::<Dvl>().len()
    );
    Ok((log, mission))
}

/// What the report says was read (`mag_kept`: the magnetometer's readings after the
/// saturation checks).
fn what_was_read(log: &hindsight::ingest::Log, mag_kept: usize) -> String {
    format!(
        "{} IMU, {} magnetometer ({} after saturation checks), {} DVL readings; \
         {} position marks; /truth: {}",
        log.role::<Imu>().len(),
        log.role::<MagneticField>().len(),
        mag_kept,
        log.role::<Dvl>().len(),
        log.role::<PositionFix>().len(),
        if log.role::<Truth>().is_empty() {
            "no"
        } else {
            "yes"
        }
    )
}

/// The angles' reference: the truth, else the smoothed MEKF (every 10th sample); and its
/// name.
fn reference_from(truth: &[Truth], runs: &[MethodRun]) -> (Vec<AttitudeSample>, Option<String>) {
    let truth_attitude = reference_from_truth(truth);
    if !truth_attitude.is_empty() {
        (truth_attitude, Some("/truth".to_string()))
    } else if let Some(r) = compare::attitude_reference(runs) {
        let decimated = r.attitude.iter().step_by(10).copied().collect();
        (decimated, Some(r.method.name().to_string()))
    } else {
        (Vec::new(), None)
    }
}

/// The spans a benchmark log scores (its `broad` record's movement intervals; none: all).
fn movement_intervals(log: &hindsight::ingest::Log) -> Vec<[i64; 2]> {
    log.metadata
        .get("broad")
        .and_then(|b| b.get("movement_intervals_ns"))
        .and_then(|text| serde_json::from_str(text).ok())
        .unwrap_or_default()
}

/// The declination, deg east: given, else the mission's, else the World Magnetic Model's or
/// IGRF-14's at the mission origin on the log's date (0 with a warning when none has one).
fn declination_deg(
    given: Option<f64>,
    mission: &hindsight::ingest::Mission,
    t0_ns: i64,
    said: &mut console::Said,
) -> f64 {
    if let Some(d) = given.or(mission.magnetic_declination_deg) {
        return d;
    }
    let (lat, lon) = (mission.origin_latitude_deg, mission.origin_longitude_deg);
    match hindsight::geomag::declination(lat, lon, 0.0, t0_ns) {
        Ok(d) => {
            said.info(format!(
                "declination {:.2} deg (+-{:.2}) from the {} at {lat:.4}, {lon:.4} on the \
                 log's date",
                d.declination_deg,
                d.sigma_deg,
                d.model.name()
            ));
            d.declination_deg
        }
        Err(e) => {
            said.warn(format!(
                "no declination: the mission gives none and {e}; 0 used (give one \
             with --declination)"
            ));
            0.0
        }
    }
}

/// What the report says besides the tracks.
struct Page<'a> {
    log: &'a std::path::Path,
    said: &'a console::Said,
    table: &'a Table,
    /// What was read.
    read: String,
}

fn write_outputs(
    out: &std::path::Path,
    runs: &[MethodRun],
    scores: &[MethodScore],
    against: Option<Against<'_>>,
    start: Option<Vector3<f64>>,
    end: Option<Vector3<f64>>,
    page: &Page<'_>,
) -> Result<()> {
    let attitude_against = against.as_ref().map(|a| a.name);
    let mut folder = Folder::create(out)?;
    let mut batches = runs.iter().zip(scores).flat_map(|(r, s)| {
        r.attitude
            .chunks(hindsight::output::parquet::ROWS_PER_BATCH)
            .map(move |c| attitude_tables::attitude_batch(r.method.name(), c, &s.track))
    });
    let first = batches
        .next()
        .unwrap_or_else(|| attitude_tables::attitude_batch("raw", &[], &[]))?;
    folder.parquet("attitude.parquet", first, || batches.next())?;
    let summary = attitude_tables::summary_batch(runs, scores, attitude_against)?;
    folder.table("attitude_summary.parquet", summary)?;
    folder.report(&report_of(
        runs,
        scores,
        against.as_ref(),
        (start, end),
        page,
    ))?;
    super::commit_and_list(folder)
}

/// The page: the comparison, what was read, the tracks, the errors against the reference,
/// the warnings.
fn report_of(
    runs: &[MethodRun],
    scores: &[MethodScore],
    against: Option<&Against<'_>>,
    (start, end): (Option<Vector3<f64>>, Option<Vector3<f64>>),
    page: &Page<'_>,
) -> Report {
    let mut report = Report {
        title: format!(
            "hindsight attitude: {}",
            page.log.file_name().unwrap_or_default().to_string_lossy()
        ),
        subtitle: format!("{}: attitude methods compared", page.log.display()),
        sections: vec![
            Section::new("Comparison")
                .with(Block::table(
                    page.table.headers.clone(),
                    page.table.rows.clone(),
                ))
                .with(Block::text(page.table.caption.clone())),
            Section::new("Inputs, calibration and notes")
                .with(Block::text(page.read.clone()))
                .with(Block::Facts(
                    page.said
                        .notes
                        .iter()
                        .map(|n| ("note".to_string(), n.clone()))
                        .collect(),
                )),
        ],
        footer: format!("hindsight {}", env!("CARGO_PKG_VERSION")),
    };
    if scores.iter().any(|s| !s.track.is_empty()) {
        report.sections.push(tracks_section(scores, start, end));
    }
    if let Some(against) = against {
        report.sections.push(error_section(runs, against));
    }
    report
        .sections
        .push(Section::new("Warnings").with(Block::Warnings(page.said.warnings.clone())));
    report
}

/// The same DVL dead reckoning with each method's attitude, in plan and in depth.
fn tracks_section(
    scores: &[MethodScore],
    start: Option<Vector3<f64>>,
    end: Option<Vector3<f64>>,
) -> Section {
    let marks: Vec<(&str, Vector3<f64>)> = [("start", start), ("end", end)]
        .into_iter()
        .filter_map(|(n, p)| Some((n, p?)))
        .collect();
    let mut tracks = Section::new("Dead-reckoned tracks").with(Block::text(
        "The same DVL dead reckoning with each method's attitude.",
    ));
    for (stem, title, x_label, y_label, y_down, pick) in [
        (
            "tracks_xy",
            "DVL dead reckoning, plan view",
            "east (m)",
            "north (m)",
            false,
            (|p: &Vector3<f64>| (p.y, p.x)) as fn(&Vector3<f64>) -> (f64, f64),
        ),
        (
            "tracks_xz",
            "DVL dead reckoning, north against depth",
            "north (m)",
            "down (m)",
            true,
            |p: &Vector3<f64>| (p.x, p.z),
        ),
    ] {
        let mut plot = Plot::new(title, x_label, y_label);
        plot.series = scores
            .iter()
            .map(|s| {
                let points: Vec<(f64, f64)> = s.track.iter().map(|t| pick(&t.ned_m)).collect();
                Series::line(s.method.name(), thin(&points, 4000))
            })
            .collect();
        plot.marks = marks
            .iter()
            .map(|(n, p)| (n.to_string(), pick(p)))
            .collect();
        plot.y_down = y_down;
        plot.equal_axes = !y_down;
        tracks.push(Block::figure(stem, title, plot));
    }
    tracks
}

/// What the dead reckoning lacks: a start or end mark, the DVL, or readings across a gap.
fn dvl_notes(
    dvl: &[Dvl],
    (start, end): (Option<Vector3<f64>>, Option<Vector3<f64>>),
    max_gap_s: f64,
    into_log_s: &dyn Fn(i64) -> f64,
    said: &mut console::Said,
) {
    if !dvl.is_empty() && start.is_none() {
        said.note(
            "no `start` mark on /position_fix: dead reckoning from the mission origin".into(),
        );
    }
    if dvl.is_empty() {
        said.note("no DVL readings: dead reckoning skipped, attitude scored only".into());
    } else if end.is_none() {
        said.note("no `end` mark on /position_fix: end-point errors not available".into());
    }
    let gaps = gaps_longer_than(dvl, max_gap_s);
    if let Some(longest) = gaps
        .iter()
        .max_by(|a, b| a.duration_s().total_cmp(&b.duration_s()))
    {
        said.warn(format!(
            "{} stretch(es) without a valid DVL reading longer than dvl.max_gap_s = \
             {} s (longest {:.1} s from {:.1} s into the log, {:.1} s in all): not bridged, the \
             dead reckoning holds its position through them",
            gaps.len(),
            max_gap_s,
            longest.duration_s(),
            into_log_s(longest.from_ns),
            gaps.iter().map(|g| g.duration_s()).sum::<f64>()
        ));
    }
}

/// The magnetometer's readings the methods take: saturated stretches left out (warned), then
/// the hard and soft iron fitted and applied when the fit is trusted.
fn prepared_mag(
    raw_mag: &[MagneticField],
    config: &AttitudeConfig,
    calibration: MagCalibration,
    into_log_s: &dyn Fn(i64) -> f64,
    said: &mut console::Said,
) -> Vec<MagneticField> {
    let (mag, spans) = without_saturation(raw_mag, config.magnetometer.saturation_repeats);
    for s in &spans {
        said.warn(format!(
            "magnetometer saturated (an axis stuck at its extreme) for {:.1} s from \
             {:.3} s into the log ({} readings): not used",
            (s.to_ns - s.from_ns) as f64 * 1e-9,
            into_log_s(s.from_ns),
            s.readings
        ));
    }
    if calibration != MagCalibration::Auto || mag.is_empty() {
        return mag;
    }
    let cal = match mag_calibration::fit(&mag) {
        Ok(cal) => cal,
        Err(e) => {
            said.warn(format!("magnetometer calibration not applied: {e}"));
            return mag;
        }
    };
    let h = cal.hard_iron * 1e9;
    let fitted = format!(
        "magnetometer calibration ({:?} fit, {} readings, {} of 36 heading sectors): \
         hard iron [{:.0}, {:.0}, {:.0}] nT; field magnitude scatter {:.2} % -> {:.2} %",
        cal.kind,
        cal.readings,
        cal.sectors_covered,
        h.x,
        h.y,
        h.z,
        cal.scatter_before * 100.0,
        cal.scatter_after * 100.0
    );
    match cal.trusted() {
        Ok(()) => {
            said.info(fitted);
            cal.applied(&mag)
        }
        Err(why) => {
            said.note(format!("{fitted}; not applied: {why}"));
            mag
        }
    }
}

/// The methods asked for (every one by default); without magnetometer readings those that
/// take yaw from it are skipped with a warning.
fn chosen_methods(
    args: &AttitudeArgs,
    no_mag: bool,
    said: &mut console::Said,
) -> Result<Vec<Method>, compare::InputError> {
    let mut methods: Vec<Method> = if args.methods.is_empty() {
        Method::ALL.to_vec()
    } else {
        args.methods.iter().map(|&m| m.into()).collect()
    };
    methods.dedup();
    if no_mag {
        let skipped: Vec<&str> = methods
            .iter()
            .filter(|m| m.needs_magnetometer())
            .map(|m| m.name())
            .collect();
        if !skipped.is_empty() {
            said.warn(format!(
                "no magnetometer readings on /mag: skipping {} (they take yaw from \
                 it); the MEKF runs on gravity alone, its yaw from the gyro",
                skipped.join(", ")
            ));
        }
        methods.retain(|m| !m.needs_magnetometer());
    }
    if methods.is_empty() {
        return Err(compare::InputError::NoMagnetometer);
    }
    Ok(methods)
}

/// The attitude the methods' angles are measured against: `/truth`, or the smoothed MEKF.
struct Against<'a> {
    name: &'a str,
    attitude: &'a [AttitudeSample],
}

/// Each method's roll, pitch and heading error against time, one picture per angle.
fn error_section(runs: &[MethodRun], against: &Against<'_>) -> Section {
    let t0 = against.attitude.first().map_or(0, |a| a.stamp_ns);
    let series: Vec<(&str, compare::ErrorSeries)> = runs
        .iter()
        .filter(|r| r.method.name() != against.name)
        .map(|r| {
            (
                r.method.name(),
                compare::euler_error_series(&r.attitude, against.attitude),
            )
        })
        .collect();
    let mut section = Section::new("Attitude errors against time").with(Block::text(format!(
        "Each method's roll, pitch and heading less {}'s, at {}'s samples.",
        against.name, against.name
    )));
    for (k, (stem, angle)) in [
        ("error_roll", "roll"),
        ("error_pitch", "pitch"),
        ("error_heading", "heading"),
    ]
    .into_iter()
    .enumerate()
    {
        let title = format!("{angle} error against {}", against.name);
        let mut plot = Plot::new(&title, "time (s)", "error (deg)");
        plot.series = series
            .iter()
            .map(|(name, errors)| {
                let points: Vec<(f64, f64)> = errors
                    .iter()
                    .map(|(t, e)| ((t - t0) as f64 * 1e-9, e[k]))
                    .collect();
                Series::trace(*name, thin(&points, 4000))
            })
            .collect();
        section.push(Block::figure(stem, &title, plot));
    }
    section
}

/// The comparison (seed 001's Tables 9-10, with the truth errors when there are some), and
/// what its columns are measured against: printed, and in the report.
struct Table {
    headers: Vec<String>,
    rows: Vec<Vec<String>>,
    caption: String,
}

impl Table {
    fn new(
        runs: &[MethodRun],
        scores: &[MethodScore],
        attitude_against: Option<&str>,
        has_end_mark: bool,
        filters_s: f64,
    ) -> Self {
        let na = |v: Option<f64>, digits: usize| {
            v.map_or("N/A".to_string(), |v| format!("{v:.digits$}"))
        };
        let returns = !has_end_mark && scores.iter().any(|s| s.closest_return_m.is_some());
        let (distance_header, distance_caption) = if has_end_mark {
            (
                "end err m",
                "end err: distance of the track's end from the `end` mark",
            )
        } else if returns {
            (
                "return m",
                "return: closest return of the track to its start (no `end` mark; the run \
                 comes back)",
            )
        } else {
            (
                "end err m",
                "end err: N/A (no `end` mark, and the run does not come back to its start)",
            )
        };
        let headers = [
            "method",
            distance_header,
            "path m",
            "% path",
            "roll rms",
            "pitch rms",
            "yaw rms",
            "total rms",
            "notes",
        ]
        .map(String::from)
        .to_vec();
        let rows = runs
            .iter()
            .zip(scores)
            .map(|(r, s)| {
                let e = s.euler.as_ref();
                let (distance, percent) = if returns {
                    (s.closest_return_m, s.closest_return_percent())
                } else {
                    (s.end_error_m, s.end_error_percent())
                };
                let mut notes = r.notes.clone();
                if attitude_against == Some(s.method.name()) {
                    notes.insert(0, "the angles' reference".to_string());
                }
                vec![
                    s.method.name().to_string(),
                    na(distance, 3),
                    na(s.path_m, 1),
                    na(percent, 2),
                    na(e.map(|e| e.roll_rms_deg), 2),
                    na(e.map(|e| e.pitch_rms_deg), 2),
                    na(e.map(|e| e.yaw_rms_deg), 2),
                    na(s.broad.map(|b| b.total_deg), 2),
                    notes.join("; "),
                ]
            })
            .collect();
        let angles_caption = match attitude_against {
            Some("/truth") => "angles: RMS error against /truth, deg".to_string(),
            Some(method) => format!(
                "angles: RMS difference from {method}, deg (no /truth in the log: the methods \
                 are compared with each other, not with the truth)"
            ),
            None => "angles: N/A (no /truth, and no MEKF to compare with)".to_string(),
        };
        Table {
            headers,
            rows,
            caption: format!(
                "{distance_caption}; {angles_caption}; {filters_s:.2} s for all methods"
            ),
        }
    }

    fn print(&self) {
        out!();
        console::print_table(&self.headers, &self.rows, &[-14, 10, 9, 8, 9, 9, 9, 9, -2]);
        out!("({})\n", self.caption);
    }
}
