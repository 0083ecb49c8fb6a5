//! The `mission` metadata record of the contract.

use std::collections::BTreeMap;

/// Parsed `mission` metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Mission {
    /// Origin of the local NED frame, WGS-84 latitude, degrees.
    pub origin_latitude_deg: f64,
    /// Origin of the local NED frame, WGS-84 longitude, degrees.
    pub origin_longitude_deg: f64,
    /// Vehicle name or file the tool knows.
    pub vehicle: String,
    pub description: String,
    /// Rough heading handed over by a launcher, rad.
    pub initial_yaw_rad: Option<f64>,
    /// Magnetic declination at the site, degrees, east positive (hindsight's addition to
    /// the contract: optional key `magnetic_declination_deg`).
    pub magnetic_declination_deg: Option<f64>,
}

/// What stands in for an absent `mission` record (a ROS 2 recording has none).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MissionDefaults {
    /// Origin of the local NED frame, degrees. Not given: the first GNSS fix.
    pub origin_latitude_deg: Option<f64>,
    pub origin_longitude_deg: Option<f64>,
    /// Not given: `unknown`.
    pub vehicle: Option<String>,
    pub magnetic_declination_deg: Option<f64>,
}

/// Why the `mission` metadata is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MissionError {
    #[error("the log has no `mission` metadata record (origin_latitude_deg, origin_longitude_deg, vehicle, description)")]
    Absent,
    #[error(
        "the log has no `mission` metadata record and no GNSS fix to take the origin from: \
         give the origin of its local frame (latitude and longitude, degrees)"
    )]
    NoOrigin,
    #[error("`mission` metadata, key `{key}`: {reason}")]
    BadKey { key: &'static str, reason: String },
}

impl Mission {
    /// Parses the key/value map of a `mission` metadata record (values are text, per MCAP).
    pub fn parse(map: &BTreeMap<String, String>) -> Result<Mission, MissionError> {
        let text = |key: &'static str| {
            map.get(key).ok_or(MissionError::BadKey {
                key,
                reason: "missing".into(),
            })
        };
        let number = |key: &'static str, min: f64, max: f64| -> Result<f64, MissionError> {
            let raw = text(key)?;
            let v: f64 = raw.trim().parse().map_err(|_| MissionError::BadKey {
                key,
                reason: format!("`{raw}` is not a number"),
            })?;
            if !(v.is_finite() && (min..=max).contains(&v)) {
                return Err(MissionError::BadKey {
                    key,
                    reason: format!("{v} is outside [{min}, {max}]"),
                });
            }
            Ok(v)
        };
        let initial_yaw_rad = match map.get("initial_yaw_rad") {
            None => None,
            Some(_) => Some(number(
                "initial_yaw_rad",
                -std::f64::consts::TAU,
                std::f64::consts::TAU,
            )?),
        };
        let magnetic_declination_deg = match map.get("magnetic_declination_deg") {
            None => None,
            Some(_) => Some(number("magnetic_declination_deg", -180.0, 180.0)?),
        };
        Ok(Mission {
            origin_latitude_deg: number("origin_latitude_deg", -90.0, 90.0)?,
            origin_longitude_deg: number("origin_longitude_deg", -180.0, 360.0)?,
            vehicle: text("vehicle")?.clone(),
            description: map.get("description").cloned().unwrap_or_default(),
            initial_yaw_rad,
            magnetic_declination_deg,
        })
    }

    /// The mission of a log without a `mission` record: the origin from `defaults`, else from
    /// `first_fix` (latitude, longitude, degrees); the vehicle `unknown` unless given.
    pub fn standing_in(
        defaults: &MissionDefaults,
        first_fix: Option<(f64, f64)>,
    ) -> Result<Mission, MissionError> {
        let given = defaults
            .origin_latitude_deg
            .zip(defaults.origin_longitude_deg);
        let (source, (lat, lon)) = match (given, first_fix) {
            (Some(o), _) => ("the configuration", o),
            (None, Some(o)) => ("the first GNSS fix", o),
            (None, None) => return Err(MissionError::NoOrigin),
        };
        let check = |key: &'static str, v: f64, limit: f64| {
            if v.is_finite() && v.abs() <= limit {
                Ok(v)
            } else {
                Err(MissionError::BadKey {
                    key,
                    reason: format!("{v} is outside [-{limit}, {limit}]"),
                })
            }
        };
        Ok(Mission {
            origin_latitude_deg: check("origin_latitude_deg", lat, 90.0)?,
            origin_longitude_deg: check("origin_longitude_deg", lon, 360.0)?,
            vehicle: defaults.vehicle.clone().unwrap_or_else(|| "unknown".into()),
            description: format!("no mission record; origin from {source}"),
            initial_yaw_rad: None,
            magnetic_declination_deg: defaults.magnetic_declination_deg,
        })
    }

    /// The key/value map of this mission, as written to a `mission` metadata record.
    pub fn to_map(&self) -> BTreeMap<String, String> {
        let mut m = BTreeMap::new();
        m.insert(
            "origin_latitude_deg".into(),
            format!("{}", self.origin_latitude_deg),
        );
        m.insert(
            "origin_longitude_deg".into(),
            format!("{}", self.origin_longitude_deg),
        );
        m.insert("vehicle".into(), self.vehicle.clone());
        m.insert("description".into(), self.description.clone());
        if let Some(y) = self.initial_yaw_rad {
            m.insert("initial_yaw_rad".into(), format!("{y}"));
        }
        if let Some(d) = self.magnetic_declination_deg {
            m.insert("magnetic_declination_deg".into(), format!("{d}"));
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mission() -> Mission {
        Mission {
            origin_latitude_deg: 35.1,
            origin_longitude_deg: 129.05,
            vehicle: "nps-auv-ii".into(),
            description: "test".into(),
            initial_yaw_rad: Some(0.5),
            magnetic_declination_deg: Some(-7.8),
        }
    }

    #[test]
    fn round_trips() {
        assert_eq!(Mission::parse(&mission().to_map()), Ok(mission()));
    }

    #[test]
    fn a_missing_record_takes_the_configured_origin_then_the_first_fix() {
        let none = MissionDefaults::default();
        assert_eq!(
            Mission::standing_in(&none, None),
            Err(MissionError::NoOrigin)
        );
        let from_fix = Mission::standing_in(&none, Some((35.0, 129.0))).unwrap();
        assert_eq!(
            (from_fix.origin_latitude_deg, from_fix.origin_longitude_deg),
            (35.0, 129.0)
        );
        assert_eq!(from_fix.vehicle, "unknown");
        let given = MissionDefaults {
            origin_latitude_deg: Some(-33.9),
            origin_longitude_deg: Some(18.4),
            vehicle: Some("remus-100".into()),
            magnetic_declination_deg: Some(-25.0),
        };
        let m = Mission::standing_in(&given, Some((35.0, 129.0))).unwrap();
        assert_eq!(
            (m.origin_latitude_deg, m.origin_longitude_deg),
            (-33.9, 18.4)
        );
        assert_eq!(m.vehicle, "remus-100");
        assert_eq!(m.magnetic_declination_deg, Some(-25.0));
        let bad = MissionDefaults {
            origin_latitude_deg: Some(95.0),
            ..given
        };
        assert!(matches!(
            Mission::standing_in(&bad, None),
            Err(MissionError::BadKey {
                key: "origin_latitude_deg",
                ..
            })
        ));
    }

    #[test]
    fn names_the_bad_key() {
        let mut m = mission().to_map();
        m.insert("origin_latitude_deg".into(), "north".into());
        assert!(matches!(
            Mission::parse(&m),
            Err(MissionError::BadKey {
                key: "origin_latitude_deg",
                ..
            })
        ));
        let mut m = mission().to_map();
        m.remove("vehicle");
        assert!(matches!(
            Mission::parse(&m),
            Err(MissionError::BadKey { key: "vehicle", .. })
        ));
    }
}
