//! The reconstruction as one library value: the library's entry, with no command line
//! involved, writes the same output folder as `hindsight reconstruct`, and every warning it
//! raises carries a code.

use crate::common::{hindsight, scratch_dir, SAMPLE};
use hindsight::recon::config::Config;
use std::path::Path;

/// summary.json without its run times (they are the one thing two runs differ in).
fn summary_without_times(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    let mut v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    v.as_object_mut().expect("an object").remove("run_time_s");
    v
}

/// report.html without its run-time row.
fn report_without_times(dir: &Path) -> String {
    let text = std::fs::read_to_string(dir.join("report.html")).expect("report.html");
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.contains("<th>run time</th>"))
        .collect();
    kept.join("\n")
}

fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn the_library_entry_writes_what_the_command_line_writes() {
    let (lib_dir, cli_dir) = (scratch_dir("entry-lib"), scratch_dir("entry-cli"));
    let job = hindsight::Job::new(Path::new(SAMPLE), Config::default());
    let mut r = hindsight::reconstruct(&job, Default::default()).expect("reconstructs");
    assert!(r.summary.epochs > 1000, "{} epochs", r.summary.epochs);
    assert!(r.summary.truth.is_some(), "the sample log carries /truth");
    let written = r.write(&lib_dir).expect("writes");
    assert_eq!(
        written.last().and_then(|p| p.file_name()),
        Some("summary.json".as_ref())
    );

    let out = hindsight(&["reconstruct", SAMPLE, "--out", cli_dir.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let names = file_names(&lib_dir);
    assert_eq!(names, file_names(&cli_dir));
    assert!(names.len() >= 10, "{names:?}");
    for name in &names {
        let (a, b) = (lib_dir.join(name), cli_dir.join(name));
        match name.as_str() {
            "summary.json" => assert_eq!(
                summary_without_times(&lib_dir),
                summary_without_times(&cli_dir)
            ),
            "report.html" => assert!(
                report_without_times(&lib_dir) == report_without_times(&cli_dir),
                "report.html differs"
            ),
            _ => assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{name} differs"
            ),
        }
    }
}

#[test]
fn every_warning_in_the_summary_has_a_code_and_its_message() {
    let dir = scratch_dir("entry-codes");
    let job = hindsight::Job::new(Path::new(SAMPLE), Config::default());
    let mut r = hindsight::reconstruct(&job, Default::default()).expect("reconstructs");
    r.write(&dir).expect("writes");
    let summary = summary_without_times(&dir);
    let warnings = summary["warnings"].as_array().expect("a list");
    assert!(!warnings.is_empty(), "the sample log raises gate warnings");
    for (w, typed) in warnings.iter().zip(&r.summary.warnings) {
        assert_eq!(w["code"].as_str(), Some(typed.code().as_str()));
        assert_eq!(w["message"].as_str(), Some(typed.to_string().as_str()));
    }
    // Every code raised is one the guide lists for programs to match.
    let guide = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide/reconstruct.md"),
    )
    .expect("the guide");
    for w in warnings {
        let code = w["code"].as_str().expect("a code");
        assert!(
            guide.contains(&format!("`{code}`")),
            "{code} is not in the guide"
        );
    }
    // The gate's warning carries its figures as numbers.
    let rejected = warnings
        .iter()
        .find(|w| w["code"] == "rejected")
        .expect("a rejection");
    assert!(rejected["rejected"].as_u64().is_some() && rejected["count"].as_u64().is_some());
}

/// The tables in memory (what the Python package hands over) are the rows the files hold:
/// trajectory.parquet, residuals.parquet and errors.parquet read back, batch for batch
/// concatenated, equal them column by column.
#[test]
fn the_tables_in_memory_are_the_files_rows() {
    let dir = scratch_dir("entry-tables");
    let job = hindsight::Job::new(Path::new(SAMPLE), Config::default());
    let mut r = hindsight::reconstruct(&job, Default::default()).expect("reconstructs");
    let tables = r.tables().expect("tables");
    r.write(&dir).expect("writes");
    let concat = |batches: &[arrow_array::RecordBatch]| {
        arrow_select::concat::concat_batches(&batches[0].schema(), batches).unwrap()
    };
    for (name, in_memory) in [
        ("trajectory.parquet", &tables.trajectory),
        ("residuals.parquet", &tables.residuals),
        ("errors.parquet", &tables.errors),
    ] {
        let from_file = concat(&crate::common::read_parquet(&dir.join(name)));
        let in_memory = concat(in_memory);
        assert!(
            in_memory.num_rows() > 100,
            "{name}: {}",
            in_memory.num_rows()
        );
        assert_eq!(in_memory.num_rows(), from_file.num_rows(), "{name}");
        for field in in_memory.schema().fields() {
            let a = in_memory.column_by_name(field.name()).unwrap();
            let b = from_file.column_by_name(field.name()).unwrap();
            assert_eq!(a.to_data(), b.to_data(), "{name}: {}", field.name());
        }
    }
}
