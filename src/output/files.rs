//! An output folder: its files staged under temporary names, each kind written one way
//! (JSON, Parquet, text, a report with its pictures), and renamed into place together.

use super::atomic::Staging;
use super::report::Report;
use super::WriteError;
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The files of one output folder. [`Folder::commit`] renames them all into place; a folder
/// dropped before that removes them, so a failed run leaves no half-written file behind.
pub struct Folder {
    dir: PathBuf,
    staging: Staging,
}

impl Folder {
    /// The folder `dir`, created if missing.
    pub fn create(dir: &Path) -> Result<Folder, WriteError> {
        std::fs::create_dir_all(dir).map_err(WriteError::at(dir))?;
        Ok(Folder {
            dir: dir.to_path_buf(),
            staging: Staging::new(),
        })
    }

    /// The staged file that becomes `name` in the folder, and that path.
    pub fn staged(&mut self, name: &str) -> Result<(PathBuf, File), WriteError> {
        let path = self.dir.join(name);
        let file = self.staging.create(&path).map_err(WriteError::at(&path))?;
        Ok((path, file))
    }

    /// `value` as pretty JSON and a newline.
    pub fn json(&mut self, name: &str, value: &impl serde::Serialize) -> Result<(), WriteError> {
        let (path, mut file) = self.staged(name)?;
        serde_json::to_writer_pretty(&mut file, value)
            .map_err(std::io::Error::from)
            .and_then(|_| std::io::Write::write_all(&mut file, b"\n"))
            .map_err(WriteError::at(&path))
    }

    /// Parquet of `first` and the batches `next` yields.
    pub fn parquet(
        &mut self,
        name: &str,
        first: RecordBatch,
        next: impl FnMut() -> Option<Result<RecordBatch, ArrowError>>,
    ) -> Result<(), WriteError> {
        let (path, file) = self.staged(name)?;
        super::parquet::write_batches(file, first, next).map_err(WriteError::at(&path))?;
        Ok(())
    }

    /// Parquet of one batch.
    pub fn table(&mut self, name: &str, batch: RecordBatch) -> Result<(), WriteError> {
        self.parquet(name, batch, || None)
    }

    pub fn text(&mut self, name: &str, text: &str) -> Result<(), WriteError> {
        let (path, mut file) = self.staged(name)?;
        std::io::Write::write_all(&mut file, text.as_bytes()).map_err(WriteError::at(&path))
    }

    /// `report.html`, and each of its figures as `<stem>.png` beside it (drawn in parallel).
    pub fn report(&mut self, report: &Report) -> Result<(), WriteError> {
        use rayon::prelude::*;
        let html = report
            .to_html()
            .map_err(WriteError::at(&self.dir.join("report.html")))?;
        self.text("report.html", &html)?;
        let pngs = (report.figures())
            .map(|f| Ok((self.staged(&format!("{}.png", f.stem))?, &f.plot)))
            .collect::<Result<Vec<_>, WriteError>>()?;
        pngs.into_par_iter().try_for_each(|((path, file), plot)| {
            super::plots::write_png(plot, std::io::BufWriter::new(file))
                .map_err(WriteError::at(&path))
        })
    }

    /// Renames every file into place; returns their paths in the order they were written.
    pub fn commit(self) -> Result<Vec<PathBuf>, WriteError> {
        self.staging.commit().map_err(WriteError::at(&self.dir))
    }
}
