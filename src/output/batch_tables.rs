//! Arrow table of `hindsight batch`: one row per mission.

use super::columns::Columns;
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;

/// What became of one mission of a batch.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MissionRow {
    /// The mission's name: its partition is `mission=<name>`.
    pub mission: String,
    pub log: String,
    /// `done` (reconstructed now), `complete` (its outputs were already there) or `failed`.
    pub status: &'static str,
    /// Why it failed.
    pub error: Option<String>,
    /// Seconds this run spent on it (none for a complete mission).
    pub run_time_s: Option<f64>,
    pub duration_s: Option<f64>,
    pub distance_travelled_m: Option<f64>,
    pub final_horizontal_sigma_forward_m: Option<f64>,
    pub final_horizontal_sigma_smoothed_m: Option<f64>,
    /// The run's verdict on its uncertainty.
    pub consistent: Option<bool>,
    /// Against `/truth`, when the log has it.
    pub forward_horizontal_rms_m: Option<f64>,
    pub smoothed_horizontal_rms_m: Option<f64>,
}

pub fn batch_summary(rows: &[MissionRow]) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.text("mission", rows.iter().map(|r| r.mission.as_str()).collect());
    c.text("log", rows.iter().map(|r| r.log.as_str()).collect());
    c.text("status", rows.iter().map(|r| r.status).collect());
    c.optional_text("error", rows.iter().map(|r| r.error.as_deref()).collect());
    numbers(
        &mut c,
        rows,
        &[
            ("run_time_s", "s", |r| r.run_time_s),
            ("duration_s", "s", |r| r.duration_s),
            ("distance_travelled_m", "m", |r| r.distance_travelled_m),
            ("final_horizontal_sigma_forward_m", "m", |r| {
                r.final_horizontal_sigma_forward_m
            }),
            ("final_horizontal_sigma_smoothed_m", "m", |r| {
                r.final_horizontal_sigma_smoothed_m
            }),
        ],
    );
    c.optional_flag("consistent", rows.iter().map(|r| r.consistent).collect());
    numbers(
        &mut c,
        rows,
        &[
            ("forward_horizontal_rms_m", "m", |r| {
                r.forward_horizontal_rms_m
            }),
            ("smoothed_horizontal_rms_m", "m", |r| {
                r.smoothed_horizontal_rms_m
            }),
        ],
    );
    c.finish()
}

/// A number column (name, unit, value) per entry, null where a row has no value.
type Column<'a> = (&'a str, &'a str, fn(&MissionRow) -> Option<f64>);

fn numbers(c: &mut Columns, rows: &[MissionRow], columns: &[Column<'_>]) {
    for (name, unit, f) in columns {
        c.optional(name, unit, rows.iter().map(f).collect());
    }
}
