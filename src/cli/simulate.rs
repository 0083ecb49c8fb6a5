//! `hindsight simulate`: a scenario to a log, with truth.

use super::console::{out, say};
use super::OutputFailed;
use anyhow::{bail, Context, Result};
use hindsight::output::atomic::Staging;
use hindsight::sim::file::{simulate_to_file, SimFileError};
use hindsight::sim::scenario::{Scenario, BUILT_IN};
use hindsight::sim::writer;
use hindsight::sim::zigzag;
use hindsight::vehicle::six_dof::description::Vehicle;
use std::path::PathBuf;

/// Simulate a mission and write its log (with `/truth`), following the log contract.
///
/// The truth moves on the WGS-84 rotating Earth; the IMU measures exactly what a perfect IMU
/// would along it, then each sensor adds its error model. Scenarios are TOML data: the built-in
/// ones are listed by --list; --scenario-file runs your own (same format, see scenarios/).
/// The same scenario and seed give a byte-identical file.
///
/// Dynamic scenarios (long-dive-dynamic, zigzag-rudder-20-20, zigzag-planes-10-10,
/// turning-circle, drop-entry) are flown by the 6-DOF vehicle model and its autopilot
/// (RK4 at the IMU rate) and also log /fins and the propeller's /rpm. Their vehicle is a
/// built-in one (nps-auv-ii, remus-100) or a vehicle JSON file (--vehicle);
/// --coef-uncertainty 0.1 flies a "true" vehicle whose every coefficient is off by a seeded
/// normal 10 % (seed 000 case 2), recorded in the log's `vehicle_truth` metadata.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct SimulateArgs {
    /// Built-in scenario name (see --list).
    #[arg(long, required_unless_present_any = ["list", "scenario_file"], conflicts_with = "scenario_file")]
    pub scenario: Option<String>,

    /// A scenario TOML file instead of a built-in one.
    #[arg(long, value_name = "FILE")]
    pub scenario_file: Option<PathBuf>,

    /// Seed of every random draw (sensor errors and noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Output log (MCAP, zstd chunks, with summary).
    #[arg(long, value_name = "FILE.mcap", required_unless_present = "list")]
    pub out: Option<PathBuf>,

    /// Dynamic scenarios: fly this vehicle (a built-in name or a vehicle JSON file) instead
    /// of the scenario's.
    #[arg(long, value_name = "NAME|FILE")]
    pub vehicle: Option<String>,

    /// Dynamic scenarios: 1-sigma relative error of the true vehicle's coefficients (0.1 =
    /// 10 %), drawn with --seed.
    #[arg(long, value_name = "FRACTION")]
    pub coef_uncertainty: Option<f64>,

    /// Zig-zags (zigzag-A-B, flown by seed 004's heave-pitch model): forward speed, m/s
    /// [default: 3.084].
    #[arg(long, value_name = "M/S")]
    pub speed: Option<f64>,

    /// Zig-zags: weight minus buoyancy, N (a known ballast change; positive heavy)
    /// [default: 0, neutral].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub weight_minus_buoyancy: Option<f64>,

    /// Zig-zags: length of the run, s [default: 200].
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,

    /// List the built-in scenarios and exit.
    #[arg(long)]
    pub list: bool,
}

/// A zig-zag with the command line's speed, ballast and duration.
fn zigzag_options(
    mut spec: zigzag::ZigzagSpec,
    args: &SimulateArgs,
) -> Result<zigzag::ZigzagSpec, SimulateArgError> {
    let positive = |flag: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(SimulateArgError(format!(
                "{flag} {v}: give a positive number"
            )))
        }
    };
    if let Some(u) = args.speed {
        spec.constants.speed_m_s = positive("--speed", u)?;
    }
    if let Some(d) = args.duration {
        spec.duration_s = positive("--duration", d)?;
    }
    if let Some(n) = args.weight_minus_buoyancy {
        if !n.is_finite() {
            return Err(SimulateArgError(format!(
                "--weight-minus-buoyancy {n}: give a number of newtons"
            )));
        }
        spec.constants.weight_minus_buoyancy_n = n;
    }
    Ok(spec)
}

pub fn run(args: SimulateArgs) -> Result<()> {
    if args.list {
        return list();
    }
    // Seed 004's zig-zags are flown by the heave-pitch model, not the kinematic simulator.
    let zigzag = args
        .scenario
        .as_deref()
        .and_then(zigzag::ZigzagSpec::built_in)
        .map(|spec| zigzag_options(spec, &args))
        .transpose()?;
    let scenario = match zigzag {
        Some(_) => None,
        None => Some(scenario_of(&args)?),
    };
    if zigzag.is_some() && (args.vehicle.is_some() || args.coef_uncertainty.is_some()) {
        return Err(SimulateArgError(
            "--vehicle and --coef-uncertainty apply to the 6-DOF scenarios, not to seed 004's zig-zags".into(),
        )
        .into());
    }
    let Some(out) = args.out else {
        bail!("give --out FILE.mcap")
    };
    let started = std::time::Instant::now();
    if let Some(spec) = zigzag {
        let mut staging = Staging::new();
        let file = staging
            .create(&out)
            .with_context(|| OutputFailed { path: out.clone() })?;
        let mut w = writer::LogWriter::new(
            std::io::BufWriter::new(file),
            writer::WriterOptions::default(),
        )?;
        say!("simulating `{}` (seed {}) ...", spec.name, args.seed);
        let r = zigzag::run(&spec, args.seed, &mut w)?;
        finish_log(w, staging, &out)?;
        out!(
            "{}: {} messages, {:.0} s, plane reversals at {} s",
            out.display(),
            r.messages,
            spec.duration_s,
            r.reversals_s
                .iter()
                .map(|t| format!("{t:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        return Ok(());
    }
    let Some(scenario) = scenario else {
        bail!("give --scenario NAME or --scenario-file FILE")
    };
    say!("simulating `{}` (seed {}) ...", scenario.name, args.seed);
    let interactive = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let summary = simulate_to_file(&scenario, args.seed, &out, |done| {
        if interactive {
            eprint!("\r  {:3.0} % of the mission", done * 100.0);
        }
    })
    .map_err(|e| match e {
        SimFileError::Output { path, source } => {
            anyhow::Error::new(source).context(OutputFailed { path })
        }
        SimFileError::Run(e) => e.into(),
    })?;
    if interactive {
        say!();
    }
    let bytes = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
    out!(
        "{}: {} messages, {:.0} s of mission, {:.1} MB, simulated in {:.1} s",
        out.display(),
        summary.messages,
        summary.duration_s,
        bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Every built-in scenario with its description.
fn list() -> Result<()> {
    for (name, _) in BUILT_IN {
        let s = Scenario::built_in(name)?;
        out!("{name:<20} {}", s.description);
    }
    for name in zigzag::BUILT_IN {
        if let Some(s) = zigzag::ZigzagSpec::built_in(name) {
            out!("{name:<20} {}", s.description());
        }
    }
    Ok(())
}

/// The scenario named or read from its file, with the 6-DOF options applied; the zig-zags'
/// options refused.
fn scenario_of(args: &SimulateArgs) -> Result<Scenario> {
    let mut scenario = match (&args.scenario, &args.scenario_file) {
        (_, Some(path)) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Scenario::from_toml(&text).with_context(|| format!("in {}", path.display()))?
        }
        (Some(name), None) => Scenario::built_in(name)?,
        (None, None) => bail!("give --scenario NAME or --scenario-file FILE"),
    };
    let base = (args.scenario_file.as_deref()).and_then(std::path::Path::parent);
    dynamic_options(&mut scenario, &args.vehicle, args.coef_uncertainty, base)?;
    if args.speed.is_some() || args.weight_minus_buoyancy.is_some() || args.duration.is_some() {
        return Err(SimulateArgError(
            "--speed, --weight-minus-buoyancy and --duration apply to seed 004's zig-zags \
             (zigzag-A-B), not to this scenario"
                .into(),
        )
        .into());
    }
    Ok(scenario)
}

/// A simulate option that does not fit the scenario (exit status 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SimulateArgError(String);

/// Applies --vehicle and --coef-uncertainty to a dynamic scenario, and reads its vehicle
/// file when it names one (relative to the scenario file, else to the working directory).
fn dynamic_options(
    scenario: &mut Scenario,
    vehicle: &Option<String>,
    coef_uncertainty: Option<f64>,
    base: Option<&std::path::Path>,
) -> Result<()> {
    let Some(d) = scenario.dynamics.as_mut() else {
        if vehicle.is_some() || coef_uncertainty.is_some() {
            return Err(SimulateArgError(format!(
                "--vehicle and --coef-uncertainty need a dynamic scenario (one with [dynamics]); \
                 `{}` is kinematic",
                scenario.name
            ))
            .into());
        }
        return Ok(());
    };
    if let Some(f) = coef_uncertainty {
        if !(0.0..=0.5).contains(&f) {
            return Err(SimulateArgError(format!(
                "--coef-uncertainty {f}: give a fraction in [0, 0.5] (0.1 = 10 %)"
            ))
            .into());
        }
        d.coef_uncertainty = f;
    }
    let from_command_line = vehicle.is_some();
    if let Some(v) = vehicle {
        d.vehicle = v.clone();
    }
    if Vehicle::built_in(&d.vehicle).is_none() {
        let path = match base {
            Some(dir) if !from_command_line => dir.join(&d.vehicle),
            _ => PathBuf::from(&d.vehicle),
        };
        let text = std::fs::read_to_string(&path).map_err(|e| {
            SimulateArgError(format!(
                "vehicle `{}`: not a built-in vehicle ({}) and reading {} failed: {e}",
                d.vehicle,
                hindsight::vehicle::six_dof::description::BUILT_IN
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
                path.display(),
            ))
        })?;
        d.vehicle_json = Some(text);
    }
    Ok(())
}

/// Closes the log (summary, index), flushes it to disk and renames it into place.
pub(super) fn finish_log(
    w: writer::LogWriter<std::io::BufWriter<std::fs::File>>,
    staging: Staging,
    out: &std::path::Path,
) -> Result<()> {
    let failed = || OutputFailed {
        path: out.to_path_buf(),
    };
    w.finish()?
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(failed)?
        .sync_all()
        .with_context(failed)?;
    staging.commit().with_context(failed)?;
    Ok(())
}
