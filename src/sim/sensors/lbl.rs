//! A long-baseline network: seabed beacons at known places, each interrogated every few
//! seconds, its two-way travel time turned into a range with a speed of sound that is off
//! by a set fraction.

use super::normal;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A seabed beacon: its id and its place, north, east and down of the mission origin, m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Beacon {
    pub id: String,
    pub ned_m: [f64; 3],
}

crate::config::with_defaults! {
    /// Parameters of the network (`[lbl]` in a scenario).
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields, default)]
    pub struct LblSpec {
        pub beacons: Vec<Beacon> = Vec::new(),
        /// Time between interrogations, s.
        pub every_s: f64 = 2.0,
        /// 1-sigma of a range, m.
        pub range_sigma_m: f64 = 0.1,
        /// The speed of sound the system converts travel times with, m/s ...
        pub sound_speed_m_s: f64 = 1500.0,
        /// ... and how far the true one is above it, a fraction (0.003: 0.3 %; the ranges
        /// then read 0.3 % short).
        pub sound_speed_error: f64 = 0.0,
        /// No reply from a beacon farther than this, m.
        pub max_range_m: f64 = 3000.0,
    }
}

impl LblSpec {
    /// What makes the parameters unusable, if anything.
    pub fn problem(&self) -> Option<String> {
        if self.beacons.is_empty() {
            return Some("lbl.beacons must list at least one beacon".into());
        }
        if !(self.every_s > 0.0 && self.sound_speed_m_s > 0.0 && self.max_range_m > 0.0) {
            return Some("lbl.every_s, sound_speed_m_s and max_range_m must be above 0".into());
        }
        if self.range_sigma_m < 0.0 || self.sound_speed_error.abs() >= 0.5 {
            return Some(
                "lbl.range_sigma_m must not be negative, sound_speed_error within 0.5".into(),
            );
        }
        None
    }

    /// The `beacons` metadata record: each id's place as `latitude_deg,longitude_deg,depth_m`,
    /// from the mission origin (rad).
    pub fn record(&self, (origin_lat, origin_lon): (f64, f64)) -> BTreeMap<String, String> {
        (self.beacons.iter())
            .map(|b| {
                let (lat, lon, height) = b.geodetic((origin_lat, origin_lon));
                let place = format!(
                    "{:.9},{:.9},{}",
                    lat.to_degrees(),
                    lon.to_degrees(),
                    -height
                );
                (b.id.clone(), place)
            })
            .collect()
    }
}

impl Beacon {
    /// The beacon's latitude, longitude (rad) and height (m, up), from the mission origin
    /// (rad).
    pub fn geodetic(&self, (origin_lat, origin_lon): (f64, f64)) -> (f64, f64, f64) {
        let [n, e, d] = self.ned_m;
        let (lat, lon) = crate::geodesy::position_of_local_m(origin_lat, origin_lon, n, e);
        (lat, lon, -d)
    }
}

/// One reply: the beacon, its two-way travel time and the range the system made of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply<'a> {
    pub beacon: &'a Beacon,
    pub two_way_travel_time_s: f64,
    pub range_m: f64,
}

/// The network of one run.
pub struct Lbl {
    spec: LblSpec,
    rng: ChaCha8Rng,
    next_s: f64,
}

impl Lbl {
    pub fn new(spec: LblSpec, rng: ChaCha8Rng) -> Self {
        Lbl {
            next_s: 0.0,
            spec,
            rng,
        }
    }

    pub fn spec(&self) -> &LblSpec {
        &self.spec
    }

    /// The replies to an interrogation at `t_s`, when one is due, from the vehicle moving at
    /// `vel_ned_m_s`; `from_beacon` gives the straight line from a beacon to the vehicle in
    /// the vehicle's north-east-down axes, m. The ping goes out from where the vehicle is
    /// and comes back to where it has moved on to by then.
    pub fn replies(
        &mut self,
        t_s: f64,
        from_beacon: impl Fn(&Beacon) -> [f64; 3],
        vel_ned_m_s: [f64; 3],
    ) -> Vec<Reply<'_>> {
        if t_s < self.next_s {
            return Vec::new();
        }
        self.next_s = t_s + self.spec.every_s;
        let true_speed = self.spec.sound_speed_m_s * (1.0 + self.spec.sound_speed_error);
        let distance = |line: &[f64; 3], after_s: f64| {
            let d = [0, 1, 2].map(|i| line[i] + vel_ned_m_s[i] * after_s);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        };
        let mut replies = Vec::new();
        for beacon in &self.spec.beacons {
            let line = from_beacon(beacon);
            let out_m = distance(&line, 0.0);
            if out_m > self.spec.max_range_m {
                continue;
            }
            // The way back ends where the vehicle is when the reply arrives (two iterations
            // of the travel time: the second is within micrometres).
            let mut back_m = out_m;
            for _ in 0..2 {
                back_m = distance(&line, (out_m + back_m) / true_speed);
            }
            let noise_m = self.spec.range_sigma_m * normal(&mut self.rng);
            let time_s = (out_m + back_m + 2.0 * noise_m) / true_speed;
            replies.push(Reply {
                beacon,
                two_way_travel_time_s: time_s,
                range_m: time_s * self.spec.sound_speed_m_s / 2.0,
            });
        }
        replies
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::sensors::rng_for;

    fn spec() -> LblSpec {
        let beacon = |id: &str, n: f64, e: f64| Beacon {
            id: id.into(),
            ned_m: [n, e, 50.0],
        };
        LblSpec {
            beacons: vec![
                beacon("A", 0.0, 0.0),
                beacon("B", 400.0, 0.0),
                beacon("C", 0.0, 4000.0),
            ],
            sound_speed_error: 0.003,
            ..LblSpec::default()
        }
    }

    /// The line from a beacon to a vehicle at `ned_m` on a flat Earth.
    fn flat(ned_m: [f64; 3]) -> impl Fn(&Beacon) -> [f64; 3] {
        move |b| [0, 1, 2].map(|i| ned_m[i] - b.ned_m[i])
    }

    /// The ranges read short by the sound speed's error, with the range noise about it, and a
    /// beacon out of range gives none.
    #[test]
    fn ranges_carry_the_sound_speed_error_and_their_noise() {
        let mut lbl = Lbl::new(spec(), rng_for(5, 98));
        let (mut sum, mut sum_sq, mut n) = (0.0, 0.0, 0.0);
        for k in 0..20_000 {
            let t = k as f64 * 2.0;
            let vehicle = [100.0 + (t * 0.01).sin() * 50.0, 30.0, 10.0];
            for r in lbl.replies(t, flat(vehicle), [0.0; 3]) {
                assert_ne!(r.beacon.id, "C", "4 km away");
                let d = [0, 1, 2].map(|i| vehicle[i] - r.beacon.ned_m[i]);
                let truth = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let error = (r.range_m * 1.003 - truth) / 0.1;
                sum += error;
                sum_sq += error * error;
                n += 1.0;
                let from_time = r.two_way_travel_time_s * 1500.0 / 2.0;
                assert!((from_time - r.range_m).abs() < 1e-9);
            }
        }
        assert_eq!(n, 40_000.0);
        let mean = sum / n;
        let sigma = (sum_sq / n - mean * mean).sqrt();
        assert!(
            mean.abs() < 0.02 && (sigma - 1.0).abs() < 0.02,
            "{mean} {sigma}"
        );
    }

    /// A moving vehicle: the range is the mean of the way out and the way back, the distance
    /// half the travel time after the interrogation.
    #[test]
    fn a_moving_vehicle_is_ranged_at_half_the_travel_time() {
        let mut lbl = Lbl::new(
            LblSpec {
                range_sigma_m: 0.0,
                ..spec()
            },
            rng_for(5, 98),
        );
        let (vehicle, vel) = ([300.0, 40.0, 10.0], [2.0, -1.0, 0.1]);
        for r in lbl.replies(0.0, flat(vehicle), vel) {
            let true_range = r.range_m * 1.003;
            let half_s = r.two_way_travel_time_s / 2.0;
            let d = [0, 1, 2].map(|i| vehicle[i] + vel[i] * half_s - r.beacon.ned_m[i]);
            let at_half = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let at_start = [0, 1, 2].map(|i| vehicle[i] - r.beacon.ned_m[i]);
            let moved = (true_range - at_start.iter().map(|x| x * x).sum::<f64>().sqrt()).abs();
            assert!(moved > 0.1, "{} moved {moved}", r.beacon.id);
            // (The mean of the two ways is the distance at half time to second order: the
            // motion across the line, (v T)^2 / 8 rho, a tenth of a millimetre here.)
            assert!(
                (true_range - at_half).abs() < 1e-3,
                "{true_range} {at_half}"
            );
        }
    }

    #[test]
    fn the_record_places_the_beacons_and_bad_parameters_are_named() {
        let record = spec().record((35f64.to_radians(), 129f64.to_radians()));
        let b: Vec<f64> = record["B"].split(',').map(|x| x.parse().unwrap()).collect();
        assert!(
            (b[0] - 35.0036).abs() < 1e-4 && (b[1] - 129.0).abs() < 1e-9,
            "{b:?}"
        );
        assert_eq!(b[2], 50.0);
        let none = LblSpec::default().problem().unwrap();
        assert!(none.contains("beacons"), "{none}");
        let slow = LblSpec {
            every_s: 0.0,
            ..spec()
        };
        assert!(slow.problem().unwrap().contains("every_s"));
    }
}
