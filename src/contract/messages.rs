//! The messages of the log contract (`docs/log-format.md`), field names, units and frames exactly as there.
//!
//! Plausible ranges are hindsight's own sanity limits (not part of the contract): wide enough
//! for any vehicle this tool serves, narrow enough to catch unit mistakes (deg for rad, uT for
//! T) and corrupt values.

use super::message;
use super::property::{angle, boolean, euler3, number, optional_number, string, vector3};
use std::f64::consts::{FRAC_PI_2, TAU};

/// Largest plausible body rate: 100 rad/s (about 5700 deg/s, above any MEMS gyro range).
const MAX_RATE_RAD_S: f64 = 100.0;
/// Largest plausible specific force: 1000 m/s^2 (about 100 g).
const MAX_SPECIFIC_FORCE_M_S2: f64 = 1000.0;
/// Largest plausible magnetic field in the body: 1 mT (20 times the Earth's field).
const MAX_FIELD_T: f64 = 1e-3;
/// Largest plausible vehicle speed: 30 m/s.
const MAX_SPEED_M_S: f64 = 30.0;
/// Deepest plausible depth or largest altitude/range: 12 km.
const MAX_RANGE_M: f64 = 12_000.0;
/// Small negative depth tolerated at the surface (pressure sensor offset, waves).
const MIN_DEPTH_M: f64 = -50.0;
/// Largest plausible local-frame coordinate: 10 000 km from the mission origin.
const MAX_LOCAL_M: f64 = 1e7;
/// Small pitch tolerance beyond +-pi/2 for converted attitudes.
const PITCH_LIMIT_RAD: f64 = FRAC_PI_2 + 1e-6;

message! {
    /// `/imu`: gyro and accelerometer, body frame (FRD).
    Imu, schema = "hindsight.Imu", topic = "/imu" {
        /// Body rate relative to inertial space, omega_ib^b, rad/s (Earth rate included).
        angular_velocity: [f64; 3] = vector3("rad/s", -MAX_RATE_RAD_S, MAX_RATE_RAD_S),
        /// Specific force f^b, m/s^2 (about [0, 0, -9.8] at rest, level, in FRD).
        specific_force: [f64; 3] = vector3("m/s^2", -MAX_SPECIFIC_FORCE_M_S2, MAX_SPECIFIC_FORCE_M_S2),
    }
}

message! {
    /// `/mag`: magnetometer, body frame.
    MagneticField, schema = "hindsight.MagneticField", topic = "/mag" {
        /// Magnetic flux density, tesla.
        magnetic_field: [f64; 3] = vector3("T", -MAX_FIELD_T, MAX_FIELD_T),
    }
}

message! {
    /// `/dvl`: Doppler velocity log.
    Dvl, schema = "hindsight.Dvl", topic = "/dvl" {
        /// Velocity over ground in the body frame, m/s.
        velocity: [f64; 3] = vector3("m/s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
        /// Bottom lock: the velocity is over ground and usable.
        valid: bool = boolean(),
        /// Height above the seabed, m, or null when the DVL gives none.
        altitude: Option<f64> = optional_number("m", 0.0, MAX_RANGE_M),
    }
}

message! {
    /// `/eml`: electromagnetic speed log.
    SpeedLog, schema = "hindsight.SpeedLog", topic = "/eml" {
        /// Speed through water (magnitude), m/s.
        speed: f64 = number("m/s", 0.0, MAX_SPEED_M_S),
    }
}

message! {
    /// `/depth`: pressure depth, positive down.
    Depth, schema = "hindsight.Depth", topic = "/depth" {
        /// Depth below the surface, m.
        depth: f64 = number("m", MIN_DEPTH_M, MAX_RANGE_M),
    }
}

message! {
    /// `/altimeter`: echo sounder height above the seabed.
    Altimeter, schema = "hindsight.Altimeter", topic = "/altimeter" {
        /// Height above the seabed, m.
        altitude: f64 = number("m", 0.0, MAX_RANGE_M),
    }
}

message! {
    /// `/rpm`: propeller speed.
    Propeller, schema = "hindsight.Propeller", topic = "/rpm" {
        /// Propeller speed, rev/min (negative astern).
        rpm: f64 = number("rev/min", -20_000.0, 20_000.0),
    }
}

message! {
    /// `/fins`: control surface angles (delta_r, delta_b, delta_s).
    ControlSurfaces, schema = "hindsight.ControlSurfaces", topic = "/fins" {
        /// Rudder angle delta_r, rad.
        rudder: f64 = angle(-FRAC_PI_2, FRAC_PI_2),
        /// Bow plane angle delta_b, rad.
        bow_plane: f64 = angle(-FRAC_PI_2, FRAC_PI_2),
        /// Stern plane angle delta_s, rad.
        stern_plane: f64 = angle(-FRAC_PI_2, FRAC_PI_2),
    }
}

message! {
    /// `/attitude`: attitude as reported by an AHRS or the vehicle's own INS (Z-Y-X Euler).
    Attitude, schema = "hindsight.Attitude", topic = "/attitude" {
        /// Roll phi, rad.
        roll: f64 = angle(-TAU, TAU),
        /// Pitch theta, rad.
        pitch: f64 = angle(-PITCH_LIMIT_RAD, PITCH_LIMIT_RAD),
        /// Yaw psi, rad (either -pi..pi or 0..2pi is accepted).
        yaw: f64 = angle(-TAU, TAU),
    }
}

message! {
    /// `/gnss`: satellite fix (at the surface).
    GnssFix, schema = "hindsight.GnssFix", topic = "/gnss" {
        /// WGS-84 latitude, degrees.
        latitude_deg: f64 = number("deg", -90.0, 90.0),
        /// WGS-84 longitude, degrees.
        longitude_deg: f64 = number("deg", -180.0, 360.0),
        /// Horizontal 1-sigma, m.
        horizontal_sigma_m: f64 = number("m", 0.0, 1e5),
    }
}

message! {
    /// `/position_fix`: a known position in the local NED frame (USBL/LBL fix, surveyed mark).
    PositionFix, schema = "hindsight.PositionFix", topic = "/position_fix" {
        /// North of the mission origin, m.
        north_m: f64 = number("m", -MAX_LOCAL_M, MAX_LOCAL_M),
        /// East of the mission origin, m.
        east_m: f64 = number("m", -MAX_LOCAL_M, MAX_LOCAL_M),
        /// Down, m, or null for a horizontal-only fix.
        down_m: Option<f64> = optional_number("m", MIN_DEPTH_M, MAX_RANGE_M),
        /// 1-sigma of the fix, m.
        sigma_m: f64 = number("m", 0.0, 1e5),
        /// `start`, `end`, or a mark name.
        label: String = string(),
    }
}

message! {
    /// `/truth`: simulated truth (only in simulated logs; used to score, never to estimate).
    Truth, schema = "hindsight.Truth", topic = "/truth" {
        /// WGS-84 latitude, degrees.
        latitude_deg: f64 = number("deg", -90.0, 90.0),
        /// WGS-84 longitude, degrees.
        longitude_deg: f64 = number("deg", -180.0, 360.0),
        /// North of the mission origin, m.
        north_m: f64 = number("m", -MAX_LOCAL_M, MAX_LOCAL_M),
        /// East of the mission origin, m.
        east_m: f64 = number("m", -MAX_LOCAL_M, MAX_LOCAL_M),
        /// Down of the mission origin, m.
        down_m: f64 = number("m", -MAX_LOCAL_M, MAX_LOCAL_M),
        /// Velocity over ground in the body frame, m/s.
        velocity_body: [f64; 3] = vector3("m/s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
        /// Velocity over ground in NED, m/s.
        velocity_ned: [f64; 3] = vector3("m/s", -MAX_SPEED_M_S, MAX_SPEED_M_S),
        /// Z-Y-X Euler angles [roll, pitch, yaw], rad.
        attitude: [f64; 3] = euler3(-TAU, TAU),
        /// Body rate relative to the local NED frame, omega_nb^b, rad/s.
        angular_velocity: [f64; 3] = vector3("rad/s", -MAX_RATE_RAD_S, MAX_RATE_RAD_S),
    }
}

// Acoustic positioning (additions to the contract: `docs/log-format.md`, "Acoustic
// positioning"). A late stamp is said, not hidden: `stamp_is_validity` tells whether
// `stamp_ns` is the time the observation was valid or only the time it was received.

/// Longest plausible wait between an acoustic observation and its receipt, s.
const MAX_ACOUSTIC_LATENCY_S: f64 = 600.0;
/// Plausible speeds of sound in sea water, m/s.
const SOUND_SPEED_M_S: (f64, f64) = (1300.0, 1800.0);

message! {
    /// `/acoustic_fix`: a positioned acoustic fix of the vehicle (USBL computed on the ship,
    /// an LBL solution).
    AcousticFix, schema = "hindsight.AcousticFix", topic = "/acoustic_fix" {
        /// Whether `stamp_ns` is the fix's time of validity (else its time of receipt).
        stamp_is_validity: bool = boolean(),
        /// Time of receipt less the time of validity, s, where both are known.
        received_after_s: Option<f64> = optional_number("s", 0.0, MAX_ACOUSTIC_LATENCY_S),
        /// WGS-84 latitude, degrees.
        latitude_deg: f64 = number("deg", -90.0, 90.0),
        /// WGS-84 longitude, degrees.
        longitude_deg: f64 = number("deg", -180.0, 360.0),
        /// Depth, m, or null for a horizontal fix.
        depth_m: Option<f64> = optional_number("m", MIN_DEPTH_M, MAX_RANGE_M),
        /// Horizontal 1-sigma, m, or null (then from the slant range).
        horizontal_sigma_m: Option<f64> = optional_number("m", 0.0, 1e5),
        /// Depth 1-sigma, m, or null.
        depth_sigma_m: Option<f64> = optional_number("m", 0.0, 1e5),
        /// The transponder's id ("" when the vehicle carries one).
        beacon_id: String = string(),
    }
}

message! {
    /// `/usbl`: a USBL observation relative to the ship's transducer, before positioning.
    UsblObservation, schema = "hindsight.UsblObservation", topic = "/usbl" {
        /// Whether `stamp_ns` is the observation's time of validity (else its time of receipt).
        stamp_is_validity: bool = boolean(),
        /// Time of receipt less the time of validity, s, where both are known.
        received_after_s: Option<f64> = optional_number("s", 0.0, MAX_ACOUSTIC_LATENCY_S),
        /// Slant range from the transducer, m.
        range_m: f64 = number("m", 0.0, MAX_RANGE_M),
        /// Azimuth in the transducer's frame, from its x axis towards its y axis, rad.
        bearing_rad: f64 = angle(-TAU, TAU),
        /// Angle below the transducer's x-y plane (towards its z axis), rad.
        elevation_rad: f64 = angle(-PITCH_LIMIT_RAD, PITCH_LIMIT_RAD),
        /// 1-sigma of the range, m, or null.
        range_sigma_m: Option<f64> = optional_number("m", 0.0, 1e4),
        /// 1-sigma of the bearing, rad, or null.
        bearing_sigma_rad: Option<f64> = optional_number("rad", 0.0, TAU),
        /// 1-sigma of the elevation, rad, or null.
        elevation_sigma_rad: Option<f64> = optional_number("rad", 0.0, TAU),
        /// The speed of sound the range was computed with, m/s, or null.
        sound_speed_m_s: Option<f64> = optional_number("m/s", SOUND_SPEED_M_S.0, SOUND_SPEED_M_S.1),
        /// The transponder's id ("" when the vehicle carries one).
        beacon_id: String = string(),
    }
}

message! {
    /// `/ship_pose`: the support ship's position and attitude (Z-Y-X Euler, its body frame
    /// FRD), for ship-relative USBL observations.
    ShipPose, schema = "hindsight.ShipPose", topic = "/ship_pose" {
        /// WGS-84 latitude, degrees.
        latitude_deg: f64 = number("deg", -90.0, 90.0),
        /// WGS-84 longitude, degrees.
        longitude_deg: f64 = number("deg", -180.0, 360.0),
        /// Roll phi, rad.
        roll: f64 = angle(-TAU, TAU),
        /// Pitch theta, rad.
        pitch: f64 = angle(-PITCH_LIMIT_RAD, PITCH_LIMIT_RAD),
        /// Yaw psi (heading), rad.
        yaw: f64 = angle(-TAU, TAU),
        /// Horizontal 1-sigma of the position, m, or null.
        horizontal_sigma_m: Option<f64> = optional_number("m", 0.0, 1e5),
        /// 1-sigma of the heading, rad, or null.
        heading_sigma_rad: Option<f64> = optional_number("rad", 0.0, TAU),
    }
}

message! {
    /// `/lbl`: a range to a seabed beacon of a long-baseline network, stamped when the reply
    /// was received (the interrogation plus the two-way travel time: the replies of one
    /// interrogation then have stamps of their own).
    LblRange, schema = "hindsight.LblRange", topic = "/lbl" {
        /// The beacon's id in the beacon table.
        beacon_id: String = string(),
        /// Two-way travel time, s, or null when only the range is given.
        two_way_travel_time_s: Option<f64> = optional_number("s", 0.0, 60.0),
        /// Slant range, m, or null when only the travel time is given.
        range_m: Option<f64> = optional_number("m", 0.0, MAX_RANGE_M),
        /// The speed of sound the range was computed with, m/s, or null.
        sound_speed_m_s: Option<f64> = optional_number("m/s", SOUND_SPEED_M_S.0, SOUND_SPEED_M_S.1),
        /// 1-sigma of the range, m, or null.
        range_sigma_m: Option<f64> = optional_number("m", 0.0, 1e4),
    }
}
