//! DVL dead reckoning with a given attitude: the same for every attitude method (seed 001's
//! comparison). The DVL's body velocity (its axes turned into the body's, the lever-arm term
//! removed) is rotated into NED by the attitude at the DVL's stamp and integrated from a
//! start position (trapezoid between readings).
//!
//! A stretch without a valid reading is bridged with the last valid velocity only when it is
//! short ([`gaps_longer_than`] finds the others): through a longer one the track holds its
//! position, since a velocity held for tens of seconds (a DVL out of the water, reading a
//! rising vehicle) invents travel that never happened.

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

/// A stretch without a valid DVL reading: from the last valid reading before it to the first
/// after it (or to the log's last reading, when none follows).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gap {
    pub from_ns: i64,
    pub to_ns: i64,
}

impl Gap {
    pub fn duration_s(&self) -> f64 {
        (self.to_ns - self.from_ns) as f64 * 1e-9
    }

    fn spans(&self, t0: i64, t1: i64) -> bool {
        self.from_ns <= t0 && t1 <= self.to_ns
    }
}

/// The stretches without a valid reading longer than `max_gap_s`, in time order.
pub fn gaps_longer_than(dvl: &[Dvl], max_gap_s: f64) -> Vec<Gap> {
    let mut gaps = Vec::new();
    let mut last_valid: Option<i64> = None;
    let mut close = |from_ns: i64, to_ns: i64| {
        let gap = Gap { from_ns, to_ns };
        if gap.duration_s() > max_gap_s {
            gaps.push(gap);
        }
    };
    for d in dvl.iter().filter(|d| d.valid) {
        if let Some(from) = last_valid {
            close(from, d.stamp_ns);
        }
        last_valid = Some(d.stamp_ns);
    }
    if let (Some(from), Some(last)) = (last_valid, dvl.last()) {
        close(from, last.stamp_ns);
    }
    gaps
}

/// Integrates the valid DVL readings from `start_ned_m` at the first one that has an
/// attitude; a reading without bottom lock holds the previous velocity, except within a
/// stretch longer than `max_gap_s`, through which the position is held. The rate term of
/// the lever arm is left out (the gyro is not among the inputs; for a DVL within a metre of
/// the reference point at pool-test rates it is millimetres per second).
pub fn dead_reckon(
    attitude: &[AttitudeSample],
    dvl: &[Dvl],
    mounting: &DvlMounting,
    start_ned_m: Vector3<f64>,
    max_gap_s: f64,
) -> Vec<TrackPoint> {
    let body_from_dvl = mounting.dvl_from_body.inverse();
    let gaps = gaps_longer_than(dvl, max_gap_s);
    let unbridged = |t0: i64, t1: i64| gaps.iter().any(|g| g.spans(t0, t1));
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
            (Some((t0, _)), Some(last)) if unbridged(t0, d.stamp_ns) => last.ned_m,
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

    /// Dead reckoning from the origin with the DVL mounted on the body's axes.
    fn from_origin(attitude: &[AttitudeSample], dvl: &[Dvl], max_gap_s: f64) -> Vec<TrackPoint> {
        dead_reckon(
            attitude,
            dvl,
            &DvlMounting::default(),
            Vector3::zeros(),
            max_gap_s,
        )
    }

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
        let track = from_origin(&attitude, &dvl, 5.0);
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

    fn reading(t_s: f64, north_m_s: f64, valid: bool) -> Dvl {
        Dvl {
            stamp_ns: (t_s * 1e9) as i64,
            velocity: [north_m_s, 0.0, 0.0],
            valid,
            altitude: valid.then_some(5.0),
        }
    }

    /// A short stretch without bottom lock is bridged with the last velocity; a long one
    /// (here a rising reading before the lock is lost for 50 s) is not, and is found.
    #[test]
    fn only_short_gaps_are_bridged() {
        let attitude: Vec<AttitudeSample> = (0..=100)
            .map(|k| AttitudeSample {
                stamp_ns: k * 1_000_000_000,
                ned_from_body: UnitQuaternion::identity(),
            })
            .collect();
        // 1 m/s for 10 s, 3 s without lock, 1 m/s to 20 s, then 50 s without lock, 1 m/s to 80 s.
        let dvl: Vec<Dvl> = (0..=80)
            .map(|k| {
                let t = k as f64;
                let lost = (10.0 < t && t < 13.0) || (20.0 < t && t < 70.0);
                reading(t, 1.0, !lost)
            })
            .collect();
        let gaps = gaps_longer_than(&dvl, 5.0);
        assert_eq!(
            gaps,
            [Gap {
                from_ns: 20_000_000_000,
                to_ns: 70_000_000_000
            }]
        );
        let track = from_origin(&attitude, &dvl, 5.0);
        let north = |t: i64| {
            track
                .iter()
                .find(|p| p.stamp_ns == t * 1_000_000_000)
                .unwrap()
                .ned_m
                .x
        };
        assert!((north(20) - 20.0).abs() < 1e-9, "{}", north(20)); // the 3 s gap bridged
        assert!((north(70) - 20.0).abs() < 1e-9, "{}", north(70)); // the 50 s gap held
        assert!((north(80) - 30.0).abs() < 1e-9, "{}", north(80));
        // Without a limit, the held velocity invents the 50 m.
        let held = from_origin(&attitude, &dvl, 1e9);
        assert!((held.last().unwrap().ned_m.x - 80.0).abs() < 1e-9);
        // A lock lost to the end of the log is a gap too.
        let trailing: Vec<Dvl> = (0..=30).map(|k| reading(k as f64, 1.0, k <= 10)).collect();
        assert_eq!(gaps_longer_than(&trailing, 5.0).len(), 1);
    }
}
