//! `hindsight simulate`: a scenario to a log, with truth.

use super::OutputFailed;
use anyhow::{bail, Context, Result};
use hindsight::output::atomic::Staging;
use hindsight::sim::scenario::{Scenario, BUILT_IN};
use hindsight::sim::zigzag;
use hindsight::sim::{run, writer};
use std::path::PathBuf;

/// Simulate a mission and write its log (with `/truth`), following the log contract.
///
/// The truth moves on the WGS-84 rotating Earth; the IMU measures exactly what a perfect IMU
/// would along it, then each sensor adds its error model. Scenarios are TOML data: the built-in
/// ones are listed by --list; --scenario-file runs your own (same format, see scenarios/).
/// The same scenario and seed give a byte-identical file.
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

    /// List the built-in scenarios and exit.
    #[arg(long)]
    pub list: bool,
}

pub fn run(args: SimulateArgs) -> Result<()> {
    if args.list {
        for (name, _) in BUILT_IN {
            let s = Scenario::built_in(name)?;
            println!("{name:<16} {}", s.description);
        }
        for name in zigzag::BUILT_IN {
            if let Some(s) = zigzag::ZigzagSpec::built_in(name) {
                println!("{name:<16} {}", s.description());
            }
        }
        return Ok(());
    }
    // Seed 004's zig-zags are flown by the heave-pitch model, not the kinematic simulator.
    let zigzag = args
        .scenario
        .as_deref()
        .and_then(zigzag::ZigzagSpec::built_in);
    let scenario = match (&args.scenario, &args.scenario_file) {
        _ if zigzag.is_some() => None,
        (_, Some(path)) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Some(Scenario::from_toml(&text).with_context(|| format!("in {}", path.display()))?)
        }
        (Some(name), None) => Some(Scenario::built_in(name)?),
        (None, None) => bail!("give --scenario NAME or --scenario-file FILE"),
    };
    let Some(out) = args.out else {
        bail!("give --out FILE.mcap")
    };
    let started = std::time::Instant::now();
    let mut staging = Staging::new();
    let file = staging
        .create(&out)
        .with_context(|| OutputFailed { path: out.clone() })?;
    let mut w = writer::LogWriter::new(
        std::io::BufWriter::new(file),
        writer::WriterOptions::default(),
    )?;
    if let Some(spec) = zigzag {
        eprintln!("simulating `{}` (seed {}) ...", spec.name, args.seed);
        let r = zigzag::run(&spec, args.seed, &mut w)?;
        finish_log(w, staging, &out)?;
        println!(
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
    eprintln!("simulating `{}` (seed {}) ...", scenario.name, args.seed);
    let interactive = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let summary = run::run_with_progress(&scenario, args.seed, &mut w, |done| {
        if interactive {
            eprint!("\r  {:3.0} % of the mission", done * 100.0);
        }
    })?;
    if interactive {
        eprintln!();
    }
    finish_log(w, staging, &out)?;
    let bytes = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
    println!(
        "{}: {} messages, {:.0} s of mission, {:.1} MB, simulated in {:.1} s",
        out.display(),
        summary.messages,
        summary.duration_s,
        bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Closes the log (summary, index), flushes it to disk and renames it into place.
fn finish_log(
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
