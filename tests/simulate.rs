//! Simulated logs: deterministic, valid against schemas/, read back identically by ingest.

use crate::common;
use hindsight::contract::{kind_by_schema, GnssFix, Message, Truth};
use hindsight::geodesy;
use hindsight::ingest::{read_log_from, Ending, IngestOptions, Log};
use hindsight::sim::scenario::Scenario;
use std::collections::HashMap;

fn simulate(name: &str, seed: u64) -> Vec<u8> {
    common::simulated_bytes(&Scenario::built_in(name).unwrap(), seed)
}

#[test]
fn same_scenario_and_seed_give_the_same_bytes() {
    let a = simulate("pool-rectangle", 3);
    let b = simulate("pool-rectangle", 3);
    assert!(a == b, "byte-identical");
    let c = simulate("pool-rectangle", 4);
    assert!(a != c, "another seed, another log");
}

/// Every message validates against the schema embedded in the log, and ingest decodes it to
/// exactly the JSON that was written.
fn check_log(name: &str, bytes: &[u8]) -> Log {
    let mut validators = HashMap::new();
    let mut per_topic: HashMap<String, Vec<Vec<u8>>> = HashMap::new();
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        let validator = validators.entry(schema.name.clone()).or_insert_with(|| {
            let doc: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
            jsonschema::validator_for(&doc).unwrap()
        });
        let value: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        assert!(
            validator.is_valid(&value),
            "{name} {}: {value}",
            m.channel.topic
        );
        per_topic
            .entry(m.channel.topic.clone())
            .or_default()
            .push(m.data.to_vec());
    }
    let log = read_log_from(bytes, &IngestOptions::default()).unwrap();
    assert_eq!(log.file.ending, Ending::Complete);
    for s in &log.streams {
        assert_eq!(
            (s.counts.invalid, s.counts.duplicates, s.counts.out_of_order),
            (0, 0, 0),
            "{name} {}",
            s.topic
        );
        let raw = &per_topic[&s.topic];
        assert_eq!(raw.len(), s.samples.len());
        assert!(kind_by_schema(&s.schema_name).is_some());
        macro_rules! same_json {
            ($($t:ident),*) => {
                $( if let Some(msgs) = s.messages::<hindsight::contract::$t>() {
                    for (m, r) in msgs.iter().zip(raw) {
                        assert_eq!(&serde_json::to_vec(m).unwrap(), r, "{name} {}", s.topic);
                    }
                } )*
            };
        }
        hindsight::for_each_message!(same_json);
    }
    log
}

#[test]
fn every_scenario_log_is_valid_and_reads_back_identically() {
    for name in [
        "pool-circle",
        "pool-rectangle",
        "survey-short",
        "dive-27min",
        "survey",
        "zigzag-rudder-20-20",
        "zigzag-planes-10-10",
        "turning-circle",
        "drop-entry",
        // usbl-survey's messages are usbl-no-dvl's (the acoustic fixes) and usbl-raw-survey's
        // (the ship's pose).
        "usbl-raw-survey",
        "lbl-box",
        "usbl-no-dvl",
    ] {
        let log = check_log(name, &simulate(name, 1));
        assert!(log.stream("/truth").is_some(), "{name}");
        assert_eq!(
            log.mission().unwrap().vehicle,
            Scenario::built_in(name).unwrap().mission.vehicle
        );
    }
}

/// The 5.5-hour long dive, too slow for CI's budget with schema validation of 4 M messages:
/// `cargo test --release --test all simulate:: -- --ignored`.
#[test]
#[ignore = "5.5 h of simulated data; run by name"]
fn long_dive_log_is_valid_and_reads_back_identically() {
    check_log("long-dive", &simulate("long-dive", 1));
    check_log("long-dive-dynamic", &simulate("long-dive-dynamic", 1));
}

#[test]
fn gnss_errors_have_their_sigma_and_only_at_the_surface() {
    let log = read_log_from(&simulate("survey", 2)[..], &IngestOptions::default()).unwrap();
    let truth = log.messages::<Truth>("/truth").unwrap();
    let gnss = log.messages::<GnssFix>("/gnss").unwrap();
    assert!(gnss.len() > 100);
    let mut sq = 0.0;
    for g in gnss {
        let (t, _) = hindsight::align::latest_at(truth, g.stamp_ns()).unwrap();
        assert_eq!(
            t.stamp_ns, g.stamp_ns,
            "truth at 10 Hz covers whole seconds"
        );
        assert!(t.down_m <= 0.5, "GNSS only at the surface: {} m", t.down_m);
        let (n, e) = geodesy::local_north_east_m(
            t.latitude_deg.to_radians(),
            t.longitude_deg.to_radians(),
            g.latitude_deg.to_radians(),
            g.longitude_deg.to_radians(),
        );
        sq += n * n + e * e;
    }
    let sigma = (sq / (2.0 * gnss.len() as f64)).sqrt();
    assert!((sigma / 2.5 - 1.0).abs() < 0.15, "{sigma}");
}

#[test]
fn pool_paths_have_the_papers_lengths_and_close() {
    for (name, length) in [("pool-circle", 282.7), ("pool-rectangle", 100.8)] {
        let log = read_log_from(&simulate(name, 1)[..], &IngestOptions::default()).unwrap();
        let truth = log.messages::<Truth>("/truth").unwrap();
        let path: f64 = truth
            .windows(2)
            .map(|w| (w[1].north_m - w[0].north_m).hypot(w[1].east_m - w[0].east_m))
            .sum();
        assert!((path / length - 1.0).abs() < 0.01, "{name}: {path} m");
        let (a, b) = (truth.first().unwrap(), truth.last().unwrap());
        let gap = (b.north_m - a.north_m).hypot(b.east_m - a.east_m);
        assert!(gap < 0.5, "{name} ends {gap} m from its start");
        let fixes = log
            .messages::<hindsight::contract::PositionFix>("/position_fix")
            .unwrap();
        let labels: Vec<&str> = fixes.iter().map(|f| f.label.as_str()).collect();
        assert_eq!(labels, ["start", "end"]);
    }
}

#[test]
fn usbl_fixes_have_their_sigma() {
    let text = hindsight::sim::scenario::BUILT_IN
        .iter()
        .find(|(n, _)| *n == "survey-short")
        .unwrap()
        .1;
    let text = format!("{text}\n[fixes]\nusbl_every_s = 0.5\nusbl_sigma_m = 2.0\n");
    let scenario = Scenario::from_toml(&text).unwrap();
    let bytes = common::simulated_bytes(&scenario, 5);
    let log = read_log_from(&bytes[..], &IngestOptions::default()).unwrap();
    let truth = log.messages::<Truth>("/truth").unwrap();
    let fixes = log
        .messages::<hindsight::contract::PositionFix>("/position_fix")
        .unwrap();
    assert!(fixes.len() > 600, "{}", fixes.len());
    let mut sq = [0.0; 3];
    for f in fixes {
        assert_eq!(f.label, "usbl");
        let (t, age) = hindsight::align::latest_at(truth, f.stamp_ns).unwrap();
        assert_eq!(age, 0);
        sq[0] += (f.north_m - t.north_m).powi(2);
        sq[1] += (f.east_m - t.east_m).powi(2);
        sq[2] += (f.down_m.unwrap() - t.down_m).powi(2);
    }
    for s in sq {
        let sigma = (s / fixes.len() as f64).sqrt();
        assert!((sigma / 2.0 - 1.0).abs() < 0.1, "{sigma}");
    }
}
