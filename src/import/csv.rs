//! CSV files into contract messages by a [`CsvMap`]: each row of a mapped file becomes one
//! message per `[[file.message]]` (its fields from the row's cells, units and signs applied,
//! checked as the contract's json decoder checks any message). A row whose mapped cells are
//! all empty gives no message (a file that interleaves sensors of different rates).
//!
//! Nothing is written until every file has been read: the messages come back in stamp order
//! for the caller to write, or the first cell that does not serve comes back, named by its
//! file, line and column.

use super::map::{matches, unit_factor, units_of, CsvMap, FileMap, MessageMap, Source};
use crate::contract::{all_kinds, MessageKind};
use crate::contract::{PropKind, Property};
use crate::ingest::roles::role_name;

/// Why CSV files cannot be imported by a map.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImportError {
    #[error("{file}: no [[file]] of the map matches its name (patterns: {patterns})")]
    NoMap { file: String, patterns: String },
    #[error("{file}: {reason}")]
    Map { file: String, reason: String },
    #[error("{file}, line {line}, column `{column}`: {reason}")]
    Cell {
        file: String,
        line: u64,
        column: String,
        reason: String,
    },
    #[error("{file}, line {line}: the {role} message is invalid: {reason}")]
    Invalid {
        file: String,
        line: u64,
        role: String,
        reason: String,
    },
    #[error("{file}: {reason}")]
    Csv { file: String, reason: String },
}

/// One CSV file: the name the map matches, the name errors give, and its bytes.
pub struct CsvFile<'a> {
    pub file_name: String,
    pub shown_as: String,
    pub bytes: &'a [u8],
}

/// One message read from a row: its topic, schema, stamp and json text.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    pub topic: String,
    pub schema_name: &'static str,
    pub schema_json: &'static str,
    pub stamp_ns: i64,
    pub json: Vec<u8>,
}

/// Every message of `files` by `map`, in stamp order (stable: a file's rows keep their
/// order).
pub fn read_all(map: &CsvMap, files: &[CsvFile<'_>]) -> Result<Vec<Imported>, ImportError> {
    let mut out = Vec::new();
    for file in files {
        let file_map = map
            .files
            .iter()
            .find(|f| matches(&f.name, &file.file_name))
            .ok_or_else(|| ImportError::NoMap {
                file: file.shown_as.clone(),
                patterns: map
                    .files
                    .iter()
                    .map(|f| f.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        read_file(file_map, file, &mut out)?;
    }
    out.sort_by_key(|m| m.stamp_ns);
    Ok(out)
}

/// A cell or a constant, scaled.
#[derive(Debug, Clone, Copy)]
enum Cell {
    Column { index: usize, scale: f64 },
    Constant(f64),
}

/// A field compiled against a file's header.
#[derive(Debug, Clone, Copy)]
enum Field {
    Number(Cell),
    Vector([Cell; 3]),
    Flag(Result<usize, bool>),
    Text(usize),
    Absent,
}

/// A message compiled against a file's header.
struct Compiled {
    kind: &'static dyn MessageKind,
    role: String,
    topic: String,
    fields: Vec<(&'static Property, Field)>,
    /// The columns it reads: a row with all of them empty gives no message.
    columns: Vec<usize>,
}

fn read_file(
    map: &FileMap,
    file: &CsvFile<'_>,
    out: &mut Vec<Imported>,
) -> Result<(), ImportError> {
    let shown = || file.shown_as.clone();
    let csv_error = |e: csv::Error| ImportError::Csv {
        file: shown(),
        reason: e.to_string(),
    };
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(u8::try_from(map.delimiter).map_err(|_| ImportError::Map {
            file: shown(),
            reason: format!("delimiter `{}` is not one byte", map.delimiter),
        })?)
        .trim(csv::Trim::All)
        .from_reader(file.bytes);
    let header: Vec<String> = reader
        .headers()
        .map_err(csv_error)?
        .iter()
        .map(str::to_string)
        .collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| ImportError::Map {
                file: shown(),
                reason: format!("no column `{name}` (the header has: {})", header.join(", ")),
            })
    };
    let time = Time::of(map, column(&map.time.column)?, &shown())?;
    let messages: Vec<Compiled> = map
        .messages
        .iter()
        .map(|m| compile(m, &column, &shown()))
        .collect::<Result<_, _>>()?;
    let mut record = csv::StringRecord::new();
    while reader.read_record(&mut record).map_err(csv_error)? {
        let line = record.position().map_or(0, |p| p.line());
        let cell_error = |index: usize, reason: String| ImportError::Cell {
            file: shown(),
            line,
            column: header.get(index).cloned().unwrap_or_default(),
            reason,
        };
        let stamp_ns = time
            .stamp(&record[time.column])
            .map_err(|r| cell_error(time.column, r))?;
        for m in &messages {
            if m.columns.iter().all(|&c| record[c].is_empty()) {
                continue;
            }
            let json = m
                .json(&record, stamp_ns)
                .map_err(|(i, r)| cell_error(i, r))?;
            check(m.kind, &json).map_err(|reason| ImportError::Invalid {
                file: shown(),
                line,
                role: m.role.clone(),
                reason,
            })?;
            out.push(Imported {
                topic: m.topic.clone(),
                schema_name: m.kind.schema_name(),
                schema_json: m.kind.schema_json(),
                stamp_ns,
                json,
            });
        }
    }
    Ok(())
}

/// Checks a message as the contract's json decoder does.
fn check(kind: &dyn MessageKind, json: &[u8]) -> Result<(), String> {
    let decoder = crate::ingest::decode::find(kind.schema_name(), "json")
        .ok_or_else(|| format!("no json decoder for {}", kind.schema_name()))?;
    let mut samples = decoder.new_samples();
    decoder
        .decode_into(json, samples.as_mut())
        .map_err(|issue| issue.to_string())
}

/// The contract kind of a role name.
fn kind_of(role: &str) -> Option<&'static dyn MessageKind> {
    all_kinds().iter().copied().find(|k| role_name(*k) == role)
}

/// What compiling one message's map needs beside it: its columns by name, and the map's
/// file for errors.
struct Compiling<'a> {
    m: &'a MessageMap,
    column: &'a dyn Fn(&str) -> Result<usize, ImportError>,
    file: &'a str,
}

impl Compiling<'_> {
    fn bad(&self, reason: String) -> ImportError {
        ImportError::Map {
            file: self.file.to_string(),
            reason,
        }
    }

    /// The fields the message has, for errors.
    fn known(kind: &dyn MessageKind) -> String {
        let names: Vec<&str> = kind.properties().iter().map(|p| p.name).collect();
        names.join(", ")
    }

    /// The contract kind the map names; every field and unit it gives must be one of it.
    fn kind(&self) -> Result<&'static dyn MessageKind, ImportError> {
        let m = self.m;
        let kind = kind_of(&m.role).ok_or_else(|| {
            let roles: Vec<&str> = all_kinds().iter().map(|k| role_name(*k)).collect();
            self.bad(format!(
                "message type `{}` is not a contract role ({})",
                m.role,
                roles.join(", ")
            ))
        })?;
        let properties = kind.properties();
        if let Some(unknown) = (m.fields.keys().chain(m.units.keys()))
            .find(|f| !properties.iter().any(|p| p.name == f.as_str()))
        {
            return Err(self.bad(format!(
                "the {} message has no field `{unknown}` (it has: {})",
                m.role,
                Self::known(kind)
            )));
        }
        Ok(kind)
    }

    /// The factor from the unit the map gives a field in to the contract's.
    fn scale(&self, p: &Property) -> Result<f64, ImportError> {
        match self.m.units.get(p.name) {
            None => Ok(1.0),
            Some(unit) => unit_factor(unit, p.unit).ok_or_else(|| {
                self.bad(format!(
                    "`{}` is in {}; `{unit}` is not a unit of it (give one of: {})",
                    p.name,
                    p.unit,
                    units_of(p.unit).join(", ")
                ))
            }),
        }
    }

    /// A number's source: a column (`-column` for its negative) or a constant.
    fn cell(
        &self,
        s: &Source,
        p: &Property,
        scale: f64,
        columns: &mut Vec<usize>,
    ) -> Result<Cell, ImportError> {
        match s {
            Source::Number(x) => Ok(Cell::Constant(x * scale)),
            Source::Column(name) => {
                let (sign, name) = match name.strip_prefix('-') {
                    Some(rest) => (-1.0, rest),
                    None => (1.0, name.as_str()),
                };
                let index = (self.column)(name)?;
                columns.push(index);
                Ok(Cell::Column {
                    index,
                    scale: sign * scale,
                })
            }
            _ => Err(self.bad(format!(
                "`{}` takes a column, `-column` or a number",
                p.name
            ))),
        }
    }

    /// How one field of the message is read, as its kind allows.
    fn field(
        &self,
        kind: &dyn MessageKind,
        p: &Property,
        columns: &mut Vec<usize>,
    ) -> Result<Field, ImportError> {
        let scale = self.scale(p)?;
        let m = self.m;
        Ok(match (p.kind, m.fields.get(p.name)) {
            (_, None) if !p.required() => Field::Absent,
            (_, None) => {
                return Err(self.bad(format!(
                    "the {} message needs `{}` ({})",
                    m.role,
                    p.name,
                    Self::known(kind)
                )))
            }
            (PropKind::F64 | PropKind::OptF64, Some(s)) => {
                Field::Number(self.cell(s, p, scale, columns)?)
            }
            (PropKind::Vec3, Some(Source::Vector(v))) if v.len() == 3 => Field::Vector([
                self.cell(&v[0], p, scale, columns)?,
                self.cell(&v[1], p, scale, columns)?,
                self.cell(&v[2], p, scale, columns)?,
            ]),
            (PropKind::Vec3, Some(_)) => {
                return Err(self.bad(format!("`{}` takes three sources: [x, y, z]", p.name)))
            }
            (PropKind::Bool, Some(Source::Flag(b))) => Field::Flag(Err(*b)),
            (PropKind::Bool, Some(Source::Column(name))) => {
                let index = (self.column)(name)?;
                columns.push(index);
                Field::Flag(Ok(index))
            }
            (PropKind::Bool, Some(_)) => {
                return Err(self.bad(format!("`{}` takes a column or true/false", p.name)))
            }
            (PropKind::Str, Some(Source::Column(name))) => Field::Text((self.column)(name)?),
            (PropKind::Str, Some(_)) => {
                return Err(self.bad(format!("`{}` takes a column", p.name)))
            }
        })
    }
}

fn compile(
    m: &MessageMap,
    column: &dyn Fn(&str) -> Result<usize, ImportError>,
    file: &str,
) -> Result<Compiled, ImportError> {
    let c = Compiling { m, column, file };
    let kind = c.kind()?;
    let mut columns = Vec::new();
    let mut fields = Vec::new();
    for p in kind.properties() {
        fields.push((p, c.field(kind, p, &mut columns)?));
    }
    Ok(Compiled {
        kind,
        role: m.role.clone(),
        topic: m
            .topic
            .clone()
            .unwrap_or_else(|| kind.default_topic().to_string()),
        fields,
        columns,
    })
}

impl Compiled {
    /// The message of one row as json; a cell that does not serve as (its index, why).
    fn json(&self, row: &csv::StringRecord, stamp_ns: i64) -> Result<Vec<u8>, (usize, String)> {
        let mut object = serde_json::Map::new();
        object.insert("stamp_ns".into(), stamp_ns.into());
        for &(p, field) in &self.fields {
            let value = match field {
                Field::Absent => serde_json::Value::Null,
                Field::Number(c) => match value(&c, row, p.required())? {
                    Some(x) => number(x, &c)?,
                    None => serde_json::Value::Null,
                },
                Field::Vector(cells) => {
                    let mut v = Vec::with_capacity(3);
                    for c in &cells {
                        let x = value(c, row, true)?.expect("a required value");
                        v.push(number(x, c)?);
                    }
                    serde_json::Value::Array(v)
                }
                Field::Flag(Err(b)) => b.into(),
                Field::Flag(Ok(i)) => flag(&row[i])
                    .ok_or_else(|| {
                        let why = format!("`{}` is not a flag (1/0, true/false, yes/no)", &row[i]);
                        (i, why)
                    })?
                    .into(),
                Field::Text(i) => row[i].into(),
            };
            object.insert(p.name.into(), value);
        }
        serde_json::to_vec(&object).map_err(|e| (0, e.to_string()))
    }
}

/// A cell's value (`None`: empty, allowed where the field may be absent).
fn value(
    c: &Cell,
    row: &csv::StringRecord,
    required: bool,
) -> Result<Option<f64>, (usize, String)> {
    match *c {
        Cell::Constant(x) => Ok(Some(x)),
        Cell::Column { index, scale } => {
            let text = &row[index];
            if text.is_empty() {
                return match required {
                    true => Err((index, "empty, and the field is needed".into())),
                    false => Ok(None),
                };
            }
            let x: f64 = text
                .parse()
                .map_err(|_| (index, format!("`{text}` is not a number")))?;
            Ok(Some(x * scale))
        }
    }
}

fn number(x: f64, c: &Cell) -> Result<serde_json::Value, (usize, String)> {
    let index = match c {
        Cell::Column { index, .. } => *index,
        Cell::Constant(_) => 0,
    };
    serde_json::Number::from_f64(x)
        .map(serde_json::Value::Number)
        .ok_or((index, format!("{x} is not a finite number")))
}

fn flag(text: &str) -> Option<bool> {
    match text.to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" | "y" | "t" => Some(true),
        "0" | "false" | "no" | "n" | "f" => Some(false),
        other => other.parse::<f64>().ok().map(|x| x != 0.0),
    }
}

/// How a file's time column becomes a stamp.
struct Time {
    column: usize,
    /// Nanoseconds per unit of a numeric column; `None`: ISO 8601 text.
    ns_per_unit: Option<i64>,
    /// Added to every stamp: the base and the offset, ns.
    add_ns: i64,
}

impl Time {
    fn of(map: &FileMap, column: usize, file: &str) -> Result<Time, ImportError> {
        let bad = |reason: String| ImportError::Map {
            file: file.to_string(),
            reason,
        };
        let ns_per_unit = match map.time.unit.as_str() {
            "s" => Some(1_000_000_000),
            "ms" => Some(1_000_000),
            "us" => Some(1_000),
            "ns" => Some(1),
            "iso8601" => None,
            other => {
                return Err(bad(format!(
                    "time unit `{other}` (s, ms, us, ns or iso8601)"
                )))
            }
        };
        let base = match &map.time.base {
            None => 0,
            Some(text) => iso8601_ns(text).map_err(|r| bad(format!("time base: {r}")))?,
        };
        let offset = crate::time::s_to_ns(map.time.offset_s).ok_or_else(|| {
            bad(format!(
                "time offset {} s is out of range",
                map.time.offset_s
            ))
        })?;
        Ok(Time {
            column,
            ns_per_unit,
            add_ns: base + offset,
        })
    }

    fn stamp(&self, text: &str) -> Result<i64, String> {
        let t = match self.ns_per_unit {
            Some(per) => decimal_ns(text, per)?,
            None => iso8601_ns(text)?,
        };
        t.checked_add(self.add_ns)
            .ok_or_else(|| format!("`{text}` is out of range"))
    }
}

/// A decimal number of units as nanoseconds, exactly for plain decimals (`1700000000.123`).
fn decimal_ns(text: &str, ns_per_unit: i64) -> Result<i64, String> {
    let bad = || format!("`{text}` is not a time");
    let (negative, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text),
    };
    let plain = !digits.is_empty() && digits.chars().all(|c| c.is_ascii_digit() || c == '.');
    if !plain {
        // Exponents and the like: through f64.
        let x: f64 = text.parse().map_err(|_| bad())?;
        let ns = x * ns_per_unit as f64;
        return (ns.is_finite() && ns.abs() < 9.2e18)
            .then_some(ns.round() as i64)
            .ok_or_else(bad);
    }
    let (whole, fraction) = digits.split_once('.').unwrap_or((digits, ""));
    if fraction.contains('.') {
        return Err(bad());
    }
    let whole: i64 = if whole.is_empty() {
        0
    } else {
        whole.parse().map_err(|_| bad())?
    };
    let mut frac_ns = 0i64;
    let mut place = ns_per_unit;
    for d in fraction.chars() {
        place /= 10;
        if place == 0 {
            break; // below a nanosecond
        }
        frac_ns += i64::from(d.to_digit(10).ok_or_else(bad)?) * place;
    }
    let ns = whole
        .checked_mul(ns_per_unit)
        .and_then(|w| w.checked_add(frac_ns))
        .ok_or_else(bad)?;
    Ok(if negative { -ns } else { ns })
}

/// `YYYY-MM-DDTHH:MM:SS[.frac][Z|+HH:MM|-HH:MM]` (or a space for `T`; no zone is UTC) as
/// nanoseconds since the Unix epoch.
pub fn iso8601_ns(text: &str) -> Result<i64, String> {
    let bad = || format!("`{text}` is not a date and time (YYYY-MM-DDTHH:MM:SS.sssZ)");
    let t = text.trim();
    let (date, rest) = t.split_at_checked(10).ok_or_else(bad)?;
    let mut d = date.split('-');
    let (y, m, day) = (d.next(), d.next(), d.next());
    let year: i64 = y.and_then(|v| v.parse().ok()).ok_or_else(bad)?;
    let month: u32 = m
        .and_then(|v| v.parse().ok())
        .filter(|m| (1..=12).contains(m))
        .ok_or_else(bad)?;
    let day: u32 = day
        .and_then(|v| v.parse().ok())
        .filter(|d| (1..=31).contains(d))
        .ok_or_else(bad)?;
    let days = crate::time::days_from_civil(year, month, day);
    let rest = rest.strip_prefix(['T', ' ']).unwrap_or(rest);
    if rest.is_empty() {
        return Ok(days * 86_400_000_000_000);
    }
    let (clock, zone_s) = match rest.find(['Z', '+', '-']) {
        Some(i) => {
            let zone = &rest[i..];
            let seconds = match zone {
                "Z" => 0,
                _ => {
                    let sign = if zone.starts_with('-') { -1 } else { 1 };
                    let (h, m) = zone[1..].split_once(':').unwrap_or((&zone[1..], "0"));
                    let h: i64 = h.parse().map_err(|_| bad())?;
                    let m: i64 = m.parse().map_err(|_| bad())?;
                    sign * (h * 3600 + m * 60)
                }
            };
            (&rest[..i], seconds)
        }
        None => (rest, 0),
    };
    let mut parts = clock.splitn(3, ':');
    let h: i64 = parts
        .next()
        .and_then(|v| v.parse().ok())
        .filter(|h| (0..24).contains(h))
        .ok_or_else(bad)?;
    let min: i64 = parts
        .next()
        .and_then(|v| v.parse().ok())
        .filter(|m| (0..60).contains(m))
        .ok_or_else(bad)?;
    let sec_ns = decimal_ns(parts.next().unwrap_or("0"), 1_000_000_000)?;
    Ok(days * 86_400_000_000_000 + (h * 3600 + min * 60 - zone_s) * 1_000_000_000 + sec_ns)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(text: &str) -> CsvMap {
        toml::from_str(text).unwrap()
    }

    const IMU_MAP: &str = r#"
        [[file]]
        name = "imu*.csv"
        time = { column = "t", unit = "s", base = "2016-05-03T00:00:00Z" }
        [[file.message]]
        type = "imu"
        angular_velocity = ["gx", "-gy", "-gz"]
        specific_force = ["ax", "-ay", "-az"]
        units = { angular_velocity = "deg/s", specific_force = "g" }
    "#;

    fn read(map_text: &str, name: &str, csv: &str) -> Result<Vec<Imported>, ImportError> {
        let file = CsvFile {
            file_name: name.into(),
            shown_as: format!("dir/{name}"),
            bytes: csv.as_bytes(),
        };
        read_all(&map(map_text), &[file])
    }

    #[test]
    fn rows_become_contract_messages_with_units_signs_and_time() {
        let got = read(
            IMU_MAP,
            "imu_1.csv",
            "t,ax,ay,az,gx,gy,gz\n0.5,0,0,1,90,0,-180\n0.51,0.1,0.2,1.0,0,0,0\n",
        )
        .unwrap();
        assert_eq!(got.len(), 2);
        let base = iso8601_ns("2016-05-03T00:00:00Z").unwrap();
        assert_eq!(got[0].stamp_ns, base + 500_000_000);
        assert_eq!(got[1].stamp_ns, base + 510_000_000);
        let v: serde_json::Value = serde_json::from_slice(&got[0].json).unwrap();
        let w = v["angular_velocity"].as_array().unwrap();
        assert!((w[0].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert_eq!(
            w[2].as_f64().unwrap(),
            std::f64::consts::PI,
            "-(-180 deg/s)"
        );
        assert_eq!(v["specific_force"][2].as_f64().unwrap(), -9.80665);
        assert_eq!(got[0].topic, "/imu");
    }

    #[test]
    fn a_bad_cell_is_named_by_file_line_and_column() {
        let e = read(
            IMU_MAP,
            "imu.csv",
            "t,ax,ay,az,gx,gy,gz\n0.5,0,0,1,90,0,1\n0.6,0,x1,1,0,0,0\n",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "dir/imu.csv, line 3, column `ay`: `x1` is not a number"
        );
        let e = read(IMU_MAP, "imu.csv", "t,ax,ay,az,gx,gy\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("no column `gz` (the header has: t, ax"),
            "{e}"
        );
        let e = read(IMU_MAP, "dvl.csv", "t\n").unwrap_err();
        assert!(
            e.to_string().contains("no [[file]] of the map matches"),
            "{e}"
        );
        let e = read(
            IMU_MAP,
            "imu.csv",
            "t,ax,ay,az,gx,gy,gz\nsoon,0,0,1,0,0,0\n",
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .contains("line 2, column `t`: `soon` is not a time"),
            "{e}"
        );
    }

    #[test]
    fn the_contract_checks_every_message() {
        // 400 m/s is beyond the contract's DVL range.
        let dvl = r#"
            [[file]]
            name = "dvl.csv"
            time = { column = "t", unit = "ms" }
            [[file.message]]
            type = "dvl"
            velocity = ["vx", "vy", "vz"]
            valid = "lock"
            altitude = "alt"
        "#;
        let ok = read(
            dvl,
            "dvl.csv",
            "t,vx,vy,vz,lock,alt\n1000,1,0,0,1,\n1200,,,,,\n",
        )
        .unwrap();
        assert_eq!(ok.len(), 1, "an all-empty row gives no message");
        let v: serde_json::Value = serde_json::from_slice(&ok[0].json).unwrap();
        assert_eq!(
            (v["valid"].as_bool(), v["altitude"].is_null()),
            (Some(true), true)
        );
        let e = read(dvl, "dvl.csv", "t,vx,vy,vz,lock,alt\n1000,400,0,0,1,3\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("dvl.csv, line 2: the dvl message is invalid")
                || e.to_string()
                    .starts_with("dir/dvl.csv, line 2: the dvl message is invalid"),
            "{e}"
        );
        let e = read(
            &dvl.replace("valid = \"lock\"", "valid = \"lock\"\nspeed = \"v\""),
            "dvl.csv",
            "t\n",
        )
        .unwrap_err();
        assert!(e.to_string().contains("has no field `speed`"), "{e}");
        let e = read(
            &dvl.replace("type = \"dvl\"", "type = \"sonar\""),
            "dvl.csv",
            "t\n",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("`sonar` is not a contract role"),
            "{e}"
        );
    }

    #[test]
    fn times_read_exactly() {
        assert_eq!(
            decimal_ns("1700000000.123456789", 1_000_000_000),
            Ok(1_700_000_000_123_456_789)
        );
        assert_eq!(decimal_ns("-0.5", 1_000_000_000), Ok(-500_000_000));
        assert_eq!(decimal_ns("1.5e3", 1_000_000), Ok(1_500_000_000));
        assert_eq!(decimal_ns("12.25", 1_000), Ok(12_250));
        assert_eq!(iso8601_ns("1970-01-02T00:00:01.5Z"), Ok(86_401_500_000_000));
        assert_eq!(
            iso8601_ns("2016-05-03 10:00:00+02:00"),
            iso8601_ns("2016-05-03T08:00:00Z")
        );
        assert!(iso8601_ns("2016-13-03T00:00:00Z").is_err());
    }
}
