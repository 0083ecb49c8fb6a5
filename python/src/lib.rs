//! `hindsight._hindsight`: the library's one entry ([`hindsight::reconstruct`]) for Python.
//! The Python package (`python/hindsight`) wraps it; this module only crosses the border:
//! - the work runs with the GIL released;
//! - errors become the package's exceptions, carrying the message the command line prints;
//! - tables cross as Arrow through the C stream interface (`__arrow_c_stream__`), so
//!   pyarrow, polars and DuckDB take the buffers as they are.

use arrow_array::ffi_stream::FFI_ArrowArrayStream;
use arrow_array::{RecordBatch, RecordBatchIterator};
use hindsight::output::batch_tables::MissionRow;
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

use hindsight::batch::error_chain as chain;

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

/// The settings of their TOML text (`""`: the defaults).
fn settings(settings_toml: &str) -> PyResult<hindsight::recon::config::Config> {
    use hindsight::config::Section;
    hindsight::recon::config::Config::from_toml(settings_toml)
        .map_err(|e| SettingsError::new_err(chain(&e)))
}

/// Tells a Python callback `(stage, fraction)` from the worker threads, the GIL taken for
/// each call; the first exception it raises is kept (and raised after the run), the rest of
/// the calls skipped.
struct Told {
    callback: Option<Py<PyAny>>,
    raised: Mutex<Option<PyErr>>,
}

impl Told {
    fn tell(&self, stage: &str, fraction: f64) {
        let Some(callback) = &self.callback else {
            return;
        };
        let mut raised = self.raised.lock().expect("not poisoned");
        if raised.is_none() {
            Python::attach(|py| {
                if let Err(e) = callback.call1(py, (stage, fraction)) {
                    *raised = Some(e);
                }
            });
        }
    }
}

/// Reconstructs `log` with the settings' TOML text (`""`: the defaults), the GIL released;
/// `progress(stage, fraction)` is told how far reading ("read"), the forward pass
/// ("forward") and the smoother ("smoother") are.
#[pyfunction]
#[pyo3(signature = (log, settings_toml, progress=None))]
fn reconstruct(
    py: Python<'_>,
    log: PathBuf,
    settings_toml: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Reconstruction> {
    let config = settings(settings_toml)?;
    let job = hindsight::Job::new(&log, config);
    let told = Told {
        callback: progress,
        raised: Mutex::new(None),
    };
    let read = |f: f64| told.tell("read", f);
    let forward = |f: f64| told.tell("forward", f);
    let smoother = |f: f64| told.tell("smoother", f);
    let solved = py.detach(|| {
        let observer = hindsight::Observer {
            read_progress: Some(&read),
            forward_progress: Some(&forward),
            smoother_progress: Some(&smoother),
            ..Default::default()
        };
        hindsight::reconstruct(&job, observer)
    });
    if let Some(e) = told.raised.lock().expect("not poisoned").take() {
        return Err(e);
    }
    let solved = solved.map_err(to_python)?;
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

/// Simulates the built-in scenario `scenario` with `seed` into the log file `out` (as
/// `hindsight simulate --scenario NAME --seed SEED --out FILE` writes it), the GIL released;
/// returns the messages written and the mission's duration, s.
#[pyfunction]
fn simulate(py: Python<'_>, scenario: &str, seed: u64, out: PathBuf) -> PyResult<(u64, f64)> {
    let scenario = hindsight::sim::scenario::Scenario::built_in(scenario)
        .map_err(|e| SettingsError::new_err(chain(&e)))?;
    let summary = py
        .detach(|| hindsight::sim::file::simulate_to_file(&scenario, seed, &out, |_| {}))
        .map_err(|e| OutputError::new_err(chain(&e)))?;
    Ok((summary.messages, summary.duration_s))
}

/// Every topic of a log as an Arrow table (as `hindsight export` writes them: `stamp_ns`,
/// `log_time_ns`, then every field), the GIL released while it is read.
#[pyfunction]
fn read_log(py: Python<'_>, path: PathBuf) -> PyResult<Vec<(String, ArrowTable)>> {
    let options = hindsight::ingest::IngestOptions::default();
    let log = py
        .detach(|| hindsight::ingest::read_log(&path, &options))
        .map_err(|e| LogError::new_err(format!("reading {}: {}", path.display(), chain(&e))))?;
    let table = |s: &hindsight::ingest::Stream| -> PyResult<(String, ArrowTable)> {
        let batches = hindsight::output::tables::stream_batches(s)
            .map_err(|e| HindsightError::new_err(e.to_string()))?;
        Ok((s.topic.clone(), ArrowTable::of(batches)))
    };
    log.streams.iter().map(table).collect()
}

/// One mission of a batch (as `hindsight batch` runs each log): reconstructed into
/// `out/mission=<name>/` unless complete there already (and not `force`), the GIL released.
/// Returns its row of batch_summary.parquet as JSON text; a failed mission is a row too.
#[pyfunction]
#[pyo3(signature = (log, out, settings_toml, force))]
fn batch_mission(
    py: Python<'_>,
    log: PathBuf,
    out: PathBuf,
    settings_toml: &str,
    force: bool,
) -> PyResult<String> {
    let config = settings(settings_toml)?;
    let row = py.detach(|| hindsight::batch::run_mission(&log, &out, &config, force));
    serde_json::to_string(&row).map_err(|e| HindsightError::new_err(e.to_string()))
}

/// A row of its JSON (as `MissionRow` serialises).
fn row_of(v: &serde_json::Value) -> PyResult<MissionRow> {
    let text = |k: &str| v[k].as_str().map(str::to_string);
    let number = |k: &str| v[k].as_f64();
    let status = match v["status"].as_str() {
        Some("done") => "done",
        Some("complete") => "complete",
        Some("failed") => "failed",
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "a batch row's status is done, complete or failed, not {other:?}"
            )))
        }
    };
    Ok(MissionRow {
        mission: text("mission").unwrap_or_default(),
        log: text("log").unwrap_or_default(),
        status,
        error: text("error"),
        run_time_s: number("run_time_s"),
        duration_s: number("duration_s"),
        distance_travelled_m: number("distance_travelled_m"),
        final_horizontal_sigma_forward_m: number("final_horizontal_sigma_forward_m"),
        final_horizontal_sigma_smoothed_m: number("final_horizontal_sigma_smoothed_m"),
        consistent: v["consistent"].as_bool(),
        forward_horizontal_rms_m: number("forward_horizontal_rms_m"),
        smoothed_horizontal_rms_m: number("smoothed_horizontal_rms_m"),
    })
}

/// batch_summary.parquet and the batch's report.html from the missions' rows (JSON text, in
/// order), as `hindsight batch` writes them; returns the summary's path.
#[pyfunction]
#[pyo3(signature = (rows_json, out, shard=None))]
fn write_batch_summary(
    py: Python<'_>,
    rows_json: &str,
    out: PathBuf,
    shard: Option<(usize, usize)>,
) -> PyResult<PathBuf> {
    let values: Vec<serde_json::Value> = serde_json::from_str(rows_json)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    let rows = values.iter().map(row_of).collect::<PyResult<Vec<_>>>()?;
    py.detach(|| hindsight::batch::write_summary(&rows, &out, shard))
        .map_err(|e| OutputError::new_err(chain(&e)))
}

#[pymodule]
fn _hindsight(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("HindsightError", py.get_type::<HindsightError>())?;
    m.add("LogError", py.get_type::<LogError>())?;
    m.add("SettingsError", py.get_type::<SettingsError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    m.add_function(wrap_pyfunction!(batch_mission, m)?)?;
    m.add_function(wrap_pyfunction!(read_log, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(write_batch_summary, m)?)?;
    m.add_class::<Reconstruction>()?;
    m.add_class::<ArrowTable>()?;
    Ok(())
}
