//! A reconstruction's solutions read back a block of epochs at a time.
//!
//! After the smoother the forward and smoothed solutions wait on temporary files (a day's
//! mission holds a million of each). Each read hands every block to threads of their own:
//! - to score them ([`score`], in the library's entry): the errors against the truth, the
//!   distance travelled and the rows the report draws ([`Scored`]), which the summary and
//!   the report are made from;
//! - to write them (`recon_folder`): trajectory.parquet (each block's forward rows, then its
//!   smoothed rows; then residuals.parquet), trajectory.mcap (both solutions' messages, row
//!   by row) and errors.parquet (each block's errors, from a scorer that hands them on).

use super::files::Folder;
use super::parquet::{write_batches, TableWriter, ROWS_PER_BATCH};
use super::recon_report::{self as report, Samples};
use super::recon_tables;
use super::WriteError;
use crate::contract::Truth;
use crate::filters::ins::record::Solution;
use crate::recon::score::{self, EpochError};
use crate::recon::stats::Distance;
use crate::recon::Reconstruction;
use arrow_array::RecordBatch;
use arrow_schema::ArrowError;
use std::path::PathBuf;
use std::sync::{mpsc, Arc};

/// Epochs read back at a time (two solutions of them are 35 MB).
const BLOCK_EPOCHS: usize = ROWS_PER_BATCH / 2;

/// A block of epochs: both solutions at every epoch from `first`, and the kept rows among
/// them.
pub struct Block {
    first: usize,
    forward: Vec<Solution>,
    smoothed: Vec<Solution>,
    /// The kept epochs in the block (indices from the run's first epoch, ascending).
    kept: Vec<usize>,
}

impl Block {
    /// Both solutions at each kept row.
    fn rows(&self) -> impl Iterator<Item = (&Solution, &Solution)> + '_ {
        self.kept.iter().map(|&k| {
            (
                &self.forward[k - self.first],
                &self.smoothed[k - self.first],
            )
        })
    }

    /// One solution's kept rows.
    fn kept_of(&self, all: &[Solution]) -> Vec<Solution> {
        self.kept.iter().map(|&k| all[k - self.first]).collect()
    }
}

/// Reads the solutions back a block at a time and hands every block to each of `to`, in
/// order. Stops at a read that fails (its error), or when a writer hangs up (it failed, and
/// its own error says why).
pub fn read_blocks(
    r: &Reconstruction,
    keep: &[usize],
    to: Vec<mpsc::SyncSender<Arc<Block>>>,
) -> std::io::Result<()> {
    let n = r.forward.len();
    let mut rest = keep;
    for first in (0..n).step_by(BLOCK_EPOCHS) {
        let end = (first + BLOCK_EPOCHS).min(n);
        let (forward, smoothed) = rayon::join(
            || r.forward.read(first..end),
            || r.smoothed.read(first..end),
        );
        let taken = rest.partition_point(|&k| k < end);
        let block = Arc::new(Block {
            first,
            forward: forward?,
            smoothed: smoothed?,
            kept: rest[..taken].to_vec(),
        });
        rest = &rest[taken..];
        for tx in &to {
            if tx.send(Arc::clone(&block)).is_err() {
                return Ok(());
            }
        }
    }
    Ok(())
}

/// A channel of blocks, as deep as one block being worked on and one waiting.
pub fn channel() -> (mpsc::SyncSender<Arc<Block>>, mpsc::Receiver<Arc<Block>>) {
    mpsc::sync_channel(1)
}

/// A staged output file and its path, for messages.
pub type Staged = (PathBuf, std::fs::File);

/// Any error of a writer, said with the file's path by [`WriteError`].
type AnyError = Box<dyn std::error::Error + Send + Sync>;

type Result<T, E = WriteError> = std::result::Result<T, E>;

/// trajectory.parquet from the blocks: each block's forward rows, then its smoothed rows.
pub fn trajectory_parquet(
    (path, file): Staged,
    blocks: mpsc::Receiver<Arc<Block>>,
    origin_rad: (f64, f64),
) -> Result<()> {
    let write = || -> Result<(), AnyError> {
        let schema = recon_tables::trajectory_batch("forward", &[], origin_rad)?.schema();
        let mut w = TableWriter::new(file, schema)?;
        for b in blocks {
            for batch in trajectory_batches(&b, origin_rad)? {
                w.write(&batch)?;
            }
        }
        w.finish()?;
        Ok(())
    };
    write().map_err(WriteError::at(&path))
}

/// A block's rows of trajectory.parquet: its forward rows, then its smoothed rows (none
/// when it keeps no row).
pub fn trajectory_batches(
    b: &Block,
    origin_rad: (f64, f64),
) -> Result<Vec<RecordBatch>, ArrowError> {
    if b.kept.is_empty() {
        return Ok(Vec::new());
    }
    [("forward", &b.forward), ("smoothed", &b.smoothed)]
        .into_iter()
        .map(|(name, all)| recon_tables::trajectory_batch(name, &b.kept_of(all), origin_rad))
        .collect()
}

/// trajectory.mcap from the blocks: the forward and smoothed solutions at each row as
/// Foxglove messages (a LocationFix on `/hindsight/<solution>/fix`, a PoseInFrame on
/// `/hindsight/<solution>/pose`, ROS 2 CDR), logged at their stamps.
pub fn trajectory_mcap(
    (path, file): Staged,
    blocks: mpsc::Receiver<Arc<Block>>,
    origin_rad: (f64, f64),
) -> Result<()> {
    use crate::output::foxglove::{
        location_fix, pose_in_frame, LOCATION_FIX, LOCATION_FIX_MSG, POSE_IN_FRAME,
        POSE_IN_FRAME_MSG,
    };
    use crate::sim::writer::{Compression, LogWriter, WriterOptions};
    let write = || -> Result<(), AnyError> {
        // lz4: a tenth of zstd's time for this output, which Foxglove and the mcap tools
        // read alike.
        let options = WriterOptions {
            compression: Compression::Lz4,
            ..WriterOptions::default()
        };
        let mut w = LogWriter::new(std::io::BufWriter::new(file), options)?;
        let topics = ["forward", "smoothed"].map(|name| {
            (
                name,
                format!("/hindsight/{name}/fix"),
                format!("/hindsight/{name}/pose"),
            )
        });
        let mut data = Vec::with_capacity(256);
        for b in blocks {
            for (f, s) in b.rows() {
                let t = u64::try_from(f.stamp_ns).unwrap_or(0);
                for (solution, (frame, fix_topic, pose_topic)) in [f, s].into_iter().zip(&topics) {
                    location_fix(solution, frame, &mut data)?;
                    w.write_raw(fix_topic, LOCATION_FIX, LOCATION_FIX_MSG, "cdr", &data, t)?;
                    pose_in_frame(solution, origin_rad, "map", &mut data)?;
                    w.write_raw(
                        pose_topic,
                        POSE_IN_FRAME,
                        POSE_IN_FRAME_MSG,
                        "cdr",
                        &data,
                        t,
                    )?;
                }
            }
        }
        std::io::Write::flush(&mut w.finish()?)?;
        Ok(())
    };
    write().map_err(WriteError::at(&path))
}

/// A solution's errors against the truth at the kept rows: their running scores, and what
/// the report draws of them.
#[derive(Debug, Default)]
pub struct SolutionErrors {
    pub sums: score::ScoreSums,
    pub points: Vec<report::ErrorPoint>,
}

impl SolutionErrors {
    fn add(&mut self, rows: &[EpochError]) {
        for e in rows {
            self.sums.add(e);
            self.points.push(e.into());
        }
    }
}

/// What the outputs take from the solutions besides the tables.
pub struct Scored {
    /// The forward and smoothed solutions' errors against the truth (logs with a truth).
    pub errors: Option<(SolutionErrors, SolutionErrors)>,
    /// Along the smoothed solution, every epoch.
    pub distance_m: f64,
    /// The rows the report draws.
    pub samples: Samples,
}

/// A block's errors against the truth: the forward solution's, then the smoothed one's.
pub type BlockErrors = (Vec<EpochError>, Vec<EpochError>);

/// The scores from the blocks: errors against `truth` (none when it is empty), each block's
/// also handed to `errors_to` (errors.parquet's writer), the distance travelled, and both
/// solutions at `sample_rows` (ascending, among the kept rows).
pub fn score(
    blocks: mpsc::Receiver<Arc<Block>>,
    truth: &[Truth],
    sample_rows: &[usize],
    errors_to: Option<mpsc::SyncSender<BlockErrors>>,
) -> Scored {
    let mut errors = (!truth.is_empty()).then(<(SolutionErrors, SolutionErrors)>::default);
    let mut distance = Distance::default();
    let mut samples = Samples::default();
    let mut samples_left = sample_rows;
    for b in blocks {
        b.smoothed.iter().for_each(|s| distance.add(s));
        if let Some((fwd, smo)) = errors.as_mut() {
            let (mut block_fwd, mut block_smo) = (Vec::new(), Vec::new());
            for (f, s) in b.rows() {
                block_fwd.extend(score::epoch_error(truth, f));
                block_smo.extend(score::epoch_error(truth, s));
            }
            fwd.add(&block_fwd);
            smo.add(&block_smo);
            // A writer that hung up has failed, and says why itself.
            if let Some(to) = &errors_to {
                let _ = to.send((block_fwd, block_smo));
            }
        }
        let end = b.first + b.forward.len();
        let taken = samples_left.partition_point(|&k| k < end);
        for &k in &samples_left[..taken] {
            samples.forward.push(b.forward[k - b.first]);
            samples.smoothed.push(b.smoothed[k - b.first]);
        }
        samples_left = &samples_left[taken..];
    }
    Scored {
        errors,
        distance_m: distance.total_m,
        samples,
    }
}

/// The table files of a run, created (staged) before they are written.
pub struct Tables {
    pub trajectory: Staged,
    pub foxglove: Staged,
    pub residuals: Staged,
    pub errors: Option<Staged>,
}

impl Tables {
    pub fn create(folder: &mut Folder, with_errors: bool) -> Result<Tables> {
        Ok(Tables {
            trajectory: folder.staged("trajectory.parquet")?,
            foxglove: folder.staged("trajectory.mcap")?,
            residuals: folder.staged("residuals.parquet")?,
            errors: if with_errors {
                Some(folder.staged("errors.parquet")?)
            } else {
                None
            },
        })
    }
}

/// A table of `rows`, a batch at a time.
pub fn write_chunks<T>(
    (path, file): Staged,
    rows: &[T],
    batch: impl Fn(&[T]) -> Result<arrow_array::RecordBatch, arrow_schema::ArrowError>,
) -> Result<()> {
    let mut chunks = rows.chunks(ROWS_PER_BATCH);
    let write = || -> Result<(), AnyError> {
        let first = batch(chunks.next().unwrap_or(&[]))?;
        write_batches(file, first, || chunks.next().map(&batch))?;
        Ok(())
    };
    write().map_err(WriteError::at(&path))
}

/// errors.parquet from the blocks' errors: each block's forward rows, then its smoothed rows.
pub fn errors_parquet((path, file): Staged, blocks: mpsc::Receiver<BlockErrors>) -> Result<()> {
    let write = || -> Result<(), AnyError> {
        let schema = recon_tables::errors_batch("forward", &[])?.schema();
        let mut w = TableWriter::new(file, schema)?;
        for block in blocks {
            for batch in errors_batches(&block)? {
                w.write(&batch)?;
            }
        }
        w.finish()?;
        Ok(())
    };
    write().map_err(WriteError::at(&path))
}

/// A block's rows of errors.parquet: its forward rows, then its smoothed rows.
pub fn errors_batches((fwd, smo): &BlockErrors) -> Result<Vec<RecordBatch>, ArrowError> {
    [("forward", fwd), ("smoothed", smo)]
        .into_iter()
        .filter(|(_, rows)| !rows.is_empty())
        .map(|(name, rows)| recon_tables::errors_batch(name, rows))
        .collect()
}

/// A thread's result; its panic goes on.
pub fn joined<T>(thread: std::thread::ScopedJoinHandle<'_, T>) -> T {
    thread
        .join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// The rows the report draws: a picture thins to a few thousand points anyway, and a
/// day-long mission has a million rows.
pub fn sample_rows(keep: &[usize]) -> Vec<usize> {
    report::spread(keep, report::REPORT_ROWS)
}
