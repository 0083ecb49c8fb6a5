//! Logs written by another MCAP writer: the official Python `mcap` package
//! (tests/fixtures/make_python_fixtures.py made the fixtures; its docstring lists the values).

use hindsight::contract::{Dvl, Imu, PositionFix};
use hindsight::ingest::{read_log, Ending, IngestOptions, Log};
use std::path::Path;

const T0: i64 = 1_700_000_000_000_000_000;

fn fixture(name: &str) -> Log {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name);
    read_log(&path, &IngestOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn check(log: &Log) {
    assert_eq!(log.file.ending, Ending::Complete);
    assert_eq!(log.file.library, "python-mcap-fixture");
    let mission = log.mission().unwrap();
    assert_eq!(mission.origin_latitude_deg, 35.1);
    assert_eq!(mission.origin_longitude_deg, 129.05);
    assert_eq!(mission.vehicle, "remus-100");

    let imu = log.messages::<Imu>("/imu").unwrap();
    assert_eq!(imu.len(), 10);
    for (i, m) in imu.iter().enumerate() {
        assert_eq!(m.stamp_ns, T0 + i as i64 * 10_000_000);
        assert_eq!(
            m.angular_velocity,
            [i as f64 * 1e-3, -(i as f64) * 1e-3, 0.5e-3]
        );
        assert_eq!(m.specific_force, [0.1, -0.2, -9.81]);
    }
    let s = log.stream("/imu").unwrap();
    assert_eq!(s.counts.out_of_order, 1);
    assert_eq!(s.log_time_ns[0], (T0 + 1_000_000) as u64);

    let dvl = log.messages::<Dvl>("/dvl").unwrap();
    assert_eq!(dvl.len(), 3);
    assert_eq!(dvl[1].velocity, [1.5, 0.0, 0.01]);
    assert_eq!(dvl[1].altitude, Some(11.5));
    assert!(!dvl[2].valid);
    assert_eq!(dvl[2].altitude, None);

    let fix = log.messages::<PositionFix>("/position_fix").unwrap();
    assert_eq!(
        fix,
        &[PositionFix {
            stamp_ns: T0,
            north_m: 1.25,
            east_m: -2.5,
            down_m: None,
            sigma_m: 0.05,
            label: "start".into()
        }]
    );
}

#[test]
fn reads_python_lz4_chunked_log() {
    let log = fixture("python_lz4_chunked.mcap");
    assert!(log.file.has_summary);
    check(&log);
}

#[test]
fn reads_python_unchunked_log() {
    check(&fixture("python_unchunked.mcap"));
}

/// The BROAD benchmark logs in `../shared/benchmarks/broad/` (written by the Python `mcap`
/// package with zstd chunks): every trial reads completely, without an invalid, duplicated or
/// out-of-order message. Needs the shared folder, so it is ignored by default:
/// `cargo test --release --test all foreign_writer:: -- --ignored`.
#[test]
#[ignore = "needs ../shared/benchmarks/broad"]
fn broad_trials_read_clean() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/benchmarks/broad");
    let mut trials = 0;
    for entry in std::fs::read_dir(&dir).expect("../shared/benchmarks/broad exists") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "mcap") {
            continue;
        }
        let log = read_log(&path, &IngestOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(log.file.ending, Ending::Complete, "{}", path.display());
        assert_eq!(log.mission().unwrap().vehicle, "broad-imu");
        for s in &log.streams {
            let c = &s.counts;
            assert_eq!(
                (c.invalid, c.duplicates, c.out_of_order),
                (0, 0, 0),
                "{} {}",
                path.display(),
                s.topic
            );
        }
        let imu = log.messages::<Imu>("/imu").unwrap();
        assert!(imu.len() > 20_000, "{}", path.display());
        trials += 1;
    }
    assert_eq!(trials, 25);
}
