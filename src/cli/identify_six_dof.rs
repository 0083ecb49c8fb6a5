//! `hindsight identify --model six-dof`: a subset of a vehicle file's coefficients from
//! manoeuvre logs, with seed 000's 6-DOF model.

use super::console::{out, say};
use super::identify::{CoefficientArgError, IdentifyArgs};
use anyhow::{bail, Context, Result};
use hindsight::identify::settings::Settings;
use hindsight::identify::six_dof::{
    identify_six_dof, SixDofIdentification, SixDofRecord, SixDofSettings, CHANNELS, HORIZONTAL,
    VERTICAL,
};
use hindsight::identify::ChannelFit;
use hindsight::output::files::Folder;
use hindsight::output::identify_tables;
use hindsight::output::report::{Block, Report, Section};
use hindsight::vehicle::six_dof::description::{Vehicle, BUILT_IN};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

pub fn run(
    args: &IdentifyArgs,
    out_dir: &Path,
    settings: &Settings,
    started: Instant,
) -> Result<()> {
    for (given, flag) in [
        (!args.fixed.is_empty(), "--fix"),
        (args.initial.is_some(), "--initial"),
        (args.suggest, "--suggest"),
        (
            !args.weight_minus_buoyancy.is_empty(),
            "--weight-minus-buoyancy",
        ),
        (args.speed.is_some(), "--speed"),
    ] {
        if given {
            bail!(CoefficientArgError(format!(
                "{flag} applies to --model heave-pitch, not to six-dof"
            )));
        }
    }
    let mut records = Vec::new();
    let mut mission_vehicle = None;
    let mut read_logs = Vec::new();
    for path in &args.logs {
        let log = super::load(path, &args.policy.ingest_options(&args.source), &[])?;
        if mission_vehicle.is_none() {
            mission_vehicle = log.mission().ok().map(|m| m.vehicle);
        }
        let name = super::identify::log_name(path);
        let record = SixDofRecord::from_log(&name, &log)
            .with_context(|| format!("identifying from {}", path.display()))?;
        let read = format!(
            "{name}: {:.0} s, {} DVL readings, the {} moves by {:.1} deg",
            record.t_s.last().copied().unwrap_or(0.0),
            record.velocity_m_s.len(),
            record.manoeuvre.0,
            record.manoeuvre.1
        );
        say!("{read}");
        read_logs.push(read);
        records.push(record);
    }
    let vehicle = vehicle(args.vehicle.as_deref().or(mission_vehicle.as_deref()))?;
    let free = free_coefficients(args.coefficients.as_deref(), &records);
    let file: Vec<f64> = free.iter().map(|n| vehicle.coefficient(n)).collect();
    let start: Vec<f64> = match super::identify::perturbation(args)? {
        Some(f) => file
            .iter()
            .enumerate()
            .map(|(i, v)| v * (1.0 + if i % 2 == 0 { f } else { -f }))
            .collect(),
        None => file.clone(),
    };
    let six = SixDofSettings {
        free,
        gyro_rad_s: settings.sigma.q_rad_s,
        dvl_m_s: settings.sigma.w_m_s,
        learn_noise: settings.learn_noise,
        noise_rounds: settings.noise_rounds,
        max_iterations: settings.max_iterations,
        thresholds: settings.thresholds,
    };
    say!(
        "identifying {} of {} with the 6-DOF model (about 10 s per 400 s of log) ...",
        six.free.join(", "),
        vehicle.name
    );
    let fitting = Instant::now();
    let id = identify_six_dof(&records, &vehicle, Some(&start), &six)
        .map_err(|e| CoefficientArgError(e.to_string()))?;
    say!(
        "identified in {:.1} s ({} noise rounds; {} Levenberg-Marquardt iterations in the last{})",
        fitting.elapsed().as_secs_f64(),
        id.noise_rounds,
        id.iterations,
        if id.converged { "" } else { ", NOT converged" }
    );
    let findings = Findings::new(&id, &six, read_logs, &vehicle.name);
    write_outputs(out_dir, &id, &findings)?;
    findings.print();
    say!("total {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// A built-in vehicle or a vehicle file.
fn vehicle(name: Option<&str>) -> Result<Vehicle> {
    let known = || {
        BUILT_IN
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let Some(name) = name else {
        bail!(CoefficientArgError(format!(
            "the log names no vehicle: give --vehicle NAME|FILE ({})",
            known()
        )));
    };
    if let Some(v) = Vehicle::built_in(name) {
        return Ok(v?);
    }
    let text = std::fs::read_to_string(name).map_err(|e| {
        CoefficientArgError(format!(
            "vehicle `{name}`: not a built-in vehicle ({}) and reading it as a file failed: {e}",
            known()
        ))
    })?;
    Vehicle::from_json(&text).with_context(|| format!("in {name}"))
}

/// `horizontal`, `vertical`, or names; by default the set the manoeuvre drives.
fn free_coefficients(given: Option<&str>, records: &[SixDofRecord]) -> Vec<String> {
    let set = |names: &[&str]| names.iter().map(|s| s.to_string()).collect();
    match given {
        Some("horizontal") => set(&HORIZONTAL),
        Some("vertical") => set(&VERTICAL),
        Some(list) => list
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect(),
        None if records.first().is_some_and(|r| r.manoeuvre.0 == "rudder") => set(&HORIZONTAL),
        None => set(&VERTICAL),
    }
}

/// The tables and warnings: printed, in the report and summary.json.
#[derive(serde::Serialize)]
struct Findings {
    model: &'static str,
    vehicle: String,
    logs: Vec<String>,
    coefficients: Vec<CoefficientRow>,
    /// Per log: channel (p, q, r, u, v, w) to fit.
    fit: Vec<BTreeMap<&'static str, ChannelFit>>,
    /// The noise the refinement used per channel (rad/s for the gyro, m/s for the DVL).
    noise: BTreeMap<&'static str, f64>,
    noise_learnt: bool,
    /// Per log, estimated with the coefficients: the DVL's bias (u, v, w), m/s, and
    /// scale-factor error.
    dvl_bias_m_s: Vec<[f64; 3]>,
    dvl_scale_error: Vec<f64>,
    /// Per log: the gyro's bias (p, q, r), rad/s, and scale-factor errors and misalignments
    /// (`E` in `(I + E) omega`, row by row; rad for the off-diagonal angles).
    gyro_bias_rad_s: Vec<[f64; 3]>,
    gyro_axes_error: Vec<[[f64; 3]; 3]>,
    iterations: usize,
    converged: bool,
    warnings: Vec<String>,
    /// Coefficients determined only together with another.
    notes: Vec<String>,
}

#[derive(serde::Serialize)]
struct CoefficientRow {
    name: String,
    file: f64,
    start: f64,
    estimate: f64,
    sigma: f64,
    relative_sigma: f64,
    poorly_determined: bool,
}

impl Findings {
    fn new(
        id: &SixDofIdentification,
        settings: &SixDofSettings,
        logs: Vec<String>,
        vehicle: &str,
    ) -> Self {
        let coefficients = id
            .names
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let sigma = id.covariance[(i, i)].sqrt();
                CoefficientRow {
                    name: name.clone(),
                    file: id.file[i],
                    start: id.start[i],
                    estimate: id.coefficients[i],
                    sigma,
                    relative_sigma: sigma / id.coefficients[i].abs().max(f64::MIN_POSITIVE),
                    poorly_determined: id
                        .assessment
                        .iter()
                        .any(|d| d.name == *name && d.poorly_determined),
                }
            })
            .collect();
        let mut warnings = id.fit_warnings(&settings.thresholds);
        let (poorly_determined, notes) =
            hindsight::identify::identifiability::Determination::warnings_and_notes(&id.assessment);
        warnings.extend(poorly_determined);
        Findings {
            model: "six-dof",
            vehicle: vehicle.to_string(),
            logs,
            coefficients,
            fit: id
                .fits
                .iter()
                .map(|f| CHANNELS.iter().copied().zip(*f).collect())
                .collect(),
            noise: CHANNELS.iter().copied().zip(id.sigma).collect(),
            noise_learnt: settings.learn_noise,
            dvl_bias_m_s: id.logs.iter().map(|e| e.dvl_bias_m_s.into()).collect(),
            dvl_scale_error: id.logs.iter().map(|e| e.dvl_scale_error).collect(),
            gyro_bias_rad_s: id.logs.iter().map(|e| e.gyro_bias_rad_s.into()).collect(),
            gyro_axes_error: id
                .logs
                .iter()
                .map(|e| {
                    let m = e.gyro_axes_error;
                    [
                        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
                    ]
                })
                .collect(),
            iterations: id.iterations,
            converged: id.converged,
            warnings,
            notes,
        }
    }

    fn rows(&self) -> Vec<Vec<String>> {
        self.coefficients
            .iter()
            .map(|c| {
                vec![
                    c.name.clone(),
                    format!("{:.4e}", c.file),
                    format!("{:.4e}", c.start),
                    format!("{:.4e}", c.estimate),
                    format!("{:.3e}", c.sigma),
                    format!("{:.3}", 100.0 * c.relative_sigma),
                    if c.poorly_determined {
                        "poorly determined".into()
                    } else {
                        String::new()
                    },
                ]
            })
            .collect()
    }

    fn fit_lines(&self) -> Vec<String> {
        self.fit
            .iter()
            .zip(&self.logs)
            .map(|(f, log)| {
                let cells: Vec<String> = CHANNELS
                    .iter()
                    .map(|ch| {
                        let c = &f[ch];
                        format!(
                            "{ch} {:.2} (lag-1 {:+.2})",
                            c.normalised_rms, c.lag1_correlation
                        )
                    })
                    .collect();
                format!(
                    "{}: {}",
                    log.split(':').next().unwrap_or(log),
                    cells.join(", ")
                )
            })
            .collect()
    }

    fn noise_line(&self) -> String {
        format!(
            "sensor noise {}: gyro p {:.2e}, q {:.2e}, r {:.2e} rad/s; DVL u {:.4}, v {:.4}, w {:.4} m/s",
            if self.noise_learnt { "learnt from the residuals" } else { "as given" },
            self.noise["p"],
            self.noise["q"],
            self.noise["r"],
            self.noise["u"],
            self.noise["v"],
            self.noise["w"],
        )
    }

    fn print(&self) {
        out!();
        super::console::print_table(&HEADERS, &self.rows(), &[-6, 12, 12, 12, 11, 8, -18]);
        out!("\nfit (normalised RMS: residual RMS over the noise; lag-one correlation of the residuals):");
        for line in self.fit_lines() {
            out!("  {line}");
        }
        out!("{}", self.noise_line());
        for w in &self.warnings {
            out!("warning: {w}");
        }
        for n in &self.notes {
            out!("note: {n}");
        }
        out!();
    }

    fn report(&self) -> Report {
        Report {
            title: format!("hindsight identify: 6-DOF coefficients of {}", self.vehicle),
            subtitle: self.logs.join("; "),
            sections: vec![
                Section::new("Coefficients")
                    .with(Block::text(
                        "SI values, as the model uses them; the file's value beside the \
                         estimate; everything else held at the file's values.",
                    ))
                    .with(Block::table(HEADERS, self.rows())),
                Section::new("Fit")
                    .with(Block::text(self.noise_line()))
                    .with(Block::Facts(
                        self.fit_lines()
                            .into_iter()
                            .map(|l| ("log".to_string(), l))
                            .collect(),
                    )),
                Section::new("Warnings").with(Block::Warnings(self.warnings.clone())),
            ]
            .into_iter()
            .chain(super::identify::notes_section(&self.notes))
            .collect(),
            footer: format!("hindsight {}", env!("CARGO_PKG_VERSION")),
        }
    }
}

const HEADERS: [&str; 7] = [
    "name", "file", "start", "estimate", "1-sigma", "sigma %", "flag",
];

fn write_outputs(out: &Path, id: &SixDofIdentification, findings: &Findings) -> Result<()> {
    let mut folder = Folder::create(out)?;
    let coefficients = identify_tables::six_dof_coefficients_batch(id)?;
    folder.table("coefficients.parquet", coefficients)?;
    folder.report(&findings.report())?;
    folder.json("summary.json", findings)?;
    super::commit_and_list(folder)
}
