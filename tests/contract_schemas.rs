//! The JSON Schemas in schemas/ and the Rust message types agree, and the schemas validate
//! what the project writes and reject what the decoders reject.

use crate::common;
use hindsight::contract::*;
use hindsight::ingest::decode::json::decode;
use serde_json::{json, Value};

fn schema_of<T: Message>() -> Value {
    serde_json::from_str(T::SCHEMA_JSON).unwrap_or_else(|e| panic!("{}: {e}", T::SCHEMA_NAME))
}

fn expected_type(kind: PropKind) -> Value {
    match kind {
        PropKind::F64 => json!("number"),
        PropKind::Vec3 => json!("array"),
        PropKind::OptF64 => json!(["number", "null"]),
        PropKind::Bool => json!("boolean"),
        PropKind::Str => json!("string"),
    }
}

/// Structure: title, the property set and order, each property's JSON type, `required`.
fn check_structure<T: Message>() {
    let schema = schema_of::<T>();
    assert_eq!(schema["title"], T::SCHEMA_NAME);
    assert_eq!(schema["type"], "object");
    assert!(schema["description"]
        .as_str()
        .unwrap()
        .contains(T::DEFAULT_TOPIC));
    let props = schema["properties"].as_object().expect("properties");
    let names: Vec<&str> = props.keys().map(String::as_str).collect();
    let mut expected = vec!["stamp_ns"];
    expected.extend(T::PROPERTIES.iter().map(|p| p.name));
    let mut sorted_names = names.clone();
    sorted_names.sort();
    let mut sorted_expected = expected.clone();
    sorted_expected.sort();
    assert_eq!(sorted_names, sorted_expected, "{}", T::SCHEMA_NAME);
    assert_eq!(props["stamp_ns"]["type"], "integer");
    for p in T::PROPERTIES {
        let s = &props[p.name];
        assert_eq!(
            s["type"],
            expected_type(p.kind),
            "{}.{}",
            T::SCHEMA_NAME,
            p.name
        );
        if p.kind == PropKind::Vec3 {
            assert_eq!(s["items"]["type"], "number");
            assert_eq!(s["minItems"], 3);
            assert_eq!(s["maxItems"], 3);
        }
        if !p.unit.is_empty() {
            assert!(
                s["description"].as_str().unwrap_or("").contains(p.unit),
                "{}.{}: unit {} not in the schema's description",
                T::SCHEMA_NAME,
                p.name,
                p.unit
            );
        }
    }
    let required: Vec<&str> = schema["required"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    let mut expected_required = vec!["stamp_ns"];
    expected_required.extend(
        T::PROPERTIES
            .iter()
            .filter(|p| p.required())
            .map(|p| p.name),
    );
    assert_eq!(required, expected_required, "{}", T::SCHEMA_NAME);
}

/// Instances: a real message validates; each mutation is rejected by the schema and the
/// decoder alike; extra fields are accepted by both.
fn check_instances<T: Message>(example: &T) {
    let validator = jsonschema::validator_for(&schema_of::<T>()).expect("schema compiles");
    let good = serde_json::to_value(example).unwrap();
    assert!(validator.is_valid(&good), "{}: {good}", T::SCHEMA_NAME);
    for (i, p) in T::PROPERTIES.iter().enumerate() {
        assert_eq!(
            example.get(i).kind(),
            p.kind,
            "{}.{}: Rust type vs spec",
            T::SCHEMA_NAME,
            p.name
        );
    }

    let decoder_accepts = |v: &Value| decode::<T>(v.to_string().as_bytes()).is_ok();
    let mut mutations: Vec<(String, Value)> = Vec::new();
    for key in std::iter::once("stamp_ns").chain(T::PROPERTIES.iter().map(|p| p.name)) {
        let mut missing = good.clone();
        missing.as_object_mut().unwrap().remove(key);
        mutations.push((format!("without {key}"), missing));
        let is_string = T::PROPERTIES
            .iter()
            .any(|p| p.name == key && p.kind == PropKind::Str);
        let mut wrong = good.clone();
        wrong[key] = if is_string {
            json!(12.5)
        } else {
            json!("12.5")
        };
        mutations.push((format!("{key} of the wrong type"), wrong));
        let mut null = good.clone();
        null[key] = Value::Null;
        mutations.push((format!("{key} null"), null));
    }
    let mut float_stamp = good.clone();
    float_stamp["stamp_ns"] = json!(1_700_000_000.5);
    mutations.push(("fractional stamp".into(), float_stamp));
    // Stricter than the schema on purpose: a stamp written as a float (1.7e18) passes JSON
    // Schema's `integer` but has lost its nanoseconds (f64 holds 53 bits); the decoder refuses it.
    let mut float_form = good.clone();
    float_form["stamp_ns"] = json!(1.7e18);
    assert!(
        !decoder_accepts(&float_form),
        "{}: float-form stamp",
        T::SCHEMA_NAME
    );
    for (what, v) in &mutations {
        let nullable = T::PROPERTIES.iter().any(|p| {
            p.kind == PropKind::OptF64
                && (what == &format!("without {}", p.name) || what == &format!("{} null", p.name))
        });
        assert_eq!(
            validator.is_valid(v),
            nullable,
            "{} {what}: schema",
            T::SCHEMA_NAME
        );
        assert_eq!(
            decoder_accepts(v),
            nullable,
            "{} {what}: decoder",
            T::SCHEMA_NAME
        );
    }
    let mut extra = good.clone();
    extra["vendor_extra"] = json!({"a": 1});
    assert!(validator.is_valid(&extra));
    assert!(decoder_accepts(&extra));
}

fn first<T: Message>(log: &hindsight::ingest::Log) -> T {
    log.messages::<T>(T::DEFAULT_TOPIC)
        .and_then(|m| m.first())
        .cloned()
        .unwrap_or_else(|| panic!("synthetic log has {}", T::DEFAULT_TOPIC))
}

fn check<T: Message>(log: &hindsight::ingest::Log) {
    check_structure::<T>();
    check_instances::<T>(&first::<T>(log));
}

#[test]
fn schemas_and_rust_types_agree() {
    let log = common::read(&common::survey_bytes(Default::default(), 5.0));
    macro_rules! check_all {
        ($($t:ident),*) => { $( check::<$t>(&log); )* };
    }
    hindsight::for_each_message!(check_all);
    // Every schema file belongs to a kind.
    assert_eq!(all_kinds().len(), 16);
    let files: Vec<String> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/schemas"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".schema.json"))
        .collect();
    assert_eq!(files.len(), all_kinds().len());
    for f in files {
        let name = f.trim_end_matches(".schema.json");
        assert!(kind_by_schema(name).is_some(), "{f} has no Rust type");
    }
}

#[test]
fn every_written_log_embeds_the_schemas() {
    let bytes = common::survey_bytes(Default::default(), 2.0);
    let summary = mcap::Summary::read(&bytes).unwrap().expect("summary");
    assert_eq!(summary.schemas.len(), 16);
    for s in summary.schemas.values() {
        let kind = kind_by_schema(&s.name).expect("contract schema");
        assert_eq!(s.encoding, "jsonschema");
        assert_eq!(&s.data[..], kind.schema_json().as_bytes());
    }
}
