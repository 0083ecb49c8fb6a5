//! `hindsight study`: a scenario simulated and reconstructed N times (seeds base + i), per
//! case, in parallel, with the runs' and the cases' tables and a plot of the error against
//! time.

use super::commit_and_list;
use super::console::{out, say};
use anyhow::{Context, Result};
use hindsight::output::files::Folder;
use hindsight::output::plots::{Plot, Series};
use hindsight::output::report::{Block, Report, Section};
use hindsight::output::study_tables::{error_vs_time_batch, runs_batch, summary_batch};
use hindsight::recon::config::Config;
use hindsight::sim::scenario::Scenario;
use hindsight::study::{
    error_vs_time, run_solutions, summarise, Case, CaseSummary, RunResult, Solution, TimeRow,
};
use rayon::prelude::*;
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
/// Seed 000's study (the model-aided velocity filter on the 5.5 h dive, exact and 10 %
/// uncertain coefficients, four solutions of the same simulated runs):
///
///   hindsight study --scenario long-dive-dynamic --imu-rate-hz 10 --runs 100 --coef-uncertainty 0
///       --coef-uncertainty 0.1 --solution pure=configs/seed000-pure.toml
///       --solution koifman=configs/seed000-koifman.toml
///       --solution proposed=configs/seed000-proposed.toml --out study000/
///
/// Writes runs.parquet (one row per run and solution), summary.parquet (one row per case
/// and solution: mean and sigma of the roll and pitch errors after the alignment, the
/// alignment time, the horizontal RMS), error_vs_time.parquet (RMS over the runs of the
/// forward and smoothed horizontal error, and the mean body-x velocity error, against
/// time), error_vs_time.png (the forward and smoothed RMS of each case and solution), and
/// prints the summary. The same seeds give the same numbers whatever the thread count.
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

    /// A case: the true vehicle's coefficients drawn about the vehicle file's with this
    /// 1-sigma fraction (0.1 = 10 %; 0: exact), for a dynamic scenario (repeatable).
    #[arg(long, value_name = "FRACTION", conflicts_with = "tilt")]
    pub coef_uncertainty: Vec<f64>,

    /// Sample the scenario's IMU at this rate instead of its own, every sensor's rate capped
    /// at it (seed 000's SDINS runs at 10 Hz; a study of 100 long runs needs the speed).
    #[arg(long, value_name = "HZ")]
    pub imu_rate_hz: Option<f64>,

    /// Reconstruction settings (TOML, as `hindsight reconstruct --config`).
    #[arg(long, value_name = "FILE", conflicts_with = "solution")]
    pub config: Option<PathBuf>,

    /// A solution to compare: LABEL=FILE, reconstruction settings applied to every run
    /// (repeatable; each run is simulated once and reconstructed with each).
    #[arg(long, value_name = "LABEL=FILE", value_parser = parse_solution)]
    pub solution: Vec<(String, PathBuf)>,

    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Worker threads [default: all cores].
    #[arg(long)]
    pub jobs: Option<usize>,
}

fn parse_solution(text: &str) -> Result<(String, PathBuf), String> {
    let (label, file) = text
        .split_once('=')
        .filter(|(l, f)| !l.trim().is_empty() && !f.trim().is_empty())
        .ok_or_else(|| {
            format!("`{text}`: give LABEL=FILE, e.g. proposed=configs/seed000-proposed.toml")
        })?;
    Ok((label.trim().to_string(), PathBuf::from(file.trim())))
}

fn read_config(path: &std::path::Path) -> Result<Config> {
    let mut config: Config = super::config_command::read(path, None)?;
    super::reconstruct::read_vehicle_file(&mut config)
        .with_context(|| format!("configuration {}", path.display()))?;
    Ok(config)
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
    let scenario = study_scenario(&args)?;
    let solutions = study_solutions(&args)?;
    let cases = study_cases(&args, &scenario)?;
    let scenarios: Vec<Scenario> = cases.iter().map(|c| c.scenario(&scenario)).collect();
    let jobs: Vec<(usize, u64)> = (0..cases.len())
        .flat_map(|k| (0..args.runs).map(move |i| (k, args.seed_base + i)))
        .collect();
    let started = std::time::Instant::now();
    let runs = run_all(&jobs, &scenarios, &solutions, args.jobs)?;
    let elapsed_s = started.elapsed().as_secs_f64();
    let labels: Vec<String> = solutions.iter().map(|s| s.label.clone()).collect();
    let summaries = summarise(&cases, &labels, &runs);
    let curves = error_vs_time(&runs, cases.len(), solutions.len());

    let mut folder = Folder::create(&args.out)?;
    write_tables(&mut folder, (&cases, &labels), (&runs, &summaries, &curves))?;
    let plot = error_plot(&cases, &labels, &curves);
    let failed = failures(&cases, &runs);
    let ran = format!(
        "{} runs in {elapsed_s:.1} s ({} threads)",
        runs.len(),
        rayon::current_num_threads()
    );
    let report = study_report(
        &args,
        &scenario,
        (&cases, &labels),
        &summaries,
        (&plot, &ran, &failed),
    );
    folder.report(&report)?;
    commit_and_list(folder)?;

    say!("{ran}");
    print_summary(&summary_rows(&summaries));
    print_error_vs_time(&cases, &labels, &curves);
    for w in failed.iter().take(5) {
        say!("warning: {w}");
    }
    Ok(())
}

/// Every run of every case, each seed simulated once and reconstructed with each solution;
/// a failed run is a row with its error.
fn run_all(
    jobs: &[(usize, u64)],
    scenarios: &[Scenario],
    solutions: &[Solution],
    threads: Option<usize>,
) -> Result<Vec<RunResult>> {
    let bar = super::console::bar(jobs.len() as u64, "study", "runs");
    let work = || -> Vec<RunResult> {
        jobs.par_iter()
            .flat_map(|&(k, seed)| {
                let failed = |solution: usize, e: &dyn std::fmt::Display| RunResult {
                    case: k,
                    solution,
                    seed,
                    error: Some(e.to_string()),
                    ..RunResult::default()
                };
                let results: Vec<RunResult> = match run_solutions(&scenarios[k], seed, solutions, k)
                {
                    Ok(each) => each
                        .into_iter()
                        .enumerate()
                        .map(|(j, r)| r.unwrap_or_else(|e| failed(j, &e)))
                        .collect(),
                    Err(e) => (0..solutions.len()).map(|j| failed(j, &e)).collect(),
                };
                bar.inc(1);
                results
            })
            .collect()
    };
    let runs = match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .context("starting the worker threads")?
            .install(work),
        None => work(),
    };
    bar.finish_and_clear();
    Ok(runs)
}

/// runs.parquet, summary.parquet and error_vs_time.parquet.
fn write_tables(
    folder: &mut Folder,
    (cases, labels): (&[Case], &[String]),
    (runs, summaries, curves): (&[RunResult], &[CaseSummary], &[TimeRow]),
) -> Result<()> {
    folder.table("runs.parquet", runs_batch(cases, labels, runs)?)?;
    folder.table("summary.parquet", summary_batch(summaries)?)?;
    let curves = error_vs_time_batch(cases, labels, curves)?;
    folder.table("error_vs_time.parquet", curves)?;
    Ok(())
}

/// The runs that failed, one line each.
fn failures(cases: &[Case], runs: &[RunResult]) -> Vec<String> {
    runs.iter()
        .filter(|r| r.error.is_some())
        .map(|r| {
            format!(
                "{} seed {}: {}",
                cases[r.case].label,
                r.seed,
                r.error.as_deref().unwrap_or_default()
            )
        })
        .collect()
}

/// The study's page: the cases, the error against time, the failed runs.
fn study_report(
    args: &StudyArgs,
    scenario: &Scenario,
    (cases, labels): (&[Case], &[String]),
    summaries: &[CaseSummary],
    (plot, ran, failed): (&Plot, &str, &[String]),
) -> Report {
    let rows = summary_rows(summaries);
    Report {
        title: format!("hindsight study: {}", scenario.name),
        subtitle: format!(
            "{} case(s) x {} seed(s) from {}; solutions: {}",
            cases.len(),
            args.runs,
            args.seed_base,
            labels.join(", ")
        ),
        sections: vec![
            Section::new("Cases")
                .with(Block::table(SUMMARY_HEADERS, rows))
                .with(Block::text(SUMMARY_CAPTION))
                .with(Block::text(ran.to_string())),
            Section::new("Error against time").with(Block::figure(
                "error_vs_time",
                "Horizontal error against /truth, RMS over the runs, per case and solution.",
                plot.clone(),
            )),
            Section::new("Warnings").with(Block::Warnings(failed.to_vec())),
        ],
        footer: format!("hindsight {}", env!("CARGO_PKG_VERSION")),
    }
}

/// The scenario flown: built in or from a file, at the IMU rate asked for.
fn study_scenario(args: &StudyArgs) -> Result<Scenario> {
    let scenario = match (&args.scenario, &args.scenario_file) {
        (_, Some(path)) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            Scenario::from_toml(&text).with_context(|| format!("in {}", path.display()))?
        }
        (Some(name), None) => Scenario::built_in(name)?,
        (None, None) => anyhow::bail!("give --scenario NAME or --scenario-file FILE"),
    };
    let scenario = match args.imu_rate_hz {
        Some(hz) => scenario
            .with_imu_rate(hz)
            .with_context(|| format!("--imu-rate-hz {hz}"))?,
        None => scenario,
    };
    Ok(scenario)
}

/// The solutions each run is reconstructed with: the configuration files given, else one.
fn study_solutions(args: &StudyArgs) -> Result<Vec<Solution>> {
    let solutions: Vec<Solution> = if args.solution.is_empty() {
        vec![Solution {
            label: "default".into(),
            config: match &args.config {
                Some(path) => read_config(path)?,
                None => Config::default(),
            },
        }]
    } else {
        args.solution
            .iter()
            .map(|(label, path)| {
                Ok(Solution {
                    label: label.clone(),
                    config: read_config(path)?,
                })
            })
            .collect::<Result<_>>()?
    };
    Ok(solutions)
}

/// The cases: start tilts, or coefficient uncertainties, or the scenario as it is.
fn study_cases(args: &StudyArgs, scenario: &Scenario) -> Result<Vec<Case>> {
    if !args.coef_uncertainty.is_empty() && scenario.dynamics.is_none() {
        anyhow::bail!(
            "--coef-uncertainty needs a dynamic scenario (one with [dynamics]); `{}` is kinematic",
            scenario.name
        );
    }
    if let Some(u) = args
        .coef_uncertainty
        .iter()
        .find(|u| !(0.0..=0.5).contains(*u))
    {
        anyhow::bail!("--coef-uncertainty {u}: give a fraction in [0, 0.5] (0.1 = 10 %)");
    }
    let cases: Vec<Case> = if !args.tilt.is_empty() {
        args.tilt
            .iter()
            .map(|&(r, p)| Case {
                label: format!("roll {r:+} pitch {p:+}"),
                start_roll_deg: Some(r),
                start_pitch_deg: Some(p),
                ..Case::default()
            })
            .collect()
    } else if !args.coef_uncertainty.is_empty() {
        args.coef_uncertainty
            .iter()
            .map(|&u| Case {
                label: format!("coefficients +-{:.0} %", u * 100.0),
                coef_uncertainty: Some(u),
                ..Case::default()
            })
            .collect()
    } else {
        vec![Case {
            label: scenario.name.clone(),
            ..Case::default()
        }]
    };
    Ok(cases)
}

/// The RMS of the horizontal error against time, forward and smoothed, per case and
/// solution.
fn error_plot(cases: &[Case], labels: &[String], curves: &[TimeRow]) -> Plot {
    let mut names = Vec::new();
    for case in cases {
        for label in labels {
            let name = |what: &str| match (cases.len(), labels.len()) {
                (1, 1) => what.to_string(),
                (1, _) => format!("{label} {what}"),
                (_, 1) => format!("{} {what}", case.label),
                _ => format!("{}, {label} {what}", case.label),
            };
            names.push((name("forward"), name("smoothed")));
        }
    }
    let mut series = Vec::new();
    for (i, (forward, smoothed)) in names.iter().enumerate() {
        let (k, j) = (i / labels.len(), i % labels.len());
        let pick = |f: fn(&TimeRow) -> f64| -> Vec<(f64, f64)> {
            curves
                .iter()
                .filter(|r| r.case == k && r.solution == j && r.runs > 0)
                .map(|r| (r.t_s / 3600.0, f(r)))
                .collect()
        };
        series.push(Series::line(forward.as_str(), pick(|r| r.forward_rms_m)));
        series.push(Series::line(smoothed.as_str(), pick(|r| r.smoothed_rms_m)));
    }
    let mut plot = Plot::new(
        "horizontal error, RMS over the runs",
        "time from the start, h",
        "horizontal error RMS, m",
    );
    plot.series = series;
    plot
}

/// The RMS of the horizontal error at each hour and at the end, per case and solution.
fn print_error_vs_time(cases: &[Case], labels: &[String], curves: &[TimeRow]) {
    let end_s = curves.iter().map(|r| r.t_s).fold(0.0, f64::max);
    if end_s < 3600.0 {
        return;
    }
    let marks: Vec<f64> = (1..)
        .map(|h| h as f64 * 3600.0)
        .take_while(|&t| t < end_s)
        .chain([end_s])
        .collect();
    out!(
        "horizontal error RMS over the runs, m (forward / smoothed), and (the mean forward \
         velocity error along the body x axis, m/s):"
    );
    for (k, case) in cases.iter().enumerate() {
        for (j, label) in labels.iter().enumerate() {
            let at = |t: f64| {
                curves
                    .iter()
                    .filter(|r| r.case == k && r.solution == j && r.runs > 0)
                    .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))
            };
            let cells: Vec<String> = marks
                .iter()
                .map(|&t| {
                    at(t).map_or("-".into(), |r| {
                        format!(
                            "{:.2} h {:.1}/{:.1} ({:+.3})",
                            r.t_s / 3600.0,
                            r.forward_rms_m,
                            r.smoothed_rms_m,
                            r.body_x_velocity_error_mean_m_s
                        )
                    })
                })
                .collect();
            out!("  {} / {label}: {}", case.label, cells.join("  "));
        }
    }
}

const SUMMARY_HEADERS: [&str; 11] = [
    "case",
    "runs",
    "failed",
    "aligned",
    "roll mean",
    "roll sd",
    "pitch mean",
    "pitch sd",
    "aligned at s",
    "fwd RMS m",
    "smo RMS m",
];

const SUMMARY_CAPTION: &str = "errors after the alignment (estimate minus truth at its middle), \
     deg; sd: sample standard deviation; RMS: horizontal error against /truth, mean over the runs";

/// The case summaries as table rows (printed, and in the report).
fn summary_rows(summaries: &[CaseSummary]) -> Vec<Vec<String>> {
    let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:+.3}"));
    let one = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.1}"));
    summaries
        .iter()
        .map(|s| {
            vec![
                if s.solution == "default" {
                    s.label.clone()
                } else {
                    format!("{} {}", s.label, s.solution)
                },
                s.runs.to_string(),
                s.failed.to_string(),
                s.aligned.to_string(),
                f(s.roll_error_mean_deg),
                f(s.roll_error_sigma_deg),
                f(s.pitch_error_mean_deg),
                f(s.pitch_error_sigma_deg),
                one(s.aligned_after_mean_s),
                one(s.forward_horizontal_rms_mean_m),
                one(s.smoothed_horizontal_rms_mean_m),
            ]
        })
        .collect()
}

fn print_summary(rows: &[Vec<String>]) {
    super::console::print_table(
        &SUMMARY_HEADERS,
        rows,
        &[-22, 5, 6, 8, 10, 9, 10, 9, 12, 11, 9],
    );
    out!("{SUMMARY_CAPTION}");
}
