//! Arrow tables of `hindsight study`: one row per run, one row per case, and the errors
//! against time.

use super::columns::Columns;
use crate::study::{Case, CaseSummary, RunResult, TimeRow};
use arrow_array::{ArrayRef, RecordBatch, UInt64Array};
use arrow_schema::{ArrowError, DataType, Field};
use std::sync::Arc;

/// One row per run and solution: case, solution, seed, error, alignment and scores.
pub fn runs_batch(
    cases: &[Case],
    solutions: &[String],
    runs: &[RunResult],
) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.text(
        "case",
        runs.iter().map(|r| cases[r.case].label.as_str()).collect(),
    );
    c.text(
        "solution",
        runs.iter()
            .map(|r| solutions[r.solution].as_str())
            .collect(),
    );
    c.push(
        Field::new("seed", DataType::UInt64, false),
        Arc::new(UInt64Array::from(
            runs.iter().map(|r| r.seed).collect::<Vec<_>>(),
        )) as ArrayRef,
    );
    c.optional_text("error", runs.iter().map(|r| r.error.as_deref()).collect());
    let opt = |f: fn(&RunResult) -> Option<f64>| runs.iter().map(f).collect::<Vec<_>>();
    c.optional("aligned_after_s", "s", opt(|r| r.aligned_after_s));
    c.optional("roll_error_deg", "deg", opt(|r| r.roll_error_deg));
    c.optional("pitch_error_deg", "deg", opt(|r| r.pitch_error_deg));
    c.optional(
        "start_roll_error_deg",
        "deg",
        opt(|r| r.start_roll_error_deg),
    );
    c.optional(
        "start_pitch_error_deg",
        "deg",
        opt(|r| r.start_pitch_error_deg),
    );
    let ok = |f: fn(&RunResult) -> f64| {
        runs.iter()
            .map(|r| r.error.is_none().then(|| f(r)))
            .collect::<Vec<_>>()
    };
    c.optional(
        "forward_horizontal_rms_m",
        "m",
        ok(|r| r.forward_horizontal_rms_m),
    );
    c.optional(
        "smoothed_horizontal_rms_m",
        "m",
        ok(|r| r.smoothed_horizontal_rms_m),
    );
    c.optional("forward_final_m", "m", ok(|r| r.forward_final_m));
    c.optional("forward_yaw_rms_deg", "deg", ok(|r| r.forward_yaw_rms_deg));
    c.finish()
}

/// One row per case, solution and time: the RMS over the runs of the horizontal errors and
/// the mean body-x velocity error.
pub fn error_vs_time_batch(
    cases: &[Case],
    solutions: &[String],
    rows: &[TimeRow],
) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.text(
        "case",
        rows.iter().map(|r| cases[r.case].label.as_str()).collect(),
    );
    c.text(
        "solution",
        rows.iter()
            .map(|r| solutions[r.solution].as_str())
            .collect(),
    );
    let col = |f: fn(&TimeRow) -> f64| rows.iter().map(|r| Some(f(r))).collect::<Vec<_>>();
    c.number("t_s", "s", rows.iter().map(|r| r.t_s).collect());
    c.push(
        Field::new("runs", DataType::UInt64, false),
        Arc::new(UInt64Array::from(
            rows.iter().map(|r| r.runs as u64).collect::<Vec<_>>(),
        )) as ArrayRef,
    );
    c.optional("forward_rms_m", "m", col(|r| r.forward_rms_m));
    c.optional("smoothed_rms_m", "m", col(|r| r.smoothed_rms_m));
    c.optional(
        "body_x_velocity_error_mean_m_s",
        "m/s",
        col(|r| r.body_x_velocity_error_mean_m_s),
    );
    c.finish()
}

/// One row per case: its statistics.
pub fn summary_batch(summaries: &[CaseSummary]) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.text("case", summaries.iter().map(|s| s.label.as_str()).collect());
    c.text(
        "solution",
        summaries.iter().map(|s| s.solution.as_str()).collect(),
    );
    let count = |f: fn(&CaseSummary) -> usize| {
        Arc::new(UInt64Array::from(
            summaries.iter().map(|s| f(s) as u64).collect::<Vec<_>>(),
        )) as ArrayRef
    };
    c.push(
        Field::new("runs", DataType::UInt64, false),
        count(|s| s.runs),
    );
    c.push(
        Field::new("failed", DataType::UInt64, false),
        count(|s| s.failed),
    );
    c.push(
        Field::new("aligned", DataType::UInt64, false),
        count(|s| s.aligned),
    );
    let opt = |f: fn(&CaseSummary) -> Option<f64>| summaries.iter().map(f).collect::<Vec<_>>();
    c.optional("roll_error_mean_deg", "deg", opt(|s| s.roll_error_mean_deg));
    c.optional(
        "roll_error_sigma_deg",
        "deg",
        opt(|s| s.roll_error_sigma_deg),
    );
    c.optional(
        "pitch_error_mean_deg",
        "deg",
        opt(|s| s.pitch_error_mean_deg),
    );
    c.optional(
        "pitch_error_sigma_deg",
        "deg",
        opt(|s| s.pitch_error_sigma_deg),
    );
    c.optional("aligned_after_mean_s", "s", opt(|s| s.aligned_after_mean_s));
    c.optional(
        "aligned_after_sigma_s",
        "s",
        opt(|s| s.aligned_after_sigma_s),
    );
    c.optional(
        "forward_horizontal_rms_mean_m",
        "m",
        opt(|s| s.forward_horizontal_rms_mean_m),
    );
    c.optional(
        "smoothed_horizontal_rms_mean_m",
        "m",
        opt(|s| s.smoothed_horizontal_rms_mean_m),
    );
    c.finish()
}
