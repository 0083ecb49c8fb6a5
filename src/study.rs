//! Monte Carlo studies: a scenario simulated with seeds `base + i`, each run reconstructed
//! and scored against its `/truth`. Pure over a scenario and a configuration (the runs are
//! made in memory); the command (`cli/study.rs`) runs them in parallel and writes the tables.
//!
//! Each run is independent and seeded, so the same seeds give the same numbers whatever the
//! number of threads.

use crate::align::latest_at;
use crate::contract::Truth;
use crate::ingest::{read_log_from, IngestOptions};
use crate::recon::config::Config;
use crate::recon::score::{epoch_error, scores};
use crate::recon::{reconstruct, Streams};
use crate::sim::scenario::Scenario;
use crate::sim::writer::{to_bytes, WriterOptions};

/// One case of a study: the scenario with its start tilt set (a dropped vehicle's roll and
/// pitch), or as it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    pub label: String,
    pub start_roll_deg: Option<f64>,
    pub start_pitch_deg: Option<f64>,
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
        s
    }
}

/// What one run gave.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunResult {
    pub case: usize,
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
    /// Forward horizontal error, m, once a second from the first IMU sample.
    pub forward_error_series: Vec<f64>,
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

/// Simulates `scenario` with `seed`, reconstructs it with `config`, scores it.
pub fn run_one(
    scenario: &Scenario,
    seed: u64,
    config: &Config,
    case: usize,
) -> Result<RunResult, StudyError> {
    let mut simulated = Ok(());
    let bytes = to_bytes(WriterOptions::default(), |w| {
        simulated = crate::sim::run::run(scenario, seed, w).map(|_| ());
        Ok(())
    })
    .map_err(|e| StudyError::Simulate(e.to_string()))?;
    simulated.map_err(|e| StudyError::Simulate(e.to_string()))?;
    let log = read_log_from(&bytes[..], &IngestOptions::default())
        .map_err(|e| StudyError::Read(e.to_string()))?;
    let mission = log.mission().map_err(|e| StudyError::Read(e.to_string()))?;
    let streams = Streams::of(&log);
    let r = reconstruct(&streams, &mission, config)
        .map_err(|e| StudyError::Reconstruct(e.to_string()))?;
    let pick = |sol: &[crate::filters::ins::record::Solution]| {
        sol.iter()
            .zip(&r.output)
            .filter(|(_, &out)| out)
            .filter_map(|(s, _)| epoch_error(streams.truth, s))
            .collect::<Vec<_>>()
    };
    let (fwd, smo) = (pick(&r.forward), pick(&r.smoothed));
    let (Some(f), Some(s)) = (scores(&fwd), scores(&smo)) else {
        return Err(StudyError::Reconstruct(
            "no epoch to score against /truth".into(),
        ));
    };
    let t0 = r.init.estimate_stamp_ns;
    let mut series = Vec::new();
    for e in &fwd {
        if (e.stamp_ns - t0) >= series.len() as i64 * 1_000_000_000 {
            series.push(e.horizontal_m());
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
        at_align = tilt_error(latest_at(streams.truth, middle), a.roll_rad, a.pitch_rad);
        let (roll, pitch, _) = r.init.estimate.nav.ned_from_body.euler_angles();
        at_start = tilt_error(latest_at(streams.truth, t0), roll, pitch);
    }
    Ok(RunResult {
        case,
        seed,
        error: None,
        aligned_after_s: r.init.in_run.map(|a| a.aligned_after_s),
        roll_error_deg: at_align.map(|e| e.0),
        pitch_error_deg: at_align.map(|e| e.1),
        start_roll_error_deg: at_start.map(|e| e.0),
        start_pitch_error_deg: at_start.map(|e| e.1),
        forward_horizontal_rms_m: f.horizontal_rms_m,
        smoothed_horizontal_rms_m: s.horizontal_rms_m,
        forward_final_m: f.horizontal_final_m,
        forward_yaw_rms_deg: f.yaw_rms_deg,
        forward_error_series: series,
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

/// One case's statistics over its runs.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CaseSummary {
    pub label: String,
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

/// The statistics of each case.
pub fn summarise(cases: &[Case], runs: &[RunResult]) -> Vec<CaseSummary> {
    cases
        .iter()
        .enumerate()
        .map(|(k, case)| {
            let mine: Vec<&RunResult> = runs.iter().filter(|r| r.case == k).collect();
            let ok: Vec<&&RunResult> = mine.iter().filter(|r| r.error.is_none()).collect();
            let stat =
                |f: &dyn Fn(&RunResult) -> Option<f64>| mean_sigma(ok.iter().filter_map(|r| f(r)));
            let roll = stat(&|r| r.roll_error_deg);
            let pitch = stat(&|r| r.pitch_error_deg);
            let after = stat(&|r| r.aligned_after_s);
            CaseSummary {
                label: case.label.clone(),
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
