//! `hindsight study`: a scenario simulated and reconstructed N times (seeds base + i), per
//! case, in parallel, with the runs' and the cases' tables and a plot of the error against
//! time.

use super::{commit_and_list, write_parquet, write_png};
use anyhow::{Context, Result};
use hindsight::output::atomic::Staging;
use hindsight::output::plots::{Series, TrackPlot};
use hindsight::output::study_tables::{runs_batch, summary_batch};
use hindsight::recon::config::Config;
use hindsight::sim::scenario::Scenario;
use hindsight::study::{mean_sigma, run_one, summarise, Case, RunResult};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::path::PathBuf;

/// Monte Carlo study: simulate a scenario with seeds BASE, BASE+1, ..., reconstruct each run
/// with the default settings (or --config) and score it against its truth.
///
/// Seed 002's study (the in-run alignment of a dropped vehicle, four cases of +-10 deg start
/// roll and pitch):
///
///   hindsight study --scenario drop-no-dvl --runs 100 --tilt 10,10 --tilt 10,-10
///       --tilt=-10,10 --tilt=-10,-10 --out study/
///
/// Writes runs.parquet (one row per run), summary.parquet (one row per case: mean and sigma
/// of the roll and pitch errors after the alignment, the alignment time, the horizontal
/// RMS), error_vs_time.png (mean forward horizontal error of each case, and mean + 1 sigma),
/// and prints the summary. The same seeds give the same numbers whatever the thread count.
#[derive(Debug, clap::Args)]
pub struct StudyArgs {
    /// Built-in scenario name (see `hindsight simulate --list`).
    #[arg(
        long,
        required_unless_present = "scenario_file",
        conflicts_with = "scenario_file"
    )]
    pub scenario: Option<String>,

    /// A scenario TOML file instead of a built-in one.
    #[arg(long, value_name = "FILE")]
    pub scenario_file: Option<PathBuf>,

    /// Runs per case (at least 1).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub runs: u64,

    /// First seed; run i uses seed BASE + i.
    #[arg(long, default_value_t = 1)]
    pub seed_base: u64,

    /// A case: the start roll and pitch of a dropped vehicle, deg (repeatable; default: the
    /// scenario's own start, one case).
    #[arg(long, value_name = "ROLL,PITCH", allow_hyphen_values = true, value_parser = parse_tilt)]
    pub tilt: Vec<(f64, f64)>,

    /// Reconstruction settings (TOML, as `hindsight reconstruct --config`).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Worker threads [default: all cores].
    #[arg(long)]
    pub jobs: Option<usize>,
}

fn parse_tilt(text: &str) -> Result<(f64, f64), String> {
    let (r, p) = text
        .split_once(',')
        .ok_or_else(|| format!("`{text}`: give ROLL,PITCH in degrees, e.g. 10,-10"))?;
    let num = |s: &str| {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= 90.0)
            .ok_or_else(|| format!("`{s}`: not an angle in degrees within +-90"))
    };
    Ok((num(r)?, num(p)?))
}

pub fn run(args: StudyArgs) -> Result<()> {
    let scenario = match (&args.scenario, &args.scenario_file) {
        (_, Some(path)) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Scenario::from_toml(&text).with_context(|| format!("in {}", path.display()))?
        }
        (Some(name), None) => Scenario::built_in(name)?,
        (None, None) => anyhow::bail!("give --scenario NAME or --scenario-file FILE"),
    };
    let config = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading the configuration {}", path.display()))?;
            Config::from_toml(&text).with_context(|| format!("configuration {}", path.display()))?
        }
        None => Config::default(),
    };
    let cases: Vec<Case> = if args.tilt.is_empty() {
        vec![Case {
            label: scenario.name.clone(),
            start_roll_deg: None,
            start_pitch_deg: None,
        }]
    } else {
        args.tilt
            .iter()
            .map(|&(r, p)| Case {
                label: format!("roll {r:+} pitch {p:+}"),
                start_roll_deg: Some(r),
                start_pitch_deg: Some(p),
            })
            .collect()
    };
    let scenarios: Vec<Scenario> = cases.iter().map(|c| c.scenario(&scenario)).collect();
    let jobs: Vec<(usize, u64)> = (0..cases.len())
        .flat_map(|k| (0..args.runs).map(move |i| (k, args.seed_base + i)))
        .collect();
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(jobs.len() as u64).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} ({eta} left)")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    } else {
        ProgressBar::hidden()
    };
    let started = std::time::Instant::now();
    let work = || -> Vec<RunResult> {
        jobs.par_iter()
            .map(|&(k, seed)| {
                let r = run_one(&scenarios[k], seed, &config, k).unwrap_or_else(|e| RunResult {
                    case: k,
                    seed,
                    error: Some(e.to_string()),
                    ..RunResult::default()
                });
                bar.inc(1);
                r
            })
            .collect()
    };
    let runs = match args.jobs {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .context("starting the worker threads")?
            .install(work),
        None => work(),
    };
    bar.finish_and_clear();
    let elapsed_s = started.elapsed().as_secs_f64();
    let summaries = summarise(&cases, &runs);

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut staging = Staging::new();
    let mut written = Vec::new();
    let path = args.out.join("runs.parquet");
    write_parquet(&mut staging, &path, runs_batch(&cases, &runs)?, || None)?;
    written.push(path);
    let path = args.out.join("summary.parquet");
    write_parquet(&mut staging, &path, summary_batch(&summaries)?, || None)?;
    written.push(path);
    let path = args.out.join("error_vs_time.png");
    let labels: Vec<(String, String)> = cases
        .iter()
        .map(|c| {
            (
                format!("{} mean", c.label),
                format!("{} mean + 1 sigma", c.label),
            )
        })
        .collect();
    let mut series = Vec::new();
    for (k, (mean_label, upper_label)) in labels.iter().enumerate() {
        let (mean, upper) = error_statistics(&runs, k);
        series.push(Series {
            name: mean_label,
            points: mean,
        });
        series.push(Series {
            name: upper_label,
            points: upper,
        });
    }
    write_png(
        &mut staging,
        &path,
        &TrackPlot {
            title: "forward horizontal error over the runs",
            x_label: "time from the start, s",
            y_label: "horizontal error, m",
            series,
            marks: Vec::new(),
            y_down: false,
            equal_axes: false,
        },
    )?;
    written.push(path);
    commit_and_list(staging, &written, &args.out)?;

    eprintln!(
        "{} runs in {elapsed_s:.1} s ({} threads)",
        runs.len(),
        rayon::current_num_threads()
    );
    print_summary(&summaries);
    for r in runs.iter().filter(|r| r.error.is_some()).take(5) {
        eprintln!(
            "warning: {} seed {}: {}",
            cases[r.case].label,
            r.seed,
            r.error.as_deref().unwrap_or_default()
        );
    }
    Ok(())
}

/// Mean and mean + 1 sigma of case `k`'s forward horizontal error at each second.
type Curve = Vec<(f64, f64)>;
fn error_statistics(runs: &[RunResult], k: usize) -> (Curve, Curve) {
    let mine: Vec<&RunResult> = runs
        .iter()
        .filter(|r| r.case == k && r.error.is_none())
        .collect();
    let len = mine
        .iter()
        .map(|r| r.forward_error_series.len())
        .max()
        .unwrap_or(0);
    let (mut mean, mut upper) = (Vec::new(), Vec::new());
    for t in 0..len {
        if let Some((m, s)) = mean_sigma(
            mine.iter()
                .filter_map(|r| r.forward_error_series.get(t).copied()),
        ) {
            mean.push((t as f64, m));
            upper.push((t as f64, m + s));
        }
    }
    (mean, upper)
}

fn print_summary(summaries: &[hindsight::study::CaseSummary]) {
    let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:+.3}"));
    println!(
        "{:<22} {:>5} {:>6} {:>8} | {:>9} {:>9} | {:>9} {:>9} | {:>11} | {:>9} {:>9}",
        "case",
        "runs",
        "failed",
        "aligned",
        "roll mean",
        "roll sd",
        "pitch mean",
        "pitch sd",
        "aligned at",
        "fwd RMS",
        "smo RMS"
    );
    for s in summaries {
        println!(
            "{:<22} {:>5} {:>6} {:>8} | {:>9} {:>9} | {:>9} {:>9} | {:>9} s | {:>7} m {:>7} m",
            s.label,
            s.runs,
            s.failed,
            s.aligned,
            f(s.roll_error_mean_deg),
            f(s.roll_error_sigma_deg),
            f(s.pitch_error_mean_deg),
            f(s.pitch_error_sigma_deg),
            s.aligned_after_mean_s
                .map_or("-".into(), |x| format!("{x:.1}")),
            s.forward_horizontal_rms_mean_m
                .map_or("-".into(), |x| format!("{x:.1}")),
            s.smoothed_horizontal_rms_mean_m
                .map_or("-".into(), |x| format!("{x:.1}")),
        );
    }
    println!("errors after the alignment (estimate minus truth at its middle), deg; sd: sample standard deviation");
}
