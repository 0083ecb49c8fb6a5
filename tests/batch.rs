//! `hindsight batch` over an archive: partitions, shards, resume, a corrupt log
//! among good ones, and the batch summary.

use crate::common;
use arrow_array::{Array, BooleanArray, Float64Array, RecordBatch, StringArray};
use common::{hindsight, read_parquet, scratch_dir, stderr, SAMPLE};
use std::path::{Path, PathBuf};

/// An archive: the sample log under three names (one in a sub-folder) and a corrupt log.
fn archive(name: &str) -> (PathBuf, PathBuf) {
    let dir = scratch_dir(name);
    let logs = dir.join("logs");
    std::fs::create_dir_all(logs.join("day2")).unwrap();
    for p in ["dive-a.mcap", "dive-b.mcap", "day2/dive-c.mcap"] {
        std::fs::copy(SAMPLE, logs.join(p)).unwrap();
    }
    // Not an MCAP file at all (a cut log is read up to its cut, with a warning).
    std::fs::write(logs.join("broken.mcap"), b"this was never a log").unwrap();
    std::fs::write(logs.join("notes.txt"), b"not a log").unwrap();
    (logs, dir.join("out"))
}

fn text(b: &RecordBatch, name: &str) -> Vec<Option<String>> {
    let a = common::column::<StringArray>(b, name);
    (0..a.len())
        .map(|i| a.is_valid(i).then(|| a.value(i).to_string()))
        .collect()
}

fn number(b: &RecordBatch, name: &str) -> Vec<Option<f64>> {
    let a = common::column::<Float64Array>(b, name);
    (0..a.len())
        .map(|i| a.is_valid(i).then(|| a.value(i)))
        .collect()
}

fn summary(path: &Path) -> RecordBatch {
    let batches = read_parquet(path);
    assert_eq!(batches.len(), 1);
    batches[0].clone()
}

fn batch(args: &[&str]) -> std::process::Output {
    hindsight(&[&["batch"], args].concat())
}

#[test]
fn an_archive_with_a_corrupt_log_is_reconstructed_and_summarised() {
    let (logs, out) = archive("batch-all");
    let run = batch(&[logs.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    // The corrupt log fails the batch (exit 3) after the others are done.
    assert_eq!(run.status.code(), Some(3), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("1 of 4 missions failed"),
        "{}",
        stderr(&run)
    );
    let b = summary(&out.join("batch_summary.parquet"));
    let missions: Vec<String> = text(&b, "mission").into_iter().flatten().collect();
    assert_eq!(missions, ["broken", "dive-a", "dive-b", "dive-c"]);
    let status = text(&b, "status");
    let errors = text(&b, "error");
    assert_eq!(status[0].as_deref(), Some("failed"));
    assert!(
        errors[0].as_deref().unwrap().contains("broken.mcap"),
        "the error names the log: {:?}",
        errors[0]
    );
    assert!(!out.join("mission=broken/summary.json").exists());
    // Every good mission: done, its outputs in its partition, and its row as its summary.
    let distance = number(&b, "distance_travelled_m");
    let sigma = number(&b, "final_horizontal_sigma_smoothed_m");
    let rms = number(&b, "smoothed_horizontal_rms_m");
    let consistent = common::column::<BooleanArray>(&b, "consistent").clone();
    for k in 1..4 {
        assert_eq!(status[k].as_deref(), Some("done"));
        assert_eq!(errors[k], None);
        let dir = out.join(format!("mission={}", missions[k]));
        for f in ["trajectory.parquet", "report.html", "summary.json"] {
            assert!(dir.join(f).is_file(), "{}/{f}", dir.display());
        }
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(distance[k], s["distance_travelled_m"].as_f64());
        assert_eq!(
            sigma[k],
            s["final_sigma"]["smoothed"]["horizontal_m"].as_f64()
        );
        assert_eq!(rms[k], s["truth"]["smoothed"]["horizontal_rms_m"].as_f64());
        assert_eq!(
            Some(consistent.value(k)),
            s["consistency"]["consistent"].as_bool()
        );
    }
    // The same log gives the same reconstruction in every partition.
    assert_eq!(distance[1], distance[2]);
    assert_eq!(rms[1], rms[3]);
    assert!(out.join("report.html").is_file());

    // A rerun: the complete missions are not run again, their outputs untouched.
    let modified = |m: &str| {
        std::fs::metadata(out.join(format!("mission={m}/trajectory.parquet")))
            .unwrap()
            .modified()
            .unwrap()
    };
    let before = modified("dive-a");
    let again = batch(&[logs.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(3));
    let b = summary(&out.join("batch_summary.parquet"));
    assert_eq!(
        text(&b, "status"),
        ["failed", "complete", "complete", "complete"].map(|s| Some(s.to_string()))
    );
    assert_eq!(number(&b, "run_time_s")[1..], [None, None, None]);
    assert_eq!(number(&b, "distance_travelled_m"), distance);
    assert_eq!(modified("dive-a"), before);
}

#[test]
fn shards_split_an_archive_without_overlap() {
    let (logs, out) = archive("batch-shards");
    std::fs::remove_file(logs.join("broken.mcap")).unwrap();
    let mut seen = Vec::new();
    for i in 0..2 {
        let shard = format!("{i}/2");
        let run = batch(&[
            logs.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--shard",
            &shard,
            "--jobs",
            "1",
        ]);
        assert!(run.status.success(), "{}", stderr(&run));
        let b = summary(&out.join(format!("batch_summary.shard-{i}-of-2.parquet")));
        assert!(text(&b, "status")
            .iter()
            .all(|s| s.as_deref() == Some("done")));
        seen.extend(text(&b, "mission").into_iter().flatten());
    }
    seen.sort();
    assert_eq!(
        seen,
        ["dive-a", "dive-b", "dive-c"],
        "every log exactly once"
    );
    let partitions: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("mission="))
        .collect();
    assert_eq!(partitions.len(), 3);
}

#[test]
fn bad_batch_arguments_are_refused_with_the_reason() {
    let (logs, out) = archive("batch-bad");
    let o = out.to_str().unwrap();
    let run = batch(&[logs.join("nothing-here").to_str().unwrap(), "--out", o]);
    assert_eq!(run.status.code(), Some(2));
    assert!(
        stderr(&run).contains("no such file or folder"),
        "{}",
        stderr(&run)
    );
    let run = batch(&[logs.to_str().unwrap(), "--out", o, "--shard", "2/2"]);
    assert_eq!(run.status.code(), Some(2));
    assert!(
        stderr(&run).contains("I must be in 0..N"),
        "{}",
        stderr(&run)
    );
    // Two logs that would be one mission.
    std::fs::copy(SAMPLE, logs.join("day2/dive-a.mcap")).unwrap();
    let run = batch(&[logs.to_str().unwrap(), "--out", o]);
    assert_eq!(run.status.code(), Some(2));
    assert!(
        stderr(&run).contains("would both be mission `dive-a`"),
        "{}",
        stderr(&run)
    );
    // A configuration that does not parse fails once, before any mission.
    let config = logs.join("bad.toml");
    std::fs::write(&config, "[imu]\ngrade = \"excellent\"\n").unwrap();
    std::fs::remove_file(logs.join("day2/dive-a.mcap")).unwrap();
    let run = batch(&[
        logs.to_str().unwrap(),
        "--out",
        o,
        "--config",
        config.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(2), "{}", stderr(&run));
    assert!(!out.join("mission=dive-a").exists());
}
