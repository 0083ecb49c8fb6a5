//! Decoders: bytes of one message encoding into one contract type, found by schema name.
//!
//! One decoder per (schema, message encoding). Today every contract schema has a JSON
//! decoder ([`json::JsonDecoder`]); ROS 2 `cdr` decoders will be added here, one per type,
//! without touching the ingest loop.

mod flat_json;
pub mod json;

use super::samples::Samples;
use crate::contract::{messages::*, FieldIssue};
use json::JsonDecoder;

/// Decodes and validates messages of one schema in one encoding.
pub trait Decoder: Send + Sync {
    /// Schema name this decoder reads, e.g. `hindsight.Imu`.
    fn schema_name(&self) -> &'static str;
    /// MCAP message encoding, e.g. `json`.
    fn message_encoding(&self) -> &'static str;
    /// An empty store for this decoder's messages.
    fn new_samples(&self) -> Box<dyn Samples>;
    /// Decodes, validates and appends one message; on failure nothing is appended.
    fn decode_into(&self, data: &[u8], out: &mut dyn Samples) -> Result<(), FieldIssue>;
}

macro_rules! json_decoders {
    ($($t:ident),*) => {
        static DECODERS: &[&dyn Decoder] = &[$(&JsonDecoder::<$t>::NEW),*];
    };
}
crate::for_each_message!(json_decoders);

/// Every registered decoder.
pub fn decoders() -> &'static [&'static dyn Decoder] {
    DECODERS
}

/// The decoder for a schema name and message encoding.
pub fn find(schema_name: &str, message_encoding: &str) -> Option<&'static dyn Decoder> {
    DECODERS
        .iter()
        .copied()
        .find(|d| d.schema_name() == schema_name && d.message_encoding() == message_encoding)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::all_kinds;

    #[test]
    fn every_contract_kind_has_a_json_decoder() {
        for kind in all_kinds() {
            let d = find(kind.schema_name(), "json")
                .unwrap_or_else(|| panic!("{}", kind.schema_name()));
            assert_eq!(d.new_samples().properties(), kind.properties());
        }
        assert_eq!(decoders().len(), all_kinds().len());
    }
}
