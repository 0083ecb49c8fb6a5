//! The streams of one log by role, each at the contract's default topic: the one place a
//! reconstruction, its initialisation and its aiding table read the log from.

use super::{
    AcousticFix, Altimeter, Beacon, ControlSurfaces, Depth, Dvl, GnssFix, Imu, LblRange,
    MagneticField, PositionFix, Propeller, ShipPose, SpeedLog, Truth, UsblObservation,
};

/// Time-sorted messages of each role (empty when the log has none).
#[derive(Debug, Clone, Copy, Default)]
pub struct Streams<'a> {
    pub imu: &'a [Imu],
    pub mag: &'a [MagneticField],
    pub dvl: &'a [Dvl],
    pub altimeter: &'a [Altimeter],
    pub eml: &'a [SpeedLog],
    pub depth: &'a [Depth],
    pub gnss: &'a [GnssFix],
    pub fixes: &'a [PositionFix],
    pub rpm: &'a [Propeller],
    pub fins: &'a [ControlSurfaces],
    pub truth: &'a [Truth],
    pub acoustic_fixes: &'a [AcousticFix],
    /// Ship-relative USBL observations, with the ship's poses.
    pub usbl: &'a [UsblObservation],
    pub ship: &'a [ShipPose],
    pub lbl: &'a [LblRange],
    /// The acoustic beacons' places (the log's `beacons` record, or the settings').
    pub beacons: &'a [Beacon],
}
