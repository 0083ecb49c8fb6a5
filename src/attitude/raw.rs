//! Seed 001's "no filtering": at every IMU sample, roll and pitch from the accelerometer
//! (eq. 1-2) and yaw from the magnetometer levelled by them (eq. 3-4).

use super::{from_gravity_and_field, AhrsInputs, AttitudeSample};
use nalgebra::Vector3;

/// The raw attitude at every IMU stamp (from the latest magnetometer reading; none before
/// the first one).
pub fn run(inputs: &AhrsInputs<'_>) -> Vec<AttitudeSample> {
    inputs
        .imu
        .iter()
        .filter_map(|m| {
            let field = inputs.mag_at(m.stamp_ns)?;
            Some(AttitudeSample {
                stamp_ns: m.stamp_ns,
                ned_from_body: from_gravity_and_field(
                    &Vector3::from(m.specific_force),
                    &field,
                    inputs.declination_rad,
                ),
            })
        })
        .collect()
}
