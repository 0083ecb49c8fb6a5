//! Seed 002's in-run alignment of a vehicle dropped unaligned, with only the IMU, the
//! propeller and the depth sensor: once the vehicle is stable, roll and pitch from the
//! accelerometers and the speed the propeller gives (eq. 3, 5), then carried back to the
//! water entry by the gyro.
//!
//! - Stability (all at once, seed 002): |phi| <= 15 deg for 3 s; |theta| <= 5 deg for 1 s;
//!   |set depth - depth| <= 10 m and |omega_y| <= 3 deg/s for 1 s; |f_x| <= 1.0 m/s^2 for 1 s,
//!   tested on 0.1 s means of the IMU, with phi and theta from eq. 3, 5 on them.
//! - Alignment over the next `align_s`: `theta = asin(f_x / g)`,
//!   `phi = asin((-f_y + omega_z v_x) / (g cos theta))` on the means, `v_x` from the propeller.
//! - The attitude at the alignment's middle, carried to the first IMU sample by the gyro
//!   (roll and pitch do not depend on the heading assumed while carrying).

use super::carry::Carry;
use crate::contract::{Depth, Imu, Propeller};
use nalgebra::{UnitQuaternion, Vector3};

/// Stability thresholds and hold times of seed 002.
const MAX_ROLL_DEG: f64 = 15.0;
const ROLL_HOLD_S: f64 = 3.0;
const MAX_PITCH_DEG: f64 = 5.0;
const MAX_DEPTH_ERROR_M: f64 = 10.0;
const MAX_PITCH_RATE_DEG_S: f64 = 3.0;
const MAX_FX_M_S2: f64 = 1.0;
const HOLD_S: f64 = 1.0;
/// Length of the means the conditions are tested on, s.
const BLOCK_S: f64 = 0.1;

/// What the in-run alignment found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct InRun {
    /// When the stability conditions all held, ns.
    pub stable_at_ns: i64,
    /// Seconds from the first IMU sample to the end of the alignment.
    pub aligned_after_s: f64,
    /// Roll and pitch at the alignment, rad.
    pub roll_rad: f64,
    pub pitch_rad: f64,
    /// Roll and pitch carried to the first IMU sample by the gyro alone, rad ([`start_tilt`]
    /// also removes the Earth's rotation once the heading is known).
    pub start_roll_rad: f64,
    pub start_pitch_rad: f64,
}

/// Means of the IMU over a block, with the depth and the propeller speed at its end.
struct Block {
    end_ns: i64,
    f: Vector3<f64>,
    w: Vector3<f64>,
    speed_m_s: f64,
    depth_m: Option<f64>,
}

/// Eq. 3 and 5: (roll, pitch), rad, from a mean specific force, yaw rate and forward speed.
pub fn tilt(f: &Vector3<f64>, yaw_rate_rad_s: f64, speed_m_s: f64, g: f64) -> (f64, f64) {
    let pitch = (f.x / g).clamp(-1.0, 1.0).asin();
    let roll = ((-f.y + yaw_rate_rad_s * speed_m_s) / (g * pitch.cos()))
        .clamp(-1.0, 1.0)
        .asin();
    (roll, pitch)
}

fn latest<T>(s: &[T], stamp: impl Fn(&T) -> i64, at: i64) -> Option<&T> {
    s[..s.partition_point(|m| stamp(m) <= at)].last()
}

/// The in-run alignment, or `None` when the conditions never hold together.
/// `speed_of_rpm`: forward speed (m/s) for a propeller reading (rev/min).
pub fn align(
    imu: &[Imu],
    depth: &[Depth],
    rpm: &[Propeller],
    set_depth_m: f64,
    speed_of_rpm: &dyn Fn(f64) -> f64,
    align_s: f64,
    g: f64,
) -> Option<InRun> {
    let t0 = imu.first()?.stamp_ns;
    let block_ns = (BLOCK_S * 1e9) as i64;
    // The blocks are made as the search goes: a long log is not averaged past the alignment.
    let mut blocks = imu
        .chunk_by(|a, b| (a.stamp_ns - t0) / block_ns == (b.stamp_ns - t0) / block_ns)
        .map(|c| {
            let n = c.len() as f64;
            let end_ns = c.last().map_or(t0, |m| m.stamp_ns);
            Block {
                end_ns,
                f: c.iter()
                    .map(|m| Vector3::from(m.specific_force))
                    .sum::<Vector3<f64>>()
                    / n,
                w: c.iter()
                    .map(|m| Vector3::from(m.angular_velocity))
                    .sum::<Vector3<f64>>()
                    / n,
                speed_m_s: latest(rpm, |p| p.stamp_ns, end_ns).map_or(0.0, |p| speed_of_rpm(p.rpm)),
                depth_m: latest(depth, |d| d.stamp_ns, end_ns).map(|d| d.depth),
            }
        });
    // Since when each condition has held (ns), if it holds now.
    let mut since: [Option<i64>; 4] = [None; 4];
    let holds = [ROLL_HOLD_S, HOLD_S, HOLD_S, HOLD_S].map(|s| (s * 1e9) as i64);
    let mut stable_at = None;
    for b in blocks.by_ref() {
        let (roll, pitch) = tilt(&b.f, b.w.z, b.speed_m_s, g);
        let now = [
            roll.to_degrees().abs() <= MAX_ROLL_DEG,
            pitch.to_degrees().abs() <= MAX_PITCH_DEG,
            b.depth_m
                .is_some_and(|d| (set_depth_m - d).abs() <= MAX_DEPTH_ERROR_M)
                && b.w.y.to_degrees().abs() <= MAX_PITCH_RATE_DEG_S,
            b.f.x.abs() <= MAX_FX_M_S2,
        ];
        for (k, ok) in now.into_iter().enumerate() {
            since[k] = if ok {
                since[k].or(Some(b.end_ns))
            } else {
                None
            };
        }
        if since
            .iter()
            .zip(&holds)
            .all(|(s, h)| s.is_some_and(|s| b.end_ns - s >= *h))
        {
            stable_at = Some(b.end_ns);
            break;
        }
    }
    let stable_at = stable_at?;
    let end = stable_at + (align_s * 1e9) as i64;
    let inside: Vec<Block> = blocks.take_while(|b| b.end_ns <= end).collect();
    if inside.is_empty() {
        return None;
    }
    let n = inside.len() as f64;
    let f = inside.iter().map(|b| b.f).sum::<Vector3<f64>>() / n;
    let w = inside.iter().map(|b| b.w).sum::<Vector3<f64>>() / n;
    let v = inside.iter().map(|b| b.speed_m_s).sum::<f64>() / n;
    let (roll, pitch) = tilt(&f, w.z, v, g);
    // Carry the attitude at the alignment's middle back to the first sample.
    let middle = stable_at + (end - stable_at) / 2;
    let carry = Carry::new(&imu[..imu.partition_point(|m| m.stamp_ns <= end)]);
    let ned_from_body = UnitQuaternion::from_euler_angles(roll, pitch, 0.0);
    let (start_roll, start_pitch, _) = (ned_from_body * carry.at(middle).inverse()).euler_angles();
    Some(InRun {
        stable_at_ns: stable_at,
        aligned_after_s: (end - t0) as f64 * 1e-9,
        roll_rad: roll,
        pitch_rad: pitch,
        start_roll_rad: start_roll,
        start_pitch_rad: start_pitch,
    })
}

/// Roll and pitch at the first IMU sample from the alignment's, with the Earth's rotation
/// over the carry removed: the local level frame turned by `omega_ie t` while the gyro
/// measured the body's inertial turn (over 77 s that is 0.26 deg of tilt, more than the
/// alignment's own error). Needs the heading (rad at the first sample, from the heading
/// sources) and the latitude.
pub fn start_tilt(imu: &[Imu], a: &InRun, start_yaw_rad: f64, lat_rad: f64) -> (f64, f64) {
    let Some(t0) = imu.first().map(|m| m.stamp_ns) else {
        return (a.start_roll_rad, a.start_pitch_rad);
    };
    let end = t0 + (a.aligned_after_s * 1e9) as i64;
    let middle = a.stable_at_ns + (end - a.stable_at_ns) / 2;
    let carry = Carry::new(&imu[..imu.partition_point(|m| m.stamp_ns <= end)]);
    let q = carry.at(middle);
    // The heading at the alignment, from the start heading and the gyro's turn.
    let start =
        UnitQuaternion::from_euler_angles(a.start_roll_rad, a.start_pitch_rad, start_yaw_rad);
    let (_, _, yaw_at) = (start * q).euler_angles();
    let at = UnitQuaternion::from_euler_angles(a.roll_rad, a.pitch_rad, yaw_at);
    let dt = (middle - t0) as f64 * 1e-9;
    let level_turn = UnitQuaternion::from_scaled_axis(crate::geodesy::earth_rate_ned(lat_rad) * dt);
    let (roll, pitch, _) = (level_turn * at * q.inverse()).euler_angles();
    (roll, pitch)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 3 and 5 invert the specific force of a tilted vehicle in a steady turn.
    #[test]
    fn tilt_inverts_a_steady_turn() {
        let (g, roll, pitch, r, u) = (9.81, 0.12_f64, -0.05_f64, 0.03, 1.6);
        // f = a - g in the body: the turn's centripetal acceleration u r along body y.
        let gravity_body = UnitQuaternion::from_euler_angles(roll, pitch, 0.0).inverse()
            * Vector3::new(0.0, 0.0, g);
        let f = Vector3::new(0.0, u * r, 0.0) - gravity_body;
        let (r_est, p_est) = tilt(&f, r, u, g);
        assert!((r_est - roll).abs() < 1e-12 && (p_est - pitch).abs() < 1e-12);
    }
}
