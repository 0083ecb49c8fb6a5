//! Helpers shared by the integration tests: logs built in memory with the project's writer.
#![allow(dead_code)]

use hindsight::contract::PropValue;
use hindsight::ingest::{read_log_from, IngestOptions, Log};
use hindsight::sim::synthetic::{write_survey, SurveySpec};
use hindsight::sim::writer::{to_bytes, WriterOptions};

/// A short synthetic survey with every contract stream, as MCAP bytes.
pub fn survey_bytes(options: WriterOptions, seconds: f64) -> Vec<u8> {
    let spec = SurveySpec {
        duration_s: seconds,
        seed: 7,
        ..SurveySpec::default()
    };
    to_bytes(options, |w| write_survey(w, &spec)).expect("in-memory write")
}

/// Reads MCAP bytes with default options.
pub fn read(bytes: &[u8]) -> Log {
    read_log_from(bytes, &IngestOptions::default()).expect("log reads")
}

/// Asserts two logs hold the same streams with the same messages.
pub fn assert_same_content(a: &Log, b: &Log) {
    assert_eq!(a.streams.len(), b.streams.len());
    for (sa, sb) in a.streams.iter().zip(&b.streams) {
        assert_eq!(sa.topic, sb.topic);
        assert_eq!(sa.schema_name, sb.schema_name);
        assert_eq!(sa.samples.len(), sb.samples.len(), "{}", sa.topic);
        assert_eq!(sa.log_time_ns, sb.log_time_ns, "{}", sa.topic);
        for i in 0..sa.samples.len() {
            assert_eq!(sa.samples.stamp_ns(i), sb.samples.stamp_ns(i));
            for p in 0..sa.samples.properties().len() {
                assert_eq!(
                    sa.samples.get(i, p),
                    sb.samples.get(i, p),
                    "{} #{i}",
                    sa.topic
                );
            }
        }
    }
    assert_eq!(a.metadata, b.metadata);
}

/// Whether two property values agree to within `rel` (relative) in every number.
pub fn close(a: PropValue<'_>, b: PropValue<'_>, rel: f64) -> bool {
    match (a, b) {
        (PropValue::Bool(x), PropValue::Bool(y)) => x == y,
        (PropValue::Str(x), PropValue::Str(y)) => x == y,
        (PropValue::OptF64(None), PropValue::OptF64(None)) => true,
        _ if a.kind() == b.kind() => (0..3).all(|c| match (a.component(c), b.component(c)) {
            (Some(x), Some(y)) => (x - y).abs() <= rel * x.abs().max(y.abs()),
            (None, None) => true,
            _ => false,
        }),
        _ => false,
    }
}

/// A fresh empty folder under the system temp folder. The folders of test runs that have
/// ended are removed the first time (they hold whole reconstructions: runs left behind
/// filled a disk).
pub fn scratch_dir(name: &str) -> std::path::PathBuf {
    static SWEPT: std::sync::Once = std::sync::Once::new();
    SWEPT.call_once(remove_ended_runs_folders);
    let d = std::env::temp_dir().join(format!("hindsight-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Removes the `scratch_dir` folders of test processes that are no longer running (Linux,
/// where `/proc` says which are; elsewhere nothing is removed).
fn remove_ended_runs_folders() {
    if !std::path::Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name
            .to_str()
            .and_then(|n| n.strip_prefix("hindsight-test-"))
        else {
            continue;
        };
        let pid = rest.rsplit('-').next().and_then(|p| p.parse::<u32>().ok());
        let ended = pid.is_some_and(|p| {
            p != std::process::id() && !std::path::Path::new(&format!("/proc/{p}")).exists()
        });
        if ended {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// A built-in or parsed scenario simulated with `seed`, as MCAP bytes.
///
/// The chunks are lz4-compressed: the content is the same as `hindsight simulate` writes
/// (zstd), and lz4 compresses several times faster, which the suite's many simulations feel.
pub fn simulated_bytes(scenario: &hindsight::sim::scenario::Scenario, seed: u64) -> Vec<u8> {
    let mut result = Ok(());
    let options = WriterOptions {
        compression: hindsight::sim::writer::Compression::Lz4,
        ..WriterOptions::default()
    };
    let bytes = to_bytes(options, |w| {
        result = hindsight::sim::run::run(scenario, seed, w).map(|_| ());
        Ok(())
    })
    .expect("in-memory write");
    result.expect("scenario runs");
    bytes
}

/// A simulated log: its bytes, for the library's entry, and the log read back, for its truth
/// (the log's members through `Deref`).
pub struct Simulated {
    pub bytes: std::sync::Arc<[u8]>,
    pub log: Log,
}

impl std::ops::Deref for Simulated {
    type Target = Log;
    fn deref(&self) -> &Log {
        &self.log
    }
}

impl Simulated {
    /// The log through the library's one entry, as `hindsight reconstruct` runs it (no CLI).
    pub fn reconstruct(
        &self,
        config: &hindsight::recon::config::Config,
    ) -> hindsight::Reconstruction {
        let job = hindsight::Job::in_memory("simulated.mcap", self.bytes.clone(), config.clone());
        hindsight::reconstruct(&job, hindsight::Observer::default()).unwrap()
    }
}

/// A scenario simulated with `seed`, as bytes and read back.
pub fn simulated(scenario: &hindsight::sim::scenario::Scenario, seed: u64) -> Simulated {
    let bytes = simulated_bytes(scenario, seed);
    let log = read(&bytes);
    Simulated {
        bytes: bytes.into(),
        log,
    }
}

/// One message as written: its schema, encoding, bytes and log time.
pub struct RawMessage {
    pub schema_name: String,
    pub schema_text: String,
    pub encoding: String,
    pub data: Vec<u8>,
    pub log_time: u64,
}

impl Simulated {
    /// The same log with each `T` reading on `topic` changed by `change` (`None`: left out);
    /// every other message and the metadata records as they were.
    pub fn with_changed<T: hindsight::contract::Message>(
        &self,
        topic: &str,
        change: impl Fn(&T) -> Option<T>,
    ) -> Simulated {
        self.with_rewritten(topic, |reading: &T, raw| {
            let changed = change(reading)?;
            Some(RawMessage {
                data: serde_json::to_vec(&changed).expect("json"),
                ..raw
            })
        })
    }

    /// The same log with each `T` reading on `topic` written as `rewrite` says (given the
    /// reading and the message as it stands; `None`: left out), e.g. in a ROS type; every
    /// other message and the metadata records as they were.
    pub fn with_rewritten<T: hindsight::contract::Message>(
        &self,
        topic: &str,
        rewrite: impl Fn(&T, RawMessage) -> Option<RawMessage>,
    ) -> Simulated {
        let bytes = to_bytes(WriterOptions::default(), |w| {
            if let Ok(mission) = self.log.mission() {
                w.write_mission(&mission)?;
            }
            for (name, record) in self.log.metadata.iter().filter(|(n, _)| *n != "mission") {
                w.write_metadata(name, record.clone())?;
            }
            for m in mcap::MessageStream::new(&self.bytes).expect("an MCAP log") {
                let m = m.expect("a whole message");
                let c = &m.channel;
                let schema = c.schema.as_ref().expect("a schema");
                let raw = RawMessage {
                    schema_name: schema.name.clone(),
                    schema_text: String::from_utf8(schema.data.to_vec()).expect("a text schema"),
                    encoding: c.message_encoding.clone(),
                    data: m.data.to_vec(),
                    log_time: m.log_time,
                };
                let raw = if c.topic == topic {
                    let reading: T = serde_json::from_slice(&m.data).expect("a json message");
                    match rewrite(&reading, raw) {
                        Some(raw) => raw,
                        None => continue,
                    }
                } else {
                    raw
                };
                w.write_raw(
                    &c.topic,
                    &raw.schema_name,
                    &raw.schema_text,
                    &raw.encoding,
                    &raw.data,
                    raw.log_time,
                )?;
            }
            Ok(())
        })
        .expect("in-memory write");
        let log = read(&bytes);
        Simulated {
            bytes: bytes.into(),
            log,
        }
    }
}

/// The warnings of the plan, the start, the tuning and the forward pass.
pub fn pipeline_warnings(
    r: &hindsight::Reconstruction,
) -> Vec<&hindsight::recon::pipeline::Warning> {
    r.summary
        .warnings
        .iter()
        .filter_map(|w| match w {
            hindsight::reconstruction::Warning::Pipeline(p) => Some(p),
            _ => None,
        })
        .collect()
}

/// A scenario simulated with `seed`, read back.
pub fn simulated_log(scenario: &hindsight::sim::scenario::Scenario, seed: u64) -> Log {
    read(&simulated_bytes(scenario, seed))
}

/// The `hindsight` binary run with `args`.
pub fn hindsight(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_hindsight"))
        .args(args)
        .output()
        .expect("binary runs")
}

/// Standard error of a run, as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `hindsight COMMAND LOG --out OUT EXTRA...`.
pub fn run_on(
    command: &str,
    log: &std::path::Path,
    out: &std::path::Path,
    extra: &[&str],
) -> std::process::Output {
    let args = [
        command,
        log.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    hindsight(&[&args[..], extra].concat())
}

/// `hindsight simulate --scenario SCENARIO --seed SEED --out LOG`, which must succeed.
pub fn simulate_to(log: &std::path::Path, scenario: &str, seed: u64) {
    let seed = seed.to_string();
    let args = ["simulate", "--scenario", scenario, "--seed", &seed, "--out"];
    let o = hindsight(&[&args[..], &[log.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Asserts that a command was refused for bad input (exit 2) with a message containing
/// `words`.
pub fn assert_refused(o: &std::process::Output, words: &str) {
    assert_eq!(o.status.code(), Some(2), "{}", stderr(o));
    assert!(stderr(o).contains(words), "{words:?} not in {}", stderr(o));
}

/// The shipped sample log.
pub const SAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/sample-logs/survey-short-seed1.mcap"
);

/// The shipped pool sample log (attitude).
pub const POOL_SAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/sample-logs/pool-rectangle-seed1.mcap"
);

/// Every batch of a Parquet file.
pub fn read_parquet(path: &std::path::Path) -> Vec<arrow_array::RecordBatch> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// A folder of the shared material (`benchmarks/broad`, `vehicles`) that holds `marker`:
/// under `$HINDSIGHT_SHARED_DIR`, else `../shared` next to the repository, else
/// `/work/shared` (a clone elsewhere on the development machine).
pub fn shared_dir(sub: &str, marker: &str) -> std::path::PathBuf {
    shared_dir_if_any(sub, marker).unwrap_or_else(|| {
        panic!("shared {sub} (with {marker}) not found; set HINDSIGHT_SHARED_DIR")
    })
}

/// [`shared_dir`], or `None` where the shared material is absent.
pub fn shared_dir_if_any(sub: &str, marker: &str) -> Option<std::path::PathBuf> {
    use std::path::PathBuf;
    let tried: Vec<PathBuf> = std::env::var_os("HINDSIGHT_SHARED_DIR")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared"),
            PathBuf::from("/work/shared"),
        ])
        .map(|d| d.join(sub))
        .collect();
    tried.into_iter().find(|d| d.join(marker).is_file())
}

/// A reconstruction's forward and smoothed errors against the truth at its output epochs.
pub fn output_errors(
    truth: &[hindsight::contract::Truth],
    r: &hindsight::recon::Reconstruction,
) -> (
    Vec<hindsight::recon::score::EpochError>,
    Vec<hindsight::recon::score::EpochError>,
) {
    let pick = |sol| hindsight::recon::score::errors(truth, sol, &r.output).unwrap();
    (pick(&r.forward), pick(&r.smoothed))
}

/// Largest distance between the positions of two solution lists, m.
pub fn largest_difference(
    a: &hindsight::recon::Reconstruction,
    b: &hindsight::recon::Reconstruction,
) -> f64 {
    const R: f64 = 6_378_137.0;
    let pairs = |x: &[hindsight::filters::ins::record::Solution],
                 y: &[hindsight::filters::ins::record::Solution]| {
        assert_eq!(x.len(), y.len());
        x.iter()
            .zip(y)
            .map(|(p, q)| {
                assert_eq!(p.stamp_ns, q.stamp_ns);
                let (p, q) = (&p.point.nav, &q.point.nav);
                let north = (p.lat_rad - q.lat_rad) * R;
                let east = (p.lon_rad - q.lon_rad) * R * p.lat_rad.cos();
                (north * north + east * east + (p.height_m - q.height_m).powi(2)).sqrt()
            })
            .fold(0.0, f64::max)
    };
    let all = |s: &hindsight::filters::ins::solutions::Solutions| s.to_vec().unwrap();
    pairs(&all(&a.forward), &all(&b.forward)).max(pairs(&all(&a.smoothed), &all(&b.smoothed)))
}

/// Asserts that two reconstructions of the same mission (`name`: how the second was read)
/// agree within a millimetre everywhere, forward and smoothed.
pub fn assert_within_a_millimetre(
    name: &str,
    a: &hindsight::recon::Reconstruction,
    b: &hindsight::recon::Reconstruction,
) {
    let d = largest_difference(a, b);
    println!("{name}: largest position difference {d:.2e} m");
    assert!(d < 1e-3, "{name}: {d} m");
}

/// A batch's column `name` as the array type `T` it must have.
pub fn column<'a, T: 'static>(batch: &'a arrow_array::RecordBatch, name: &str) -> &'a T {
    batch
        .column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<T>()
        .unwrap_or_else(|| panic!("column {name} of another type"))
}

/// The float columns of a Parquet file, concatenated over its batches.
pub fn float_columns(path: &std::path::Path) -> Vec<(String, Vec<f64>)> {
    use arrow_array::{Array, Float64Array};
    let batches = read_parquet(path);
    let schema = batches[0].schema();
    let mut out = Vec::new();
    for (i, field) in schema.fields().iter().enumerate() {
        let mut values = Vec::new();
        for b in &batches {
            let Some(c) = b.column(i).as_any().downcast_ref::<Float64Array>() else {
                break;
            };
            values.extend((0..c.len()).map(|k| if c.is_null(k) { f64::NAN } else { c.value(k) }));
        }
        if !values.is_empty() {
            out.push((field.name().clone(), values));
        }
    }
    out
}

/// What stands in for a log's absent mission record: the given mission's origin, vehicle and
/// declination (as a user gives them with --origin and --declination).
pub fn defaults_of(mission: &hindsight::ingest::Mission) -> hindsight::ingest::MissionDefaults {
    hindsight::ingest::MissionDefaults {
        origin_latitude_deg: Some(mission.origin_latitude_deg),
        origin_longitude_deg: Some(mission.origin_longitude_deg),
        vehicle: Some(mission.vehicle.clone()),
        magnetic_declination_deg: mission.magnetic_declination_deg,
    }
}

/// Asserts that two Parquet files have the same float columns, each within 1e-3 (positions
/// within 1 mm; angles, `_rad`, on the circle; scores), and prints the largest differences.
pub fn assert_same_float_columns(a: &std::path::Path, b: &std::path::Path, what: &str) {
    let (a, b) = (float_columns(a), float_columns(b));
    assert!(!a.is_empty() && a.len() == b.len(), "{what}");
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert_eq!(x.len(), y.len(), "{what} {name}");
        let worst = x
            .iter()
            .zip(y)
            .filter(|(p, q)| !(p.is_nan() && q.is_nan()))
            .map(|(p, q)| match name.ends_with("_rad") {
                true => hindsight::angle::wrap_pi(p - q).abs(),
                false => (p - q).abs(),
            })
            .fold(0.0, f64::max);
        println!("{what} {name}: largest difference {worst:.1e}");
        assert!(worst < 1e-3, "{what} {name}: differs by {worst}");
    }
}

/// A path inside the repository (`sample-logs/...`, `tests/fixtures/...`).
pub fn repo_path(relative: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// A test that cannot run here (`missing` says what is missing) skips, saying so on stderr
/// (`skipped`), unless the environment variable `require` is set, as CI sets it: then it
/// fails.
pub fn skip_unless_required(require: &str, missing: &str, skipped: &str) {
    assert!(
        std::env::var_os(require).is_none(),
        "{require} is set, but {missing}"
    );
    eprintln!("{skipped}");
}

/// What the simulator recorded of its USBL (`usbl_truth`), which the reconstruction never
/// reads: the receipt delay and which observations were multipath outliers.
pub struct UsblTruth {
    pub receipt_delay_s: f64,
    /// The outliers' stamps of receipt, ns.
    pub outlier_receipts_ns: std::collections::BTreeSet<i64>,
}

impl Simulated {
    pub fn usbl_truth(&self) -> UsblTruth {
        let truth = &self.log.metadata["usbl_truth"];
        UsblTruth {
            receipt_delay_s: truth["receipt_delay_s"].parse().unwrap(),
            outlier_receipts_ns: truth["outlier_receipt_stamps_ns"]
                .split(',')
                .filter(|s| !s.is_empty())
                .map(|s| s.parse().unwrap())
                .collect(),
        }
    }
}

/// A source's readings as the forward filter took them, told apart by the simulator's
/// outliers.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct Refusals {
    pub outliers: usize,
    pub outliers_refused: usize,
    pub good: usize,
    pub good_refused: usize,
}

impl Refusals {
    /// The `sensor`'s residuals, an outlier where `is_outlier` says so of its stamp.
    pub fn of(
        residuals: &[hindsight::filters::ins::driver::Residual],
        sensor: hindsight::filters::ins::aid_table::Sensor,
        is_outlier: impl Fn(i64) -> bool,
    ) -> Refusals {
        let mut r = Refusals::default();
        for res in residuals.iter().filter(|x| x.sensor == sensor) {
            let refused = usize::from(!res.accepted);
            if is_outlier(res.stamp_ns) {
                r.outliers += 1;
                r.outliers_refused += refused;
            } else {
                r.good += 1;
                r.good_refused += refused;
            }
        }
        r
    }

    /// Several runs' together.
    pub fn total<'a>(runs: impl IntoIterator<Item = &'a Refusals>) -> Refusals {
        runs.into_iter().fold(Refusals::default(), |a, r| Refusals {
            outliers: a.outliers + r.outliers,
            outliers_refused: a.outliers_refused + r.outliers_refused,
            good: a.good + r.good,
            good_refused: a.good_refused + r.good_refused,
        })
    }

    /// Issue 58's bars: at least 99 % of the outliers refused, at most 1 % of the good
    /// readings.
    pub fn assert_outliers_cannot_move_the_track(&self) {
        assert!(
            self.outliers_refused as f64 >= 0.99 * self.outliers as f64,
            "{} of {} outliers refused",
            self.outliers_refused,
            self.outliers
        );
        assert!(
            self.good_refused as f64 <= 0.01 * self.good as f64,
            "{} of {} good readings refused",
            self.good_refused,
            self.good
        );
    }
}

/// The good observations' median positioned sigma (their own noise and the ship's errors),
/// m, each placed at its stamp: the ship a few seconds off moves the sigma little.
pub fn median_positioned_sigma_m(log: &Simulated) -> f64 {
    let outliers = log.usbl_truth().outlier_receipts_ns;
    let config = hindsight::recon::config::Config::default();
    let aiding = config.usbl.aid(&config.acoustic_fix, true).unwrap();
    let received_ns = |o: &hindsight::contract::UsblObservation| {
        o.stamp_ns + o.received_after_s.map_or(0, |s| (s * 1e9).round() as i64)
    };
    let good: Vec<hindsight::contract::UsblObservation> =
        (log.role::<hindsight::contract::UsblObservation>().iter())
            .filter(|o| !outliers.contains(&received_ns(o)))
            .cloned()
            .collect();
    let aid = hindsight::filters::ins::usbl::UsblAid::new(
        &good,
        hindsight::recon::Streams::of(log).ship,
        &aiding,
    );
    let mut sigmas: Vec<f64> = aid.positioned_fixes().map(|f| f.sigma_m).collect();
    sigmas.sort_by(f64::total_cmp);
    sigmas[sigmas.len() / 2]
}

/// The acoustic receipt delay the plan estimated and used, s.
pub fn found_acoustic_delay_s(r: &hindsight::Reconstruction) -> Option<f64> {
    use hindsight::recon::plan::{Part, Why};
    let d = (r.summary.plan.decisions.iter()).find(|d| d.part == Part::AcousticFixDelay)?;
    match d.why {
        Why::EstimatedReceiptDelay { delay_s, .. } if d.used => Some(delay_s),
        _ => None,
    }
}

/// One seed's run with acoustic positions, against the simulator's truth.
#[derive(Debug)]
pub struct AcousticRun {
    pub seed: u64,
    pub true_delay_s: f64,
    pub found_delay_s: Option<f64>,
    /// The good readings' median horizontal sigma as positions, m.
    pub median_sigma_m: f64,
    pub smoothed_rms_m: f64,
    pub forward_rms_m: f64,
    pub forward_nees_inside: f64,
    pub smoothed_nees_inside: f64,
    pub refusals: Refusals,
}

impl AcousticRun {
    /// The run `r` of `log` scored: the `sensor`'s residuals told apart by `is_outlier` (of
    /// a residual's stamp), the output against `/truth`.
    pub fn of(
        (log, seed): (&Simulated, u64),
        r: &hindsight::Reconstruction,
        sensor: hindsight::filters::ins::aid_table::Sensor,
        median_sigma_m: f64,
        is_outlier: impl Fn(i64) -> bool,
    ) -> AcousticRun {
        use hindsight::recon::score::scores;
        let truth = log.usbl_truth();
        let refusals = Refusals::of(&r.solved.run.residuals, sensor, is_outlier);
        assert_eq!(
            refusals.outliers,
            truth.outlier_receipts_ns.len(),
            "every outlier reached the filter"
        );
        let (fwd, smo) = output_errors(hindsight::recon::Streams::of(log).truth, &r.solved);
        let (fwd, smo) = (scores(&fwd).unwrap(), scores(&smo).unwrap());
        AcousticRun {
            seed,
            true_delay_s: truth.receipt_delay_s,
            found_delay_s: found_acoustic_delay_s(r),
            median_sigma_m,
            smoothed_rms_m: smo.horizontal_rms_m,
            forward_rms_m: fwd.horizontal_rms_m,
            forward_nees_inside: fwd.nees_horizontal_inside_95,
            smoothed_nees_inside: smo.nees_horizontal_inside_95,
            refusals,
        }
    }

    /// The delay found within 0.1 s of the simulator's.
    pub fn assert_delay_found(&self) {
        let found = self.found_delay_s.expect("the delay estimated and used");
        assert!(
            (found - self.true_delay_s).abs() <= 0.1,
            "seed {}: delay {found:.3} s found, {:.3} s true",
            self.seed,
            self.true_delay_s
        );
    }

    /// The smoothed horizontal RMS at most half the median sigma, the forward one at most
    /// the median sigma.
    pub fn assert_placed(&self) {
        assert!(
            self.smoothed_rms_m <= 0.5 * self.median_sigma_m,
            "seed {}: smoothed RMS {:.2} m against a median sigma of {:.2} m",
            self.seed,
            self.smoothed_rms_m,
            self.median_sigma_m
        );
        assert!(self.forward_rms_m <= self.median_sigma_m, "{self:?}");
    }

    /// The runs' smoothed NEES inside its 95 % bounds, over the seeds.
    pub fn mean_smoothed_nees_inside(runs: &[AcousticRun]) -> f64 {
        runs.iter().map(|r| r.smoothed_nees_inside).sum::<f64>() / runs.len() as f64
    }

    /// Issue 58's bars of a USBL survey: on each seed the delay found, the track placed and
    /// the forward NEES inside its 95 % bounds for at least 90 % of the epochs; over the
    /// seeds the smoothed NEES likewise, and at least `min_outliers` outliers, which cannot
    /// move the track.
    pub fn assert_survey_bars(runs: &[AcousticRun], min_outliers: usize) {
        for run in runs {
            run.assert_delay_found();
            run.assert_placed();
            assert!(run.forward_nees_inside >= 0.9, "{run:?}");
        }
        let smoothed_nees = AcousticRun::mean_smoothed_nees_inside(runs);
        assert!(smoothed_nees >= 0.9, "{smoothed_nees}");
        let refusals = Refusals::total(runs.iter().map(|r| &r.refusals));
        assert!(
            refusals.outliers >= min_outliers,
            "{} outliers in {} seeds",
            refusals.outliers,
            runs.len()
        );
        refusals.assert_outliers_cannot_move_the_track();
    }
}
