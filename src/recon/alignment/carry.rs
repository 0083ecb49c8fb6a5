//! Vectors measured in the body at different times, carried to the body axes of one time by
//! the gyro: what lets a start be levelled and headed while the vehicle still moves.

use crate::contract::Imu;
use nalgebra::{UnitQuaternion, Vector3};

/// The body's attitude at each IMU sample of the window relative to the first sample's (start
/// body from body), the gyro integrated. The Earth's rate is not removed: 0.13 deg over the
/// 30 s levelling window at most (the in-run alignment, carried further, removes it itself).
pub struct Carry {
    stamps: Vec<i64>,
    pub q: Vec<UnitQuaternion<f64>>,
}

impl Carry {
    pub fn new(window: &[Imu]) -> Carry {
        let mut q = Vec::with_capacity(window.len());
        let mut at = UnitQuaternion::identity();
        q.push(at);
        for w in window.windows(2) {
            let dt = (w[1].stamp_ns - w[0].stamp_ns) as f64 * 1e-9;
            let omega =
                (Vector3::from(w[0].angular_velocity) + Vector3::from(w[1].angular_velocity)) * 0.5;
            at *= UnitQuaternion::from_scaled_axis(omega * dt);
            q.push(at);
        }
        Carry {
            stamps: window.iter().map(|m| m.stamp_ns).collect(),
            q,
        }
    }

    /// The rotation at a stamp (interpolated between samples; held beyond the window).
    pub fn at(&self, stamp_ns: i64) -> UnitQuaternion<f64> {
        let k = self.stamps.partition_point(|&s| s <= stamp_ns);
        match (k.checked_sub(1), self.q.get(k)) {
            (Some(i), Some(next)) => {
                let span = (self.stamps[k] - self.stamps[i]) as f64;
                let s = if span > 0.0 {
                    (stamp_ns - self.stamps[i]) as f64 / span
                } else {
                    0.0
                };
                self.q[i].slerp(next, s)
            }
            (Some(i), None) => self.q[i],
            (None, _) => self
                .q
                .first()
                .copied()
                .unwrap_or_else(UnitQuaternion::identity),
        }
    }
}
