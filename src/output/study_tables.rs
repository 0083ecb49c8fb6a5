//! Arrow tables of `hindsight study`: one row per run, one row per case, and the errors
//! against time.

use super::columns::Columns;
use crate::study::{Case, CaseSummary, RunResult, TimeRow};
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;

/// A number column of a table: its name, its unit and how a row gives it.
type Column<Row> = (&'static str, &'static str, fn(&Row) -> Option<f64>);

/// Adds `columns`, each read from every row.
fn add_columns<Row>(c: &mut Columns, rows: &[Row], columns: &[Column<Row>]) {
    for &(name, unit, value) in columns {
        c.optional(name, unit, rows.iter().map(value).collect());
    }
}

/// Columns that start with each row's case label and solution name (`of_row`: each row's
/// case and solution).
fn case_and_solution(
    cases: &[Case],
    solutions: &[String],
    of_row: impl Iterator<Item = (usize, usize)> + Clone,
) -> Columns {
    let mut c = Columns::default();
    let labels = of_row.clone().map(|(case, _)| cases[case].label.as_str());
    c.text("case", labels.collect());
    let names = of_row.map(|(_, solution)| solutions[solution].as_str());
    c.text("solution", names.collect());
    c
}

/// One row per run and solution: case, solution, seed, error, alignment and scores.
pub fn runs_batch(
    cases: &[Case],
    solutions: &[String],
    runs: &[RunResult],
) -> Result<RecordBatch, ArrowError> {
    let mut c = case_and_solution(cases, solutions, runs.iter().map(|r| (r.case, r.solution)));
    c.count("seed", runs.iter().map(|r| r.seed).collect());
    c.optional_text("error", runs.iter().map(|r| r.error.as_deref()).collect());
    add_columns(
        &mut c,
        runs,
        &[
            ("aligned_after_s", "s", |r| r.aligned_after_s),
            ("roll_error_deg", "deg", |r| r.roll_error_deg),
            ("pitch_error_deg", "deg", |r| r.pitch_error_deg),
            ("start_roll_error_deg", "deg", |r| r.start_roll_error_deg),
            ("start_pitch_error_deg", "deg", |r| r.start_pitch_error_deg),
            // Scores of a run that did not fail.
            ("forward_horizontal_rms_m", "m", |r| {
                r.error.is_none().then_some(r.forward_horizontal_rms_m)
            }),
            ("smoothed_horizontal_rms_m", "m", |r| {
                r.error.is_none().then_some(r.smoothed_horizontal_rms_m)
            }),
            ("forward_final_m", "m", |r| {
                r.error.is_none().then_some(r.forward_final_m)
            }),
            ("forward_yaw_rms_deg", "deg", |r| {
                r.error.is_none().then_some(r.forward_yaw_rms_deg)
            }),
        ],
    );
    c.finish()
}

/// One row per case, solution and time: the RMS over the runs of the horizontal errors and
/// the mean body-x velocity error.
pub fn error_vs_time_batch(
    cases: &[Case],
    solutions: &[String],
    rows: &[TimeRow],
) -> Result<RecordBatch, ArrowError> {
    let mut c = case_and_solution(cases, solutions, rows.iter().map(|r| (r.case, r.solution)));
    c.number("t_s", "s", rows.iter().map(|r| r.t_s).collect());
    c.count("runs", rows.iter().map(|r| r.runs as u64).collect());
    add_columns(
        &mut c,
        rows,
        &[
            ("forward_rms_m", "m", |r| Some(r.forward_rms_m)),
            ("smoothed_rms_m", "m", |r| Some(r.smoothed_rms_m)),
            ("body_x_velocity_error_mean_m_s", "m/s", |r| {
                Some(r.body_x_velocity_error_mean_m_s)
            }),
        ],
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
    c.count("runs", summaries.iter().map(|s| s.runs as u64).collect());
    c.count(
        "failed",
        summaries.iter().map(|s| s.failed as u64).collect(),
    );
    c.count(
        "aligned",
        summaries.iter().map(|s| s.aligned as u64).collect(),
    );
    add_columns(
        &mut c,
        summaries,
        &[
            ("roll_error_mean_deg", "deg", |s| s.roll_error_mean_deg),
            ("roll_error_sigma_deg", "deg", |s| s.roll_error_sigma_deg),
            ("pitch_error_mean_deg", "deg", |s| s.pitch_error_mean_deg),
            ("pitch_error_sigma_deg", "deg", |s| s.pitch_error_sigma_deg),
            ("aligned_after_mean_s", "s", |s| s.aligned_after_mean_s),
            ("aligned_after_sigma_s", "s", |s| s.aligned_after_sigma_s),
            ("forward_horizontal_rms_mean_m", "m", |s| {
                s.forward_horizontal_rms_mean_m
            }),
            ("smoothed_horizontal_rms_mean_m", "m", |s| {
                s.smoothed_horizontal_rms_mean_m
            }),
        ],
    );
    c.finish()
}
