//! EvoLogics' `USBLLONG` positioning output, as the ROS drivers publish it
//! (`vehicle_interface/AcousticModemUSBLLONG` and its copies), turned into the contract's
//! ship-relative USBL observation.
//!
//! What the message carries (EvoLogics, "S2C communication and positioning devices, AT
//! command reference", 1.7, section 5.13.1 and appendix B):
//! - `X`, `Y`, `Z`: the target in the USBL device's own right-handed frame, m. Its `Z` axis
//!   points out of the transducer head: a head-down device with `X` towards the bow has `X`
//!   forward, `Y` to starboard and `Z` down, the ship's own axes. The observation keeps these
//!   axes as the transducer's, so `[usbl] transducer_alignment_deg` is zero for that
//!   mounting and states any other. The device's own roll, pitch and yaw (`E`, `N`, `U`
//!   come from them) are not used: the ship's attitude comes from `/ship_pose`.
//! - `current_time` (when the string was output) and `measurement_time` (when the target
//!   was fixed), in the device's clock, s. Their difference is how late the header's stamp
//!   is. Drivers carry them as `float32`: beyond about 36 hours of device time (or on an
//!   epoch clock) the difference is coarser than 10 ms and is not used; nor when a driver
//!   leaves `current_time` out. Then the stamp is taken as the time of receipt, and the
//!   reconstruction estimates the delay.
//! - `propagation_time`: the one-way travel time, us. With the range it gives the speed of
//!   sound the device used.
//! - `accuracy`: its unit differs between the manual (rad) and the drivers (m), so it is not
//!   read; the sigmas come from the slant range.

use super::map::RosSettings;
use crate::contract::{FieldIssue, UsblObservation};
use nalgebra::Vector3;

/// The fields read, after the stamp, in [`usbl_long`]'s order.
pub const FIELDS: [&str; 7] = [
    "current_time",
    "measurement_time",
    "remote_address",
    "X",
    "Y",
    "Z",
    "propagation_time",
];

/// The fields a driver may leave out (one variant of the message has no `current_time`).
pub const OPTIONAL: [&str; 1] = ["current_time"];

/// The coarsest resolution of the device's times at which their difference is still used, s.
const FINEST_USABLE_RESOLUTION_S: f64 = 0.01;
/// The longest delay taken from the two times, s; a longer one is a clock's jump.
const LONGEST_DELAY_S: f64 = 30.0;
/// The speeds of sound a propagation time may give, m/s (else it is not a one-way time).
const SOUND_SPEED_M_S: (f64, f64) = (1300.0, 1800.0);

/// The spacing of the numbers around `t` in the type it was written as: a `float32`'s when
/// `t` is one, else a `float64`'s.
fn resolution_s(t: f64) -> f64 {
    let x = t.abs();
    if (x as f32) as f64 == x {
        let x = x as f32;
        (f32::from_bits(x.to_bits() + 1) - x) as f64
    } else {
        f64::from_bits(x.to_bits() + 1) - x
    }
}

/// How late the string was output after the fix, s, when the device's two times say it
/// finely enough.
pub fn received_after_s(current_time: f64, measurement_time: f64) -> Option<f64> {
    let delay = current_time - measurement_time;
    let fine = [current_time, measurement_time]
        .iter()
        .all(|&t| t.is_finite() && resolution_s(t) <= FINEST_USABLE_RESOLUTION_S);
    (fine && (0.0..=LONGEST_DELAY_S).contains(&delay)).then_some(delay)
}

/// The observation of one `USBLLONG` (`f`: [`FIELDS`] after the stamp).
pub fn usbl_long(stamp_ns: i64, f: &[f64], s: &RosSettings) -> Result<UsblObservation, FieldIssue> {
    let target = Vector3::new(f[3], f[4], f[5]);
    if let Some(i) = (0..3).find(|&i| !target[i].is_finite()) {
        return Err(FieldIssue::new(FIELDS[3 + i], "not a number"));
    }
    let range_m = target.norm();
    if range_m <= 0.0 {
        return Err(FieldIssue::new(
            "X",
            "the target at the transducer (zero range)",
        ));
    }
    let sound_speed_m_s = Some(range_m / (f[6] * 1e-6))
        .filter(|c| (SOUND_SPEED_M_S.0..=SOUND_SPEED_M_S.1).contains(c));
    let received_after_s = received_after_s(f[0], f[1]);
    let (stamp_ns, stamp_is_validity) = match received_after_s {
        Some(delay) => (stamp_ns - (delay * 1e9).round() as i64, true),
        None => (stamp_ns, s.acoustic_stamp_is_validity),
    };
    Ok(UsblObservation {
        stamp_ns,
        stamp_is_validity,
        received_after_s,
        range_m,
        bearing_rad: target.y.atan2(target.x),
        elevation_rad: (target.z / range_m).asin(),
        range_sigma_m: None,
        bearing_sigma_rad: None,
        elevation_sigma_rad: None,
        sound_speed_m_s,
        beacon_id: if f[2].is_finite() {
            format!("{:.0}", f[2])
        } else {
            String::new()
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manual's example (section 5.11.4), its times moved onto a device clock of hours.
    #[test]
    fn the_manuals_example_becomes_an_observation_at_its_time_of_validity() {
        let f = [
            5852.499612,
            5852.365264,
            2.0,
            1099.5699,
            -1000.1375,
            2.3383,
            990922.0,
        ]
        .map(|v: f64| v as f32 as f64);
        let o = usbl_long(10_000_000_000, &f, &RosSettings::default()).unwrap();
        let delay = o.received_after_s.unwrap();
        assert!((delay - 0.134348).abs() < 1e-3, "{delay}");
        assert!(o.stamp_is_validity);
        assert_eq!(o.stamp_ns, 10_000_000_000 - (delay * 1e9).round() as i64);
        let range = (1099.5699f64.powi(2) + 1000.1375f64.powi(2) + 2.3383f64.powi(2)).sqrt();
        assert!((o.range_m - range).abs() < 1e-3);
        assert!((o.bearing_rad - (-1000.1375f64).atan2(1099.5699)).abs() < 1e-6);
        assert!((o.elevation_rad - (2.3383 / range).asin()).abs() < 1e-6);
        // 1486.4 m in 990.9 ms: the device's 1500 m/s.
        let c = o.sound_speed_m_s.unwrap();
        assert!((c - range / 0.990922).abs() < 0.01, "{c}");
        assert_eq!(o.beacon_id, "2");
        assert_eq!(o.range_sigma_m, None);
    }

    /// The manual's own epoch clock as `float32`: 128 s between numbers, no delay to read.
    #[test]
    fn coarse_or_missing_device_times_leave_the_stamp_as_receipt() {
        let epoch = [1377811852.499612f64, 1377811852.365264].map(|t| t as f32 as f64);
        assert_eq!(received_after_s(epoch[0], epoch[1]), None);
        // The same times written as float64 are fine.
        let d = received_after_s(1377811852.499612, 1377811852.365264).unwrap();
        assert!((d - 0.134348).abs() < 1e-6);
        assert_eq!(received_after_s(f64::NAN, 100.0), None);
        assert_eq!(received_after_s(99.0, 100.0), None, "output before the fix");
        assert_eq!(received_after_s(200.0, 100.0), None, "a clock's jump");
        let f = [f64::NAN, 100.0, 7.0, 30.0, 40.0, 50.0, 0.0];
        let s = RosSettings::default();
        let o = usbl_long(5, &f, &s).unwrap();
        assert_eq!((o.stamp_ns, o.stamp_is_validity), (5, false));
        assert_eq!((o.received_after_s, o.sound_speed_m_s), (None, None));
        let valid = RosSettings {
            acoustic_stamp_is_validity: true,
            ..s
        };
        assert!(usbl_long(5, &f, &valid).unwrap().stamp_is_validity);
    }

    #[test]
    fn a_target_without_a_position_is_named() {
        let s = RosSettings::default();
        let nan = [1.0, 1.0, 2.0, 1.0, f64::NAN, 3.0, 0.0];
        assert_eq!(usbl_long(0, &nan, &s).unwrap_err().field, "Y");
        let zero = [1.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(usbl_long(0, &zero, &s).unwrap_err().field, "X");
    }
}
