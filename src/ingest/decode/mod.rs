//! Decoders: bytes of one message encoding into one contract type, found by schema name.
//!
//! One decoder per (schema, message encoding): every contract schema has a JSON decoder
//! ([`json::JsonDecoder`]); a ROS 2 topic in `cdr` gets one built from the schema text the
//! file carries ([`crate::ingest::ros`]), one mapping per standard type.

mod flat_json;
pub mod json;

use super::samples::Samples;
use crate::contract::{messages::*, FieldIssue};
use json::JsonDecoder;

/// Decodes and validates messages of one schema in one encoding.
pub trait Decoder: Send + Sync {
    /// Schema name this decoder reads, e.g. `hindsight.Imu`.
    fn schema_name(&self) -> &str;
    /// MCAP message encoding, e.g. `json`.
    fn message_encoding(&self) -> &str;
    /// An empty store for this decoder's messages.
    fn new_samples(&self) -> Box<dyn Samples>;
    /// Decodes, validates and appends one message; on failure nothing is appended.
    fn decode_into(&self, data: &[u8], out: &mut dyn Samples) -> Result<(), FieldIssue>;
}

/// Validates a decoded message and appends it to its typed store.
pub fn push_validated<T: crate::contract::Message>(
    out: &mut dyn Samples,
    msg: T,
) -> Result<(), FieldIssue> {
    crate::contract::validate(&msg)?;
    out.as_any_mut()
        .downcast_mut::<Vec<T>>()
        .ok_or_else(|| FieldIssue::new("", "internal: sample store of the wrong type"))?
        .push(msg);
    Ok(())
}

macro_rules! json_decoders {
    ($($t:ident),*) => {
        static DECODERS: &[&dyn Decoder] = &[$(&JsonDecoder::<$t>::NEW),*];
    };
}
crate::for_each_message!(json_decoders);

/// A topic's decoder: a registered one, or one built from the topic's schema text.
pub enum TopicDecoder {
    Registered(&'static dyn Decoder),
    Built(Box<dyn Decoder>),
}

impl TopicDecoder {
    pub fn get(&self) -> &dyn Decoder {
        match self {
            TopicDecoder::Registered(d) => *d,
            TopicDecoder::Built(d) => d.as_ref(),
        }
    }
}

/// The decoder of a topic (`None`: no decoder reads it): a standard ROS type in `cdr`
/// (ROS 2) or `ros1` from its schema text, else the registered decoder of its schema name
/// and encoding.
pub fn for_topic(
    topic: &str,
    schema_name: &str,
    schema_text: &[u8],
    message_encoding: &str,
    options: &crate::ingest::IngestOptions,
) -> Result<Option<TopicDecoder>, crate::ingest::ros::decoder::RosSchemaError> {
    if let Some(dialect) = ros_dialect(message_encoding) {
        let text = String::from_utf8_lossy(schema_text);
        let convention = options.frame_conventions.get(topic).copied();
        use crate::ingest::ros::decoder::{RosDecoder, TopicRoles};
        let roles = TopicRoles {
            topic,
            named: &options.topics,
        };
        let built =
            RosDecoder::for_topic_in(dialect, schema_name, &text, roles, convention, options.ros2)?;
        // A type read only for a role the user names (an odometry as the reference) is
        // skipped on any other topic.
        let named = |role| options.topics.get(role).is_some_and(|t| t == topic);
        let wanted = |d: &crate::ingest::ros::decoder::RosDecoder| {
            d.ros_type().only_when_named_for().is_none_or(named)
        };
        return Ok(built
            .filter(wanted)
            .map(|d| TopicDecoder::Built(Box::new(d))));
    }
    Ok(find(schema_name, message_encoding).map(TopicDecoder::Registered))
}

/// The ROS whose messages a message encoding holds: `cdr` (ROS 2) or `ros1`.
pub fn ros_dialect(message_encoding: &str) -> Option<crate::ingest::ros::msg::Dialect> {
    use crate::ingest::ros::msg::Dialect;
    match message_encoding {
        "cdr" => Some(Dialect::Ros2),
        "ros1" => Some(Dialect::Ros1),
        _ => None,
    }
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
        assert_eq!(DECODERS.len(), all_kinds().len());
    }
}
