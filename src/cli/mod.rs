//! Command-line interface: clap arguments, validated settings, one file per command.
//!
//! Errors carry context here (anyhow); [`exit_code`] is the one place that maps them to the
//! process exit status.

mod attitude;
mod batch;
mod bench;
mod bench_attitude;
mod bench_identify;
mod bench_reconstruct;
mod bench_simulate;
mod choices;
mod config_command;
mod console;
mod export;
mod identify;
mod identify_six_dof;
mod import;
mod info;
mod memory;
mod reconstruct;
mod simulate;
mod source;
mod study;
mod vehicle;

use anyhow::Result;
use clap::{Parser, Subcommand};
use console::{out, say};
use hindsight::align::{AlignError, ClockOffset};
use hindsight::config::ConfigError;
use hindsight::ingest::{IngestError, IngestOptions, Log, MissionError};
use hindsight::recon::ReconError;
use std::path::{Path, PathBuf};

/// Exit status: a bad command line or configuration file.
pub const EXIT_USAGE: u8 = 2;
/// Exit status: an unexpected failure.
pub const EXIT_FAILURE: u8 = 1;
/// Exit status: the input log cannot be read or breaks the log contract.
pub const EXIT_BAD_INPUT: u8 = 3;
/// Exit status: an output file could not be written.
pub const EXIT_OUTPUT: u8 = 4;

const AFTER_HELP: &str = "\
Exit status: 0 success; 2 bad command line or configuration file; 3 the input log cannot be read or breaks the log
contract (the message names topic, log time and field); 4 an output could not be written;
1 anything else.

Logs follow the recorded-log contract: MCAP with JSON messages whose schemas are in schemas/,
or ROS 2 recordings (rosbag2 MCAP, cdr) of the standard types (sensor_msgs Imu, MagneticField,
NavSatFix, FluidPressure, Range; geometry_msgs TwistWithCovarianceStamped, QuaternionStamped,
PointStamped, PoseWithCovarianceStamped; geographic_msgs GeoPointStamped, GeoPoseStamped;
driver types such as Water Linked's DVL and EvoLogics' USBLLONG: docs/guide/logs.md), or
both in one file. Each role (imu, dvl, ...) takes its default topic, else
the one topic of its type, else --topic ROLE=TOPIC.";

/// Reconstruct what an underwater vehicle did from its recorded sensor logs (MCAP).
#[derive(Debug, Parser)]
#[command(name = "hindsight", version, about, after_help = AFTER_HELP)]
pub struct Args {
    /// Print nothing but errors (no progress, notes, warnings or tables; the outputs and
    /// their report.html are written as usual).
    #[arg(long, short, global = true)]
    pub quiet: bool,

    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    Reconstruct(reconstruct::ReconstructArgs),
    Batch(batch::BatchArgs),
    Attitude(attitude::AttitudeArgs),
    Identify(identify::IdentifyArgs),
    Vehicle(vehicle::VehicleArgs),
    Config(config_command::ConfigArgs),
    Info(info::InfoArgs),
    Export(export::ExportArgs),
    Import(import::ImportArgs),
    Simulate(simulate::SimulateArgs),
    Study(study::StudyArgs),
    /// Measure speed: ingest throughput on a generated log, or the other jobs (reconstruct,
    /// simulate, attitude, identify), as medians and ratios to the ingest.
    Bench(bench::BenchArgs),
}

/// Renames a command's staged outputs into place (the library's writers: their errors map
/// to the output exit status), then lists them.
fn commit_and_list(folder: hindsight::output::files::Folder) -> Result<()> {
    for p in folder.commit()? {
        out!("wrote {}", p.display());
    }
    Ok(())
}

/// Output written by a command could not be written (exit status 4).
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}", path.display())]
pub struct OutputFailed {
    pub path: PathBuf,
}

/// Runs a command.
pub fn run(args: Args) -> Result<()> {
    console::set_quiet(args.quiet);
    match args.command {
        Command::Reconstruct(a) => reconstruct::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Attitude(a) => attitude::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Vehicle(a) => vehicle::run(a),
        Command::Config(a) => config_command::run(a),
        Command::Info(a) => info::run(a),
        Command::Export(a) => export::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Import(a) => import::run(a),
        Command::Study(a) => study::run(a),
        Command::Bench(a) => bench::run(a),
    }
}

/// Maps an error to the exit status (see [`AFTER_HELP`]).
/// What the user can give on the command line to get past `err`: the library says what is
/// wrong, this says which flag helps.
pub fn hint(err: &anyhow::Error) -> Option<&'static str> {
    use hindsight::identify::record::RecordError;
    use hindsight::recon::alignment::start::InitError;
    use hindsight::reconstruction::Error as ReconstructionError;
    use hindsight::sim::scenario::ScenarioError;
    err.chain().find_map(|cause| {
        // The library's reconstruction boxes what failed under it.
        let boxed = cause.downcast_ref::<ReconstructionError>();
        let (ingest, recon) = match boxed {
            Some(ReconstructionError::Read { source, .. }) => (Some(&**source), None),
            Some(ReconstructionError::Reconstruct { source, .. }) => (None, Some(&**source)),
            _ => (cause.downcast_ref::<IngestError>(), cause.downcast_ref()),
        };
        if let Some(e) = ingest {
            match e {
                IngestError::UnknownSchema { .. } => {
                    Some("pass --skip-unknown to ignore the topic")
                }
                IngestError::TooManyInvalid { .. } => Some("--max-invalid raises the limit"),
                _ => None,
            }
        } else if let Some(ReconError::Init(InitError::NoHeading(_))) = recon {
            Some("give the initial heading with --initial-yaw DEG (or [initial] yaw_deg)")
        } else if let Some(InitError::NoHeading(_)) = cause.downcast_ref() {
            Some("give the initial heading with --initial-yaw DEG (or [initial] yaw_deg)")
        } else if let Some(ScenarioError::Unknown { .. }) = cause.downcast_ref() {
            Some("give your own with --scenario-file FILE")
        } else if let Some(hindsight::config::ConfigError::Toml { section, .. }) =
            cause.downcast_ref()
        {
            Some(config_command::every_key_hint(section))
        } else if let Some(RecordError::NoDvl { .. }) = cause.downcast_ref() {
            Some("give the speed with --speed M_S")
        } else {
            None
        }
    })
}

pub fn exit_code(err: &anyhow::Error) -> u8 {
    use hindsight::reconstruction::Error as ReconstructionError;
    // downcast_ref sees context values and the root error through every context layer.
    if err.downcast_ref::<OutputFailed>().is_some()
        || err
            .downcast_ref::<hindsight::output::WriteError>()
            .is_some()
        || matches!(
            err.downcast_ref::<ReconstructionError>(),
            Some(ReconstructionError::Write(_))
        )
    {
        EXIT_OUTPUT
    } else if matches!(
        err.downcast_ref::<ReconstructionError>(),
        Some(
            ReconstructionError::Read { .. }
                | ReconstructionError::Align { .. }
                | ReconstructionError::Mission { .. }
                | ReconstructionError::Reconstruct { .. }
        )
    ) || err.downcast_ref::<IngestError>().is_some()
        || err.downcast_ref::<batch::MissionsFailed>().is_some()
        || err.downcast_ref::<AlignError>().is_some()
        || err.downcast_ref::<MissionError>().is_some()
        || err.downcast_ref::<ReconError>().is_some()
        || err
            .downcast_ref::<hindsight::attitude::compare::InputError>()
            .is_some()
        || err
            .downcast_ref::<hindsight::identify::record::RecordError>()
            .is_some()
        || err
            .downcast_ref::<hindsight::vehicle::six_dof::description::VehicleError>()
            .is_some()
        || err.downcast_ref::<vehicle::SingularMass>().is_some()
    {
        EXIT_BAD_INPUT
    } else if err.downcast_ref::<ConfigError>().is_some()
        || err
            .downcast_ref::<identify::CoefficientArgError>()
            .is_some()
        || err.downcast_ref::<simulate::SimulateArgError>().is_some()
        || err.downcast_ref::<batch::ArchiveError>().is_some()
        || err
            .downcast_ref::<hindsight::sim::scenario::ScenarioError>()
            .is_some()
        || err
            .downcast_ref::<hindsight::sim::run::SimError>()
            .is_some_and(|e| matches!(e, hindsight::sim::run::SimError::Scenario(_)))
        || err
            .downcast_ref::<hindsight::recon::model_velocity::VehicleError>()
            .is_some()
    {
        EXIT_USAGE
    } else {
        EXIT_FAILURE
    }
}

/// Options shared by the commands that read a log.
#[derive(Debug, Clone, clap::Args)]
pub struct LogArgs {
    /// Recorded log (MCAP, contract schemas, JSON messages).
    pub log: PathBuf,

    /// Clock offset of one topic, added to its stamps: TOPIC=SECONDS (repeatable),
    /// e.g. --offset /dvl=-0.120 when the DVL stamps run 120 ms late. Without one for the
    /// DVL, its stamp delay is estimated from the log (and used when it is clear: the plan).
    #[arg(long = "offset", value_name = "TOPIC=SECONDS")]
    pub offsets: Vec<ClockOffset>,

    #[command(flatten)]
    pub source: source::SourceArgs,
}

/// What a command that needs clean data tolerates in a log.
#[derive(Debug, Clone, clap::Args)]
pub struct PolicyArgs {
    /// Skip topics whose schema or encoding hindsight cannot decode (counted and reported)
    /// instead of failing.
    #[arg(long)]
    pub skip_unknown: bool,

    /// Largest fraction of invalid messages per topic that is dropped with a warning; more
    /// fails the run (0 = any invalid message fails, 1 = never fail).
    #[arg(long = "max-invalid", value_name = "FRACTION", default_value_t = 0.01,
          value_parser = parse_fraction)]
    pub max_invalid_fraction: f64,
}

impl Default for PolicyArgs {
    /// As the command line has it when neither option is given.
    fn default() -> Self {
        PolicyArgs {
            skip_unknown: false,
            max_invalid_fraction: 0.01,
        }
    }
}

fn parse_fraction(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is not a fraction in [0, 1]"))
    }
}

impl PolicyArgs {
    /// Ingest options of this policy with `source`'s topic roles and conversions.
    fn ingest_options(&self, source: &source::SourceArgs) -> IngestOptions {
        let mut options = IngestOptions {
            skip_unknown: self.skip_unknown,
            max_invalid_fraction: self.max_invalid_fraction,
            keep_messages: true,
            ..IngestOptions::default()
        };
        source.apply(&mut options);
        options
    }
}

/// Prints the roles not played by their default topic (found by type or named), so that a
/// user sees which ROS 2 topic became the IMU.
fn print_roles(log: &Log) {
    use hindsight::ingest::RoleSource;
    for c in log
        .roles
        .iter()
        .filter(|c| c.source != RoleSource::DefaultTopic)
    {
        let how = match c.source {
            RoleSource::Named => "as named",
            _ => "the one topic of its type",
        };
        say!("{}: {} ({how})", c.role, c.topic);
    }
}

/// Reads a log, applies the clock offsets and prints warnings to stderr.
fn load(path: &Path, options: &IngestOptions, offsets: &[ClockOffset]) -> Result<Log> {
    use anyhow::Context;
    let reading = || format!("reading {}", path.display());
    let sqlite = hindsight::ingest::sqlite::bag_at(path).with_context(reading)?;
    let mut log = if sqlite.is_some() {
        // A database is read by SQLite, not streamed: a spinner, not a byte bar.
        let spinner = console::spinner("reading the bag");
        let log = hindsight::ingest::read_log(path, options).with_context(reading)?;
        spinner.finish_and_clear();
        log
    } else {
        let file = std::fs::File::open(path)
            .map_err(IngestError::from)
            .with_context(reading)?;
        let size = file.metadata().map(|m| m.len()).unwrap_or(0);
        let bar = console::bytes_bar(size, "reading the log");
        let input = std::io::BufReader::with_capacity(1 << 20, bar.wrap_read(file));
        let log = hindsight::ingest::read_log_from(input, options).with_context(reading)?;
        bar.finish_and_clear();
        log
    };
    hindsight::align::apply_offsets(&mut log, offsets)
        .with_context(|| format!("aligning {}", path.display()))?;
    for w in log.warnings() {
        say!("warning: {w}");
    }
    Ok(log)
}

/// The log's mission (its record, else `defaults` and the first GNSS fix), its reference
/// tracks placed on the origin; warns where that origin may not be the tracks'.
fn settle_mission(
    log: &mut hindsight::ingest::Log,
    defaults: &hindsight::ingest::MissionDefaults,
    path: &Path,
) -> Result<hindsight::ingest::Mission> {
    use anyhow::Context;
    let (mission, notes) = log
        .settle_mission(defaults)
        .with_context(|| format!("reading {}", path.display()))?;
    for w in notes {
        say!("warning: {w} (--origin LAT,LON)");
    }
    Ok(mission)
}
