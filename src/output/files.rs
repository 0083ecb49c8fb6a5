//! One staged output file of each kind: JSON, Parquet, a report with its pictures.

use super::atomic::Staging;
use super::report::Report;
use super::WriteError;
use std::path::{Path, PathBuf};

/// Writes `value` as pretty JSON (and a newline) to the staged file that becomes `path`.
pub fn write_json(
    staging: &mut Staging,
    path: &Path,
    value: &impl serde::Serialize,
) -> Result<(), WriteError> {
    let mut file = staging.create(path).map_err(WriteError::at(path))?;
    serde_json::to_writer_pretty(&mut file, value)
        .map_err(std::io::Error::from)
        .and_then(|_| std::io::Write::write_all(&mut file, b"\n"))
        .map_err(WriteError::at(path))
}

/// Writes `first` and the batches `next` yields as Parquet to the staged file that becomes
/// `path`.
pub fn write_parquet(
    staging: &mut Staging,
    path: &Path,
    first: arrow_array::RecordBatch,
    next: impl FnMut() -> Option<Result<arrow_array::RecordBatch, arrow_schema::ArrowError>>,
) -> Result<(), WriteError> {
    let file = staging.create(path).map_err(WriteError::at(path))?;
    super::parquet::write_batches(file, first, next).map_err(WriteError::at(path))?;
    Ok(())
}

/// Writes `text` to the staged file that becomes `path`.
pub fn write_text(staging: &mut Staging, path: &Path, text: &str) -> Result<(), WriteError> {
    let mut file = staging.create(path).map_err(WriteError::at(path))?;
    std::io::Write::write_all(&mut file, text.as_bytes()).map_err(WriteError::at(path))
}

/// Writes `report.html` and each of its figures as `<stem>.png` beside it (drawn in
/// parallel) into the staged files of `out`, and lists them in `written`.
pub fn write_report(
    staging: &mut Staging,
    out: &Path,
    report: &Report,
    written: &mut Vec<PathBuf>,
) -> Result<(), WriteError> {
    use rayon::prelude::*;
    let path = out.join("report.html");
    let html = report.to_html().map_err(WriteError::at(&path))?;
    write_text(staging, &path, &html)?;
    written.push(path);
    let mut pngs = Vec::new();
    for f in report.figures() {
        let path = out.join(format!("{}.png", f.stem));
        let file = staging.create(&path).map_err(WriteError::at(&path))?;
        pngs.push((path, file, &f.plot));
    }
    pngs.par_iter()
        .map(|(path, file, plot)| {
            super::plots::write_png(plot, std::io::BufWriter::new(file))
                .map_err(WriteError::at(path))
        })
        .collect::<Result<Vec<()>, _>>()?;
    written.extend(pngs.into_iter().map(|(path, ..)| path));
    Ok(())
}
