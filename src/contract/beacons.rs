//! The acoustic beacons' places: the `beacons` metadata record of the contract (one key per
//! beacon id, the value `latitude_deg,longitude_deg,depth_m`) or a settings table.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A transponder at a known place: a seabed beacon of a long-baseline network.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Beacon {
    pub id: String,
    /// WGS-84 latitude, degrees.
    pub latitude_deg: f64,
    /// WGS-84 longitude, degrees.
    pub longitude_deg: f64,
    /// Depth below the surface, m.
    pub depth_m: f64,
}

impl Beacon {
    /// What makes the place unusable, if anything.
    pub fn problem(&self) -> Option<String> {
        let plausible = self.latitude_deg.abs() <= 90.0
            && (-180.0..=360.0).contains(&self.longitude_deg)
            && (-100.0..=12_000.0).contains(&self.depth_m);
        (!plausible).then(|| {
            format!(
                "beacon `{}`: latitude {} deg, longitude {} deg, depth {} m is not a place \
                 (latitude within 90, longitude -180..360, depth -100..12000)",
                self.id, self.latitude_deg, self.longitude_deg, self.depth_m
            )
        })
    }
}

/// The beacons of a `beacons` metadata record, and what was wrong with the entries left out.
pub fn from_record(record: &BTreeMap<String, String>) -> (Vec<Beacon>, Vec<String>) {
    let (mut beacons, mut problems) = (Vec::new(), Vec::new());
    for (id, value) in record {
        let numbers: Vec<Option<f64>> = value.split(',').map(|v| v.trim().parse().ok()).collect();
        let beacon = match numbers[..] {
            [Some(latitude_deg), Some(longitude_deg), Some(depth_m)] => Beacon {
                id: id.clone(),
                latitude_deg,
                longitude_deg,
                depth_m,
            },
            _ => {
                problems.push(format!(
                    "`beacons` metadata, key `{id}`: `{value}` is not \
                     `latitude_deg,longitude_deg,depth_m`; the beacon is left out"
                ));
                continue;
            }
        };
        match beacon.problem() {
            Some(p) => problems.push(format!("`beacons` metadata: {p}; the beacon is left out")),
            None => beacons.push(beacon),
        }
    }
    (beacons, problems)
}

/// The settings' beacons, then the log's whose ids the settings do not give.
pub fn merged(settings: &[Beacon], log: &[Beacon]) -> Vec<Beacon> {
    let mut out = settings.to_vec();
    out.extend(
        (log.iter())
            .filter(|b| settings.iter().all(|s| s.id != b.id))
            .cloned(),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_gives_its_beacons_and_names_the_bad_ones() {
        let record: BTreeMap<String, String> = [
            ("A", "35.1,129.05,80"),
            ("B", " 35.2 , 129.06 , 81.5 "),
            ("C", "35.1,129.05"),
            ("D", "95,129.05,80"),
        ]
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .into_iter()
        .collect();
        let (beacons, problems) = from_record(&record);
        assert_eq!(
            beacons.iter().map(|b| b.id.as_str()).collect::<Vec<_>>(),
            ["A", "B"]
        );
        assert_eq!(beacons[1].depth_m, 81.5);
        assert_eq!(problems.len(), 2);
        assert!(problems[0].contains("key `C`"), "{}", problems[0]);
        assert!(problems[1].contains("beacon `D`"), "{}", problems[1]);
    }

    #[test]
    fn the_settings_override_the_log_beacon_by_beacon() {
        let at = |id: &str, depth_m: f64| Beacon {
            id: id.into(),
            latitude_deg: 35.0,
            longitude_deg: 129.0,
            depth_m,
        };
        let m = merged(&[at("B", 90.0)], &[at("A", 80.0), at("B", 80.0)]);
        assert_eq!(m, [at("B", 90.0), at("A", 80.0)]);
    }
}
