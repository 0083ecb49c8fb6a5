//! DVL dead reckoning with a given attitude: the same for every attitude method (seed 001's
//! comparison). The DVL's body velocity (its axes turned into the body's, the lever-arm term
//! removed) is rotated into NED by the attitude at the DVL's stamp and integrated from a
//! start position (trapezoid between readings).

use super::AttitudeSample;
use crate::contract::Dvl;
use crate::filters::ins::forward::DvlMounting;
use nalgebra::{UnitQuaternion, Vector3};

/// A dead-reckoned position, m, in the mission frame (north, east, down).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    pub stamp_ns: i64,
    pub ned_m: Vector3<f64>,
}

/// The attitude at `stamp_ns`, interpolated (slerp) between the samples around it; `None`
/// outside their span.
pub fn attitude_at(samples: &[AttitudeSample], stamp_ns: i64) -> Option<UnitQuaternion<f64>> {
    let i = samples.partition_point(|s| s.stamp_ns <= stamp_ns);
    let before = samples.get(i.checked_sub(1)?)?;
    if before.stamp_ns == stamp_ns {
        return Some(before.ned_from_body);
    }
    let after = samples.get(i)?;
    let s = (stamp_ns - before.stamp_ns) as f64 / (after.stamp_ns - before.stamp_ns) as f64;
    Some(before.ned_from_body.slerp(&after.ned_from_body, s))
}

/// Integrates the valid DVL readings from `start_ned_m` at the first one that has an
/// attitude; a reading without bottom lock holds the previous velocity. The rate term of the
/// lever arm is left out (the gyro is not among the inputs; for a DVL within a metre of the
/// reference point at pool-test rates it is millimetres per second).
pub fn dead_reckon(
    attitude: &[AttitudeSample],
    dvl: &[Dvl],
    mounting: &DvlMounting,
    start_ned_m: Vector3<f64>,
) -> Vec<TrackPoint> {
    let body_from_dvl = mounting.dvl_from_body.inverse();
    let mut track: Vec<TrackPoint> = Vec::with_capacity(dvl.len());
    let mut previous: Option<(i64, Vector3<f64>)> = None;
    for d in dvl {
        let Some(q) = attitude_at(attitude, d.stamp_ns) else {
            continue;
        };
        let v_ned = if d.valid {
            q * (body_from_dvl * Vector3::from(d.velocity))
        } else {
            match previous {
                Some((_, v)) => v,
                None => continue,
            }
        };
        let position = match (previous, track.last()) {
            (Some((t0, v0)), Some(last)) => {
                last.ned_m + (v0 + v_ned) * 0.5 * ((d.stamp_ns - t0) as f64 * 1e-9)
            }
            _ => start_ned_m,
        };
        track.push(TrackPoint {
            stamp_ns: d.stamp_ns,
            ned_m: position,
        });
        previous = Some((d.stamp_ns, v_ned));
    }
    track
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DVL reading 1 m/s forward while the attitude turns at a constant rate traces the
    /// circle the kinematics say.
    #[test]
    fn a_constant_turn_traces_its_circle() {
        let rate = 0.1; // rad/s
        let stamps: Vec<i64> = (0..=6283).map(|k| k * 10_000_000).collect(); // 62.83 s
        let attitude: Vec<AttitudeSample> = stamps
            .iter()
            .map(|&t| AttitudeSample {
                stamp_ns: t,
                ned_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, rate * t as f64 * 1e-9),
            })
            .collect();
        let dvl: Vec<Dvl> = stamps
            .iter()
            .step_by(20)
            .map(|&t| Dvl {
                stamp_ns: t,
                velocity: [1.0, 0.0, 0.0],
                valid: true,
                altitude: Some(5.0),
            })
            .collect();
        let track = dead_reckon(&attitude, &dvl, &DvlMounting::default(), Vector3::zeros());
        // Radius 1 / 0.1 = 10 m: north sin(w t) / w, east (1 - cos(w t)) / w.
        let worst = track
            .iter()
            .map(|p| {
                let t = p.stamp_ns as f64 * 1e-9;
                let exact = Vector3::new((rate * t).sin(), 1.0 - (rate * t).cos(), 0.0) / rate;
                (p.ned_m - exact).norm()
            })
            .fold(0.0, f64::max);
        assert!(worst < 0.01, "{worst} m");
        assert_eq!(track.len(), dvl.len());
    }
}
