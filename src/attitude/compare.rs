//! The comparison `hindsight attitude` makes: every method on the same inputs (in parallel,
//! each a pure function), each attitude through the same DVL dead reckoning, each scored
//! against the `end` mark and, when the log has it, `/truth`.
//!
//! Without them the methods are still compared: with each other, against the smoothed MEKF
//! (the best attitude the log itself gives, [`attitude_reference`]), and by how close each
//! track comes back to its start when the run returns ([`closest_return_m`]).

use super::config::Filters;
use super::dead_reckoning::{attitude_at, dead_reckon, TrackPoint};
use super::euler::{self, from_quaternion};
use super::score::{attitude_error, AttitudeRms};
use super::{mekf, raw, AhrsInputs, AttitudeSample};
use crate::angle::wrap_pi;
use crate::contract::Dvl;
use crate::filters::ins::forward::DvlMounting;
use nalgebra::{UnitQuaternion, Vector3};
use rayon::prelude::*;

/// Why a log cannot be compared.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    #[error("no IMU data on /imu (at least two samples are needed)")]
    NoImu,
    #[error("no magnetometer readings on /mag, and every method asked for needs them")]
    NoMagnetometer,
}

/// An attitude method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Seed 001 eq. 1-4: accelerometer and magnetometer, sample by sample.
    Raw,
    /// Seed 001 Table 1 (Euler-angle EKF).
    Ekf,
    /// Seed 001 Table 2 (Euler-angle UKF).
    Ukf,
    /// Seed 001 Table 3 (complementary filter with PI rate-bias correction).
    Cf,
    /// hindsight's quaternion error-state filter with gyro-bias states.
    Mekf,
    /// The MEKF smoothed forward and backward over the whole log.
    MekfSmoothed,
}

impl Method {
    pub const ALL: [Method; 6] = [
        Method::Raw,
        Method::Ekf,
        Method::Ukf,
        Method::Cf,
        Method::Mekf,
        Method::MekfSmoothed,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::Raw => "raw",
            Method::Ekf => "ekf",
            Method::Ukf => "ukf",
            Method::Cf => "cf",
            Method::Mekf => "mekf",
            Method::MekfSmoothed => "mekf-smoothed",
        }
    }

    /// Whether the method cannot run without a magnetometer (seed 001's methods take yaw
    /// from it; the MEKF then runs on gravity alone, its yaw from the gyro).
    pub fn needs_magnetometer(self) -> bool {
        !matches!(self, Method::Mekf | Method::MekfSmoothed)
    }
}

/// One method's attitude and what it reports.
#[derive(Debug, Clone)]
pub struct MethodRun {
    pub method: Method,
    pub attitude: Vec<AttitudeSample>,
    /// Counts worth reporting (rejections, covariance repairs), as text.
    pub notes: Vec<String>,
    /// Covariance repairs (the UKF's; zero for the others).
    pub repairs: usize,
}

/// Runs one method.
pub fn run_method(method: Method, inputs: &AhrsInputs<'_>, filters: &Filters) -> MethodRun {
    let mut notes = Vec::new();
    let mut repairs = 0;
    let attitude = match method {
        Method::Raw => raw::run(inputs),
        Method::Ekf => euler::run(&filters.ekf, inputs).0,
        Method::Ukf => {
            let (attitude, last) = euler::run(&filters.ukf, inputs);
            repairs = last.map_or(0, |s| s.repairs);
            notes.push(format!("{repairs} covariance repairs"));
            attitude
        }
        Method::Cf => euler::run(&filters.cf, inputs).0,
        Method::Mekf | Method::MekfSmoothed => {
            let (attitude, counts) = if method == Method::Mekf {
                mekf::run(inputs, &filters.mekf)
            } else {
                mekf::run_smoothed(inputs, &filters.mekf).unwrap_or_else(|| {
                    notes.push("smoother failed: forward attitude kept".to_string());
                    mekf::run(inputs, &filters.mekf)
                })
            };
            notes.push(format!(
                "rejected: {} accelerometer, {} magnetometer; {} disturbed fields skipped",
                counts.accel_rejected, counts.mag_rejected, counts.mag_disturbed
            ));
            attitude
        }
    };
    MethodRun {
        method,
        attitude,
        notes,
        repairs,
    }
}

/// Runs the methods in parallel, in the order given.
pub fn run_methods(
    methods: &[Method],
    inputs: &AhrsInputs<'_>,
    filters: &Filters,
) -> Vec<MethodRun> {
    methods
        .par_iter()
        .map(|&m| run_method(m, inputs, filters))
        .collect()
}

/// Per-axis Euler-angle errors against the truth, deg.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EulerErrors {
    pub roll_rms_deg: f64,
    pub roll_max_deg: f64,
    pub pitch_rms_deg: f64,
    pub pitch_max_deg: f64,
    pub yaw_rms_deg: f64,
    pub yaw_max_deg: f64,
}

/// A method's scores.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodScore {
    pub method: Method,
    /// The dead reckoning (empty without a DVL or a start position).
    pub track: Vec<TrackPoint>,
    /// Horizontal distance from the track's end to the `end` mark, m.
    pub end_error_m: Option<f64>,
    /// Path length of the track (horizontal), m.
    pub path_m: Option<f64>,
    pub euler: Option<EulerErrors>,
    /// BROAD's total / heading / inclination RMS against the truth.
    pub broad: Option<AttitudeRms>,
    /// How close the track comes back to its start, m, when it returns.
    pub closest_return_m: Option<f64>,
}

impl MethodScore {
    pub fn end_error_percent(&self) -> Option<f64> {
        percent_of(self.end_error_m, self.path_m)
    }

    pub fn closest_return_percent(&self) -> Option<f64> {
        percent_of(self.closest_return_m, self.path_m)
    }
}

fn percent_of(distance_m: Option<f64>, path_m: Option<f64>) -> Option<f64> {
    match (distance_m, path_m) {
        (Some(e), Some(p)) if p > 0.0 => Some(100.0 * e / p),
        _ => None,
    }
}

/// What the scores are measured against.
pub struct Reference<'a> {
    pub dvl: &'a [Dvl],
    pub mounting: &'a DvlMounting,
    /// The longest stretch without a valid reading that the dead reckoning bridges, s.
    pub max_gap_s: f64,
    /// Where the dead reckoning starts (the `start` mark), NED m.
    pub start_ned_m: Option<Vector3<f64>>,
    pub end_ned_m: Option<Vector3<f64>>,
    /// The reference attitude (`/truth`, or without it another method's; empty for none)
    /// and the stamps to score it at.
    pub truth: &'a [AttitudeSample],
    pub scored: &'a (dyn Fn(i64) -> bool + Sync),
}

/// Scores one method's attitude.
pub fn score(run: &MethodRun, reference: &Reference<'_>) -> MethodScore {
    let track = match reference.start_ned_m {
        Some(start) if !reference.dvl.is_empty() => dead_reckon(
            &run.attitude,
            reference.dvl,
            reference.mounting,
            start,
            reference.max_gap_s,
        ),
        _ => Vec::new(),
    };
    let path_m = (!track.is_empty()).then(|| {
        track
            .windows(2)
            .map(|w| (w[1].ned_m - w[0].ned_m).xy().norm())
            .sum()
    });
    let end_error_m = match (track.last(), reference.end_ned_m) {
        (Some(last), Some(end)) => Some((last.ned_m - end).xy().norm()),
        _ => None,
    };
    let (euler, broad) = truth_errors(&run.attitude, reference);
    MethodScore {
        method: run.method,
        closest_return_m: closest_return_m(&track),
        track,
        end_error_m,
        path_m,
        euler,
        broad,
    }
}

/// A track must go this far from its start to be said to come back (m).
pub const MIN_EXCURSION_M: f64 = 2.0;
/// ... and come back within this fraction of its farthest distance.
pub const RETURN_FRACTION: f64 = 0.25;

/// The horizontal distance from the start of the closest point of the track after its
/// farthest one, m: how well a run that returns to where it began closes. `None` when the
/// track never goes [`MIN_EXCURSION_M`] away, or does not come back within
/// [`RETURN_FRACTION`] of its farthest distance.
pub fn closest_return_m(track: &[TrackPoint]) -> Option<f64> {
    let start = track.first()?.ned_m;
    let distance = |p: &TrackPoint| (p.ned_m - start).xy().norm();
    let (farthest, d_max) = track
        .iter()
        .enumerate()
        .map(|(i, p)| (i, distance(p)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if d_max < MIN_EXCURSION_M {
        return None;
    }
    let closest = track[farthest..]
        .iter()
        .map(distance)
        .fold(f64::INFINITY, f64::min);
    (closest <= RETURN_FRACTION * d_max).then_some(closest)
}

/// The method the others are compared with when the log has no truth: the smoothed MEKF,
/// else the forward one, if it ran.
pub fn attitude_reference(runs: &[MethodRun]) -> Option<&MethodRun> {
    [Method::MekfSmoothed, Method::Mekf]
        .into_iter()
        .find_map(|m| runs.iter().find(|r| r.method == m))
}

/// Errors against the truth at its scored stamps (the estimate interpolated there).
/// Roll, pitch and yaw of `q` less those of `reference`, rad (roll and yaw wrapped).
fn euler_difference(q: &UnitQuaternion<f64>, reference: &UnitQuaternion<f64>) -> [f64; 3] {
    let (e, r) = (from_quaternion(q), from_quaternion(reference));
    [wrap_pi(e[0] - r[0]), e[1] - r[1], wrap_pi(e[2] - r[2])]
}

/// Roll, pitch and yaw errors over time: `(stamp ns, [roll, pitch, yaw] deg)`.
pub type ErrorSeries = Vec<(i64, [f64; 3])>;

/// A method's roll, pitch and yaw errors against the reference attitude over time, at each
/// reference sample the method has an attitude for.
pub fn euler_error_series(
    attitude: &[AttitudeSample],
    reference: &[AttitudeSample],
) -> ErrorSeries {
    reference
        .iter()
        .filter_map(|t| {
            let q = attitude_at(attitude, t.stamp_ns)?;
            Some((
                t.stamp_ns,
                euler_difference(&q, &t.ned_from_body).map(f64::to_degrees),
            ))
        })
        .collect()
}

fn truth_errors(
    attitude: &[AttitudeSample],
    reference: &Reference<'_>,
) -> (Option<EulerErrors>, Option<AttitudeRms>) {
    let mut sums = [0.0; 6];
    let mut max = [0.0f64; 3];
    let mut n = 0usize;
    for t in reference.truth {
        if !(reference.scored)(t.stamp_ns) {
            continue;
        }
        let Some(q) = attitude_at(attitude, t.stamp_ns) else {
            continue;
        };
        let d = euler_difference(&q, &t.ned_from_body);
        for i in 0..3 {
            sums[i] += d[i] * d[i];
            max[i] = max[i].max(d[i].abs());
        }
        let b = attitude_error(&q, &t.ned_from_body);
        sums[3] += b.total.powi(2);
        sums[4] += b.heading.powi(2);
        sums[5] += b.inclination.powi(2);
        n += 1;
    }
    if n == 0 {
        return (None, None);
    }
    let rms = |s: f64| (s / n as f64).sqrt().to_degrees();
    (
        Some(EulerErrors {
            roll_rms_deg: rms(sums[0]),
            roll_max_deg: max[0].to_degrees(),
            pitch_rms_deg: rms(sums[1]),
            pitch_max_deg: max[1].to_degrees(),
            yaw_rms_deg: rms(sums[2]),
            yaw_max_deg: max[2].to_degrees(),
        }),
        Some(AttitudeRms::of(n, [sums[3], sums[4], sums[5]])),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(points: &[(f64, f64)]) -> Vec<TrackPoint> {
        points
            .iter()
            .enumerate()
            .map(|(i, &(n, e))| TrackPoint {
                stamp_ns: i as i64,
                ned_m: Vector3::new(n, e, 0.0),
            })
            .collect()
    }

    #[test]
    fn a_run_that_comes_back_has_a_closest_return() {
        // Out 10 m, across, back to within 0.5 m, then away again.
        let t = track(&[(0.0, 0.0), (10.0, 0.0), (10.0, 5.0), (0.3, 0.4), (3.0, 0.0)]);
        assert!((closest_return_m(&t).unwrap() - 0.5).abs() < 1e-12);
        // A straight run does not come back; a run that never leaves has nothing to close.
        assert_eq!(
            closest_return_m(&track(&[(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)])),
            None
        );
        assert_eq!(
            closest_return_m(&track(&[(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)])),
            None
        );
        assert_eq!(closest_return_m(&[]), None);
    }
}

#[cfg(test)]
mod error_series {
    use super::*;

    /// The error series is what the summary's RMS is made of: a method turned off the
    /// reference by known angles gives them back at every sample, and their RMS is the
    /// summary's.
    #[test]
    fn the_error_series_gives_back_a_known_offset_and_the_summarys_rms() {
        let reference: Vec<AttitudeSample> = (0..50)
            .map(|k| AttitudeSample {
                stamp_ns: k * 100_000_000,
                ned_from_body: UnitQuaternion::from_euler_angles(0.1, -0.05, 0.02 * k as f64),
            })
            .collect();
        let offset_deg = [0.5, -0.3, 2.0];
        let method: Vec<AttitudeSample> = reference
            .iter()
            .map(|r| {
                let (roll, pitch, yaw) = r.ned_from_body.euler_angles();
                let o = offset_deg.map(f64::to_radians);
                AttitudeSample {
                    stamp_ns: r.stamp_ns,
                    ned_from_body: UnitQuaternion::from_euler_angles(
                        roll + o[0],
                        pitch + o[1],
                        yaw + o[2],
                    ),
                }
            })
            .collect();
        let series = euler_error_series(&method, &reference);
        assert_eq!(series.len(), reference.len());
        for (_, e) in &series {
            for k in 0..3 {
                assert!((e[k] - offset_deg[k]).abs() < 1e-9, "{e:?}");
            }
        }
        let mounting = DvlMounting::default();
        let everywhere = |_: i64| true;
        let summary = truth_errors(
            &method,
            &Reference {
                dvl: &[],
                mounting: &mounting,
                max_gap_s: 5.0,
                start_ned_m: None,
                end_ned_m: None,
                truth: &reference,
                scored: &everywhere,
            },
        )
        .0
        .unwrap();
        assert!((summary.roll_rms_deg - 0.5).abs() < 1e-9);
        assert!((summary.yaw_rms_deg - 2.0).abs() < 1e-9);
    }
}
