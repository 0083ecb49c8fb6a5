//! The recorded-log contract (`docs/log-format.md`) as Rust types.
//!
//! Every message type implements [`Message`]: its schema name, default topic, the JSON Schema
//! text from `schemas/` (embedded in every MCAP the project writes), and a table of
//! [`Property`]s that drives validation, Parquet columns and interpolation generically, so no
//! code is written per message beyond its declaration in [`messages`].
//!
//! May import: `time`. Nothing here does I/O.

pub mod beacons;
mod kind;
pub mod messages;
mod property;
mod streams;
mod validate;

pub use beacons::Beacon;
pub use kind::{all_kinds, kind_by_schema, Kind, MessageKind};
pub use messages::*;
pub use property::{Component, PropKind, PropValue, Property};
pub use streams::Streams;
pub use validate::{validate, FieldIssue};

use serde::{de::DeserializeOwned, Serialize};

/// Calls macro `$callback` with the list of every contract message type, in the contract's
/// table order: the one list that registries (kinds, decoders) and tests expand.
#[macro_export]
macro_rules! for_each_message {
    ($callback:ident) => {
        $callback! {
            Imu,
            MagneticField,
            Dvl,
            SpeedLog,
            Depth,
            Altimeter,
            Propeller,
            ControlSurfaces,
            Attitude,
            GnssFix,
            PositionFix,
            Truth,
            AcousticFix,
            UsblObservation,
            ShipPose,
            LblRange
        }
    };
}

/// One message of the contract.
pub trait Message:
    Clone + Default + std::fmt::Debug + PartialEq + Send + Sync + Serialize + DeserializeOwned + 'static
{
    /// Schema name as in the contract, e.g. `hindsight.Imu`.
    const SCHEMA_NAME: &'static str;
    /// Default topic, e.g. `/imu`.
    const DEFAULT_TOPIC: &'static str;
    /// The JSON Schema text of `schemas/<SCHEMA_NAME>.schema.json`.
    const SCHEMA_JSON: &'static str;
    /// The message's fields other than `stamp_ns`, in declaration order.
    const PROPERTIES: &'static [Property];

    /// Time of validity, nanoseconds since the Unix epoch.
    fn stamp_ns(&self) -> i64;
    /// Moves the time of validity (clock offsets, interpolation).
    fn set_stamp_ns(&mut self, stamp_ns: i64);
    /// Value of property `index` (an index into [`Message::PROPERTIES`]).
    fn get(&self, index: usize) -> PropValue<'_>;
    /// Sets numeric component `component` of property `index`; ignored for non-numeric
    /// properties and out-of-range indexes.
    fn set_component(&mut self, index: usize, component: usize, value: f64);
    /// Sets property `index`; `false` (and no change) when the value's kind does not match.
    fn set(&mut self, index: usize, value: PropValue<'_>) -> bool;
}

/// Declares a contract message: the struct, its serde form and its [`Message`] impl.
///
/// Each field is `name: RustType = property_spec`, where the spec (a `const fn` of
/// [`property`]) gives the kind, unit and plausible range. A test checks that each spec's kind
/// matches the Rust type and that the whole agrees with the JSON Schema file.
macro_rules! message {
    (
        $(#[$meta:meta])*
        $name:ident, schema = $schema:literal, topic = $topic:literal {
            $( $(#[$fmeta:meta])* $field:ident : $ty:ty = $spec:expr ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
        pub struct $name {
            /// Time of validity, nanoseconds since the Unix epoch.
            pub stamp_ns: i64,
            $( $(#[$fmeta])* pub $field: $ty, )+
        }

        impl $crate::contract::Message for $name {
            const SCHEMA_NAME: &'static str = $schema;
            const DEFAULT_TOPIC: &'static str = $topic;
            const SCHEMA_JSON: &'static str =
                include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/schemas/", $schema, ".schema.json"));
            const PROPERTIES: &'static [$crate::contract::Property] = &[
                $( $crate::contract::Property { name: stringify!($field), ..$spec } ),+
            ];

            fn stamp_ns(&self) -> i64 {
                self.stamp_ns
            }
            fn set_stamp_ns(&mut self, stamp_ns: i64) {
                self.stamp_ns = stamp_ns;
            }
            fn get(&self, index: usize) -> $crate::contract::PropValue<'_> {
                use $crate::contract::property::AsProp;
                type Getter = for<'a> fn(&'a $name) -> $crate::contract::PropValue<'a>;
                const GETTERS: &[Getter] = &[ $( |m| AsProp::as_prop(&m.$field) ),+ ];
                GETTERS[index](self)
            }
            fn set_component(&mut self, index: usize, component: usize, value: f64) {
                use $crate::contract::property::AsProp;
                let fields: &mut [&mut dyn AsProp] = &mut [ $( &mut self.$field ),+ ];
                if let Some(field) = fields.get_mut(index) {
                    field.set_component(component, value);
                }
            }
            fn set(&mut self, index: usize, value: $crate::contract::PropValue<'_>) -> bool {
                use $crate::contract::property::AsProp;
                let fields: &mut [&mut dyn AsProp] = &mut [ $( &mut self.$field ),+ ];
                fields.get_mut(index).is_some_and(|field| field.set(value))
            }
        }
    };
}
pub(crate) use message;
