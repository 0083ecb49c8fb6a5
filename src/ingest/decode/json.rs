//! The `json` message encoding: one serde-derived decoder per contract type.

use super::Decoder;
use crate::contract::{FieldIssue, Message};
use crate::ingest::samples::Samples;
use std::marker::PhantomData;

/// Decodes JSON messages of type `T` and validates them.
pub struct JsonDecoder<T>(PhantomData<fn() -> T>);

impl<T> JsonDecoder<T> {
    /// The decoder of `T` (a constant, usable in statics).
    pub const NEW: Self = JsonDecoder(PhantomData);
}

impl<T: Message> Decoder for JsonDecoder<T> {
    fn schema_name(&self) -> &str {
        T::SCHEMA_NAME
    }
    fn message_encoding(&self) -> &str {
        "json"
    }
    fn new_samples(&self) -> Box<dyn Samples> {
        Box::new(Vec::<T>::new())
    }
    fn decode_into(&self, data: &[u8], out: &mut dyn Samples) -> Result<(), FieldIssue> {
        super::push_validated(out, decode::<T>(data)?)
    }
}

/// Parses one JSON message: the flat fast path when the message has the plain shape, serde
/// otherwise; a failing message is parsed once more to name the field at fault.
pub fn decode<T: Message>(data: &[u8]) -> Result<T, FieldIssue> {
    if let Some(msg) = super::flat_json::parse::<T>(data) {
        return Ok(msg);
    }
    serde_json::from_slice::<T>(data).map_err(|_| explain::<T>(data))
}

fn explain<T: Message>(data: &[u8]) -> FieldIssue {
    let de = &mut serde_json::Deserializer::from_slice(data);
    match serde_path_to_error::deserialize::<_, T>(de) {
        Ok(_) => FieldIssue::new("", "message decoded only on the second attempt"),
        Err(err) => {
            let path = err.path().to_string();
            let inner = err.into_inner();
            let reason = without_position(&inner);
            // serde names a missing field in the message, not the path.
            let field = match reason.strip_prefix("missing field `") {
                Some(rest) => rest.split('`').next().unwrap_or(rest).to_string(),
                None if path == "." => "(message)".to_string(),
                None => path,
            };
            FieldIssue::new(field, reason)
        }
    }
}

/// serde_json's text without " at line L column C" (the message is one line of JSON; the
/// field path says where).
fn without_position(err: &serde_json::Error) -> String {
    let text = err.to_string();
    match text.rfind(" at line ") {
        Some(i) => format!("{} (byte {})", &text[..i], err.column()),
        None => text,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{Dvl, Imu, PositionFix};

    #[test]
    fn decodes_a_valid_message() {
        let m: Imu = decode(
            br#"{"stamp_ns":5,"angular_velocity":[1,2,3],"specific_force":[0,0,-9.8],"extra":1}"#,
        )
        .unwrap();
        assert_eq!(m.angular_velocity, [1.0, 2.0, 3.0]);
    }

    #[test]
    fn names_missing_field() {
        let e = decode::<Imu>(br#"{"stamp_ns":5,"angular_velocity":[1,2,3]}"#).unwrap_err();
        assert_eq!(e.field, "specific_force");
        assert!(e.reason.contains("missing field"), "{e}");
    }

    #[test]
    fn names_wrong_type_with_path() {
        let e = decode::<Imu>(
            br#"{"stamp_ns":5,"angular_velocity":[1,"a",3],"specific_force":[0,0,0]}"#,
        )
        .unwrap_err();
        assert_eq!(e.field, "angular_velocity[1]");
        assert!(e.reason.contains("invalid type"), "{e}");
    }

    #[test]
    fn rejects_nan_token_and_float_stamp() {
        let e = decode::<Imu>(
            br#"{"stamp_ns":5,"angular_velocity":[NaN,0,0],"specific_force":[0,0,0]}"#,
        )
        .unwrap_err();
        assert_eq!(e.field, "angular_velocity[0]");
        let e = decode::<Imu>(
            br#"{"stamp_ns":1.5e18,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
        )
        .unwrap_err();
        assert_eq!(e.field, "stamp_ns");
    }

    #[test]
    fn wrong_vector_length_is_named() {
        let e =
            decode::<Imu>(br#"{"stamp_ns":5,"angular_velocity":[0,0],"specific_force":[0,0,0]}"#)
                .unwrap_err();
        assert_eq!(e.field, "angular_velocity");
    }

    #[test]
    fn nullable_fields_accept_null_or_absence() {
        let d: Dvl =
            decode(br#"{"stamp_ns":5,"velocity":[1,0,0],"valid":false,"altitude":null}"#).unwrap();
        assert_eq!(d.altitude, None);
        let d: Dvl = decode(br#"{"stamp_ns":5,"velocity":[1,0,0],"valid":true}"#).unwrap();
        assert_eq!(d.altitude, None);
        let p: PositionFix = decode(
            br#"{"stamp_ns":5,"north_m":1,"east_m":2,"down_m":null,"sigma_m":0.1,"label":"start"}"#,
        )
        .unwrap();
        assert_eq!(p.down_m, None);
    }

    #[test]
    fn not_json_is_reported() {
        let e = decode::<Imu>(b"\xff\x00garbage").unwrap_err();
        assert!(!e.reason.is_empty());
    }
}
