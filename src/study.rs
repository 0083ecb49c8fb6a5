//! Monte Carlo studies: a scenario simulated with seeds `base + i`, each run reconstructed
//! and scored against its `/truth`. Pure over a scenario and a configuration (the runs are
//! made in memory); the command (`cli/study.rs`) runs them in parallel and writes the tables.
//!
//! Each run is independent and seeded, so the same seeds give the same numbers whatever the
//! number of threads.

use crate::align::latest_at;
use crate::contract::Truth;
use crate::recon::config::Config;
use crate::recon::score::scores;
use crate::recon::{AttitudeTrack, Reconstruction as Solved};
use crate::reconstruction::{Job, Observer};
use crate::sim::scenario::Scenario;
use crate::sim::writer::{to_bytes, Compression, WriterOptions};
use std::sync::Arc;

/// One case of a study: the scenario with its start tilt set (a dropped vehicle's roll and
/// pitch) or its vehicle's coefficients drawn with an uncertainty (seed 000's case 2), or as
/// it is.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Case {
    pub label: String,
    pub start_roll_deg: Option<f64>,
    pub start_pitch_deg: Option<f64>,
    /// 1-sigma fraction of the true vehicle's coefficients about the file's (a dynamic
    /// scenario's).
    pub coef_uncertainty: Option<f64>,
}

impl Case {
    /// The scenario of this case.
    pub fn scenario(&self, base: &Scenario) -> Scenario {
        let mut s = base.clone();
        if let Some(r) = self.start_roll_deg {
            s.start.roll_deg = r;
        }
        if let Some(p) = self.start_pitch_deg {
            s.start.pitch_deg = p;
        }
        if let (Some(u), Some(d)) = (self.coef_uncertainty, s.dynamics.as_mut()) {
            d.coef_uncertainty = u;
        }
        s
    }
}

/// One way of reconstructing each run (a study compares them on the same simulated logs).
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub label: String,
    pub config: Config,
}

/// What one run gave.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunResult {
    pub case: usize,
    /// Which solution (index into the study's solutions).
    pub solution: usize,
    pub seed: u64,
    /// Why the run failed, if it did.
    pub error: Option<String>,
    /// Seed 002's in-run alignment: seconds from the first IMU sample to its end, and the
    /// roll and pitch errors then and carried to the start, deg.
    pub aligned_after_s: Option<f64>,
    pub roll_error_deg: Option<f64>,
    pub pitch_error_deg: Option<f64>,
    pub start_roll_error_deg: Option<f64>,
    pub start_pitch_error_deg: Option<f64>,
    pub forward_horizontal_rms_m: f64,
    pub smoothed_horizontal_rms_m: f64,
    pub forward_final_m: f64,
    pub forward_yaw_rms_deg: f64,
    /// Interval of the error series, s.
    pub series_step_s: f64,
    /// Forward horizontal error, m, every `series_step_s` from the first IMU sample.
    pub forward_error_series: Vec<f64>,
    /// Smoothed horizontal error, m, at the same times.
    pub smoothed_error_series: Vec<f64>,
    /// Forward velocity error along the true body x axis, m/s, at the same times.
    pub forward_body_x_velocity_error_series: Vec<f64>,
}

/// Interval of a run's error series: one second, or longer for a long mission (at most about
/// 2000 points).
pub fn series_step_s(duration_s: f64) -> f64 {
    (duration_s / 2000.0).ceil().max(1.0)
}

/// Why a run could not be made (its message goes into the run's row).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("simulating: {0}")]
    Simulate(String),
    #[error("reading the simulated log: {0}")]
    Read(String),
    #[error("{0}")]
    Reconstruct(String),
}

/// Simulates `scenario` with `seed` once and reconstructs it with each solution's
/// configuration (its `initial.truth_seed` set to the run's seed), each scored.
pub fn run_solutions(
    scenario: &Scenario,
    seed: u64,
    solutions: &[Solution],
    case: usize,
) -> Result<Vec<Result<RunResult, StudyError>>, StudyError> {
    let mut simulated = Ok(());
    // The log lives in memory for a moment: compressing it would only cost time.
    let options = WriterOptions {
        compression: Compression::None,
        ..WriterOptions::default()
    };
    let bytes = to_bytes(options, |w| {
        simulated = crate::sim::run::run(scenario, seed, w).map(|_| ());
        Ok(())
    })
    .map_err(|e| StudyError::Simulate(e.to_string()))?;
    simulated.map_err(|e| StudyError::Simulate(e.to_string()))?;
    let bytes: Arc<[u8]> = bytes.into();
    // Solutions whose settings differ only in the model aid's share its first pass.
    let mut shared: Vec<(Config, AttitudeTrack)> = Vec::new();
    Ok(solutions
        .iter()
        .enumerate()
        .map(|(k, solution)| {
            let mut config = solution.config.clone();
            config.initial.truth_seed = seed;
            let key = Config {
                model_velocity: Default::default(),
                ..config.clone()
            };
            let name = format!("{} seed {seed}", solution.label);
            let job = Job {
                shared_attitude: shared.iter().find(|(c, _)| *c == key).map(|s| s.1.clone()),
                ..Job::in_memory(&name, bytes.clone(), config)
            };
            let r = crate::reconstruct(&job, Observer::default()).map_err(study_error)?;
            if let Some(track) = r.model_attitude.clone() {
                shared.push((key, track));
            }
            let truth = r.truth.read().map_err(study_error)?;
            let mut run = score_run(&r.solved, &truth)?;
            (run.case, run.solution, run.seed) = (case, k, seed);
            Ok(run)
        })
        .collect())
}

/// A reconstruction's failure as a run's: the filter's own message, or the reading's.
fn study_error(e: crate::reconstruction::Error) -> StudyError {
    use std::error::Error as _;
    match e {
        crate::reconstruction::Error::Reconstruct { source, .. } => {
            StudyError::Reconstruct(source.to_string())
        }
        other => StudyError::Read(match other.source() {
            Some(source) => format!("{other}: {source}"),
            None => other.to_string(),
        }),
    }
}

/// Seconds from the first to the last truth sample.
fn truth_span_s(truth: &[Truth]) -> f64 {
    match (truth.first(), truth.last()) {
        (Some(a), Some(b)) => (b.stamp_ns - a.stamp_ns) as f64 * 1e-9,
        _ => 0.0,
    }
}

/// Scores one reconstruction against its `/truth`.
fn score_run(r: &Solved, truth: &[Truth]) -> Result<RunResult, StudyError> {
    let step_s = series_step_s(truth_span_s(truth));
    let pick = |sol| {
        crate::recon::score::errors(truth, sol, &r.output)
            .map_err(|e| StudyError::Reconstruct(format!("reading the solutions back: {e}")))
    };
    let (fwd, smo) = (pick(&r.forward)?, pick(&r.smoothed)?);
    let (Some(f), Some(s)) = (scores(&fwd), scores(&smo)) else {
        return Err(StudyError::Reconstruct(
            "no epoch to score against /truth".into(),
        ));
    };
    let t0 = r.init.estimate_stamp_ns;
    let step_ns = (step_s * 1e9) as i64;
    let (mut series, mut smoothed_series, mut body_x) = (Vec::new(), Vec::new(), Vec::new());
    for (e, s) in fwd.iter().zip(&smo) {
        if (e.stamp_ns - t0) >= series.len() as i64 * step_ns {
            series.push(e.horizontal_m());
            smoothed_series.push(s.horizontal_m());
            let along = latest_at(truth, e.stamp_ns).map_or(f64::NAN, |(t, _)| {
                let ned_from_body = nalgebra::UnitQuaternion::from_euler_angles(
                    t.attitude[0],
                    t.attitude[1],
                    t.attitude[2],
                );
                (ned_from_body.inverse() * e.velocity_m_s).x
            });
            body_x.push(along);
        }
    }
    let tilt_error = |truth: Option<(&Truth, i64)>, roll: f64, pitch: f64| {
        truth.map(|(t, _)| {
            (
                crate::angle::wrap_pi(roll - t.attitude[0]).to_degrees(),
                crate::angle::wrap_pi(pitch - t.attitude[1]).to_degrees(),
            )
        })
    };
    let (mut at_align, mut at_start) = (None, None);
    if let Some(a) = r.init.in_run {
        let middle = a.stable_at_ns + (t0 + (a.aligned_after_s * 1e9) as i64 - a.stable_at_ns) / 2;
        at_align = tilt_error(latest_at(truth, middle), a.roll_rad, a.pitch_rad);
        let (roll, pitch, _) = r.init.estimate.nav.ned_from_body.euler_angles();
        at_start = tilt_error(latest_at(truth, t0), roll, pitch);
    }
    Ok(RunResult {
        aligned_after_s: r.init.in_run.map(|a| a.aligned_after_s),
        roll_error_deg: at_align.map(|e| e.0),
        pitch_error_deg: at_align.map(|e| e.1),
        start_roll_error_deg: at_start.map(|e| e.0),
        start_pitch_error_deg: at_start.map(|e| e.1),
        forward_horizontal_rms_m: f.horizontal_rms_m,
        smoothed_horizontal_rms_m: s.horizontal_rms_m,
        forward_final_m: f.horizontal_final_m,
        forward_yaw_rms_deg: f.yaw_rms_deg,
        series_step_s: step_s,
        forward_error_series: series,
        smoothed_error_series: smoothed_series,
        forward_body_x_velocity_error_series: body_x,
        ..RunResult::default()
    })
}

/// Mean and sample standard deviation (`None` for no values; sigma 0 for one).
pub fn mean_sigma(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let v: Vec<f64> = values.collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    Some((mean, var.sqrt()))
}

/// One case's statistics over its runs (of one solution).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CaseSummary {
    pub label: String,
    pub solution: String,
    pub runs: usize,
    pub failed: usize,
    /// Runs in which the in-run alignment happened.
    pub aligned: usize,
    pub roll_error_mean_deg: Option<f64>,
    pub roll_error_sigma_deg: Option<f64>,
    pub pitch_error_mean_deg: Option<f64>,
    pub pitch_error_sigma_deg: Option<f64>,
    pub aligned_after_mean_s: Option<f64>,
    pub aligned_after_sigma_s: Option<f64>,
    pub forward_horizontal_rms_mean_m: Option<f64>,
    pub smoothed_horizontal_rms_mean_m: Option<f64>,
}

/// The statistics of each case and solution.
pub fn summarise(cases: &[Case], solutions: &[String], runs: &[RunResult]) -> Vec<CaseSummary> {
    let pairs = cases.iter().enumerate().flat_map(|(k, case)| {
        solutions
            .iter()
            .enumerate()
            .map(move |(j, solution)| (k, case, j, solution))
    });
    pairs
        .map(|(k, case, j, solution)| {
            let mine: Vec<&RunResult> = runs
                .iter()
                .filter(|r| r.case == k && r.solution == j)
                .collect();
            let ok: Vec<&&RunResult> = mine.iter().filter(|r| r.error.is_none()).collect();
            let stat =
                |f: &dyn Fn(&RunResult) -> Option<f64>| mean_sigma(ok.iter().filter_map(|r| f(r)));
            let roll = stat(&|r| r.roll_error_deg);
            let pitch = stat(&|r| r.pitch_error_deg);
            let after = stat(&|r| r.aligned_after_s);
            CaseSummary {
                label: case.label.clone(),
                solution: solution.clone(),
                runs: mine.len(),
                failed: mine.len() - ok.len(),
                aligned: ok.iter().filter(|r| r.aligned_after_s.is_some()).count(),
                roll_error_mean_deg: roll.map(|s| s.0),
                roll_error_sigma_deg: roll.map(|s| s.1),
                pitch_error_mean_deg: pitch.map(|s| s.0),
                pitch_error_sigma_deg: pitch.map(|s| s.1),
                aligned_after_mean_s: after.map(|s| s.0),
                aligned_after_sigma_s: after.map(|s| s.1),
                forward_horizontal_rms_mean_m: stat(&|r| Some(r.forward_horizontal_rms_m))
                    .map(|s| s.0),
                smoothed_horizontal_rms_mean_m: stat(&|r| Some(r.smoothed_horizontal_rms_m))
                    .map(|s| s.0),
            }
        })
        .collect()
}

/// The runs' errors at one time, for one case and solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeRow {
    pub case: usize,
    pub solution: usize,
    pub t_s: f64,
    /// Runs with a value at this time.
    pub runs: usize,
    /// Root mean square over the runs of the horizontal error, m.
    pub forward_rms_m: f64,
    pub smoothed_rms_m: f64,
    /// Mean over the runs of the forward velocity error along the body x axis, m/s.
    pub body_x_velocity_error_mean_m_s: f64,
}

/// RMS over the runs of the horizontal error against time (and the mean body-x velocity
/// error), per case and solution: seed 000's figures 9-13.
pub fn error_vs_time(runs: &[RunResult], cases: usize, solutions: usize) -> Vec<TimeRow> {
    let mut rows = Vec::new();
    for case in 0..cases {
        for solution in 0..solutions {
            let mine: Vec<&RunResult> = runs
                .iter()
                .filter(|r| r.case == case && r.solution == solution && r.error.is_none())
                .collect();
            let len = mine.iter().map(|r| r.forward_error_series.len()).max();
            for i in 0..len.unwrap_or(0) {
                let at = |f: fn(&RunResult) -> &Vec<f64>| -> Vec<f64> {
                    mine.iter()
                        .filter_map(|r| f(r).get(i).copied())
                        .filter(|v| v.is_finite())
                        .collect()
                };
                let rms =
                    |v: Vec<f64>| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
                let forward = at(|r| &r.forward_error_series);
                let runs_here = forward.len();
                let body_x = at(|r| &r.forward_body_x_velocity_error_series);
                rows.push(TimeRow {
                    case,
                    solution,
                    t_s: i as f64 * mine[0].series_step_s,
                    runs: runs_here,
                    forward_rms_m: rms(forward),
                    smoothed_rms_m: rms(at(|r| &r.smoothed_error_series)),
                    body_x_velocity_error_mean_m_s: mean_sigma(body_x.into_iter())
                        .map_or(f64::NAN, |s| s.0),
                });
            }
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_sigma() {
        let (m, s) = mean_sigma([1.0, 2.0, 3.0, 4.0].into_iter()).unwrap();
        assert_eq!(m, 2.5);
        assert!((s - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!(mean_sigma(std::iter::empty()).is_none());
        assert_eq!(mean_sigma([7.0].into_iter()), Some((7.0, 0.0)));
    }
}
