//! The `hindsight` binary: exit codes, one-line errors, atomic output, untouched input.

use crate::common;
use arrow_array::{Array, Float64Array, RecordBatch, TimestampNanosecondArray};
use common::{hindsight, stderr, SAMPLE};
use hindsight::contract::{Imu, Message};
use hindsight::sim::writer::{to_bytes, WriterOptions};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::{Path, PathBuf};

fn read_parquet(path: &Path) -> RecordBatch {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .with_batch_size(1 << 20)
        .build()
        .unwrap();
    let batches: Vec<RecordBatch> = reader.map(Result::unwrap).collect();
    assert_eq!(batches.len(), 1, "test files fit one batch");
    batches[0].clone()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn export_writes_typed_parquet_and_a_correct_aligned_table() {
    let out = common::scratch_dir("export");
    let before = std::fs::read(SAMPLE).unwrap();
    let o = hindsight(&["export", SAMPLE, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(SAMPLE).unwrap(), before, "input untouched");
    let names = files_in(&out);
    assert_eq!(names.len(), 10, "{names:?}");
    assert!(names.iter().all(|n| !n.contains(".tmp-")), "{names:?}");

    let imu = read_parquet(&out.join("imu.parquet"));
    let log = hindsight::ingest::read_log(Path::new(SAMPLE), &Default::default()).unwrap();
    let msgs = log.messages::<Imu>("/imu").unwrap();
    assert_eq!(imu.num_rows(), msgs.len());
    let schema = imu.schema();
    assert_eq!(
        schema.field_with_name("stamp_ns").unwrap().data_type(),
        &hindsight::output::tables::timestamp_type()
    );
    let columns: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    assert_eq!(
        columns,
        [
            "stamp_ns",
            "log_time_ns",
            "angular_velocity_x",
            "angular_velocity_y",
            "angular_velocity_z",
            "specific_force_x",
            "specific_force_y",
            "specific_force_z"
        ]
    );
    assert_eq!(
        schema
            .field_with_name("specific_force_z")
            .unwrap()
            .metadata()["unit"],
        "m/s^2"
    );
    let sz = common::column::<Float64Array>(&imu, "specific_force_z");
    assert_eq!(sz.value(123), msgs[123].specific_force[2]);

    // aligned.parquet: every row holds each stream's latest value at or before its time.
    let aligned = read_parquet(&out.join("aligned.parquet"));
    let clock = common::column::<TimestampNanosecondArray>(&aligned, "stamp_ns");
    let age = common::column::<Float64Array>(&aligned, "imu_age_s");
    let wz = common::column::<Float64Array>(&aligned, "imu_angular_velocity_z");
    assert!(aligned.num_rows() > 1000);
    for row in (0..aligned.num_rows()).step_by(37) {
        let t = clock.value(row);
        assert_eq!(t % 100_000_000, 0, "10 Hz grid on whole tenths");
        let (m, age_ns) = hindsight::align::latest_at(msgs, t).unwrap();
        assert_eq!(wz.value(row), m.angular_velocity[2]);
        assert!((age.value(row) - age_ns as f64 * 1e-9).abs() < 1e-12);
    }
    // Streams that start later are null (not zero) until their first message.
    let rpm_age = aligned.column_by_name("gnss_age_s").unwrap();
    assert_eq!(rpm_age.null_count(), 0, "gnss has a fix at the first stamp");
}

#[test]
fn clock_offset_shifts_one_topic() {
    let a = common::scratch_dir("offset-a");
    let b = common::scratch_dir("offset-b");
    assert!(hindsight(&["export", SAMPLE, "--out", a.to_str().unwrap()])
        .status
        .success());
    let o = hindsight(&[
        "export",
        SAMPLE,
        "--out",
        b.to_str().unwrap(),
        "--offset",
        "/dvl=-0.120",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stamp = |dir: &Path, f: &str| {
        let t = read_parquet(&dir.join(f));
        common::column::<TimestampNanosecondArray>(&t, "stamp_ns").value(3)
    };
    assert_eq!(
        stamp(&a, "dvl.parquet") - stamp(&b, "dvl.parquet"),
        120_000_000
    );
    assert_eq!(stamp(&a, "imu.parquet"), stamp(&b, "imu.parquet"));

    let o = hindsight(&["info", SAMPLE, "--offset", "/sonar=0.1"]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        stderr(&o).contains("topic /sonar: the log has no such topic (it has: /imu,"),
        "{}",
        stderr(&o)
    );
    let o = hindsight(&["info", SAMPLE, "--offset", "/dvl"]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "malformed offset is a usage error"
    );
}

#[test]
fn info_prints_the_table() {
    let o = hindsight(&["info", SAMPLE]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("mission: origin 35.1000000 deg N"), "{text}");
    let imu = text.lines().find(|l| l.starts_with("/imu ")).unwrap();
    let cells: Vec<&str> = imu.split_whitespace().collect();
    assert_eq!(
        &cells[..5],
        ["/imu", "hindsight.Imu", "json", "36276", "100.000"]
    );
    let dvl = text.lines().find(|l| l.starts_with("/dvl ")).unwrap();
    assert!(dvl.contains("5.000"), "{dvl}");
}

/// Bad inputs: (file name, bytes, extra args, expected exit code, words in the error)
fn bad_inputs(dir: &Path) -> Vec<(PathBuf, Vec<&'static str>, i32, Vec<&'static str>)> {
    let good = common::survey_bytes(WriterOptions::default(), 3.0);
    let bad_msg = |raw: &'static str| {
        to_bytes(WriterOptions::default(), |w| {
            w.write_raw(
                "/imu",
                Imu::SCHEMA_NAME,
                Imu::SCHEMA_JSON,
                "json",
                raw.as_bytes(),
                1_700_000_000_000_000_000,
            )
        })
        .unwrap()
    };
    let unknown = to_bytes(WriterOptions::default(), |w| {
        w.write_raw("/sonar", "acme.Ping", "{}", "json", b"{}", 1)
    })
    .unwrap();
    vec![
        (write(dir, "empty.mcap", b""), vec![], 3, vec!["empty"]),
        (
            write(
                dir,
                "random.mcap",
                &[0x17, 0xd2, 0x00, 0x9c, 0x44, 0x81, 0x3f, 0xee, 0x01],
            ),
            vec![],
            3,
            vec!["not an MCAP file"],
        ),
        (
            write(dir, "notes.csv", b"time,depth\n0,1\n"),
            vec![],
            3,
            vec!["not an MCAP file", "time,dep"],
        ),
        (
            dir.join("missing.mcap"),
            vec![],
            3,
            vec!["reading", "missing.mcap", "No such file"],
        ),
        (
            write(dir, "unknown.mcap", &unknown),
            vec![],
            3,
            vec!["/sonar", "acme.Ping", "--skip-unknown"],
        ),
        (
            write(
                dir,
                "missing-field.mcap",
                &bad_msg(r#"{"stamp_ns":1700000000000000000,"angular_velocity":[0,0,0]}"#),
            ),
            vec![],
            3,
            vec!["topic /imu at log time", "field `specific_force`"],
        ),
        (
            write(
                dir,
                "nan.mcap",
                &bad_msg(
                    r#"{"stamp_ns":1700000000000000000,"angular_velocity":[NaN,0,0],"specific_force":[0,0,0]}"#,
                ),
            ),
            vec![],
            3,
            vec!["field `angular_velocity[0]`"],
        ),
        (
            write(
                dir,
                "string.mcap",
                &bad_msg(
                    r#"{"stamp_ns":1700000000000000000,"angular_velocity":[0,0,0],"specific_force":[0,"x",0]}"#,
                ),
            ),
            vec![],
            3,
            vec!["field `specific_force[1]`", "invalid type"],
        ),
        (
            write(
                dir,
                "pre1970.mcap",
                &bad_msg(r#"{"stamp_ns":-5,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#),
            ),
            vec![],
            3,
            vec!["field `stamp_ns`", "1969"],
        ),
        (
            write(
                dir,
                "post2100.mcap",
                &bad_msg(
                    r#"{"stamp_ns":4200000000000000000,"angular_velocity":[0,0,0],"specific_force":[0,0,0]}"#,
                ),
            ),
            vec![],
            3,
            vec!["field `stamp_ns`", "2103"],
        ),
        (
            write(dir, "cut-header.mcap", &good[..20]),
            vec![],
            3,
            vec!["no decodable message"],
        ),
        (
            write(dir, "good.mcap", &good),
            vec!["--rate", "0"],
            2,
            vec!["--rate"],
        ),
    ]
}

#[test]
fn bad_input_gets_one_line_error_exit_code_and_no_output() {
    let dir = common::scratch_dir("bad");
    for (path, extra, code, words) in bad_inputs(&dir) {
        let out = dir.join(format!(
            "out-{}",
            path.file_name().unwrap().to_string_lossy()
        ));
        let before = std::fs::read(&path).ok();
        let o = common::run_on("export", &path, &out, &extra);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{}: {err}", path.display());
        if code == 3 {
            // One error line; anything else printed is a warning line, or the hint of which
            // flag gets past the error.
            let errors: Vec<&str> = err
                .lines()
                .filter(|l| !l.starts_with("warning: ") && !l.starts_with("hint: "))
                .collect();
            assert_eq!(errors.len(), 1, "{}: one line: {err}", path.display());
            assert!(errors[0].starts_with("error: reading "), "{err}");
        }
        for w in words {
            assert!(err.contains(w), "{}: `{w}` not in: {err}", path.display());
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            files_in(&out).is_empty(),
            "{}: output left behind: {:?}",
            path.display(),
            files_in(&out)
        );
        assert_eq!(std::fs::read(&path).ok(), before, "input untouched");
        // info fails the same way on unreadable files.
        if code == 3 && !path.ends_with("unknown.mcap") && !path.to_string_lossy().contains("field")
        {
            let o = hindsight(&["info", path.to_str().unwrap()]);
            if ![
                "nan.mcap",
                "string.mcap",
                "pre1970.mcap",
                "post2100.mcap",
                "cut-header.mcap",
            ]
            .iter()
            .any(|n| path.ends_with(n))
            {
                assert_eq!(
                    o.status.code(),
                    Some(3),
                    "info {}: {}",
                    path.display(),
                    stderr(&o)
                );
            }
        }
    }
}

#[test]
fn truncated_log_exports_with_a_warning() {
    let dir = common::scratch_dir("trunc");
    let options = WriterOptions {
        chunk_size: 32 * 1024,
        ..WriterOptions::default()
    };
    let good = common::survey_bytes(options, 30.0);
    let path = write(&dir, "cut.mcap", &good[..good.len() / 2]);
    let out = dir.join("out");
    let o = hindsight(&[
        "export",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: the log is cut short (no footer): recovered"),
        "{}",
        stderr(&o)
    );
    assert!(files_in(&out).contains(&"aligned.parquet".to_string()));
}

#[test]
fn unwritable_output_is_exit_4_and_leaves_nothing() {
    let dir = common::scratch_dir("unwritable");
    let blocker = write(&dir, "not-a-dir", b"x");
    let o = hindsight(&[
        "export",
        SAMPLE,
        "--out",
        blocker.join("sub").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("error: cannot write"),
        "{}",
        stderr(&o)
    );
    assert_eq!(files_in(&dir), vec!["not-a-dir".to_string()]);
}

#[test]
fn info_reports_invalid_messages_without_failing() {
    let dir = common::scratch_dir("info-invalid");
    let bytes = to_bytes(WriterOptions::default(), |w| {
        for i in 0..10i64 {
            let t = 1_700_000_000_000_000_000 + i * 10_000_000;
            let m = Imu {
                stamp_ns: t,
                angular_velocity: [0.0; 3],
                specific_force: [0.0; 3],
            };
            w.write("/imu", &m, t as u64)?;
        }
        w.write_raw(
            "/imu",
            Imu::SCHEMA_NAME,
            Imu::SCHEMA_JSON,
            "json",
            br#"{"stamp_ns":1}"#,
            9,
        )
    })
    .unwrap();
    let path = write(&dir, "one-bad.mcap", &bytes);
    let o = hindsight(&["info", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let row: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("/imu "))
        .unwrap()
        .split_whitespace()
        .collect();
    assert_eq!(row.last(), Some(&"1"), "invalid column: {text}");
    assert!(
        text.contains("field `angular_velocity`: missing field"),
        "{text}"
    );
}
