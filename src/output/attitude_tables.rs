//! Arrow tables of `hindsight attitude`: `attitude` (every method's attitude and dead
//! reckoning at its stamps) and `attitude_summary` (one row per method).

use super::columns::Columns;
use crate::attitude::compare::{MethodRun, MethodScore};
use crate::attitude::dead_reckoning::TrackPoint;
use crate::attitude::euler::from_quaternion;
use crate::attitude::AttitudeSample;
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;
use nalgebra::Vector3;

/// Rows of `attitude.parquet` for one method: stamp, method, roll/pitch/yaw (rad) and the
/// dead-reckoned north/east/down (m, interpolated between DVL readings; null outside the
/// track).
pub fn attitude_batch(
    method: &str,
    rows: &[AttitudeSample],
    track: &[TrackPoint],
) -> Result<RecordBatch, ArrowError> {
    let euler: Vec<_> = rows
        .iter()
        .map(|s| from_quaternion(&s.ned_from_body))
        .collect();
    let position: Vec<Option<Vector3<f64>>> = rows
        .iter()
        .map(|s| position_at(track, s.stamp_ns))
        .collect();
    let mut c = Columns::default();
    c.stamps(rows.iter().map(|s| s.stamp_ns).collect());
    c.text("method", vec![method; rows.len()]);
    for (i, name) in ["roll_rad", "pitch_rad", "yaw_rad"].iter().enumerate() {
        c.number(name, "rad", euler.iter().map(|e| e[i]).collect());
    }
    for (i, name) in ["north_m", "east_m", "down_m"].iter().enumerate() {
        c.optional(
            name,
            "m",
            position.iter().map(|p| p.map(|p| p[i])).collect(),
        );
    }
    c.finish()
}

/// The track's position at `stamp_ns` (linear between its points), `None` outside it.
fn position_at(track: &[TrackPoint], stamp_ns: i64) -> Option<Vector3<f64>> {
    let i = track.partition_point(|p| p.stamp_ns <= stamp_ns);
    let before = track.get(i.checked_sub(1)?)?;
    if before.stamp_ns == stamp_ns {
        return Some(before.ned_m);
    }
    let after = track.get(i)?;
    let s = (stamp_ns - before.stamp_ns) as f64 / (after.stamp_ns - before.stamp_ns) as f64;
    Some(before.ned_m + (after.ned_m - before.ned_m) * s)
}

/// `attitude_summary.parquet`: one row per method.
pub fn summary_batch(
    runs: &[MethodRun],
    scores: &[MethodScore],
    attitude_against: Option<&str>,
) -> Result<RecordBatch, ArrowError> {
    let mut c = Columns::default();
    c.text("method", scores.iter().map(|s| s.method.name()).collect());
    c.text(
        "angles_against",
        scores
            .iter()
            .map(|_| attitude_against.unwrap_or(""))
            .collect(),
    );
    c.optional(
        "end_error_m",
        "m",
        scores.iter().map(|s| s.end_error_m).collect(),
    );
    c.optional("path_m", "m", scores.iter().map(|s| s.path_m).collect());
    c.optional(
        "closest_return_m",
        "m",
        scores.iter().map(|s| s.closest_return_m).collect(),
    );
    c.optional(
        "closest_return_percent_of_path",
        "%",
        scores.iter().map(|s| s.closest_return_percent()).collect(),
    );
    c.optional(
        "end_error_percent_of_path",
        "%",
        scores.iter().map(|s| s.end_error_percent()).collect(),
    );
    let euler = |f: fn(&crate::attitude::compare::EulerErrors) -> f64| {
        scores
            .iter()
            .map(|s| s.euler.as_ref().map(f))
            .collect::<Vec<_>>()
    };
    c.optional("roll_rms_deg", "deg", euler(|e| e.roll_rms_deg));
    c.optional("roll_max_deg", "deg", euler(|e| e.roll_max_deg));
    c.optional("pitch_rms_deg", "deg", euler(|e| e.pitch_rms_deg));
    c.optional("pitch_max_deg", "deg", euler(|e| e.pitch_max_deg));
    c.optional("yaw_rms_deg", "deg", euler(|e| e.yaw_rms_deg));
    c.optional("yaw_max_deg", "deg", euler(|e| e.yaw_max_deg));
    let broad = |f: fn(&crate::attitude::score::AttitudeRms) -> f64| {
        scores
            .iter()
            .map(|s| s.broad.as_ref().map(f))
            .collect::<Vec<_>>()
    };
    c.optional("total_rms_deg", "deg", broad(|b| b.total_deg));
    c.optional("heading_rms_deg", "deg", broad(|b| b.heading_deg));
    c.optional("inclination_rms_deg", "deg", broad(|b| b.inclination_deg));
    c.count(
        "covariance_repairs",
        runs.iter().map(|r| r.repairs as u64).collect(),
    );
    c.finish()
}
