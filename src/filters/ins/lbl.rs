//! Long-baseline ranges (`/lbl`) as an aid, tightly coupled: each range to a seabed beacon
//! is an update of its own at its time of validity, and the speed of sound the ranges were
//! converted with is corrected by a state of the filter (`idx::SOUND_SPEED_SCALE`).
//!
//! A reply is stamped when it was received, the interrogation's time plus the two-way travel
//! time. The range is the mean of the way out and the way back, so it is valid half the
//! travel time before the stamp (to second order in the vehicle's motion).

use super::aid_table::{Aid, Epoch, Measurement, Sensor, Update};
use super::forward::measure;
use crate::contract::{Beacon, LblRange};
use nalgebra::{SMatrix, Vector3};
use std::collections::BTreeMap;

/// How the LBL ranges are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LblAiding {
    /// 1-sigma of a range that carries none, m.
    pub range_sigma_m: f64,
    /// The speed of sound a travel time without one is converted with, m/s.
    pub sound_speed_m_s: f64,
    /// The transponder on the vehicle, body FRD from the IMU, m.
    pub lever_arm_body_m: [f64; 3],
}

/// A range made ready: when it was valid, from where, how long, how well.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidRange {
    /// Time of validity, ns.
    pub stamp_ns: i64,
    pub beacon_lat_rad: f64,
    pub beacon_lon_rad: f64,
    pub beacon_depth_m: f64,
    pub range_m: f64,
    pub sigma_m: f64,
}

/// The range of a reply, m, and its two-way travel time, s: each from the other where the
/// reply gives one only (with its own speed of sound, else `sound_speed_m_s`).
pub fn range_and_travel_time(reply: &LblRange, sound_speed_m_s: f64) -> Option<(f64, f64)> {
    let speed = reply.sound_speed_m_s.unwrap_or(sound_speed_m_s);
    match (reply.range_m, reply.two_way_travel_time_s) {
        (Some(r), Some(t)) => Some((r, t)),
        (Some(r), None) => Some((r, 2.0 * r / speed)),
        (None, Some(t)) => Some((t * speed / 2.0, t)),
        (None, None) => None,
    }
}

/// The 1-sigma of a reply's range: its own, else the settings' `range_sigma_m`.
pub fn range_sigma_m(reply: &LblRange, a: &LblAiding) -> f64 {
    reply
        .range_sigma_m
        .filter(|s| *s > 0.0)
        .unwrap_or(a.range_sigma_m)
}

/// The LBL ranges' row of the aiding table.
pub struct LblAid {
    ranges: Vec<ValidRange>,
    lever_arm_body_m: Vector3<f64>,
    /// Replies left out, per beacon id not in the table.
    unknown_beacons: BTreeMap<String, usize>,
    /// Replies with neither a range nor a travel time.
    without_range: usize,
}

impl LblAid {
    pub fn new(replies: &[LblRange], beacons: &[Beacon], a: &LblAiding) -> Self {
        let mut aid = LblAid {
            ranges: Vec::with_capacity(replies.len()),
            lever_arm_body_m: Vector3::from(a.lever_arm_body_m),
            unknown_beacons: BTreeMap::new(),
            without_range: 0,
        };
        for reply in replies {
            let Some(beacon) = beacons.iter().find(|b| b.id == reply.beacon_id) else {
                *aid.unknown_beacons
                    .entry(reply.beacon_id.clone())
                    .or_default() += 1;
                continue;
            };
            let Some((range_m, travel_s)) = range_and_travel_time(reply, a.sound_speed_m_s) else {
                aid.without_range += 1;
                continue;
            };
            aid.ranges.push(ValidRange {
                stamp_ns: reply.stamp_ns - (travel_s * 0.5e9).round() as i64,
                beacon_lat_rad: beacon.latitude_deg.to_radians(),
                beacon_lon_rad: beacon.longitude_deg.to_radians(),
                beacon_depth_m: beacon.depth_m,
                range_m,
                sigma_m: range_sigma_m(reply, a),
            });
        }
        aid.ranges.sort_by_key(|r| r.stamp_ns);
        aid
    }

    /// The ranges in use, in time order.
    pub fn ranges(&self) -> &[ValidRange] {
        &self.ranges
    }
}

impl Aid for LblAid {
    fn sensor(&self) -> Sensor {
        Sensor::Lbl
    }
    fn len(&self) -> usize {
        self.ranges.len()
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self.ranges[i].stamp_ns
    }
    fn measure(&self, i: usize, at: &Epoch<'_>) -> Option<Update> {
        let r = &self.ranges[i];
        let (y, h) = measure::slant_range(
            at.est,
            r.beacon_lat_rad,
            r.beacon_lon_rad,
            r.beacon_depth_m,
            &self.lever_arm_body_m,
            r.range_m,
        );
        let r = SMatrix::<f64, 1, 1>::new(r.sigma_m.powi(2));
        Some(Update::One(Measurement { y, h, r }))
    }
    fn slant_range_m(&self, i: usize) -> Option<f64> {
        Some(self.ranges[i].range_m)
    }
    fn left_out_notes(&self) -> Vec<String> {
        self.why_left_out()
    }
}

impl LblAid {
    /// Why replies were left out.
    fn why_left_out(&self) -> Vec<String> {
        let mut notes: Vec<String> = (self.unknown_beacons.iter())
            .map(|(id, n)| {
                format!(
                    "{n} ranges to beacon `{id}` were left out: it is not in the beacon table \
                     (the log's `beacons` record or the settings' [lbl] beacons)"
                )
            })
            .collect();
        if self.without_range > 0 {
            notes.push(format!(
                "{} replies with neither a range nor a travel time were left out",
                self.without_range
            ));
        }
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reply(stamp_s: f64, id: &str, range_m: Option<f64>, travel_s: Option<f64>) -> LblRange {
        LblRange {
            stamp_ns: (stamp_s * 1e9) as i64,
            beacon_id: id.into(),
            two_way_travel_time_s: travel_s,
            range_m,
            sound_speed_m_s: Some(1500.0),
            range_sigma_m: None,
        }
    }

    fn aiding() -> LblAiding {
        LblAiding {
            range_sigma_m: 0.4,
            sound_speed_m_s: 1480.0,
            lever_arm_body_m: [0.0; 3],
        }
    }

    #[test]
    fn a_range_is_valid_half_its_travel_time_before_its_stamp() {
        let beacons = [Beacon {
            id: "A".into(),
            latitude_deg: 35.1,
            longitude_deg: 129.05,
            depth_m: 80.0,
        }];
        let replies = [
            reply(10.0, "A", Some(750.0), Some(1.0)),
            reply(12.0, "A", None, Some(0.8)),
            reply(14.0, "A", Some(300.0), None),
            reply(16.0, "A", None, None),
            reply(17.0, "Z", Some(300.0), None),
            reply(18.0, "Z", Some(300.0), None),
        ];
        let aid = LblAid::new(&replies, &beacons, &aiding());
        let r = aid.ranges();
        assert_eq!(r.len(), 3);
        assert_eq!(r[0].stamp_ns, 9_500_000_000);
        // A travel time alone: the range from the reply's own speed of sound.
        assert_eq!((r[1].stamp_ns, r[1].range_m), (11_600_000_000, 600.0));
        // A range alone: its travel time from that speed too.
        assert_eq!(r[2].stamp_ns, 14_000_000_000 - 200_000_000);
        assert_eq!(r[2].sigma_m, 0.4);
        let notes = aid.left_out_notes();
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(
            notes[0].starts_with("2 ranges to beacon `Z`"),
            "{}",
            notes[0]
        );
        assert!(notes[1].starts_with("1 replies"), "{}", notes[1]);
    }
}
