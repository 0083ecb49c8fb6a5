//! The map of a CSV export: which file holds which contract messages, which column is which
//! field, in which unit and axis, and how each file's time column reads. Written in TOML:
//!
//! ```toml
//! [mission]                      # optional: the log's mission record
//! origin_latitude_deg = 35.1
//! origin_longitude_deg = 129.0
//! vehicle = "remus100"
//!
//! [[file]]
//! name = "imu*.csv"              # the file names it maps (`*` matches any run)
//! time = { column = "time_s", unit = "s" }   # s, ms, us, ns or iso8601; base, offset_s
//!
//! [[file.message]]
//! type = "imu"                   # a contract role: imu, mag, dvl, depth, gnss, ...
//! angular_velocity = ["gx", "-gy", "-gz"]    # columns into FRD; `-` flips a sign
//! specific_force = ["ax", "-ay", "-az"]
//! units = { angular_velocity = "deg/s", specific_force = "g" }
//! ```
//!
//! A field's value is a column name, `-column`, a number (a constant), or `true`/`false` for
//! a flag; a vector field takes three of them. Fields the map leaves out that the contract
//! allows to be absent (`altitude`, `down_m`) are null.

use serde::Deserialize;
use std::collections::BTreeMap;

/// A whole map.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CsvMap {
    #[serde(default)]
    pub mission: Option<MissionMap>,
    #[serde(rename = "file")]
    pub files: Vec<FileMap>,
}

/// The mission record the log gets.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionMap {
    pub origin_latitude_deg: f64,
    pub origin_longitude_deg: f64,
    #[serde(default = "unknown")]
    pub vehicle: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub magnetic_declination_deg: Option<f64>,
}

fn unknown() -> String {
    "unknown".into()
}

/// One kind of file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileMap {
    /// File name pattern (`*` matches any run of characters).
    pub name: String,
    /// Field separator (default `,`).
    #[serde(default = "comma")]
    pub delimiter: char,
    pub time: TimeMap,
    #[serde(rename = "message")]
    pub messages: Vec<MessageMap>,
}

fn comma() -> char {
    ','
}

/// How a file's time column becomes a stamp.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeMap {
    pub column: String,
    /// `s`, `ms`, `us`, `ns` (a number) or `iso8601` (a UTC date and time).
    #[serde(default = "seconds")]
    pub unit: String,
    /// The time a number of 0 is: a UTC date and time (default the Unix epoch). For a
    /// column of seconds since the start of a run, give the run's start.
    #[serde(default)]
    pub base: Option<String>,
    /// Added to every stamp of the file (a clock offset), s.
    #[serde(default)]
    pub offset_s: f64,
}

fn seconds() -> String {
    "s".into()
}

/// One contract message per row.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct MessageMap {
    /// The contract role (`imu`, `dvl`, ...): the message type and its default topic.
    #[serde(rename = "type")]
    pub role: String,
    /// Topic to write on (default the role's).
    #[serde(default)]
    pub topic: Option<String>,
    /// Units of the fields given in another unit than the contract's.
    #[serde(default)]
    pub units: BTreeMap<String, String>,
    /// Field name to source.
    #[serde(flatten)]
    pub fields: BTreeMap<String, Source>,
}

/// Where a field's value comes from.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Source {
    Flag(bool),
    Number(f64),
    /// A column, `-column` for its negative.
    Column(String),
    /// Three sources of a vector.
    Vector(Vec<Source>),
}

/// The factor that turns a value in `unit` into the contract's `si` unit, if it is one of
/// that quantity's units.
pub fn unit_factor(unit: &str, si: &str) -> Option<f64> {
    use std::f64::consts::PI;
    let table: &[(&str, &[(&str, f64)])] = &[
        ("rad", &[("rad", 1.0), ("deg", PI / 180.0)]),
        (
            "rad/s",
            &[
                ("rad/s", 1.0),
                ("deg/s", PI / 180.0),
                ("deg/h", PI / 180.0 / 3600.0),
            ],
        ),
        (
            "m/s^2",
            &[("m/s^2", 1.0), ("g", 9.80665), ("mg", 9.80665e-3)],
        ),
        (
            "T",
            &[
                ("T", 1.0),
                ("mT", 1e-3),
                ("uT", 1e-6),
                ("nT", 1e-9),
                ("gauss", 1e-4),
                ("G", 1e-4),
            ],
        ),
        (
            "m",
            &[("m", 1.0), ("cm", 1e-2), ("mm", 1e-3), ("ft", 0.3048)],
        ),
        (
            "m/s",
            &[
                ("m/s", 1.0),
                ("cm/s", 1e-2),
                ("mm/s", 1e-3),
                ("knots", 1852.0 / 3600.0),
            ],
        ),
        ("deg", &[("deg", 1.0), ("rad", 180.0 / PI)]),
        (
            "rev/min",
            &[
                ("rev/min", 1.0),
                ("rpm", 1.0),
                ("rev/s", 60.0),
                ("Hz", 60.0),
            ],
        ),
    ];
    table
        .iter()
        .find(|(s, _)| *s == si)
        .and_then(|(_, units)| units.iter().find(|(u, _)| *u == unit))
        .map(|(_, f)| *f)
}

/// The units a contract unit can be given in, for an error message.
pub fn units_of(si: &str) -> Vec<&'static str> {
    [
        "rad", "deg", "rad/s", "deg/s", "deg/h", "m/s^2", "g", "mg", "T", "mT", "uT", "nT",
        "gauss", "G", "m", "cm", "mm", "ft", "m/s", "cm/s", "mm/s", "knots", "rev/min", "rpm",
        "rev/s", "Hz",
    ]
    .into_iter()
    .filter(|u| unit_factor(u, si).is_some())
    .collect()
}

/// Whether `name` matches `pattern` (`*` matches any run of characters).
pub fn matches(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !name.starts_with(first) || !name[first.len()..].ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_convert_into_the_contract_s() {
        assert_eq!(unit_factor("g", "m/s^2"), Some(9.80665));
        assert!((unit_factor("deg/s", "rad/s").unwrap() - 0.017453292519943295).abs() < 1e-18);
        assert_eq!(unit_factor("uT", "T"), Some(1e-6));
        assert_eq!(unit_factor("g", "T"), None, "not a field strength");
        assert_eq!(units_of("m/s"), ["m/s", "cm/s", "mm/s", "knots"]);
    }

    #[test]
    fn names_match_patterns() {
        assert!(matches("imu.csv", "imu.csv"));
        assert!(!matches("imu.csv", "imu2.csv"));
        assert!(matches("imu*.csv", "imu_2016-05-03.csv"));
        assert!(matches("*dvl*", "run3_dvl_a.csv"));
        assert!(!matches("dvl*.csv", "imu.csv"));
        assert!(!matches("a*b*c", "ac"));
    }

    #[test]
    fn a_map_reads_from_toml() {
        let map: CsvMap = toml::from_str(
            r#"
            [[file]]
            name = "imu.csv"
            time = { column = "t", unit = "ms" }
            [[file.message]]
            type = "imu"
            angular_velocity = ["gx", "-gy", "-gz"]
            specific_force = ["ax", "ay", 9.8]
            units = { angular_velocity = "deg/s" }
            "#,
        )
        .unwrap();
        let m = &map.files[0].messages[0];
        assert_eq!(m.role, "imu");
        assert_eq!(
            m.fields["specific_force"],
            Source::Vector(vec![
                Source::Column("ax".into()),
                Source::Column("ay".into()),
                Source::Number(9.8)
            ])
        );
        assert_eq!(m.units["angular_velocity"], "deg/s");
    }
}
