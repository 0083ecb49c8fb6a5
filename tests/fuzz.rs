//! Fuzzed parsers: structured mutations of valid input, not only bit flips. Each parser gets
//! [`cases`] cases (10 000 in CI; `HINDSIGHT_FUZZ_CASES=200000 cargo test --release --test all
//! fuzz:: -- --nocapture` for a longer run), each drawn from its own seed so that a failure
//! names the seed that reproduces it. The property: reading never panics. A mutated log may
//! read, or fail with a typed error; either is fine.
//!
//! - JSON messages: fields replaced by other types, extreme and malformed numbers, dropped,
//!   renamed and added keys, vectors of the wrong length, deep nesting, text cut short,
//!   stray bytes (invalid UTF-8 among them).
//! - ROS 2 (cdr) and ROS 1 messages in MCAP: length and count prefixes set to extremes,
//!   payloads cut and extended, the encapsulation header changed, and the message
//!   definitions the decoding plans are built from edited (types, arrays, lines).
//! - The MCAP container: record opcodes and lengths, a chunk's sizes and compression,
//!   records dropped, repeated and cut.
//! - ROS 1 bags: record header and data lengths, header fields and their lengths, the op,
//!   a chunk's compression and size, records dropped, repeated and cut.

use hindsight::ingest::ros::map::{Convention, RosSettings};
use hindsight::ingest::{read_log_from, IngestOptions};
use hindsight::sim::synthetic::{write_survey, SurveySpec};
use hindsight::sim::writer::{to_bytes, Compression, WriterOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Cases per parser.
fn cases() -> u64 {
    std::env::var("HINDSIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000)
}

fn options() -> IngestOptions {
    IngestOptions {
        decode_threads: 1,
        ..IngestOptions::default()
    }
}

/// Runs `case` for every seed of the parser `name`; a panic fails with the seed that
/// reproduces it. Returns how many of the cases read (the rest were refused with an error).
fn fuzz(name: &str, mut case: impl FnMut(&mut ChaCha8Rng) -> Vec<u8>) -> u64 {
    let mut read = 0;
    let n = cases();
    for seed in 0..n {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let bytes = case(&mut rng);
        let outcome = catch_unwind(AssertUnwindSafe(|| read_log_from(&bytes[..], &options())));
        match outcome {
            Ok(Ok(_)) => read += 1,
            Ok(Err(_)) => {}
            Err(_) => panic!("{name}: case seed {seed} panicked ({} bytes)", bytes.len()),
        }
    }
    println!(
        "{name}: {n} cases, {read} read, {} refused, none panicked",
        n - read
    );
    read
}

/// A message of a log: its topic, schema (name, encoding, text), encoding and bytes.
#[derive(Clone)]
struct Seed {
    topic: String,
    schema_name: String,
    schema_text: String,
    encoding: String,
    data: Vec<u8>,
}

/// The first `per_channel` messages of each channel of an MCAP file.
fn seeds(path: &str, per_channel: usize) -> Vec<Seed> {
    let bytes = std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path))
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut count = std::collections::HashMap::new();
    let mut out = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let n = count.entry(m.channel.id).or_insert(0);
        if *n >= per_channel {
            continue;
        }
        *n += 1;
        let schema = m.channel.schema.as_ref().expect("a schema");
        out.push(Seed {
            topic: m.channel.topic.clone(),
            schema_name: schema.name.clone(),
            schema_text: String::from_utf8_lossy(&schema.data).into_owned(),
            encoding: m.channel.message_encoding.clone(),
            data: m.data.into_owned(),
        });
    }
    assert!(!out.is_empty(), "{path}: no messages");
    out
}

/// A one-message log of `seed` with its data and schema text as given (unchunked: the
/// container is not what these cases try, and a compressor per case would cost most of it).
fn log_of(seed: &Seed, schema_text: &str, data: &[u8]) -> Vec<u8> {
    let options = WriterOptions {
        chunked: false,
        ..WriterOptions::default()
    };
    to_bytes(options, |w| {
        w.write_raw(
            &seed.topic,
            &seed.schema_name,
            schema_text,
            &seed.encoding,
            data,
            1_700_000_000_000_000_000,
        )
    })
    .expect("in-memory write")
}

fn pick<'a, T>(rng: &mut ChaCha8Rng, items: &'a [T]) -> &'a T {
    &items[rng.random_range(0..items.len())]
}

// ---- JSON ----------------------------------------------------------------------------

/// A value of another kind than the field's, or an extreme one.
fn odd_value(rng: &mut ChaCha8Rng) -> Value {
    let deep = (0..rng.random_range(1..200)).fold(Value::from(1), |v, _| Value::Array(vec![v]));
    match rng.random_range(0..14) {
        0 => Value::Null,
        1 => Value::Bool(rng.random()),
        2 => Value::from(-1),
        3 => Value::from(u64::MAX),
        4 => Value::from(i64::MIN),
        5 => Value::from(1e308),
        6 => Value::from(-5e-324),
        7 => Value::from("NaN"),
        8 => Value::from(""),
        9 => Value::from("x".repeat(rng.random_range(0..5000))),
        10 => Value::Array(vec![]),
        11 => Value::Array((0..rng.random_range(1..6)).map(Value::from).collect()),
        12 => deep,
        _ => Value::Object(Default::default()),
    }
}

/// One structural change to a JSON value: a field replaced, dropped, renamed or added, or a
/// vector's length changed; applied at a random depth.
fn mutate_value(v: &mut Value, rng: &mut ChaCha8Rng) {
    match v {
        Value::Object(map) if !map.is_empty() => {
            let keys: Vec<String> = map.keys().cloned().collect();
            let key = pick(rng, &keys).clone();
            match rng.random_range(0..6) {
                0 => {
                    map.remove(&key);
                }
                1 => {
                    let x = map.remove(&key).unwrap();
                    map.insert(format!("{key}_"), x);
                }
                2 => {
                    map.insert("unknown_field".into(), odd_value(rng));
                }
                3 | 4 => mutate_value(map.get_mut(&key).unwrap(), rng),
                _ => {
                    map.insert(key, odd_value(rng));
                }
            }
        }
        Value::Array(items) if !items.is_empty() && rng.random_bool(0.7) => {
            match rng.random_range(0..3) {
                0 => {
                    items.pop();
                }
                1 => items.push(odd_value(rng)),
                _ => {
                    let i = rng.random_range(0..items.len());
                    mutate_value(&mut items[i], rng);
                }
            }
        }
        _ => *v = odd_value(rng),
    }
}

/// Text-level damage that a value cannot express: cut short, stray bytes, malformed numbers.
fn damage_text(mut text: Vec<u8>, rng: &mut ChaCha8Rng) -> Vec<u8> {
    match rng.random_range(0..5) {
        0 => text.truncate(rng.random_range(0..=text.len())),
        1 => {
            let at = rng.random_range(0..=text.len());
            let stray = *pick(rng, &[0xff, 0xc3, 0x00, b'"', b'\\', b'{', b']', 0xe2]);
            text.insert(at, stray);
        }
        2 => {
            // A number as JSON does not write it.
            let odd = pick(
                rng,
                &["1e999", "-0", "0x10", "1.", ".5", "+1", "01", "1e", "--1"],
            );
            let s = String::from_utf8_lossy(&text).into_owned();
            let digits: Vec<usize> = s
                .char_indices()
                .filter(|(_, c)| c.is_ascii_digit())
                .map(|(i, _)| i)
                .collect();
            if let Some(&at) = digits.get(rng.random_range(0..digits.len().max(1))) {
                let mut s = s;
                s.replace_range(at..at + 1, odd);
                text = s.into_bytes();
            }
        }
        3 => {
            // A key given twice.
            let s = String::from_utf8_lossy(&text).into_owned();
            if let Some(at) = s.find(',') {
                let mut s = s;
                s.insert_str(at + 1, "\"stamp_ns\":1,");
                text = s.into_bytes();
            }
        }
        _ => {}
    }
    text
}

#[test]
fn json_messages_never_panic_the_reader() {
    let seeds = seeds("sample-logs/survey-short-seed1.mcap", 2);
    let read = fuzz("json", |rng| {
        let seed = pick(rng, &seeds);
        let mut value: Value = serde_json::from_slice(&seed.data).unwrap();
        for _ in 0..rng.random_range(1..4) {
            mutate_value(&mut value, rng);
        }
        let text = damage_text(serde_json::to_vec(&value).unwrap(), rng);
        log_of(seed, &seed.schema_text, &text)
    });
    // The mutations keep some messages readable (an unknown field, a dropped optional one):
    // the harness reaches past the first check.
    assert!(read > 0);
}

// ---- ROS messages (cdr, ros1) ----------------------------------------------------------

/// One structural change to a ROS message's bytes: a length or count prefix (any aligned
/// 4-byte word) set to an extreme, the payload cut or extended, the cdr encapsulation header
/// changed.
fn mutate_ros_bytes(data: &mut Vec<u8>, rng: &mut ChaCha8Rng) {
    match rng.random_range(0..4) {
        0 | 1 if data.len() >= 4 => {
            let words = data.len() / 4;
            let at = rng.random_range(0..words) * 4;
            let len = data.len() as u32;
            let value = *pick(
                rng,
                &[0, 1, 3, len, len + 1, 0x7fff_ffff, u32::MAX, 1 << 20],
            );
            data[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
        2 => data.truncate(rng.random_range(0..=data.len())),
        3 if data.len() >= 2 => data[1] = *pick(rng, &[0, 1, 2, 3, 0x10, 0xff]),
        _ => data.extend((0..rng.random_range(1..64)).map(|_| rng.random::<u8>())),
    }
}

/// One edit of a message definition: a line dropped or repeated, a field's type changed, an
/// array made of it, a field of an unknown type added.
fn mutate_definition(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return "int32 x".into();
    }
    let i = rng.random_range(0..lines.len());
    match rng.random_range(0..5) {
        0 => {
            lines.remove(i);
        }
        1 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        2 => {
            let types = [
                "uint8", "int32", "float64", "string", "bool", "time", "duration", "char",
            ];
            let mut words: Vec<String> = lines[i].split_whitespace().map(str::to_string).collect();
            if let Some(w) = words.first_mut() {
                *w = pick(rng, &types).to_string();
            }
            lines[i] = words.join(" ");
        }
        3 => {
            let suffix = *pick(rng, &["[]", "[3]", "[0]", "[4294967295]", "[<=2]"]);
            if let Some(sp) = lines[i].find(' ') {
                lines[i].insert_str(sp, suffix);
            }
        }
        _ => lines.insert(i, "acme_msgs/Unknown extra".into()),
    }
    lines.join("\n")
}

fn fuzz_ros(name: &str, seeds: &[Seed]) {
    fuzz(name, |rng| {
        let seed = pick(rng, seeds);
        let mut data = seed.data.clone();
        let mut schema = seed.schema_text.clone();
        for _ in 0..rng.random_range(1..4) {
            if rng.random_bool(0.2) {
                schema = mutate_definition(&schema, rng);
            } else {
                mutate_ros_bytes(&mut data, rng);
            }
        }
        log_of(seed, &schema, &data)
    });
}

#[test]
fn ros2_cdr_messages_never_panic_the_reader() {
    fuzz_ros(
        "cdr",
        &seeds("tests/fixtures/ros2/survey_humble_rep103.mcap", 2),
    );
}

#[test]
fn ros1_messages_never_panic_the_reader() {
    fuzz_ros(
        "ros1",
        &seeds("tests/fixtures/bags/survey_ros1_native.mcap", 2),
    );
}

// ---- containers ------------------------------------------------------------------------

/// A short valid log: a few seconds of the synthetic survey.
fn short_log(options: WriterOptions) -> Vec<u8> {
    let spec = SurveySpec {
        duration_s: 3.0,
        seed: 5,
        ..SurveySpec::default()
    };
    to_bytes(options, |w| write_survey(w, &spec)).expect("in-memory write")
}

/// Where an MCAP file's records start (after the magic): `(offset, opcode, length)`.
fn mcap_records(bytes: &[u8]) -> Vec<(usize, u8, u64)> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let op = bytes[at];
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
        out.push((at, op, len));
        let Some(next) = (at + 9).checked_add(len as usize) else {
            break;
        };
        at = next;
    }
    out
}

fn extreme_u64(rng: &mut ChaCha8Rng, near: u64) -> u64 {
    *pick(
        rng,
        &[
            0,
            1,
            near.saturating_sub(1),
            near + 1,
            near * 2,
            u64::MAX,
            u64::MAX / 2,
            1 << 40,
        ],
    )
}

/// One structural change to an MCAP file.
fn mutate_mcap(bytes: &mut Vec<u8>, rng: &mut ChaCha8Rng) {
    let records = mcap_records(bytes);
    if records.is_empty() {
        // Cut before its first record: what is left grows by stray bytes.
        bytes.extend((0..rng.random_range(1..32)).map(|_| rng.random::<u8>()));
        return;
    }
    let &(at, op, len) = pick(rng, &records);
    let end = (at + 9 + len as usize).min(bytes.len());
    match rng.random_range(0..7) {
        0 => {
            let v = extreme_u64(rng, len);
            bytes[at + 1..at + 9].copy_from_slice(&v.to_le_bytes());
        }
        1 => bytes[at] = rng.random(),
        2 => {
            bytes.drain(at..end);
        }
        3 => {
            let copy = bytes[at..end].to_vec();
            bytes.splice(end..end, copy);
        }
        4 => bytes.truncate((at + rng.random_range(0..20)).min(bytes.len())),
        // A chunk (op 6): start, end, uncompressed size, crc, then the compression's name.
        5 | 6 if op == 6 && end >= at + 9 + 32 => {
            let body = at + 9;
            if rng.random_bool(0.5) {
                let v = extreme_u64(rng, 1000);
                bytes[body + 16..body + 24].copy_from_slice(&v.to_le_bytes());
            } else {
                let name_len = u32::from_le_bytes(bytes[body + 28..body + 32].try_into().unwrap());
                let names: [&[u8]; 5] = [b"", b"lz4", b"zstd", b"gzip", b"zst"];
                let name = *pick(rng, &names);
                let stop = (body + 32 + name_len as usize).min(bytes.len());
                let mut field = (name.len() as u32).to_le_bytes().to_vec();
                field.extend_from_slice(name);
                bytes.splice(body + 28..stop, field);
            }
        }
        _ if !bytes.is_empty() => {
            let at = rng.random_range(0..bytes.len());
            bytes[at] = rng.random();
        }
        _ => {}
    }
}

#[test]
fn mcap_containers_never_panic_the_reader() {
    let originals = [
        short_log(WriterOptions::default()),
        short_log(WriterOptions {
            compression: Compression::Lz4,
            chunk_size: 4096,
            ..WriterOptions::default()
        }),
        short_log(WriterOptions {
            chunked: false,
            ..WriterOptions::default()
        }),
    ];
    for o in &originals {
        assert!(mcap_records(o).len() > 5);
        read_log_from(&o[..], &options()).expect("the original reads");
    }
    fuzz("mcap", |rng| {
        let mut bytes = pick(rng, &originals).clone();
        for _ in 0..rng.random_range(1..4) {
            mutate_mcap(&mut bytes, rng);
        }
        bytes
    });
}

/// Where a ROS 1 bag's records start (after its version line): `(offset, header length,
/// data length)`.
fn bag_records(bytes: &[u8]) -> Vec<(usize, u32, u32)> {
    let mut out = Vec::new();
    let mut at = b"#ROSBAG V2.0\n".len();
    while at + 4 <= bytes.len() {
        let header = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let data_at = at + 4 + header as usize;
        if data_at + 4 > bytes.len() {
            break;
        }
        let data = u32::from_le_bytes(bytes[data_at..data_at + 4].try_into().unwrap());
        out.push((at, header, data));
        at = data_at + 4 + data as usize;
    }
    out
}

/// One structural change to a ROS 1 bag.
fn mutate_bag(bytes: &mut Vec<u8>, rng: &mut ChaCha8Rng) {
    let records = bag_records(bytes);
    if records.is_empty() {
        bytes.extend((0..rng.random_range(1..32)).map(|_| rng.random::<u8>()));
        return;
    }
    let &(at, header, data) = pick(rng, &records);
    let data_at = at + 4 + header as usize;
    let end = (data_at + 4 + data as usize).min(bytes.len());
    let extreme = |rng: &mut ChaCha8Rng, near: u32| {
        *pick(
            rng,
            &[0, 1, near.saturating_sub(1), near + 1, u32::MAX, 1 << 30],
        )
    };
    match rng.random_range(0..7) {
        0 => {
            let v = extreme(rng, header);
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        1 => {
            let v = extreme(rng, data);
            bytes[data_at..data_at + 4].copy_from_slice(&v.to_le_bytes());
        }
        2 => {
            // A header field's own length, or its value's first byte (`op=`, `compression=`).
            let fields = at + 4;
            let mut f = fields;
            let mut starts = Vec::new();
            while f + 4 <= data_at {
                starts.push(f);
                let n = u32::from_le_bytes(bytes[f..f + 4].try_into().unwrap()) as usize;
                f += 4 + n;
            }
            if let Some(&s) = starts.get(rng.random_range(0..starts.len().max(1))) {
                if rng.random_bool(0.5) {
                    let n = u32::from_le_bytes(bytes[s..s + 4].try_into().unwrap());
                    let v = extreme(rng, n);
                    bytes[s..s + 4].copy_from_slice(&v.to_le_bytes());
                } else if let Some(eq) = bytes[s + 4..data_at].iter().position(|&b| b == b'=') {
                    let value = s + 4 + eq + 1;
                    if value < data_at {
                        bytes[value] = *pick(rng, &[0x01, 0x02, 0x03, 0x05, 0x06, 0x07, b'b']);
                    }
                }
            }
        }
        3 => {
            bytes.drain(at..end);
        }
        4 => {
            let copy = bytes[at..end].to_vec();
            bytes.splice(end..end, copy);
        }
        5 => bytes.truncate((at + rng.random_range(0..40)).min(bytes.len())),
        _ if !bytes.is_empty() => {
            let at = rng.random_range(0..bytes.len());
            bytes[at] = rng.random();
        }
        _ => {}
    }
}

#[test]
fn ros1_bags_never_panic_the_reader() {
    let log = read_log_from(&short_log(WriterOptions::default())[..], &options()).unwrap();
    let dir = std::env::temp_dir().join(format!("hindsight-fuzz-bag-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("short.bag");
    hindsight::sim::bag::write_ros1_bag(&log, Convention::Native, &RosSettings::default(), &path)
        .unwrap();
    let original = std::fs::read(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    assert!(bag_records(&original).len() > 3);
    read_log_from(&original[..], &options()).expect("the original reads");
    fuzz("ros1 bag", |rng| {
        let mut bytes = original.clone();
        for _ in 0..rng.random_range(1..4) {
            mutate_bag(&mut bytes, rng);
        }
        bytes
    });
}
