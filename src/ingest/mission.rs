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

/// Why the `mission` metadata is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MissionError {
    #[error("the log has no `mission` metadata record (origin_latitude_deg, origin_longitude_deg, vehicle, description)")]
    Absent,
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
