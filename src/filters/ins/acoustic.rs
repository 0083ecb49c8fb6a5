//! Positioned acoustic fixes (`/acoustic_fix`: a USBL's, an LBL system's) as an aid: each at
//! its time of validity, of the transponder on its lever arm, with its own sigma or one from
//! its slant range to the ship.
//!
//! The log is read after the dive, so a fix stamped when the ship received it is applied
//! where it was valid: its stamp less the delay it carries (`received_after_s`), or, when it
//! carries none, less the delay the reconstruction estimated (`recon::acoustic_delay`).

use super::aid_table::{Aid, Epoch, Measurement, Sensor, SensorReading, Update};
use super::forward::measure;
use crate::align::latest_at;
use crate::contract::{AcousticFix, ShipPose};
use crate::geodesy;
use nalgebra::{SMatrix, Vector3};

/// How the acoustic fixes are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcousticAiding {
    /// Time of receipt less time of validity, s, of the fixes stamped on receipt that do not
    /// carry theirs.
    pub receipt_delay_s: f64,
    /// A fix without a sigma: this fraction of its slant range from the ship ...
    pub slant_range_fraction: f64,
    /// ... and at least this, m ...
    pub sigma_floor_m: f64,
    /// ... or, without the ship's position, this, m.
    pub sigma_without_ship_m: f64,
    /// The transponder on the vehicle, body FRD from the IMU, m.
    pub lever_arm_body_m: [f64; 3],
}

/// A fix made ready: when it was valid, where, how well.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidFix {
    /// Time of validity, ns.
    pub stamp_ns: i64,
    pub lat_rad: f64,
    pub lon_rad: f64,
    /// Horizontal 1-sigma per axis, m.
    pub sigma_m: f64,
    /// Slant range from the ship when its position is known, m.
    pub slant_range_m: Option<f64>,
}

/// The time of validity of a fix: its stamp, or its stamp less its own delay, or less
/// `receipt_delay_s`.
pub fn validity_ns(fix: &AcousticFix, receipt_delay_s: f64) -> i64 {
    validity_of(
        fix.stamp_ns,
        fix.stamp_is_validity,
        fix.received_after_s,
        receipt_delay_s,
    )
}

/// The time of validity of an acoustic observation stamped `stamp_ns`: the stamp itself when
/// it is the time of validity, else less its own delay, else less `receipt_delay_s`.
pub fn validity_of(
    stamp_ns: i64,
    stamp_is_validity: bool,
    received_after_s: Option<f64>,
    receipt_delay_s: f64,
) -> i64 {
    if stamp_is_validity {
        return stamp_ns;
    }
    let delay_s = received_after_s.unwrap_or(receipt_delay_s);
    stamp_ns - (delay_s * 1e9).round() as i64
}

/// Whether the fix's time of validity is not known from the log alone.
pub fn needs_delay(fix: &AcousticFix) -> bool {
    !fix.stamp_is_validity && fix.received_after_s.is_none()
}

/// The slant range from the ship's position at `t_ns` (the latest within 10 s) to a fix at
/// `lat, lon` and `depth_m`, m.
pub fn slant_range_m(
    ship: &[ShipPose],
    t_ns: i64,
    lat_rad: f64,
    lon_rad: f64,
    depth_m: f64,
) -> Option<f64> {
    const MAX_AGE_NS: i64 = 10_000_000_000;
    let (pose, age) = latest_at(ship, t_ns)?;
    (age <= MAX_AGE_NS).then(|| {
        let (north, east) = geodesy::local_north_east_m(
            pose.latitude_deg.to_radians(),
            pose.longitude_deg.to_radians(),
            lat_rad,
            lon_rad,
        );
        north.hypot(east).hypot(depth_m)
    })
}

/// The fixes at their times of validity, in time order.
pub fn valid_fixes(
    readings: &[AcousticFix],
    ship: &[ShipPose],
    a: &AcousticAiding,
) -> Vec<ValidFix> {
    let mut fixes: Vec<ValidFix> = readings
        .iter()
        .map(|f| {
            let stamp_ns = validity_ns(f, a.receipt_delay_s);
            let (lat_rad, lon_rad) = (f.latitude_deg.to_radians(), f.longitude_deg.to_radians());
            let slant = slant_range_m(ship, stamp_ns, lat_rad, lon_rad, f.depth_m.unwrap_or(0.0));
            let sigma_m = f
                .horizontal_sigma_m
                .filter(|s| *s > 0.0)
                .unwrap_or_else(|| {
                    slant.map_or(a.sigma_without_ship_m, |r| {
                        (a.slant_range_fraction * r).max(a.sigma_floor_m)
                    })
                });
            ValidFix {
                stamp_ns,
                lat_rad,
                lon_rad,
                sigma_m,
                slant_range_m: slant,
            }
        })
        .collect();
    fixes.sort_by_key(|f| f.stamp_ns);
    fixes
}

/// The acoustic fixes' row of the aiding table.
pub struct AcousticFixAid {
    fixes: Vec<ValidFix>,
    lever_arm_body_m: Vector3<f64>,
}

impl AcousticFixAid {
    pub fn new(readings: &[AcousticFix], ship: &[ShipPose], a: &AcousticAiding) -> Self {
        AcousticFixAid {
            fixes: valid_fixes(readings, ship, a),
            lever_arm_body_m: Vector3::from(a.lever_arm_body_m),
        }
    }
}

impl Aid for AcousticFixAid {
    fn sensor(&self) -> Sensor {
        Sensor::AcousticFix
    }
    fn len(&self) -> usize {
        self.fixes.len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.fixes[i].stamp_ns
    }
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let f = &self.fixes[i];
        let (y, h) = measure::offset_horizontal_position(
            at.est,
            f.lat_rad,
            f.lon_rad,
            &self.lever_arm_body_m,
        );
        let r = SMatrix::<f64, 2, 2>::identity() * f.sigma_m.powi(2);
        Some(Update::Two(Measurement { y, h, r }))
    }
    fn slant_range_m(&self, i: usize) -> Option<f64> {
        self.fixes[i].slant_range_m
    }
    /// The fix in metres from the first, so that a run of refused fixes reopens the gate
    /// only when the fixes follow one smooth track ([`super::reopen`]): multipath outliers
    /// scatter off it.
    fn reading(&self, i: usize) -> Option<SensorReading> {
        let (first, f) = (self.fixes.first()?, &self.fixes[i]);
        let (north, east) =
            geodesy::local_north_east_m(first.lat_rad, first.lon_rad, f.lat_rad, f.lon_rad);
        Some(SensorReading {
            dims: 2,
            value: [north, east, 0.0],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAT: f64 = 35.1;
    const LON: f64 = 129.05;

    fn fix(stamp_s: f64, stamp_is_validity: bool, received_after_s: Option<f64>) -> AcousticFix {
        AcousticFix {
            stamp_ns: (stamp_s * 1e9) as i64,
            stamp_is_validity,
            received_after_s,
            latitude_deg: LAT,
            longitude_deg: LON,
            depth_m: Some(40.0),
            horizontal_sigma_m: None,
            depth_sigma_m: None,
            beacon_id: String::new(),
        }
    }

    fn aiding() -> AcousticAiding {
        AcousticAiding {
            receipt_delay_s: 2.0,
            slant_range_fraction: 0.01,
            sigma_floor_m: 0.5,
            sigma_without_ship_m: 5.0,
            lever_arm_body_m: [0.0; 3],
        }
    }

    #[test]
    fn a_fix_is_placed_at_its_time_of_validity() {
        let s = 1_000_000_000;
        assert_eq!(validity_ns(&fix(100.0, true, Some(1.5)), 2.0), 100 * s);
        assert_eq!(
            validity_ns(&fix(100.0, false, Some(1.5)), 2.0),
            98 * s + s / 2
        );
        assert_eq!(validity_ns(&fix(100.0, false, None), 2.0), 98 * s);
        assert!(needs_delay(&fix(100.0, false, None)));
        assert!(!needs_delay(&fix(100.0, false, Some(1.5))));
        assert!(!needs_delay(&fix(100.0, true, None)));
    }

    /// A fix without a sigma: 1 % of its slant range from the ship (300 m north, 40 m down:
    /// 302.65 m), at least the floor; without the ship's position, the default; its own sigma
    /// when it gives one. The fixes come out in order of validity.
    #[test]
    fn a_fix_without_a_sigma_takes_one_from_its_slant_range() {
        let (ship_lat, ship_lon) =
            crate::geodesy::position_of_local_m(LAT.to_radians(), LON.to_radians(), -300.0, 0.0);
        let ship = ShipPose {
            stamp_ns: 97_000_000_000,
            latitude_deg: ship_lat.to_degrees(),
            longitude_deg: ship_lon.to_degrees(),
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
            horizontal_sigma_m: None,
            heading_sigma_rad: None,
        };
        let given = AcousticFix {
            horizontal_sigma_m: Some(0.7),
            ..fix(98.0, true, None)
        };
        let readings = [fix(101.0, false, None), given];
        let placed = valid_fixes(&readings, std::slice::from_ref(&ship), &aiding());
        assert_eq!(placed[0].sigma_m, 0.7);
        assert_eq!(placed[0].stamp_ns, 98_000_000_000);
        assert_eq!(placed[1].stamp_ns, 99_000_000_000);
        let slant = placed[1].slant_range_m.unwrap();
        assert!((slant - 300f64.hypot(40.0)).abs() < 0.05, "{slant}");
        assert!((placed[1].sigma_m - 0.01 * slant).abs() < 1e-12);
        let near = ShipPose {
            latitude_deg: LAT,
            longitude_deg: LON,
            ..ship.clone()
        };
        let floored = valid_fixes(&readings[..1], &[near], &aiding());
        assert_eq!(
            floored[0].sigma_m, 0.5,
            "0.4 m from 40 m is under the floor"
        );
        let alone = valid_fixes(&readings[..1], &[], &aiding());
        assert_eq!((alone[0].sigma_m, alone[0].slant_range_m), (5.0, None));
        let stale = ShipPose {
            stamp_ns: 80_000_000_000,
            ..ship
        };
        let too_old = valid_fixes(&readings[..1], &[stale], &aiding());
        assert_eq!(
            too_old[0].slant_range_m, None,
            "a ship pose 19 s old is not used"
        );
        assert_eq!(too_old[0].sigma_m, 5.0);
    }
}
