//! `hindsight import`: logs in other forms written as contract logs.

use super::console::out;
use super::OutputFailed;
use anyhow::{Context, Result};
use hindsight::import::csv::{read_all, CsvFile};
use hindsight::import::map::CsvMap;
use hindsight::output::atomic::Staging;
use hindsight::sim::writer;
use std::path::PathBuf;

/// Import a log kept in another form, writing a contract log every command reads.
#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    #[command(subcommand)]
    pub form: ImportForm,
}

#[derive(Debug, clap::Subcommand)]
pub enum ImportForm {
    Csv(CsvArgs),
}

/// CSV exports (one file per sensor or several sensors per file) by a map: which columns
/// are which contract fields, their units, the axis order and signs into FRD/NED, and each
/// file's time column with its base and offset.
///
/// Two maps are shipped: sample-logs/csv/vehicle-computer.toml (IMU, DVL and navigation
/// sensors in three files) and sample-logs/csv/ins-export.toml (a vehicle INS's solution:
/// its attitude and depth). A cell that does not parse is named with its file, line and
/// column, and nothing is written.
///
///   hindsight import csv --map sample-logs/csv/vehicle-computer.toml \
///       run3/imu.csv run3/dvl.csv run3/nav.csv --out run3.mcap
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct CsvArgs {
    /// The map (TOML): [mission], then a [[file]] per kind of file with its
    /// [[file.message]] tables.
    #[arg(long, value_name = "MAP.toml")]
    pub map: PathBuf,
    /// The CSV files; each is matched to a [[file]] of the map by its name.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// The contract log to write (MCAP).
    #[arg(long, value_name = "LOG.mcap")]
    pub out: PathBuf,
}

pub fn run(args: ImportArgs) -> Result<()> {
    match args.form {
        ImportForm::Csv(a) => csv(a),
    }
}

fn csv(args: CsvArgs) -> Result<()> {
    let text = std::fs::read_to_string(&args.map)
        .with_context(|| format!("reading the map {}", args.map.display()))?;
    let map: CsvMap =
        toml::from_str(&text).with_context(|| format!("the map {}", args.map.display()))?;
    let contents: Vec<(PathBuf, Vec<u8>)> = args
        .files
        .iter()
        .map(|p| {
            std::fs::read(p)
                .map(|b| (p.clone(), b))
                .with_context(|| format!("reading {}", p.display()))
        })
        .collect::<Result<_>>()?;
    let files: Vec<CsvFile<'_>> = contents
        .iter()
        .map(|(path, bytes)| CsvFile {
            file_name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            shown_as: path.display().to_string(),
            bytes,
        })
        .collect();
    let messages = read_all(&map, &files)?;
    let mut staging = Staging::new();
    let file = staging.create(&args.out).with_context(|| OutputFailed {
        path: args.out.clone(),
    })?;
    let mut w = writer::LogWriter::new(
        std::io::BufWriter::new(file),
        writer::WriterOptions::default(),
    )?;
    hindsight::import::write_log(map.mission.as_ref(), &messages, &mut w)?;
    super::simulate::finish_log(w, staging, &args.out)?;
    let mut topics: Vec<(&str, usize)> = Vec::new();
    for m in &messages {
        match topics.iter_mut().find(|(t, _)| *t == m.topic) {
            Some((_, n)) => *n += 1,
            None => topics.push((&m.topic, 1)),
        }
    }
    out!(
        "{}: {} messages from {} files ({})",
        args.out.display(),
        messages.len(),
        files.len(),
        topics
            .iter()
            .map(|(t, n)| format!("{t} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
