//! A reconstruction as one library value: [`reconstruct`] takes a log and its settings and
//! returns a [`Reconstruction`] (the plan, the start, the tuning, both solutions, the
//! residuals, the scores against a truth, the consistency verdict and the typed warnings);
//! [`Reconstruction::write`] writes the output folder (`output::recon_folder`).
//!
//! `hindsight reconstruct`, `batch` and `study` call this one entry; the command line keeps
//! parsing, the console and its hints, told what happens through an [`Observer`].

pub mod summary;
pub mod warning;

use crate::align::{AlignError, ClockOffset};
use crate::contract::{MagneticField, Truth};
use crate::disk_backed::Spilled;
use crate::ingest::{IngestError, IngestOptions, Log, Mission, MissionDefaults, MissionError};
use crate::output::recon_blocks::{self, Scored};
use crate::output::recon_report::FromLog;
use crate::progress::Progress;
use crate::recon::config::Config;
use crate::recon::pipeline::{self, Stage};
use crate::recon::{AttitudeTrack, ReconError, Reconstruction as Solved, Streams};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
pub use summary::Summary;
pub use warning::Warning;

/// Where a log comes from.
#[derive(Debug, Clone)]
pub enum LogSource {
    /// A file or folder: MCAP, ROS 1 bag, rosbag2 (sqlite) bag.
    File(PathBuf),
    /// An MCAP log already in memory (a simulated one), named for messages.
    Memory { name: String, bytes: Arc<[u8]> },
}

impl LogSource {
    /// The name messages and `summary.json` give the log.
    pub fn name(&self) -> PathBuf {
        match self {
            LogSource::File(path) => path.clone(),
            LogSource::Memory { name, .. } => PathBuf::from(name),
        }
    }
}

/// One mission to reconstruct: the log, the settings, how to read it.
#[derive(Debug, Clone)]
pub struct Job {
    pub log: LogSource,
    pub config: Config,
    pub ingest: IngestOptions,
    /// Clock offsets applied to topics before anything else.
    pub offsets: Vec<ClockOffset>,
    /// The mission where the log has no record of it.
    pub mission_defaults: MissionDefaults,
    /// The attitude the model-aided velocity is driven by, from a reconstruction of the same
    /// log whose settings differ only in `[model_velocity]` (its
    /// [`Reconstruction::model_attitude`]), instead of a pass of its own.
    pub shared_attitude: Option<AttitudeTrack>,
}

impl Job {
    /// The log reconstructed with `config` and nothing else: its topics, frames and ROS 2
    /// conversions from the settings, no clock offsets.
    pub fn new(log: &Path, config: Config) -> Job {
        Job::of(LogSource::File(log.to_path_buf()), config)
    }

    /// An MCAP log in memory, named `name`, reconstructed with `config` as [`Job::new`] says.
    pub fn in_memory(name: &str, bytes: Arc<[u8]>, config: Config) -> Job {
        let name = name.to_string();
        Job::of(LogSource::Memory { name, bytes }, config)
    }

    fn of(log: LogSource, config: Config) -> Job {
        let ingest = IngestOptions {
            topics: config.topics.clone(),
            frame_conventions: config.frames.clone(),
            ros2: config.ros2,
            keep_log_times: false,
            ..IngestOptions::default()
        };
        Job {
            log,
            mission_defaults: config.mission.clone(),
            ingest,
            offsets: Vec::new(),
            shared_attitude: None,
            config,
        }
    }
}

/// What the reconstruction tells as it goes, for a console or a notebook to show.
#[derive(Debug)]
pub enum Note<'a> {
    /// The log is being read: its size in bytes (`None`: a database, read whole).
    Reading { bytes: Option<u64> },
    /// A warning of the reading (dropped messages, roles found by type).
    ReadWarning(String),
    /// A warning of the mission's origin.
    MissionWarning(String),
    /// The log is read.
    Read { log: &'a Log, seconds: f64 },
    /// The forward pass is done: the plan, the tuning and the start are known.
    Forward(&'a pipeline::Forward),
    /// The smoother is done.
    Smoothed { seconds: f64 },
}

/// Who is told what happens: every member optional.
#[derive(Default, Clone, Copy)]
pub struct Observer<'a> {
    pub on_note: Option<&'a (dyn Fn(Note<'_>) + Sync)>,
    pub on_stage: Option<&'a dyn Fn(Stage)>,
    /// The fraction of the log's bytes read.
    pub read_progress: Progress<'a>,
    pub forward_progress: Progress<'a>,
    pub smoother_progress: Progress<'a>,
}

impl Observer<'_> {
    fn note(&self, note: Note<'_>) {
        if let Some(tell) = self.on_note {
            tell(note);
        }
    }
}

/// Why a reconstruction failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("reading {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: Box<IngestError>,
    },
    #[error("aligning {}", path.display())]
    Align {
        path: PathBuf,
        #[source]
        source: Box<AlignError>,
    },
    #[error("reading {}", path.display())]
    Mission {
        path: PathBuf,
        #[source]
        source: Box<MissionError>,
    },
    #[error("reconstructing {}", path.display())]
    Reconstruct {
        path: PathBuf,
        #[source]
        source: Box<ReconError>,
    },
    /// The solutions or the truth could not be read back from their temporary files.
    #[error("{what}")]
    ReadBack {
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Write(#[from] crate::output::WriteError),
}

/// A whole reconstruction: what `summary.json` holds, both solutions and what the outputs
/// draw.
pub struct Reconstruction {
    /// Everything `summary.json` holds; its run times of the outputs are filled as they are
    /// written.
    pub summary: Summary,
    /// The start, the magnetometer's preparation, the forward pass's residuals and counts,
    /// and both solutions (on temporary files for a long mission).
    pub solved: Solved,
    /// Every epoch written as a trajectory row (ascending).
    pub kept_rows: Vec<usize>,
    /// The mission origin, radians.
    pub origin_rad: (f64, f64),
    /// What the report draws of the log.
    pub from_log: FromLog,
    /// The solutions' errors against the truth, the distance, the rows the report draws.
    pub scored: Scored,
    /// The attitude the model-aided velocity was driven by, to share with a reconstruction
    /// of the same log ([`Job::shared_attitude`]).
    pub model_attitude: Option<AttitudeTrack>,
    pub(crate) truth: TruthKept,
    pub(crate) started: Instant,
}

/// The log's truth, kept for the errors table: in memory, or on a temporary file.
pub(crate) enum TruthKept {
    None,
    Held(Vec<Truth>),
    Parked(Spilled<Truth>),
}

impl TruthKept {
    pub(crate) fn is_empty(&self) -> bool {
        match self {
            TruthKept::None => true,
            TruthKept::Held(t) => t.is_empty(),
            TruthKept::Parked(t) => t.is_empty(),
        }
    }

    /// The truth read back (a day of it is 140 MB: held only while the errors are taken).
    pub(crate) fn read(&self) -> Result<Vec<Truth>, Error> {
        match self {
            TruthKept::None => Ok(Vec::new()),
            TruthKept::Held(t) => Ok(t.clone()),
            TruthKept::Parked(t) => t.to_vec().map_err(|source| Error::ReadBack {
                what: "reading the truth back",
                source,
            }),
        }
    }
}

/// Reads the log, runs the pipeline (plan, start, tuning, forward pass, smoother) and scores
/// the solutions: the library's one entry.
pub fn reconstruct(job: &Job, observer: Observer<'_>) -> Result<Reconstruction, Error> {
    let started = Instant::now();
    let mut log = read(job, observer)?;
    let mission = log
        .settle_mission(&job.mission_defaults)
        .map_err(|source| Error::Mission {
            path: job.log.name(),
            source: Box::new(source),
        });
    let (mission, notes) = mission?;
    notes
        .into_iter()
        .for_each(|w| observer.note(Note::MissionWarning(w)));
    let ingest_s = started.elapsed().as_secs_f64();
    observer.note(Note::Read {
        log: &log,
        seconds: ingest_s,
    });
    let mut run = solve(job, &mission, log, observer)?;
    let truth = std::mem::replace(&mut run.truth, TruthKept::None);
    // Read back once for the scores and the report's track (a day of it is 140 MB).
    let truth_read = truth.read()?;
    let scored = score(&run.outcome.reconstruction, &run.kept_rows, &truth_read)?;
    let summary = summary::build(&summary::Parts {
        job,
        mission: &mission,
        run: &run,
        scored: &scored,
        ingest_s,
        started,
    })?;
    let from_log = run.from_log.with_truth(&truth_read);
    drop(truth_read);
    Ok(Reconstruction {
        summary,
        model_attitude: run.outcome.model_attitude,
        solved: run.outcome.reconstruction,
        kept_rows: run.kept_rows,
        origin_rad: run.origin_rad,
        from_log,
        scored,
        truth,
        started,
    })
}

impl Reconstruction {
    /// Writes every file of the output folder into `dir` (created if missing), all renamed
    /// into place together; returns their paths.
    pub fn write(&mut self, dir: &Path) -> Result<Vec<PathBuf>, Error> {
        crate::output::recon_folder::write(self, dir)
    }

    /// The output folder's tables as Arrow batches in memory (trajectory, residuals and
    /// errors), as the files hold them.
    pub fn tables(&self) -> Result<crate::output::recon_arrow::ArrowTables, Error> {
        crate::output::recon_arrow::tables(self)
    }
}

/// The log, read and put on one clock.
fn read(job: &Job, observer: Observer<'_>) -> Result<Log, Error> {
    let failed = |source| Error::Read {
        path: job.log.name(),
        source: Box::new(source),
    };
    let mut log = match &job.log {
        LogSource::File(path) => read_file(path, &job.ingest, observer).map_err(failed)?,
        LogSource::Memory { bytes, .. } => {
            observer.note(Note::Reading {
                bytes: Some(bytes.len() as u64),
            });
            crate::ingest::read_log_from(&bytes[..], &job.ingest).map_err(failed)?
        }
    };
    crate::align::apply_offsets(&mut log, &job.offsets).map_err(|source| Error::Align {
        path: job.log.name(),
        source: Box::new(source),
    })?;
    for w in log.warnings() {
        observer.note(Note::ReadWarning(w));
    }
    Ok(log)
}

/// A log file read as `ingest` says, its reading's progress told.
fn read_file(
    path: &Path,
    ingest: &IngestOptions,
    observer: Observer<'_>,
) -> Result<Log, IngestError> {
    if crate::ingest::sqlite::bag_at(path)?.is_some() {
        observer.note(Note::Reading { bytes: None });
        return crate::ingest::read_log(path, ingest);
    }
    let file = std::fs::File::open(path)?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    observer.note(Note::Reading { bytes: Some(size) });
    let counted = crate::progress::ReadProgress::new(file, size, observer.read_progress);
    let input = std::io::BufReader::with_capacity(1 << 20, counted);
    crate::ingest::read_log_from(input, ingest)
}

/// The pipeline's outcome and what the outputs need from the log, which is freed before the
/// smoother (a day-long mission's log and its records would not fit together).
pub(crate) struct Solve {
    pub(crate) outcome: pipeline::Outcome,
    pub(crate) inputs: Vec<summary::InputCount>,
    pub(crate) kept_rows: Vec<usize>,
    pub(crate) origin_rad: (f64, f64),
    pub(crate) from_log: FromLog,
    pub(crate) truth: TruthKept,
    pub(crate) records_failure: Option<String>,
}

fn solve(
    job: &Job,
    mission: &Mission,
    mut log: Log,
    observer: Observer<'_>,
) -> Result<Solve, Error> {
    // What the filter does not need, or needs prepared, leaves the log: a day's truth waits
    // on disk, and its magnetometer is prepared in place (each would be 150 MB held twice).
    let parked = park_truth(&mut log, &job.config);
    let mag = (job.config.mag.enabled).then(|| log.take_role::<MagneticField>());
    let beacons = crate::contract::beacons::merged(&job.config.lbl.beacons, &log.beacons);
    let streams = Streams {
        beacons: &beacons,
        ..Streams::of(&log)
    };
    let options = pipeline::Options {
        forward_progress: observer.forward_progress,
        on_stage: observer.on_stage,
        mag,
        shared_attitude: job.shared_attitude.clone(),
    };
    let failed = |source| Error::Reconstruct {
        path: job.log.name(),
        source: Box::new(source),
    };
    let forward = pipeline::forward(&streams, mission, &job.config, options).map_err(failed)?;
    observer.note(Note::Forward(&forward));
    let inputs = summary::input_counts(&log, &streams, &forward.config);
    let origin_rad = (
        mission.origin_latitude_deg.to_radians(),
        mission.origin_longitude_deg.to_radians(),
    );
    let from_log = FromLog::new(streams.gnss, streams.fixes, streams.dvl, origin_rad);
    let truth = match parked {
        Some(p) => TruthKept::Parked(p),
        None => TruthKept::Held(streams.truth.to_vec()),
    };
    drop(log);
    let records_failure = forward.pass.run.records.spill_failure();
    let outcome = forward
        .smooth(observer.smoother_progress, observer.on_stage)
        .map_err(failed)?;
    observer.note(Note::Smoothed {
        seconds: outcome.times.smoother_s,
    });
    let kept_rows = kept_rows(&outcome.reconstruction, &outcome.config);
    Ok(Solve {
        outcome,
        inputs,
        kept_rows,
        origin_rad,
        from_log,
        truth,
        records_failure,
    })
}

/// The rows the outputs hold: every output epoch (and every epoch with `aiding_epochs`).
fn kept_rows(r: &Solved, config: &Config) -> Vec<usize> {
    (0..r.forward.len())
        .filter(|&k| r.output[k] || config.output.aiding_epochs)
        .collect()
}

/// The log's truth moved to a temporary file (it is for the scores, after the filter), unless
/// the run starts from it.
fn park_truth(log: &mut Log, config: &Config) -> Option<Spilled<Truth>> {
    if config.initial.from_truth {
        return None;
    }
    Some(log.take_role::<Truth>().into_iter().collect())
}

/// The solutions read back once, scored against the truth.
fn score(r: &Solved, keep: &[usize], truth: &[Truth]) -> Result<Scored, Error> {
    let (to_scores, blocks) = recon_blocks::channel();
    let sample_rows = recon_blocks::sample_rows(keep);
    std::thread::scope(|s| {
        let scores = s.spawn(|| recon_blocks::score(blocks, truth, &sample_rows, None));
        let read = recon_blocks::read_blocks(r, keep, vec![to_scores]);
        let scored = scores
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        read.map(|()| scored)
    })
    .map_err(|source| Error::ReadBack {
        what: "reading the solutions back",
        source,
    })
}
