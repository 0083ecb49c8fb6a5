//! ROS message definitions as MCAP stores them (schema encodings `ros2msg` and `ros1msg`,
//! and a ROS 1 bag's `message_definition`): the main type's `.msg` text, then each
//! dependency after a line of `=` signs and a `MSG: pkg/Type` line.
//!
//! Read here: fields (`type name [default]`), constants (`TYPE NAME=value`, skipped: they take
//! no room in a message), comments, primitive types, bounded and unbounded strings, fixed,
//! bounded and unbounded arrays, and type names relative to the enclosing package (`Header`
//! is `std_msgs/Header`). `builtin_interfaces/Time` and `Duration` are known without their
//! text, since some writers leave them out. A message with no fields (constants only) takes
//! one byte, as rosidl gives it (`uint8 structure_needs_at_least_one_member`).
//!
//! ROS 1 ([`Dialect::Ros1`]) differs only in its built-in `time` and `duration` (two 32-bit
//! fields, read here under ROS 2's names `sec` and `nanosec`, so one path serves both) and in
//! giving an empty message no room at all.

use std::collections::HashMap;

/// A fixed-size type of the ROS 2 IDL.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    Bool,
    Byte,
    Char,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Primitive {
    /// Bytes on the wire (and the CDR alignment).
    pub fn size(self) -> usize {
        match self {
            Primitive::Bool | Primitive::Byte | Primitive::Char | Primitive::I8 | Primitive::U8 => {
                1
            }
            Primitive::I16 | Primitive::U16 => 2,
            Primitive::I32 | Primitive::U32 | Primitive::F32 => 4,
            Primitive::I64 | Primitive::U64 | Primitive::F64 => 8,
        }
    }

    fn named(name: &str) -> Option<Primitive> {
        Some(match name {
            "bool" => Primitive::Bool,
            "byte" => Primitive::Byte,
            "char" => Primitive::Char,
            "int8" => Primitive::I8,
            "uint8" => Primitive::U8,
            "int16" => Primitive::I16,
            "uint16" => Primitive::U16,
            "int32" => Primitive::I32,
            "uint32" => Primitive::U32,
            "int64" => Primitive::I64,
            "uint64" => Primitive::U64,
            "float32" => Primitive::F32,
            "float64" => Primitive::F64,
            _ => return None,
        })
    }
}

/// What one element of a field is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Element {
    Primitive(Primitive),
    /// `string` or `string<=N` (the bound is not checked on reading).
    String,
    /// `wstring`: 32-bit characters.
    WString,
    /// Another message, by its full name `pkg/Type`.
    Message(String),
}

/// How many elements a field holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    One,
    /// `T[N]`: no count on the wire.
    Fixed(usize),
    /// `T[]` or `T[<=N]`: a 32-bit count, then the elements.
    Sequence,
}

/// One field of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub element: Element,
    pub shape: Shape,
}

/// Which ROS the definitions come from: it decides the built-in types and the wire format
/// ([`super::cdr`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dialect {
    /// ROS 1: messages serialised little-endian with no alignment and no header.
    Ros1,
    /// ROS 2: messages in CDR.
    Ros2,
}

/// A schema's message types by full name, and which is the main one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Definitions {
    pub root: String,
    pub types: HashMap<String, Vec<Field>>,
    pub dialect: Dialect,
}

/// Why a schema text could not be read.
/// The longest fixed array a definition may declare: every element of a fixed array of
/// numbers is a step of the decoding plan (the largest standard ones are 36-element
/// covariances), so a corrupt or hostile length must not size the plan.
pub const MAX_FIXED_LENGTH: usize = 1 << 16;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SchemaError {
    #[error("schema name `{0}` is not a ROS 2 type name (pkg/Type or pkg/msg/Type)")]
    BadName(String),
    #[error("line {line} of the schema (`{text}`): {why}")]
    Line {
        line: usize,
        text: String,
        why: String,
    },
    #[error("type `{0}` is used but not defined in the schema text")]
    Undefined(String),
    #[error("type `{0}` contains itself")]
    Recursive(String),
}

/// `pkg/msg/Type` or `pkg/Type` as `pkg/Type`.
pub fn full_name(name: &str) -> Option<String> {
    let parts: Vec<&str> = name.trim().split('/').collect();
    match parts.as_slice() {
        [pkg, ty] | [pkg, "msg", ty] if !pkg.is_empty() && !ty.is_empty() => {
            Some(format!("{pkg}/{ty}"))
        }
        _ => None,
    }
}

const BUILTIN: [(&str, &str); 2] = [
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"),
];

/// ROS 1's built-in `time` and `duration` (`secs`, `nsecs` on the wire), named as ROS 2's.
const BUILTIN_ROS1: [(&str, &str); 2] = [
    ("ros1/time", "uint32 sec\nuint32 nanosec\n"),
    ("ros1/duration", "int32 sec\nint32 nanosec\n"),
];

/// Parses the ROS 2 schema text of the type `schema_name` (the MCAP schema record's name).
pub fn parse(schema_name: &str, text: &str) -> Result<Definitions, SchemaError> {
    parse_as(Dialect::Ros2, schema_name, text)
}

/// Parses the schema text of the type `schema_name` in the given ROS's dialect.
pub fn parse_as(
    dialect: Dialect,
    schema_name: &str,
    text: &str,
) -> Result<Definitions, SchemaError> {
    let root = full_name(schema_name).ok_or_else(|| SchemaError::BadName(schema_name.into()))?;
    let mut types = HashMap::new();
    let mut current = root.clone();
    let mut fields = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        let bad = |why: String| SchemaError::Line {
            line: i + 1,
            text: raw.to_string(),
            why,
        };
        if line.starts_with("==") && line.chars().all(|c| c == '=') {
            types.insert(std::mem::take(&mut current), std::mem::take(&mut fields));
            continue;
        }
        if let Some(name) = line.strip_prefix("MSG:") {
            current = full_name(name).ok_or_else(|| bad("not a pkg/Type name".into()))?;
            continue;
        }
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        if let Some(field) = parse_line(content, package(&current), dialect).map_err(bad)? {
            fields.push(field);
        }
    }
    types.insert(current, fields);
    types.remove("");
    // ROS 2 gives a message without fields (constants only) one byte on the wire.
    if dialect == Dialect::Ros2 {
        for fields in types.values_mut().filter(|f| f.is_empty()) {
            fields.push(Field {
                name: "structure_needs_at_least_one_member".into(),
                element: Element::Primitive(Primitive::U8),
                shape: Shape::One,
            });
        }
    }
    let builtin: &[(&str, &str)] = match dialect {
        Dialect::Ros1 => &BUILTIN_ROS1,
        Dialect::Ros2 => &BUILTIN,
    };
    for (name, body) in builtin {
        if !types.contains_key(*name) {
            let fields = body
                .lines()
                .filter_map(|l| parse_line(l, package(name), dialect).ok().flatten())
                .collect();
            types.insert(name.to_string(), fields);
        }
    }
    let defs = Definitions {
        root,
        types,
        dialect,
    };
    check(&defs, &defs.root, &mut Vec::new())?;
    Ok(defs)
}

fn package(full: &str) -> &str {
    full.split('/').next().unwrap_or("")
}

/// A field, or `None` for a constant.
fn parse_line(content: &str, package: &str, dialect: Dialect) -> Result<Option<Field>, String> {
    let (type_text, rest) = content
        .split_once(char::is_whitespace)
        .ok_or("a field needs a type and a name")?;
    let rest = rest.trim();
    if rest.contains('=') {
        return Ok(None); // a constant: NAME=value
    }
    let name = rest.split_whitespace().next().ok_or("no field name")?;
    if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!("`{name}` is not a field name"));
    }
    let (base, shape) = match type_text.split_once('[') {
        None => (type_text, Shape::One),
        Some((base, dims)) => {
            let dims = dims.strip_suffix(']').ok_or("unclosed `[`")?;
            let shape = if dims.is_empty() || dims.starts_with("<=") {
                Shape::Sequence
            } else {
                let n: usize = dims
                    .parse()
                    .map_err(|_| format!("`{dims}` is not an array length"))?;
                if n > MAX_FIXED_LENGTH {
                    return Err(format!(
                        "a fixed array of {n} elements (hindsight reads at most \
                         {MAX_FIXED_LENGTH})"
                    ));
                }
                Shape::Fixed(n)
            };
            (base, shape)
        }
    };
    let element = if let Some(p) = Primitive::named(base) {
        Element::Primitive(p)
    } else if base == "string" || base.starts_with("string<=") {
        Element::String
    } else if base == "wstring" || base.starts_with("wstring<=") {
        Element::WString
    } else if base == "Header" {
        Element::Message("std_msgs/Header".into())
    } else if dialect == Dialect::Ros1 && (base == "time" || base == "duration") {
        Element::Message(format!("ros1/{base}"))
    } else if base.contains('/') {
        Element::Message(full_name(base).ok_or_else(|| format!("`{base}` is not a type name"))?)
    } else if base.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        Element::Message(format!("{package}/{base}"))
    } else {
        return Err(format!("`{base}` is not a type"));
    };
    Ok(Some(Field {
        name: name.to_string(),
        element,
        shape,
    }))
}

/// Every type used is defined, and none contains itself.
fn check(defs: &Definitions, name: &str, stack: &mut Vec<String>) -> Result<(), SchemaError> {
    if stack.iter().any(|s| s == name) {
        return Err(SchemaError::Recursive(name.into()));
    }
    let fields = defs
        .types
        .get(name)
        .ok_or_else(|| SchemaError::Undefined(name.into()))?;
    stack.push(name.to_string());
    for f in fields {
        if let Element::Message(inner) = &f.element {
            check(defs, inner, stack)?;
        }
    }
    stack.pop();
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// `sensor_msgs/msg/Range` as rosbag2 stores it on Jazzy (with `variance`), with its
    /// dependencies, constants and comments.
    pub(crate) const RANGE_JAZZY: &str = "\
# Single scan from a planar laser range-finder
std_msgs/Header header # timestamp in the header is the time the ranger
uint8 ULTRASOUND=0
uint8 INFRARED = 1
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
float32 variance
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
";

    #[test]
    fn reads_fields_constants_and_dependencies() {
        let d = parse("sensor_msgs/msg/Range", RANGE_JAZZY).unwrap();
        assert_eq!(d.root, "sensor_msgs/Range");
        let names: Vec<&str> = d.types[&d.root].iter().map(|f| f.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "header",
                "radiation_type",
                "field_of_view",
                "min_range",
                "max_range",
                "range",
                "variance"
            ]
        );
        assert_eq!(
            d.types["std_msgs/Header"][0].element,
            Element::Message("builtin_interfaces/Time".into())
        );
        assert_eq!(d.types["builtin_interfaces/Time"].len(), 2);
    }

    #[test]
    fn reads_arrays_bounds_and_relative_names() {
        let text = "\
float64[9] orientation_covariance
int32[] counts
string<=8[<=3] tags
Point p
Header h
================================================================================
MSG: geometry_msgs/Point
float64 x 1.5
float64 y
float64 z
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
";
        let d = parse("geometry_msgs/Sample", text).unwrap();
        let f = &d.types[&d.root];
        assert_eq!(f[0].shape, Shape::Fixed(9));
        assert_eq!(f[0].element, Element::Primitive(Primitive::F64));
        assert_eq!(f[1].shape, Shape::Sequence);
        assert_eq!(
            (f[2].element.clone(), f[2].shape),
            (Element::String, Shape::Sequence)
        );
        assert_eq!(f[3].element, Element::Message("geometry_msgs/Point".into()));
        assert_eq!(f[4].element, Element::Message("std_msgs/Header".into()));
        // builtin_interfaces/Time was not in the text: it is known anyway.
        assert!(d.types.contains_key("builtin_interfaces/Time"));
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        assert!(matches!(
            parse("Imu", "float64 x\n"),
            Err(SchemaError::BadName(_))
        ));
        assert!(matches!(
            parse("a/B", "geometry_msgs/Vector3 v\n"),
            Err(SchemaError::Undefined(t)) if t == "geometry_msgs/Vector3"
        ));
        let e = parse("a/B", "float64\n").unwrap_err();
        assert!(e.to_string().contains("line 1"), "{e}");
        let e = parse("a/B", "float64[x] v\n").unwrap_err();
        assert!(e.to_string().contains("array length"), "{e}");
        assert!(matches!(
            parse("a/B", "B inner\n"),
            Err(SchemaError::Recursive(_))
        ));
    }
}
