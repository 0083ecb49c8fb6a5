//! Bad input gets a typed error naming what and where, or a counted warning; never a panic.

use crate::common;
use hindsight::contract::Streams;

use hindsight::contract::{Imu, Message};
use hindsight::ingest::{read_log_from, Ending, IngestError, IngestOptions};
use hindsight::sim::writer::{to_bytes, Compression, WriterOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const T0: i64 = 1_700_000_000_000_000_000;

fn read(bytes: &[u8], options: &IngestOptions) -> Result<hindsight::ingest::Log, IngestError> {
    read_log_from(bytes, options)
}

fn strict() -> IngestOptions {
    IngestOptions {
        max_invalid_fraction: 0.0,
        ..IngestOptions::default()
    }
}

/// 99 good IMU messages and, at index 50, `bad` raw JSON on /imu.
fn log_with_bad_imu(bad: &str) -> Vec<u8> {
    to_bytes(WriterOptions::default(), |w| {
        for i in 0..100i64 {
            let t = T0 + i * 10_000_000;
            if i == 50 {
                w.write_raw(
                    "/imu",
                    Imu::SCHEMA_NAME,
                    Imu::SCHEMA_JSON,
                    "json",
                    bad.as_bytes(),
                    t as u64,
                )?;
            } else {
                let m = Imu {
                    stamp_ns: t,
                    angular_velocity: [0.0; 3],
                    specific_force: [0.0, 0.0, -9.8],
                };
                w.write("/imu", &m, t as u64)?;
            }
        }
        Ok(())
    })
    .unwrap()
}

#[test]
fn empty_file() {
    assert!(matches!(
        read(b"", &IngestOptions::default()),
        Err(IngestError::Empty)
    ));
}

#[test]
fn non_mcap_files_are_named_by_their_first_bytes() {
    let cases: [&[u8]; 4] = [
        b"time,depth\n0,1.5\n",
        b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR",
        b"PAR1\x15\x04\x15",
        b"{\"stamp_ns\": 1}",
    ];
    for bytes in cases {
        match read(bytes, &IngestOptions::default()) {
            Err(e @ IngestError::NotMcap { .. }) => {
                let text = e.to_string();
                assert!(text.starts_with("not an MCAP file"), "{text}");
                assert!(!text.contains('\n'));
            }
            other => panic!("{:?}: {other:?}", String::from_utf8_lossy(bytes)),
        }
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for round in 0..300 {
        let len = rng.random_range(0..4096);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.random()).collect();
        if round % 2 == 1 {
            // Valid magic, then garbage: exercises the record decoder.
            bytes.splice(0..0, mcap::MAGIC.iter().copied());
        }
        let result = read(&bytes, &IngestOptions::default());
        if round % 2 == 0 && !bytes.is_empty() && bytes[0] != mcap::MAGIC[0] {
            assert!(
                matches!(result, Err(IngestError::NotMcap { .. })),
                "round {round}"
            );
        }
    }
}

#[test]
fn corrupted_logs_never_panic() {
    use hindsight::ingest::ros::map::Convention;
    use hindsight::ingest::ros::msg::Dialect;
    use hindsight::sim::ros::write_standard_streams;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (chunked, compression) in [
        (true, Compression::Zstd),
        (true, Compression::Lz4),
        (true, Compression::None),
        (false, Compression::None),
    ] {
        let options = WriterOptions {
            chunked,
            compression,
            summary: true,
            chunk_size: 8 * 1024,
        };
        let json = common::survey_bytes(options, 3.0);
        // The same log as a ROS 2 recording (cdr, REP-103) and as ROS 1 messages in MCAP,
        // flipped the same way.
        let log = read(&json, &IngestOptions::default()).unwrap();
        let as_ros = |dialect| {
            to_bytes(options, |w| {
                let settings = Default::default();
                write_standard_streams(&log, dialect, Convention::Rep103, &settings, w).map(|_| ())
            })
            .unwrap()
        };
        let (cdr, ros1) = (as_ros(Dialect::Ros2), as_ros(Dialect::Ros1));
        for (bytes, encoding) in [(&cdr, "cdr"), (&ros1, "ros1")] {
            let back = read(bytes, &IngestOptions::default()).unwrap();
            assert_eq!(back.streams[0].message_encoding, encoding);
            assert_eq!(Streams::of(&back).imu, Streams::of(&log).imu);
            // TwistWithCovarianceStamped carries no altitude.
            let velocities = |l: &hindsight::ingest::Log| -> Vec<_> {
                Streams::of(l)
                    .dvl
                    .iter()
                    .map(|d| (d.stamp_ns, d.velocity, d.valid))
                    .collect()
            };
            assert_eq!(velocities(&back), velocities(&log));
        }
        for (_, good) in (0..300).zip([&json, &cdr, &ros1].into_iter().cycle()) {
            let mut bytes = good.clone();
            for _ in 0..rng.random_range(1..4) {
                let i = rng.random_range(8..bytes.len());
                bytes[i] ^= 1 << rng.random_range(0..8);
            }
            // Any outcome but a panic is acceptable; errors must be one line.
            if let Err(e) = read(
                &bytes,
                &IngestOptions {
                    max_invalid_fraction: 1.0,
                    skip_unknown: true,
                    ..IngestOptions::default()
                },
            ) {
                assert!(!e.to_string().contains('\n'), "{e}");
            }
        }
    }
}

#[test]
fn truncated_file_is_a_warning_not_an_error() {
    let full = common::survey_bytes(WriterOptions::default(), 5.0);
    let log = read(&full[..full.len() * 2 / 3], &IngestOptions::default()).unwrap();
    assert!(matches!(log.file.ending, Ending::Truncated { .. }));
    let w = log.warnings();
    assert!(
        w[0].starts_with("the log is cut short (no footer): recovered"),
        "{w:?}"
    );
    // A file holding only part of the magic is a truncated MCAP with nothing in it.
    let log = read(&mcap::MAGIC[..5], &IngestOptions::default()).unwrap();
    assert_eq!(log.message_count(), 0);
}

#[test]
fn unknown_schema_names_the_topic_unless_skipped() {
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_raw("/sonar", "acme.SidescanPing", "{}", "json", b"{\"x\":1}", 5)?;
        let m = Imu {
            stamp_ns: T0,
            angular_velocity: [0.0; 3],
            specific_force: [0.0; 3],
        };
        w.write("/imu", &m, 6)
    })
    .unwrap();
    let e = read(&bytes, &IngestOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, IngestError::UnknownSchema { .. }));
    assert!(
        text.contains("/sonar") && text.contains("acme.SidescanPing"),
        "{text}"
    );
    // The library says what is wrong; the command adds which flag gets past it.
    let dir = std::env::temp_dir().join(format!("hindsight-unknown-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sonar.mcap");
    std::fs::write(&path, &bytes).unwrap();
    let out = common::hindsight(&["export", path.to_str().unwrap(), "--out"])
        .status
        .code();
    assert_eq!(out, Some(2), "export without --out is a usage error");
    let run = common::hindsight(&[
        "export",
        path.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let said = common::stderr(&run);
    assert_eq!(run.status.code(), Some(3), "{said}");
    assert!(
        said.contains("acme.SidescanPing") && said.contains("hint: pass --skip-unknown"),
        "{said}"
    );
    std::fs::remove_dir_all(&dir).ok();

    let log = read(
        &bytes,
        &IngestOptions {
            skip_unknown: true,
            ..IngestOptions::default()
        },
    )
    .unwrap();
    assert_eq!(log.skipped.len(), 1);
    assert_eq!(log.skipped[0].messages, 1);
    assert_eq!(log.messages::<Imu>("/imu").unwrap().len(), 1);

    // A known schema in an encoding without a decoder is unknown too.
    let bytes = to_bytes(WriterOptions::default(), |w| {
        w.write_raw("/imu", Imu::SCHEMA_NAME, "", "cdr", &[0, 1, 0, 0], 5)
    })
    .unwrap();
    let text = read(&bytes, &IngestOptions::default())
        .unwrap_err()
        .to_string();
    assert!(text.contains("encoding `cdr`"), "{text}");
}

/// (raw message, field the error must name, words the reason must contain)
const BAD_MESSAGES: &[(&str, &str, &str)] = &[
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[0,0,0]}"#,
        "specific_force",
        "missing field",
    ),
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[NaN,0,0],"specific_force":[0,0,0]}"#,
        "angular_velocity[0]",
        "expected",
    ),
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[0,0,0],"specific_force":[0,Infinity,0]}"#,
        "specific_force[1]",
        "expected",
    ),
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[0,"fast",0],"specific_force":[0,0,0]}"#,
        "angular_velocity[1]",
        "invalid type",
    ),
    (
        r#"{"stamp_ns":"1700000000500000000","angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
        "stamp_ns",
        "invalid type",
    ),
    (
        r#"{"stamp_ns":-1000000000,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
        "stamp_ns",
        "1969-12-31",
    ),
    (
        r#"{"stamp_ns":4200000000000000000,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
        "stamp_ns",
        "outside 1970-01-01..2100-01-01",
    ),
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[0,0,0],"specific_force":[0,0,1e400]}"#,
        "specific_force[2]",
        "out of range",
    ),
    (
        r#"{"stamp_ns":1700000000500000000,"angular_velocity":[0,0,573],"specific_force":[0,0,0]}"#,
        "angular_velocity[2]",
        "plausible range",
    ),
    (r#"not json at all"#, "(message)", "expected"),
];

#[test]
fn each_bad_message_is_counted_with_topic_time_and_field() {
    for &(raw, field, words) in BAD_MESSAGES {
        let bytes = log_with_bad_imu(raw);
        // Default policy (1 % per topic): dropped, counted, reported.
        let log = read(&bytes, &IngestOptions::default()).unwrap();
        let s = log.stream("/imu").unwrap();
        assert_eq!(
            (s.counts.received, s.counts.invalid, s.samples.len()),
            (100, 1, 99),
            "{raw}"
        );
        let issue = &s.issues[0];
        assert_eq!(issue.field, field, "{raw}");
        assert!(issue.reason.contains(words), "{raw}: {}", issue.reason);
        assert_eq!(issue.log_time_ns, (T0 + 50 * 10_000_000) as u64);
        let warning = log.warnings().join("\n");
        assert!(
            warning.contains("/imu: dropped 1 invalid of 100 messages"),
            "{warning}"
        );
        assert!(warning.contains("2023-11-14T22:13:20.500Z"), "{warning}");

        // Strict policy: an error naming topic, log time and field, on one line.
        let e = read(&bytes, &strict()).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, IngestError::TooManyInvalid { .. }));
        assert!(
            text.starts_with("topic /imu at log time 2023-11-14T22:13:20.500Z"),
            "{text}"
        );
        assert!(text.contains(&format!("field `{field}`")), "{text}");
        assert!(!text.contains('\n'), "{text}");
    }
}

/// The fixture a bag test flips and cuts (written by `rosbags`; see tests/foreign_bags.rs).
fn bag_fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/bags")
        .join(name)
}

#[test]
fn corrupted_and_cut_ros1_bags_never_panic() {
    let good = std::fs::read(bag_fixture("pool_noetic_native.bag")).unwrap();
    let whole = read(&good, &IngestOptions::default()).unwrap();
    assert_eq!(whole.file.ending, Ending::Complete);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let lenient = IngestOptions {
        max_invalid_fraction: 1.0,
        skip_unknown: true,
        ..IngestOptions::default()
    };
    for _ in 0..60 {
        let mut bytes = good.clone();
        for _ in 0..rng.random_range(1..4) {
            let i = rng.random_range(13..bytes.len());
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        if let Err(e) = read(&bytes, &lenient) {
            assert!(!e.to_string().contains('\n'), "{e}");
        }
    }
    // Cut anywhere: the whole chunks before the cut are read, and the bag is reported cut
    // short (its header's index position is set only when it is closed, and the index is
    // at the end).
    let counts: Vec<u64> = (1..=20)
        .map(|k| {
            let cut = good.len() * k / 21;
            let log = read(&good[..cut], &IngestOptions::default()).unwrap();
            let cut_short = matches!(log.file.ending, Ending::Truncated { .. });
            assert!(cut_short || k == 20, "cut at {cut}");
            log.message_count()
        })
        .collect();
    assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{counts:?}");
    assert_eq!(counts[0], 0, "inside the first chunk");
    assert!(
        counts.iter().any(|&c| c > 0 && c < whole.message_count()),
        "{counts:?}"
    );
}

#[test]
fn corrupted_sqlite_bags_never_panic() {
    let dir = common::scratch_dir("bad-sqlite");
    let good = std::fs::read(bag_fixture("pool_jazzy_native/pool_jazzy_native.db3")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for round in 0..30 {
        let mut bytes = good.clone();
        for _ in 0..rng.random_range(1..8) {
            let i = rng.random_range(0..bytes.len());
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        // Some rounds also cut the file.
        if round % 3 == 0 {
            bytes.truncate(rng.random_range(0..bytes.len()));
        }
        let path = dir.join(format!("flipped-{round}.db3"));
        std::fs::write(&path, &bytes).unwrap();
        let options = IngestOptions {
            max_invalid_fraction: 1.0,
            skip_unknown: true,
            ..IngestOptions::default()
        };
        if let Err(e) = hindsight::ingest::read_log(&path, &options) {
            assert!(!e.to_string().contains('\n'), "{e}");
        }
    }
    // A folder without a database says so.
    let empty = dir.join("empty-bag");
    std::fs::create_dir_all(&empty).unwrap();
    let e = hindsight::ingest::read_log(&empty, &IngestOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no .db3 file"), "{e}");
}
