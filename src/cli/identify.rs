//! `hindsight identify LOG... --out DIR`: hydrodynamic coefficients from sea-trial logs.

use super::config_command::SectionChoice;
use super::console::{out, say};
use super::PolicyArgs;
use anyhow::{bail, Context, Result};
use hindsight::identify::config::IdentifyConfig;
use hindsight::identify::design::{suggest, Addition, DesignSettings, Suggestion};
use hindsight::identify::record::Record;
use hindsight::identify::settings::Settings;
use hindsight::identify::{identify, perturbed, Identification, CHANNELS};
use hindsight::output::files::Folder;
use hindsight::output::identify_tables;
use hindsight::output::plots::{Plot, Series};
use hindsight::output::report::{Block, Report, Section};
use hindsight::vehicle::heave_pitch::{Coefficients, HeavePitch, NAMES, TRUE_COEFFICIENTS, UNITS};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Identify hydrodynamic coefficients from sea-trial logs (zig-zags), with their uncertainty.
///
/// Model (--model heave-pitch): seed 004's vertical-plane model as
/// docs/methods/heave-pitch-model.md fixes it: state w, theta, q, depth; input the stern plane;
/// ten nondimensional coefficients (Z_w, Z_wdot, Z_q, Z_qdot, Z_delta, M_w, M_wdot, M_q,
/// M_qdot, M_delta). Measurements from each log: q from the gyro (/imu y), theta from
/// /attitude (else hindsight's own attitude from the IMU), w from the DVL's body z
/// velocity, depth from /depth; the plane from /fins; U from the DVL's body x (or --speed).
///
/// Two stages over all the logs together:
///   1. seed 004's continuous-discrete EKF with the coefficients as constant states;
///   2. output-error maximum likelihood (Levenberg-Marquardt) on the whole record, started
///      from the EKF's answer: estimates, standard deviations, correlation matrix.
///
/// The sensors' noise is learnt from the fit: the refinement is alternated with setting each
/// channel's sigma to the RMS of its residuals, and the coefficients' sigmas are at the
/// learnt noise (given figures and learnt ones in summary.json; `learn = false` in the
/// config takes the given ones as they are). A fit whose residuals are correlated from one
/// sample to the next (a slow misfit, not white noise) is a POOR FIT.
///
/// A coefficient whose 1-sigma exceeds 5 % of its value is flagged as poorly determined: the
/// data do not tell it. One correlated above 0.95 with another is noted: the data determine
/// the two together. Every threshold, the noise and the filters' tuning are settings
/// (`hindsight config identify` prints them).
///
/// --model six-dof: seed 000's 6-DOF model of a vehicle file (--vehicle; default the log's
/// mission vehicle): the coefficients of --coefficients (horizontal: Yv, Yr, Ydr, Nv, Nr,
/// Ndr from a rudder zig-zag; vertical: Zw, Zq, Zds, Mw, Mq, Mds from a plane zig-zag;
/// default by the fin that moves most) by output error on the gyro and the DVL, the
/// model driven by /fins and /rpm (needed), everything else held at the file's values; each
/// log's initial state, DVL bias and scale factor, and the sensors' noise are estimated with
/// them. Writes coefficients.parquet, report.html, summary.json.
///
/// Starting values: the published set (the spec's table) unless --initial FILE (TOML,
/// NAME = value) or --perturb F (the published set moved by F, alternately up and down).
///
/// Writes to DIR, atomically: coefficients.parquet, correlation.parquet,
/// coefficient_history.parquet (the EKF pass), fit.parquet (measured and re-simulated),
/// convergence.png, fit_theta.png, fit_w.png, summary.json.
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct IdentifyArgs {
    /// Recorded logs (MCAP): one coefficient set is fitted to all of them.
    #[arg(required_unless_present = "print_config")]
    pub logs: Vec<PathBuf>,

    #[command(flatten)]
    pub policy: PolicyArgs,

    #[command(flatten)]
    pub source: super::source::SourceArgs,

    /// The model to identify.
    #[arg(long, value_enum, default_value_t = Model::HeavePitch)]
    pub model: Model,

    /// Output folder.
    #[arg(long, value_name = "DIR", required_unless_present = "print_config")]
    pub out: Option<PathBuf>,

    /// Settings file (TOML: sensor noise and whether it is learnt, the EKF's tuning, the
    /// refinement, the warning thresholds); `hindsight config identify` prints every key and
    /// its default.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// The same as `hindsight config identify` (kept for old scripts).
    #[arg(long, hide = true)]
    pub print_config: bool,

    /// Starting coefficients (TOML: NAME = value, nondimensional; missing ones take the
    /// published value).
    #[arg(long, value_name = "FILE", conflicts_with = "perturb")]
    pub initial: Option<PathBuf>,

    /// Start from the published coefficients moved by this fraction, alternately up and
    /// down (Z_w up, Z_wdot down, ...).
    #[arg(long, value_name = "FRACTION")]
    pub perturb: Option<f64>,

    /// Hold a coefficient at a value instead of estimating it: NAME=VALUE (repeatable).
    #[arg(long = "fix", value_name = "NAME=VALUE")]
    pub fixed: Vec<String>,

    /// Forward speed, m/s [default: each log's mean DVL body x velocity].
    #[arg(long, value_name = "M/S")]
    pub speed: Option<f64>,

    /// Weight minus buoyancy during one log, N, when a known ballast change made it differ
    /// from neutral: LOG=N, LOG as given or its file name (repeatable).
    #[arg(long = "weight-minus-buoyancy", value_name = "LOG=N")]
    pub weight_minus_buoyancy: Vec<String>,

    /// Experiment design: for the coefficients these logs leave poorly determined, which
    /// manoeuvre (a zig-zag at another speed, with a known ballast change) or coefficient
    /// known from elsewhere would determine them, and the sigma predicted after it (the
    /// Fisher information of the candidate simulated with the identified coefficients, at the
    /// learnt noise). Candidates: [design] in the config. Printed, and in the report and
    /// summary.json.
    #[arg(long)]
    pub suggest: bool,

    /// --model six-dof: the vehicle description, a built-in name (nps-auv-ii, remus-100) or
    /// a vehicle JSON file [default: the first log's mission vehicle].
    #[arg(long, value_name = "NAME|FILE")]
    pub vehicle: Option<String>,

    /// --model six-dof: the coefficients to identify: `horizontal` (Yv, Yr, Ydr, Nv, Nr, Ndr:
    /// a rudder zig-zag), `vertical` (Zw, Zq, Zds, Mw, Mq, Mds: a plane zig-zag), or names
    /// separated by commas [default: by the fin that moves most].
    #[arg(long, value_name = "SET|NAMES")]
    pub coefficients: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Model {
    /// Seed 004's vertical-plane (heave-pitch) model.
    HeavePitch,
    /// Seed 000's 6-DOF model of a vehicle file (--vehicle): a subset of its coefficients
    /// (--coefficients), the rest held at the file's values; needs /imu, /fins, /rpm, /dvl.
    SixDof,
}

/// A bad coefficient name or value on the command line or in --initial.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct CoefficientArgError(pub String);

pub(super) fn index_of(name: &str) -> Result<usize, CoefficientArgError> {
    NAMES.iter().position(|n| *n == name).ok_or_else(|| {
        CoefficientArgError(format!(
            "unknown coefficient `{name}` (known: {})",
            NAMES.join(", ")
        ))
    })
}

/// `--weight-minus-buoyancy LOG=N`, by log.
fn ballast_by_log(args: &IdentifyArgs) -> Result<BTreeMap<String, f64>, CoefficientArgError> {
    args.weight_minus_buoyancy
        .iter()
        .map(|arg| {
            let bad = || {
                CoefficientArgError(format!(
                    "--weight-minus-buoyancy {arg}: give LOG=NEWTONS, e.g. heavy.mcap=14078"
                ))
            };
            let (log, n) = arg.rsplit_once('=').ok_or_else(bad)?;
            let n: f64 = n.trim().parse().map_err(|_| bad())?;
            if !n.is_finite() {
                return Err(bad());
            }
            Ok((log.to_string(), n))
        })
        .collect()
}

/// A log's file name (its path when it has none): how its results and `LOG=` options name it.
pub(super) fn log_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

/// `--perturb`, checked.
pub(super) fn perturbation(args: &IdentifyArgs) -> Result<Option<f64>, CoefficientArgError> {
    match args.perturb {
        Some(f) if !(f.is_finite() && f.abs() < 1.0) => Err(CoefficientArgError(format!(
            "--perturb {f}: give a fraction between -1 and 1"
        ))),
        f => Ok(f),
    }
}

fn start_values(args: &IdentifyArgs) -> Result<Coefficients> {
    let published = Coefficients::from(TRUE_COEFFICIENTS);
    if let Some(f) = perturbation(args)? {
        return Ok(perturbed(&published, f));
    }
    let Some(path) = &args.initial else {
        return Ok(published);
    };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let table: BTreeMap<String, f64> = toml::from_str(&text)
        .map_err(|e| CoefficientArgError(format!("{}: {e}", path.display())))?;
    let mut c = published;
    for (name, value) in table {
        let i =
            index_of(&name).map_err(|e| CoefficientArgError(format!("{}: {e}", path.display())))?;
        c[i] = value;
    }
    Ok(c)
}

pub fn run(args: IdentifyArgs) -> Result<()> {
    if args.print_config {
        print!(
            "{}",
            super::config_command::default_toml(SectionChoice::Identify)
        );
        return Ok(());
    }
    let Some(out_dir) = args.out.clone() else {
        bail!("--out DIR is needed");
    };
    let started = Instant::now();
    let config = match &args.config {
        Some(path) => super::config_command::read::<IdentifyConfig>(path, None)?,
        None => IdentifyConfig::default(),
    };
    let mut settings = config.settings()?;
    let design = config.design()?;
    if args.model == Model::SixDof {
        return super::identify_six_dof::run(&args, &out_dir, &settings, started);
    }
    if args.vehicle.is_some() || args.coefficients.is_some() {
        bail!(CoefficientArgError(
            "--vehicle and --coefficients apply to --model six-dof".into()
        ));
    }
    fix_coefficients(&args.fixed, &mut settings)?;
    let start = start_values(&args)?;
    let (records, read_logs) = read_records(&args)?;
    let fitting = Instant::now();
    let id = identify(&records, &start, &settings);
    say!(
        "identified in {:.2} s (EKF, then {} Levenberg-Marquardt iterations{})",
        fitting.elapsed().as_secs_f64(),
        id.refined.iterations,
        if id.refined.converged {
            ""
        } else {
            ", NOT converged"
        }
    );
    let model = HeavePitch::new(hindsight::vehicle::heave_pitch::Constants {
        speed_m_s: records[0].speed_m_s,
        ..settings.constants
    });
    let suggestions = if args.suggest {
        let t = Instant::now();
        let s = suggest(&id, &records, &settings, &design);
        say!(
            "{} candidates predicted in {:.2} s",
            s.len(),
            t.elapsed().as_secs_f64()
        );
        Some(s)
    } else {
        None
    };
    let mut findings = Findings::new(&id, &records, &model, &settings, read_logs);
    findings.design = suggestions
        .as_deref()
        .map(|s| DesignFindings::new(&id, s, &design));
    write_outputs(&out_dir, &id, &records, &model, &settings, &findings)?;
    findings.print();
    say!("total {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// `--fix NAME=VALUE`: the coefficients held at a value.
fn fix_coefficients(fixed: &[String], settings: &mut Settings) -> Result<()> {
    for f in fixed {
        let (name, value) = f.split_once('=').ok_or_else(|| {
            CoefficientArgError(format!(
                "--fix {f}: give NAME=VALUE, e.g. --fix Z_wdot=-0.01258"
            ))
        })?;
        let value: f64 = value
            .trim()
            .parse()
            .map_err(|_| CoefficientArgError(format!("--fix {f}: `{value}` is not a number")))?;
        settings.fixed[index_of(name.trim())?] = Some(value);
    }
    Ok(())
}

/// Each log's record for the identification, with its ballast; and a line on each, said.
fn read_records(args: &IdentifyArgs) -> Result<(Vec<Record>, Vec<String>)> {
    let mut ballast = ballast_by_log(args)?;
    let mut records = Vec::new();
    let mut read_logs = Vec::new();
    for path in &args.logs {
        let log = super::load(path, &args.policy.ingest_options(&args.source), &[])?;
        let name = log_name(path);
        let mut record = Record::from_log(&name, &log, args.speed)
            .with_context(|| format!("identifying from {}", path.display()))?;
        record.weight_minus_buoyancy_n = ballast
            .remove(&name)
            .or(ballast.remove(&path.display().to_string()));
        let mut read = format!(
            "{name}: {:.0} s, U = {:.3} m/s, {} DVL and {} depth readings, theta from {}",
            record.t_s.last().copied().unwrap_or(0.0),
            record.speed_m_s,
            record.w_m_s.len(),
            record.depth_m.len(),
            record.theta_source
        );
        if let Some(n) = record.weight_minus_buoyancy_n {
            read += &format!(", W - B = {n} N");
        }
        say!("{read}");
        read_logs.push(read);
        records.push(record);
    }
    if let Some(log) = ballast.keys().next() {
        bail!(CoefficientArgError(format!(
            "--weight-minus-buoyancy {log}=...: no log of that name (give the path as on the \
             command line, or its file name)"
        )));
    }
    Ok((records, read_logs))
}

#[derive(serde::Serialize)]
struct Summary<'a> {
    logs: Vec<&'a str>,
    iterations: usize,
    converged: bool,
    /// Per log and channel (q, theta, w, depth).
    fit: Vec<BTreeMap<&'static str, hindsight::identify::ChannelFit>>,
    noise: NoiseSummary,
    poorly_determined: Vec<String>,
    warnings: &'a [String],
    /// Coefficients determined only together with another.
    notes: &'a [String],
    /// `--suggest`'s candidates, best first.
    #[serde(skip_serializing_if = "Option::is_none")]
    design: Option<&'a DesignFindings>,
}

/// The sensor noise per channel, 1 sigma: as given, and as the refinement used it (learnt
/// from its residuals, or the given figures).
#[derive(serde::Serialize)]
struct NoiseSummary {
    learnt: bool,
    rounds: usize,
    given: BTreeMap<&'static str, f64>,
    used: BTreeMap<&'static str, f64>,
}

impl NoiseSummary {
    fn new(id: &Identification, settings: &Settings) -> Self {
        let names = ["q_rad_s", "theta_rad", "w_m_s", "depth_m"];
        let by_name = |s: [f64; 4]| names.into_iter().zip(s).collect();
        NoiseSummary {
            learnt: id.noise.learnt,
            rounds: id.noise.rounds,
            given: by_name(settings.sigma.by_channel()),
            used: by_name(id.noise.sigma.by_channel()),
        }
    }
}

fn write_outputs(
    out: &Path,
    id: &Identification,
    records: &[Record],
    model: &HeavePitch,
    settings: &Settings,
    findings: &Findings,
) -> Result<()> {
    let mut folder = Folder::create(out)?;
    let coefficients = identify_tables::coefficients_batch(id, model, &settings.fixed)?;
    folder.table("coefficients.parquet", coefficients)?;
    folder.table(
        "correlation.parquet",
        identify_tables::correlation_batch(id)?,
    )?;
    let history = identify_tables::history_batch(id, records)?;
    folder.table("coefficient_history.parquet", history)?;
    folder.table("fit.parquet", identify_tables::fit_batch(id, records)?)?;
    folder.report(&findings.report(figures(id, records, settings)))?;
    folder.json(
        "summary.json",
        &Summary::new(id, records, settings, findings),
    )?;
    super::commit_and_list(folder)
}

impl<'a> Summary<'a> {
    fn new(
        id: &Identification,
        records: &'a [Record],
        settings: &Settings,
        findings: &'a Findings,
    ) -> Self {
        Summary {
            logs: records.iter().map(|r| r.name.as_str()).collect(),
            iterations: id.refined.iterations,
            converged: id.refined.converged,
            fit: id
                .fits
                .iter()
                .map(|f| CHANNELS.iter().copied().zip(f.channels).collect())
                .collect(),
            noise: NoiseSummary::new(id, settings),
            warnings: &findings.warnings,
            notes: &findings.notes,
            design: findings.design.as_ref(),
            poorly_determined: id
                .assessment
                .iter()
                .filter(|d| d.poorly_determined)
                .map(|d| d.to_string())
                .collect(),
        }
    }
}

/// The report's figures: the EKF's convergence (each coefficient over its final refined
/// value) and the fit of pitch and heave velocity.
fn figures(id: &Identification, records: &[Record], settings: &Settings) -> Vec<Block> {
    let log_start: Vec<f64> = (records.iter())
        .scan(0.0, |end, r| {
            let start = *end;
            *end += r.t_s.last().copied().unwrap_or(0.0);
            Some(start)
        })
        .collect();
    let mut convergence = Plot::new(
        "EKF pass: coefficient / refined estimate (logs one after the other)",
        "time (s)",
        "ratio",
    );
    convergence.series = (0..10)
        .filter(|&i| settings.fixed[i].is_none())
        .map(|i| {
            let c = id.refined.coefficients[i];
            let history = id.ekf.history.iter();
            let ratios = history.map(|p| (log_start[p.log] + p.t_s, p.value[i] / c));
            Series::line(NAMES[i], ratios.collect())
        })
        .collect();
    let fit_plot = |title: &'static str,
                    y_label: &'static str,
                    measured: &dyn Fn(&Record) -> Vec<(f64, f64)>,
                    state: usize,
                    scale: f64| {
        let mut plot = Plot::new(title, "time (s)", y_label);
        for (r, fit) in records.iter().zip(&id.fits) {
            let model = r.t_s.iter().zip(&fit.simulated);
            let model = model.map(|(t, s)| (*t, s[state] * scale)).collect();
            plot.series
                .push(Series::line(format!("{} measured", r.name), measured(r)));
            plot.series
                .push(Series::line(format!("{} model", r.name), model));
        }
        plot
    };
    let theta = fit_plot(
        "pitch: measured and re-simulated (every log)",
        "theta (deg)",
        &|r| {
            r.t_s
                .iter()
                .zip(&r.theta_rad)
                .map(|(t, v)| (*t, v.to_degrees()))
                .collect()
        },
        1,
        1f64.to_degrees(),
    );
    let w = fit_plot(
        "heave velocity: measured and re-simulated (every log)",
        "w (m/s)",
        &|r| r.w_m_s.iter().map(|(k, v)| (r.t_s[*k], *v)).collect(),
        0,
        1.0,
    );
    vec![
        Block::figure(
            "convergence",
            "The EKF stage: each coefficient over its refined value, the logs one after the \
             other (converged: flat at 1).",
            convergence,
        ),
        Block::figure("fit_theta", "Pitch, measured and re-simulated.", theta),
        Block::figure("fit_w", "Heave velocity, measured and re-simulated.", w),
    ]
}

/// The coefficients determined only together with another, when there are any.
pub(super) fn notes_section(notes: &[String]) -> Option<Section> {
    (!notes.is_empty()).then(|| {
        Section::new("Notes").with(Block::Facts(
            notes
                .iter()
                .map(|n| ("note".to_string(), n.clone()))
                .collect(),
        ))
    })
}

/// The noise per channel the refinement used, with the given figures beside learnt ones.
fn noise_line(id: &Identification, settings: &Settings) -> String {
    let (used, given, deg) = (id.noise.sigma, settings.sigma, f64::to_degrees);
    let cells = [
        ("q", deg(used.q_rad_s), deg(given.q_rad_s), "deg/s"),
        ("theta", deg(used.theta_rad), deg(given.theta_rad), "deg"),
        ("w", used.w_m_s, given.w_m_s, "m/s"),
        ("depth", used.depth_m, given.depth_m, "m"),
    ];
    let learnt = id.noise.learnt;
    let list = cells
        .map(|(n, u, g, unit)| match learnt {
            true => format!("{n} {u:.4} {unit} (given {g:.4})"),
            false => format!("{n} {u:.4} {unit}"),
        })
        .join(", ");
    match learnt {
        true => format!(
            "sensor noise learnt from the residuals ({} refinements): {list}",
            id.noise.rounds
        ),
        false => format!("sensor noise as given: {list}"),
    }
}

/// What identify found, as tables and warnings: printed, and in the report.
struct Findings {
    /// Seed 004's Tables 5.2-5.3: start, EKF, refined, with sigma.
    coefficients: Vec<Vec<String>>,
    /// Per log: name, then "channel normalised RMS (fit %)" per channel.
    fit: Vec<(String, Vec<String>)>,
    warnings: Vec<String>,
    /// Coefficients determined only together with another.
    notes: Vec<String>,
    /// What each log held.
    logs: Vec<String>,
    /// The sensor noise the refinement used, and where it came from.
    noise: String,
    /// `--suggest`'s candidates, best first.
    design: Option<DesignFindings>,
}

/// The experiment design in words and figures (`--suggest`): printed, in the report, and in
/// summary.json.
#[derive(serde::Serialize)]
struct DesignFindings {
    /// How the prediction is made.
    method: &'static str,
    /// 1-sigma now, % of the value, of each poorly determined coefficient.
    now_sigma_percent: BTreeMap<&'static str, f64>,
    /// Best first.
    candidates: Vec<CandidateFinding>,
}

#[derive(serde::Serialize)]
struct CandidateFinding {
    candidate: String,
    reversals: usize,
    /// Poorly determined now, determined after it.
    determines: Vec<&'static str>,
    /// Predicted 1-sigma after it, % of the value, of every coefficient estimated.
    predicted_sigma_percent: BTreeMap<&'static str, f64>,
    /// How to follow it.
    how: String,
}

/// Candidates on the console (all of them in the report and summary.json).
const CANDIDATES_PRINTED: usize = 5;

const DESIGN_METHOD: &str = "predicted 1-sigma: the Cramer-Rao bound of these logs together \
     with the candidate, whose Fisher information is that of a noise-free simulation with the \
     identified coefficients, sampled as these logs are, at the learnt noise";

/// A number with four significant digits (a ballast in N for a 30 kg AUV or a submarine).
fn significant(v: f64) -> String {
    let digits = if v == 0.0 {
        0
    } else {
        (3 - v.abs().log10().floor() as i32).max(0) as usize
    };
    format!("{v:.digits$}")
}

impl DesignFindings {
    fn new(id: &Identification, suggestions: &[Suggestion], design: &DesignSettings) -> Self {
        let c = &id.refined.coefficients;
        let percent = |sigma: f64, i: usize| 100.0 * sigma / c[i].abs().max(f64::MIN_POSITIVE);
        let poorly: Vec<usize> = (0..10)
            .filter(|&i| {
                id.assessment
                    .iter()
                    .any(|d| d.name == NAMES[i] && d.poorly_determined)
            })
            .collect();
        let now_sigma_percent = poorly
            .iter()
            .map(|&i| (NAMES[i], percent(id.refined.covariance[(i, i)].sqrt(), i)))
            .collect();
        let candidates = suggestions
            .iter()
            .map(|s| CandidateFinding {
                candidate: s.description.clone(),
                reversals: s.reversals,
                determines: s.determines.clone(),
                predicted_sigma_percent: s
                    .assessment
                    .iter()
                    .filter_map(|d| {
                        let i = NAMES.iter().position(|n| *n == d.name)?;
                        Some((NAMES[i], percent(s.sigma(i), i)))
                    })
                    .collect(),
                how: how_to_follow(s, design),
            })
            .collect();
        DesignFindings {
            method: DESIGN_METHOD,
            now_sigma_percent,
            candidates,
        }
    }

    /// "NAME sigma%, ..." over the coefficients poorly determined now.
    fn sigmas(&self, of: &BTreeMap<&'static str, f64>) -> String {
        NAMES
            .iter()
            .filter(|n| self.now_sigma_percent.contains_key(*n))
            .map(|n| match of.get(n) {
                Some(v) => format!("{n} {v:.2}"),
                None => format!("{n} (held)"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn rows(&self) -> Vec<Vec<String>> {
        self.candidates
            .iter()
            .enumerate()
            .map(|(k, c)| {
                vec![
                    format!("{}", k + 1),
                    format!("{} ({} reversals)", c.candidate, c.reversals),
                    self.sigmas(&c.predicted_sigma_percent),
                    c.determines.join(", "),
                    c.how.clone(),
                ]
            })
            .collect()
    }

    fn print(&self) {
        if self.now_sigma_percent.is_empty() {
            out!("experiment design: every coefficient is determined; nothing to suggest");
            return;
        }
        out!("experiment design (--suggest), best first; {DESIGN_METHOD}");
        out!(
            "  now: 1-sigma % of the value: {}",
            self.sigmas(&self.now_sigma_percent)
        );
        let rows = self.rows();
        for row in rows.iter().take(CANDIDATES_PRINTED) {
            out!("  {}. {}", row[0], row[1]);
            out!("       1-sigma %: {}", row[2]);
            if !row[3].is_empty() {
                out!("       determines: {}", row[3]);
            }
            out!("       how: {}", row[4]);
        }
        if rows.len() > CANDIDATES_PRINTED {
            out!(
                "  ... and {} more in report.html and summary.json",
                rows.len() - CANDIDATES_PRINTED
            );
        }
    }

    fn section(&self) -> Section {
        let mut section = Section::new("Experiment design").with(Block::text(format!(
            "Coefficients poorly determined now (1-sigma, % of the value): {}. Candidates, \
             best first; {DESIGN_METHOD}.",
            self.sigmas(&self.now_sigma_percent)
        )));
        section.push(Block::table(
            [
                "rank",
                "candidate",
                "1-sigma % after it",
                "determines",
                "how",
            ],
            self.rows(),
        ));
        section
    }
}

/// What to do to follow a suggestion, at sea or in the simulator.
fn how_to_follow(s: &Suggestion, design: &DesignSettings) -> String {
    match s.addition {
        Addition::Zigzag(m) => {
            let ballast = if m.weight_minus_buoyancy_n != 0.0 {
                format!(
                    " --weight-minus-buoyancy {}",
                    significant(m.weight_minus_buoyancy_n)
                )
            } else {
                String::new()
            };
            format!(
                "fly it, then identify from all the logs{}; in the simulator: hindsight \
                 simulate --scenario zigzag-{}-{} --speed {:.3}{ballast} --duration {} --out \
                 candidate.mcap",
                if ballast.is_empty() {
                    String::new()
                } else {
                    format!(
                        " with --weight-minus-buoyancy candidate.mcap={}",
                        significant(m.weight_minus_buoyancy_n)
                    )
                },
                design.plane_deg,
                design.trigger_deg,
                m.speed_m_s,
                design.duration_s,
            )
        }
        Addition::Known(i) => format!(
            "identify again with --fix {}=VALUE, the value from elsewhere (its error carries \
             into the coefficients correlated with it)",
            NAMES[i]
        ),
    }
}

const COEFFICIENT_HEADERS: [&str; 8] = [
    "name",
    "start",
    "EKF",
    "refined",
    "1-sigma",
    "sigma %",
    "dimensional",
    "unit",
];

impl Findings {
    fn new(
        id: &Identification,
        records: &[Record],
        model: &HeavePitch,
        settings: &Settings,
        logs: Vec<String>,
    ) -> Self {
        let coefficients = (0..10)
            .map(|i| {
                let c = id.refined.coefficients[i];
                let s = id.refined.covariance[(i, i)].sqrt();
                let flag = if settings.fixed[i].is_some() {
                    " (fixed)"
                } else if id
                    .assessment
                    .iter()
                    .any(|d| d.name == NAMES[i] && d.poorly_determined)
                {
                    " (poorly determined)"
                } else {
                    ""
                };
                vec![
                    NAMES[i].to_string(),
                    format!("{:.6}", id.start[i]),
                    format!("{:.6}", id.ekf.coefficients[i]),
                    format!("{c:.6}"),
                    format!("{s:.6}"),
                    format!("{:.2}", 100.0 * s / c.abs().max(f64::MIN_POSITIVE)),
                    format!("{:.4e}", c * model.scale(i)),
                    format!("{}{flag}", UNITS[i]),
                ]
            })
            .collect();
        let fit = records
            .iter()
            .zip(&id.fits)
            .map(|(r, f)| {
                let cells = CHANNELS
                    .iter()
                    .zip(&f.channels)
                    .map(|(n, c)| format!("{n} {:.2} ({:.1} %)", c.normalised_rms, c.fit_percent))
                    .collect();
                (r.name.clone(), cells)
            })
            .collect();
        let mut warnings = Vec::new();
        if id.ekf_diverged {
            warnings.push(
                "the EKF stage ran away (its coefficients cannot be simulated); the refinement \
                 started from the starting values"
                    .to_string(),
            );
        }
        warnings.extend(id.fit_warnings(settings));
        let (poorly_determined, notes) =
            hindsight::identify::identifiability::Determination::warnings_and_notes(&id.assessment);
        warnings.extend(poorly_determined);
        Findings {
            coefficients,
            fit,
            warnings,
            notes,
            logs,
            noise: noise_line(id, settings),
            design: None,
        }
    }

    /// The console table, the fit and the warnings.
    fn print(&self) {
        out!();
        super::console::print_table(
            &COEFFICIENT_HEADERS,
            &self.coefficients,
            &[-8, 12, 12, 12, 12, 9, 14, -9],
        );
        out!("\nfit of the identified model (normalised RMS: residual RMS over the sensor's sigma; fit %):");
        for (name, cells) in &self.fit {
            out!("  {:<24} {}", name, cells.join(", "));
        }
        out!("{}", self.noise);
        for w in &self.warnings {
            out!("warning: {w}");
        }
        for n in &self.notes {
            out!("note: {n}");
        }
        if let Some(d) = &self.design {
            out!();
            d.print();
        }
        out!();
    }

    fn report(&self, figures: Vec<Block>) -> Report {
        let mut fit = Section::new("Fit").with(Block::text(
            "Normalised RMS: the residual RMS of the re-simulated model over the sensor's sigma \
             (about 1 for a model that fits to the noise); fit %.",
        ));
        fit.push(Block::text(self.noise.clone()));
        fit.push(Block::table(
            ["log", "fit per channel"],
            self.fit
                .iter()
                .map(|(n, c)| vec![n.clone(), c.join(", ")])
                .collect(),
        ));
        for f in figures {
            fit.push(f);
        }
        Report {
            title: "hindsight identify: heave-pitch coefficients".into(),
            subtitle: self.logs.join("; "),
            sections: vec![
                Section::new("Coefficients")
                    .with(Block::table(COEFFICIENT_HEADERS, self.coefficients.clone())),
                Section::new("Inputs").with(Block::Facts(
                    self.logs
                        .iter()
                        .map(|l| ("log".to_string(), l.clone()))
                        .collect(),
                )),
                fit,
                Section::new("Warnings").with(Block::Warnings(self.warnings.clone())),
            ]
            .into_iter()
            .chain(notes_section(&self.notes))
            .chain(self.design.as_ref().map(DesignFindings::section))
            .collect(),
            footer: format!("hindsight {}", env!("CARGO_PKG_VERSION")),
        }
    }
}
