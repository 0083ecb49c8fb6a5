//! Type-erased, typed storage of one stream's decoded messages.

use crate::contract::{Message, PropValue, Property};
use std::any::Any;

/// A `Vec<T>` of one message type, seen without knowing `T`.
///
/// Generic code (statistics, alignment, Parquet export) uses this view; filters get the typed
/// slice back with [`Samples::as_slice`].
pub trait Samples: Send + Sync + std::fmt::Debug {
    /// Number of messages.
    fn len(&self) -> usize;
    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// `stamp_ns` of message `i`.
    fn stamp_ns(&self, i: usize) -> i64;
    /// Property `prop` of message `i`.
    fn get(&self, i: usize, prop: usize) -> PropValue<'_>;
    /// The message type's fields.
    fn properties(&self) -> &'static [Property];
    /// The message type's contract schema name, e.g. `hindsight.Imu`.
    fn schema_name(&self) -> &'static str;
    /// Keeps the messages at `order`, in that order.
    fn permute(&mut self, order: &[usize]);
    /// Drops every message.
    fn clear(&mut self);
    /// Drops every message but the last.
    fn keep_last(&mut self);
    /// Adds `offset_ns` to every stamp (saturating).
    fn shift_stamps(&mut self, offset_ns: i64);
    /// Message `i` as the contract's JSON.
    fn to_json(&self, i: usize) -> Vec<u8>;
    /// Upcast for typed access.
    fn as_any(&self) -> &dyn Any;
    /// Upcast for typed appends.
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Message> Samples for Vec<T> {
    fn len(&self) -> usize {
        Vec::len(self)
    }
    fn stamp_ns(&self, i: usize) -> i64 {
        self[i].stamp_ns()
    }
    fn get(&self, i: usize, prop: usize) -> PropValue<'_> {
        self[i].get(prop)
    }
    fn properties(&self) -> &'static [Property] {
        T::PROPERTIES
    }
    fn schema_name(&self) -> &'static str {
        T::SCHEMA_NAME
    }
    fn permute(&mut self, order: &[usize]) {
        let mut taken: Vec<Option<T>> = self.drain(..).map(Some).collect();
        self.extend(order.iter().filter_map(|&i| taken[i].take()));
    }
    fn clear(&mut self) {
        Vec::clear(self);
    }
    fn keep_last(&mut self) {
        let n = Vec::len(self);
        if n > 1 {
            self.drain(..n - 1);
        }
    }
    fn shift_stamps(&mut self, offset_ns: i64) {
        for m in self.iter_mut() {
            let s = m.stamp_ns().saturating_add(offset_ns);
            m.set_stamp_ns(s);
        }
    }
    fn to_json(&self, i: usize) -> Vec<u8> {
        serde_json::to_vec(&self[i]).expect("a contract message serializes")
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

impl dyn Samples {
    /// The typed messages, if this stream holds `T`.
    pub fn as_slice<T: Message>(&self) -> Option<&[T]> {
        self.as_any().downcast_ref::<Vec<T>>().map(Vec::as_slice)
    }
}

impl dyn Samples {
    /// Whether messages `i` and `j` hold the same value in every field (stamps aside).
    pub fn same_values(&self, i: usize, j: usize) -> bool {
        (0..self.properties().len()).all(|p| self.get(i, p) == self.get(j, p))
    }

    /// The index of the `valid` field, where a message says whether it is usable (a DVL's
    /// bottom lock).
    pub fn valid_property(&self) -> Option<usize> {
        self.properties().iter().position(|p| p.name == "valid")
    }

    /// Whether message `i` says it is not usable (`valid` at `property` is false).
    pub fn flagged_invalid(&self, i: usize, property: usize) -> bool {
        self.get(i, property) == crate::contract::PropValue::Bool(false)
    }
}
