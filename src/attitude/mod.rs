//! Attitude from a MEMS AHRS (gyro, accelerometer, magnetometer): the methods compared by
//! `hindsight attitude`, and their scores.
//!
//! Every method is a pure function of the same [`AhrsInputs`] and returns the attitude
//! (`ned_from_body` quaternion) at every IMU stamp. Internals are quaternions or rotation
//! matrices; Euler angles appear only at the edges.
//!
//! - [`raw`]: seed 001 eq. 1-4, roll and pitch from the accelerometer, yaw from the
//!   tilt-compensated magnetometer, sample by sample (no filter).
//! - [`mekf`]: a multiplicative (error-state) quaternion Kalman filter with gyro-bias states,
//!   aided by the accelerometer's gravity direction and the magnetometer's heading.
//! - [`score`]: errors against a reference, as BROAD scores them (total, heading,
//!   inclination).
//! - [`dead_reckoning`]: the DVL dead reckoning every method's attitude feeds.

pub mod cf;
pub mod compare;
pub mod config;
pub mod dead_reckoning;
pub mod ekf;
pub mod euler;
pub mod mag_calibration;
pub mod mag_checks;
pub mod mekf;
pub mod raw;
pub mod score;
pub mod ukf;

use crate::contract::{Imu, MagneticField};
use nalgebra::{UnitQuaternion, Vector3};

/// What every attitude method reads: time-sorted IMU and magnetometer samples, and the
/// site's magnetic declination.
#[derive(Debug, Clone, Copy)]
pub struct AhrsInputs<'a> {
    pub imu: &'a [Imu],
    pub mag: &'a [MagneticField],
    /// Magnetic declination, rad, east positive (0 where north is magnetic north).
    pub declination_rad: f64,
    /// Initial yaw for a method that runs without a magnetometer (the mission's
    /// `initial_yaw_rad`), rad.
    pub initial_yaw_rad: Option<f64>,
}

/// The attitude at one stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeSample {
    pub stamp_ns: i64,
    pub ned_from_body: UnitQuaternion<f64>,
}

impl AhrsInputs<'_> {
    /// The magnetometer reading at or before `stamp_ns` (the latest one), if any.
    pub fn mag_at(&self, stamp_ns: i64) -> Option<Vector3<f64>> {
        crate::align::latest_at(self.mag, stamp_ns).map(|(m, _)| Vector3::from(m.magnetic_field))
    }
}

/// Attitude from the accelerometer and magnetometer alone (seed 001 eq. 1-4): the
/// quaternion of roll and pitch levelled from `specific_force_body` and the tilt-compensated
/// magnetic heading (plus the declination).
pub fn from_gravity_and_field(
    specific_force_body: &Vector3<f64>,
    field_body: &Vector3<f64>,
    declination_rad: f64,
) -> UnitQuaternion<f64> {
    let (roll, pitch) = crate::recon::alignment::at_rest::level(specific_force_body);
    let yaw = crate::recon::alignment::at_rest::magnetic_heading(
        field_body,
        roll,
        pitch,
        declination_rad,
    );
    UnitQuaternion::from_euler_angles(roll, pitch, yaw)
}
