//! Object-safe view of a message type, so tables of all kinds can be iterated.

use super::messages::*;
use super::{Message, Property};
use std::marker::PhantomData;

/// A message type seen at run time: what generic code needs without knowing `T`.
pub trait MessageKind: Send + Sync {
    /// Schema name, e.g. `hindsight.Imu`.
    fn schema_name(&self) -> &'static str;
    /// Default topic, e.g. `/imu`.
    fn default_topic(&self) -> &'static str;
    /// JSON Schema text as shipped in `schemas/`.
    fn schema_json(&self) -> &'static str;
    /// Fields other than `stamp_ns`.
    fn properties(&self) -> &'static [Property];
}

/// The [`MessageKind`] of `T`.
pub struct Kind<T>(PhantomData<fn() -> T>);

impl<T> Kind<T> {
    /// The kind of `T` (a constant, usable in statics).
    pub const NEW: Self = Kind(PhantomData);
}

impl<T: Message> MessageKind for Kind<T> {
    fn schema_name(&self) -> &'static str {
        T::SCHEMA_NAME
    }
    fn default_topic(&self) -> &'static str {
        T::DEFAULT_TOPIC
    }
    fn schema_json(&self) -> &'static str {
        T::SCHEMA_JSON
    }
    fn properties(&self) -> &'static [Property] {
        T::PROPERTIES
    }
}

macro_rules! kinds {
    ($($t:ident),*) => {
        static ALL: &[&dyn MessageKind] = &[$(&Kind::<$t>::NEW),*];
    };
}
crate::for_each_message!(kinds);

/// Every message kind of the contract, in the contract's table order.
pub fn all_kinds() -> &'static [&'static dyn MessageKind] {
    ALL
}

/// The kind with this schema name.
pub fn kind_by_schema(schema_name: &str) -> Option<&'static dyn MessageKind> {
    ALL.iter().copied().find(|k| k.schema_name() == schema_name)
}
