//! `hindsight._hindsight`: the library's one entry ([`hindsight::reconstruct`]) for Python.
//! The Python package (`python/hindsight`) wraps it; this module only crosses the border:
//! - the work runs with the GIL released;
//! - errors become the package's exceptions, carrying the message the command line prints;
//! - tables cross as Arrow through the C stream interface (`__arrow_c_stream__`), so
//!   pyarrow, polars and DuckDB take the buffers as they are.

use arrow_array::ffi_stream::FFI_ArrowArrayStream;
use arrow_array::{RecordBatch, RecordBatchIterator};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyCapsule;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

create_exception!(
    _hindsight,
    HindsightError,
    PyException,
    "A hindsight failure."
);
create_exception!(
    _hindsight,
    LogError,
    HindsightError,
    "The log cannot be read: missing, not a log, or breaking the log contract."
);
create_exception!(
    _hindsight,
    SettingsError,
    HindsightError,
    "The settings cannot be used: not TOML, an unknown key, a wrong type or a value out of range."
);
create_exception!(
    _hindsight,
    OutputError,
    HindsightError,
    "An output could not be written (nothing is left half-written)."
);

/// The message the command line prints: the error and its causes, joined by `: `.
fn chain(err: &(dyn std::error::Error + 'static)) -> String {
    let mut text = err.to_string();
    let mut source = err.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// A reconstruction's failure as the package's exception.
fn to_python(err: hindsight::reconstruction::Error) -> PyErr {
    use hindsight::reconstruction::Error as E;
    let message = chain(&err);
    match err {
        E::Read { .. } | E::Mission { .. } | E::Align { .. } => LogError::new_err(message),
        E::Write(_) => OutputError::new_err(message),
        _ => HindsightError::new_err(message),
    }
}

/// Reconstructs `log` with the settings' TOML text (`""`: the defaults), the GIL released.
#[pyfunction]
#[pyo3(signature = (log, settings_toml))]
fn reconstruct(py: Python<'_>, log: PathBuf, settings_toml: &str) -> PyResult<Reconstruction> {
    use hindsight::config::Section;
    let config = hindsight::recon::config::Config::from_toml(settings_toml)
        .map_err(|e| SettingsError::new_err(chain(&e)))?;
    let job = hindsight::Job::new(&log, config);
    let solved = py
        .detach(|| hindsight::reconstruct(&job, hindsight::Observer::default()))
        .map_err(to_python)?;
    let summary_json = serde_json::to_string(&solved.summary)
        .map_err(|e| HindsightError::new_err(e.to_string()))?;
    Ok(Reconstruction {
        inner: Arc::new(Mutex::new(solved)),
        tables: Mutex::new(None),
        summary_json,
    })
}

/// One reconstruction: its summary (as JSON text), its tables (made on first use) and its
/// output folder.
#[pyclass(module = "hindsight._hindsight", frozen)]
struct Reconstruction {
    inner: Arc<Mutex<hindsight::Reconstruction>>,
    tables: Mutex<Option<hindsight::output::recon_arrow::ArrowTables>>,
    summary_json: String,
}

impl Reconstruction {
    /// The tables, made once (the solutions read back from their files), the GIL released.
    fn tables(&self, py: Python<'_>) -> PyResult<hindsight::output::recon_arrow::ArrowTables> {
        let mut tables = self.tables.lock().expect("not poisoned");
        if tables.is_none() {
            let inner = Arc::clone(&self.inner);
            let made = py.detach(move || inner.lock().expect("not poisoned").tables());
            *tables = Some(made.map_err(to_python)?);
        }
        Ok(tables.clone().expect("made above"))
    }
}

#[pymethods]
impl Reconstruction {
    /// summary.json's content, as JSON text.
    #[getter]
    fn summary_json(&self) -> &str {
        &self.summary_json
    }

    /// trajectory.parquet's rows, as an Arrow table.
    #[getter]
    fn trajectory(&self, py: Python<'_>) -> PyResult<ArrowTable> {
        Ok(ArrowTable::of(self.tables(py)?.trajectory))
    }

    /// residuals.parquet's rows, as an Arrow table.
    #[getter]
    fn residuals(&self, py: Python<'_>) -> PyResult<ArrowTable> {
        Ok(ArrowTable::of(self.tables(py)?.residuals))
    }

    /// errors.parquet's rows (none without a truth), as an Arrow table.
    #[getter]
    fn errors(&self, py: Python<'_>) -> PyResult<ArrowTable> {
        Ok(ArrowTable::of(self.tables(py)?.errors))
    }

    /// Writes the output folder (as `hindsight reconstruct --out` does) into `dir`; returns
    /// the files' paths. The files are staged and renamed into place together.
    fn write(&self, py: Python<'_>, dir: PathBuf) -> PyResult<Vec<PathBuf>> {
        let inner = Arc::clone(&self.inner);
        py.detach(move || inner.lock().expect("not poisoned").write(&dir))
            .map_err(to_python)
    }
}

/// An Arrow table: record batches of one schema, handed over through the Arrow PyCapsule
/// interface without a copy.
#[pyclass(module = "hindsight._hindsight", frozen)]
struct ArrowTable {
    batches: Vec<RecordBatch>,
}

impl ArrowTable {
    fn of(batches: Vec<RecordBatch>) -> ArrowTable {
        ArrowTable { batches }
    }
}

#[pymethods]
impl ArrowTable {
    /// The rows of every batch.
    #[getter]
    fn num_rows(&self) -> usize {
        self.batches.iter().map(RecordBatch::num_rows).sum()
    }

    /// The column names.
    #[getter]
    fn column_names(&self) -> Vec<String> {
        let schema = self.batches[0].schema();
        schema.fields().iter().map(|f| f.name().clone()).collect()
    }

    /// The Arrow C stream of the batches (the PyCapsule protocol). A requested schema is not
    /// cast to: the table is given as it is.
    #[pyo3(signature = (requested_schema=None))]
    fn __arrow_c_stream__<'py>(
        &self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyCapsule>> {
        let _ = requested_schema;
        let schema = self.batches[0].schema();
        let batches = self.batches.clone().into_iter().map(Ok);
        let reader = RecordBatchIterator::new(batches, schema);
        let stream = FFI_ArrowArrayStream::new(Box::new(reader));
        PyCapsule::new_with_value(py, stream, c"arrow_array_stream")
    }

    /// The address of the values of `column` in the first batch with rows (0 when there is
    /// none): what a consumer that took the buffer without a copy also points at.
    fn _values_address(&self, column: &str) -> PyResult<usize> {
        let Some(batch) = self.batches.iter().find(|b| b.num_rows() > 0) else {
            return Ok(0);
        };
        let array = batch
            .column_by_name(column)
            .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(column.to_string()))?;
        let data = array.to_data();
        Ok(data.buffers().first().map_or(0, |b| b.as_ptr() as usize))
    }
}

#[pymodule]
fn _hindsight(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("HindsightError", py.get_type::<HindsightError>())?;
    m.add("LogError", py.get_type::<LogError>())?;
    m.add("SettingsError", py.get_type::<SettingsError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    m.add_class::<Reconstruction>()?;
    m.add_class::<ArrowTable>()?;
    Ok(())
}
