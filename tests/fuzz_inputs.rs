//! Fuzzed inputs a user hands over besides a log: settings files, scenario files, vehicle
//! files, CSV files with their map, and ROS 2 sqlite bags. Structured mutations of the shipped
//! files (lines dropped, repeated and swapped, values replaced by extreme, malformed and
//! wrongly typed ones, keys renamed, text cut short, stray bytes); [`cases`] per input, each
//! from its own seed so that a failure names the seed that reproduces it. The property:
//! reading never panics, and a refusal is one line that says what is wrong.

use hindsight::import::csv::{read_all, CsvFile};
use hindsight::import::map::CsvMap;
use hindsight::recon::config::Config;
use hindsight::recon::model_velocity::{parse_vehicle_file, vehicle_model};
use hindsight::sim::scenario::Scenario;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Cases per input (10 000 in CI; `HINDSIGHT_FUZZ_CASES` for a longer run).
fn cases() -> u64 {
    std::env::var("HINDSIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000)
}

fn shipped(path: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Runs `case` for every seed: a panic fails with the seed, and so does a refusal whose
/// message is empty or spans lines. Returns how many cases were accepted.
fn fuzz(name: &str, mut case: impl FnMut(&mut ChaCha8Rng) -> Result<(), String>) -> u64 {
    let (n, mut accepted) = (cases(), 0);
    for seed in 0..n {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        match catch_unwind(AssertUnwindSafe(|| case(&mut rng))) {
            Ok(Ok(())) => accepted += 1,
            Ok(Err(why)) => assert!(
                !why.trim().is_empty() && !why.contains('\n'),
                "{name}: case seed {seed} was refused with {why:?} (not one line)"
            ),
            Err(_) => panic!("{name}: case seed {seed} panicked"),
        }
    }
    println!("{name}: {n} cases, {accepted} accepted, none panicked");
    accepted
}

/// A value a hand-written file might hold where a good one should be.
fn odd_value(rng: &mut ChaCha8Rng) -> String {
    let odd = [
        "0",
        "-1",
        "1e308",
        "-1e308",
        "1e-320",
        "nan",
        "inf",
        "-inf",
        "\"\"",
        "\"x\"",
        "[]",
        "[1, 2]",
        "{}",
        "true",
        "9999999999999999999999",
        "-0.0",
        "\"\u{0}\"",
        "[[[[1]]]]",
        "1e400",
        "0x10",
    ];
    if rng.random_bool(0.3) {
        format!("{}", rng.random_range(-1e6..1e6_f64))
    } else {
        odd[rng.random_range(0..odd.len())].to_string()
    }
}

/// One structured edit of a TOML or JSON file's text, or of a CSV file's lines.
fn mutate_text(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return text.to_string();
    }
    for _ in 0..rng.random_range(1..4) {
        let k = rng.random_range(0..lines.len());
        match rng.random_range(0..9) {
            0 => {
                lines.remove(k);
            }
            1 => lines.insert(k, lines[k].clone()),
            2 => {
                let j = rng.random_range(0..lines.len());
                lines.swap(k, j);
            }
            // A value replaced: after `=` (TOML), `:` (JSON) or a comma (CSV).
            3..=5 => {
                let line = &lines[k];
                if let Some(at) = line.rfind(['=', ':', ',']) {
                    let tail = if line.trim_end().ends_with(',') && line[at..].len() > 1 {
                        ","
                    } else {
                        ""
                    };
                    lines[k] = format!("{}{}{tail}", &line[..=at], odd_value(rng));
                }
            }
            6 => {
                // A key renamed.
                if let Some(at) = lines[k].find(['=', ':']) {
                    lines[k] = format!("x_{}", &lines[k][at.min(1)..]);
                }
            }
            7 => {
                let cut = rng.random_range(0..=lines[k].len());
                let cut = (0..=cut)
                    .rev()
                    .find(|&c| lines[k].is_char_boundary(c))
                    .unwrap_or(0);
                lines[k].truncate(cut);
            }
            _ => lines.insert(k, odd_value(rng)),
        }
        if lines.is_empty() {
            break;
        }
    }
    let mut out = lines.join("\n");
    if rng.random_bool(0.05) {
        let cut = rng.random_range(0..=out.len());
        let cut = (0..=cut)
            .rev()
            .find(|&c| out.is_char_boundary(c))
            .unwrap_or(0);
        out.truncate(cut);
    }
    out
}

/// A configuration error as the user reads it: on one line.
fn one_line(e: impl std::fmt::Display) -> String {
    e.to_string()
}

#[test]
fn settings_files_never_panic_the_reader() {
    let seeds: Vec<String> = ["survey", "long-dive", "dive-27min", "seed000-proposed"]
        .iter()
        .map(|n| shipped(&format!("configs/{n}.toml")))
        .collect();
    let accepted = fuzz("settings", |rng| {
        let text = mutate_text(&seeds[rng.random_range(0..seeds.len())], rng);
        hindsight::config::load::<Config>(&text)
            .map(|_| ())
            .map_err(one_line)
    });
    assert!(accepted > 0, "some mutated settings files still read");
}

#[test]
fn scenario_files_never_panic_the_reader() {
    let names = [
        "survey-short",
        "auv-at-sea",
        "pool-circle",
        "drop-no-dvl",
        "trench-eml",
    ];
    let seeds: Vec<String> = names
        .iter()
        .map(|n| shipped(&format!("scenarios/{n}.toml")))
        .collect();
    let accepted = fuzz("scenarios", |rng| {
        let text = mutate_text(&seeds[rng.random_range(0..seeds.len())], rng);
        Scenario::from_toml(&text).map(|_| ()).map_err(one_line)
    });
    assert!(accepted > 0, "some mutated scenarios still read");
}

#[test]
fn vehicle_files_never_panic_the_reader() {
    let seeds: Vec<String> = ["nps-auv-ii", "remus-100"]
        .iter()
        .map(|n| shipped(&format!("assets/vehicles/{n}.json")))
        .collect();
    let accepted = fuzz("vehicles", |rng| {
        let text = mutate_text(&seeds[rng.random_range(0..seeds.len())], rng);
        let vehicle = parse_vehicle_file("fuzzed.json", &text).map_err(one_line)?;
        vehicle_model("fuzzed.json", Some(&vehicle))
            .map(|_| ())
            .map_err(one_line)
    });
    assert!(accepted > 0, "some mutated vehicle files still read");
}

#[test]
fn csv_files_and_their_maps_never_panic_the_importer() {
    let csv = shipped("sample-logs/csv/ins-example.csv");
    let maps = [
        shipped("sample-logs/csv/ins-export.toml"),
        shipped("sample-logs/csv/vehicle-computer.toml"),
    ];
    let accepted = fuzz("csv", |rng| {
        let map_text = &maps[rng.random_range(0..maps.len())];
        let map_text = if rng.random_bool(0.5) {
            mutate_text(map_text, rng)
        } else {
            map_text.clone()
        };
        let csv_text = if rng.random_bool(0.7) {
            mutate_text(&csv, rng)
        } else {
            csv.clone()
        };
        let map: CsvMap = toml::from_str(&map_text).map_err(|e| {
            // The command line names the map; what toml says of it is its own.
            e.message().to_string()
        })?;
        let files = [CsvFile {
            file_name: "ins-example.csv".into(),
            shown_as: "ins-example.csv".into(),
            bytes: csv_text.as_bytes(),
        }];
        read_all(&map, &files).map(|_| ()).map_err(one_line)
    });
    assert!(accepted > 0, "some mutated CSV files still import");
}

/// A sqlite bag's bytes with a few pages' bytes changed, cut or repeated.
fn mutate_db(bytes: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for _ in 0..rng.random_range(1..6) {
        let at = rng.random_range(0..out.len());
        match rng.random_range(0..4) {
            0 => out[at] = rng.random(),
            1 => {
                let end = (at + rng.random_range(1..64)).min(out.len());
                out[at..end].fill(if rng.random_bool(0.5) { 0 } else { 0xff });
            }
            2 => out.truncate(at.max(100)),
            _ => {
                let end = (at + rng.random_range(1..4096)).min(out.len());
                let piece = out[at..end].to_vec();
                let to = rng.random_range(0..out.len());
                let end = (to + piece.len()).min(out.len());
                out[to..end].copy_from_slice(&piece[..end - to]);
            }
        }
    }
    out
}

/// The fixture ROS 2 bag cut to its first messages of each topic (a few kB), as bytes.
fn small_bag(dir: &Path) -> Vec<u8> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bags");
    let from = root.join("survey_humble_rep103/survey_humble_rep103.db3");
    let to = dir.join("small.db3");
    let _ = std::fs::remove_file(&to);
    let db =
        rusqlite::Connection::open_with_flags(&from, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .expect("the fixture bag");
    db.execute("VACUUM INTO ?1", [to.to_str().unwrap()])
        .expect("a copy");
    let small = rusqlite::Connection::open(&to).expect("the copy");
    small
        .execute_batch(
            "DELETE FROM messages WHERE id NOT IN \
             (SELECT MIN(id) + k FROM messages, (SELECT 0 AS k UNION SELECT 1 UNION SELECT 2) \
              GROUP BY topic_id, k); VACUUM;",
        )
        .expect("cut");
    drop(small);
    std::fs::read(&to).expect("the small bag")
}

#[test]
fn sqlite_bags_never_panic_the_reader() {
    let dir = crate::common::scratch_dir("fuzz-sqlite");
    let bag = small_bag(&dir);
    assert!(bag.len() < 200_000, "{} bytes", bag.len());
    let path = dir.join("fuzzed.db3");
    let n = cases();
    let mut accepted = 0;
    for seed in 0..n {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        std::fs::write(&path, mutate_db(&bag, &mut rng)).expect("scratch file");
        let options = hindsight::ingest::IngestOptions {
            decode_threads: 1,
            ..Default::default()
        };
        match catch_unwind(AssertUnwindSafe(|| {
            hindsight::ingest::read_log(&path, &options)
        })) {
            Ok(Ok(_)) => accepted += 1,
            Ok(Err(e)) => {
                let why = e.to_string();
                assert!(
                    !why.contains('\n'),
                    "sqlite seed {seed}: {why:?} spans lines"
                );
            }
            Err(_) => panic!("sqlite: case seed {seed} panicked"),
        }
    }
    println!("sqlite: {n} cases, {accepted} read, none panicked");
}
