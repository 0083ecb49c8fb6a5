//! Field descriptions shared by validation, Parquet columns and interpolation.

/// JSON shape of a property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PropKind {
    /// A JSON number.
    F64,
    /// An array of exactly three JSON numbers.
    Vec3,
    /// A JSON number or `null` (absent reads as `null`).
    OptF64,
    /// A JSON boolean.
    Bool,
    /// A JSON string.
    Str,
}

/// How the components of a [`PropKind::Vec3`] are named in flat tables (`_x`, `_roll`, ...).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Component {
    /// Vector components: `_x`, `_y`, `_z`.
    Xyz,
    /// Euler angles in the contract's order: `_roll`, `_pitch`, `_yaw`.
    RollPitchYaw,
}

impl Component {
    /// Column suffixes of the three components.
    pub fn suffixes(self) -> [&'static str; 3] {
        match self {
            Component::Xyz => ["x", "y", "z"],
            Component::RollPitchYaw => ["roll", "pitch", "yaw"],
        }
    }
}

/// One field of a message (other than `stamp_ns`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Property {
    /// JSON key and Rust field name.
    pub name: &'static str,
    /// JSON shape.
    pub kind: PropKind,
    /// SI unit, as in the contract (`""` for booleans and strings).
    pub unit: &'static str,
    /// Plausible range `[min, max]` of every numeric component; values outside are invalid.
    pub range: Option<(f64, f64)>,
    /// Angle in radians: interpolated on the circle (wrapped), not linearly.
    pub angle: bool,
    /// Component naming of a `Vec3`.
    pub components: Component,
}

impl Property {
    /// Whether the JSON key must be present (everything but nullable numbers).
    pub fn required(&self) -> bool {
        self.kind != PropKind::OptF64
    }

    /// Flat column names: `name` or `name_x`, `name_y`, `name_z`.
    pub fn column_names(&self) -> Vec<String> {
        match self.kind {
            PropKind::Vec3 => self
                .components
                .suffixes()
                .iter()
                .map(|s| format!("{}_{s}", self.name))
                .collect(),
            _ => vec![self.name.to_string()],
        }
    }
}

const BASE: Property = Property {
    name: "",
    kind: PropKind::F64,
    unit: "",
    range: None,
    angle: false,
    components: Component::Xyz,
};

/// A number in `unit`, plausible within `[min, max]`.
pub const fn number(unit: &'static str, min: f64, max: f64) -> Property {
    Property {
        unit,
        range: Some((min, max)),
        ..BASE
    }
}

/// An angle in radians, plausible within `[min, max]`.
pub const fn angle(min: f64, max: f64) -> Property {
    Property {
        unit: "rad",
        range: Some((min, max)),
        angle: true,
        ..BASE
    }
}

/// A number or null.
pub const fn optional_number(unit: &'static str, min: f64, max: f64) -> Property {
    Property {
        kind: PropKind::OptF64,
        ..number(unit, min, max)
    }
}

/// Three numbers `[x, y, z]` each within `[min, max]`.
pub const fn vector3(unit: &'static str, min: f64, max: f64) -> Property {
    Property {
        kind: PropKind::Vec3,
        ..number(unit, min, max)
    }
}

/// Three Euler angles `[roll, pitch, yaw]` each within `[min, max]`.
pub const fn euler3(min: f64, max: f64) -> Property {
    Property {
        kind: PropKind::Vec3,
        components: Component::RollPitchYaw,
        ..angle(min, max)
    }
}

/// A boolean.
pub const fn boolean() -> Property {
    Property {
        kind: PropKind::Bool,
        ..BASE
    }
}

/// A string.
pub const fn string() -> Property {
    Property {
        kind: PropKind::Str,
        ..BASE
    }
}

/// A property's value, borrowed from a message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PropValue<'a> {
    F64(f64),
    Vec3([f64; 3]),
    OptF64(Option<f64>),
    Bool(bool),
    Str(&'a str),
}

impl PropValue<'_> {
    /// The `i`-th numeric component (0 for scalars), `None` for null, bool and string.
    pub fn component(&self, i: usize) -> Option<f64> {
        match self {
            PropValue::F64(v) => (i == 0).then_some(*v),
            PropValue::Vec3(v) => v.get(i).copied(),
            PropValue::OptF64(v) => v.filter(|_| i == 0),
            PropValue::Bool(_) | PropValue::Str(_) => None,
        }
    }

    /// The kind this value has.
    pub fn kind(&self) -> PropKind {
        match self {
            PropValue::F64(_) => PropKind::F64,
            PropValue::Vec3(_) => PropKind::Vec3,
            PropValue::OptF64(_) => PropKind::OptF64,
            PropValue::Bool(_) => PropKind::Bool,
            PropValue::Str(_) => PropKind::Str,
        }
    }
}

/// Field types a message may hold; used by the `message!` macro.
pub trait AsProp {
    fn as_prop(&self) -> PropValue<'_>;
    fn set_component(&mut self, component: usize, value: f64);
    /// Takes `value` if it is of this field's kind.
    fn set(&mut self, value: PropValue<'_>) -> bool;
}

impl AsProp for f64 {
    fn as_prop(&self) -> PropValue<'_> {
        PropValue::F64(*self)
    }
    fn set_component(&mut self, component: usize, value: f64) {
        if component == 0 {
            *self = value;
        }
    }
    fn set(&mut self, value: PropValue<'_>) -> bool {
        match value {
            PropValue::F64(v) => {
                *self = v;
                true
            }
            _ => false,
        }
    }
}

impl AsProp for [f64; 3] {
    fn as_prop(&self) -> PropValue<'_> {
        PropValue::Vec3(*self)
    }
    fn set_component(&mut self, component: usize, value: f64) {
        if let Some(c) = self.get_mut(component) {
            *c = value;
        }
    }
    fn set(&mut self, value: PropValue<'_>) -> bool {
        match value {
            PropValue::Vec3(v) => {
                *self = v;
                true
            }
            _ => false,
        }
    }
}

impl AsProp for Option<f64> {
    fn as_prop(&self) -> PropValue<'_> {
        PropValue::OptF64(*self)
    }
    fn set_component(&mut self, component: usize, value: f64) {
        if component == 0 {
            *self = Some(value);
        }
    }
    fn set(&mut self, value: PropValue<'_>) -> bool {
        match value {
            PropValue::OptF64(v) => {
                *self = v;
                true
            }
            _ => false,
        }
    }
}

impl AsProp for bool {
    fn as_prop(&self) -> PropValue<'_> {
        PropValue::Bool(*self)
    }
    fn set_component(&mut self, _: usize, _: f64) {}
    fn set(&mut self, value: PropValue<'_>) -> bool {
        match value {
            PropValue::Bool(v) => {
                *self = v;
                true
            }
            _ => false,
        }
    }
}

impl AsProp for String {
    fn as_prop(&self) -> PropValue<'_> {
        PropValue::Str(self)
    }
    fn set_component(&mut self, _: usize, _: f64) {}
    fn set(&mut self, value: PropValue<'_>) -> bool {
        match value {
            PropValue::Str(v) => {
                v.clone_into(self);
                true
            }
            _ => false,
        }
    }
}
