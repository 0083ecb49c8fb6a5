//! Reads a recorded log (MCAP with json, ROS 2 or ROS 1 messages; a ROS 1 bag; a ROS 2
//! sqlite3 bag) into typed, time-sorted streams with a report of everything that was wrong
//! with it.
//!
//! The file is streamed ([`reader`], [`bag`]; a sqlite3 bag is read by SQLite, [`sqlite`]);
//! each message is decoded by the decoder registered for its schema name ([`decode`]),
//! validated, and appended to its topic's typed store. Nothing of the raw file is kept. At the end each stream is sorted by `stamp_ns` (stably), duplicates are
//! dropped, and its timing statistics are computed ([`stats`]).
//!
//! May import: `contract`, `time`, `mcap`, `serde_json`, `bzip2`, `lz4`, `zstd`, `rusqlite`.

pub mod bag;
mod builder;
pub mod decode;
mod error;
mod log;
mod mission;
mod reader;
pub mod roles;
pub mod ros;
mod samples;
pub mod sqlite;
pub mod stats;

pub use error::{IngestError, MessageIssue};
pub use mission::{Mission, MissionDefaults, MissionError};
pub use reader::Ending;
pub use roles::{RoleChoice, RoleError, RoleSource};
pub use samples::Samples;

pub use log::{
    Container, FileReport, Held, IngestOptions, LayoutCheck, Log, SkippedTopic, Stream,
    StreamCounts,
};

use builder::Builder;
use mcap::records::Record;
use std::io::Read;
use std::path::Path;

/// Reads the log at `path`: an MCAP file, a ROS 1 bag, or a ROS 2 sqlite3 bag (its folder or
/// its `.db3` file).
pub fn read_log(path: &Path, options: &IngestOptions) -> Result<Log, IngestError> {
    if let Some(bag) = sqlite::bag_at(path)? {
        return read_records(options, |on_record| {
            let read = sqlite::for_each_record(&bag, on_record)?;
            Ok((Container::Ros2Sqlite, read))
        });
    }
    let file = std::fs::File::open(path)?;
    read_log_from(std::io::BufReader::with_capacity(1 << 20, file), options)
}

/// Reads a log from any byte source (a file, a slice in tests).
///
/// With more than one core, the messages are decoded on other threads (up to
/// [`IngestOptions::decode_threads`]) while this one reads and decompresses the next chunks;
/// the log read is the same.
pub fn read_log_from<R: Read>(input: R, options: &IngestOptions) -> Result<Log, IngestError> {
    read_records(options, |on_record| for_each_record(input, on_record))
}

/// The records a container walk hands on, built into a log.
type Walked = Result<(Container, (Ending, u64)), IngestError>;

/// Builds a log from the records `walk` hands on, decoding on other threads with more than
/// one core.
fn read_records(
    options: &IngestOptions,
    walk: impl FnOnce(&mut dyn FnMut(Record<'_>) -> Result<(), IngestError>) -> Walked,
) -> Result<Log, IngestError> {
    let threads = options.decode_threads.min(
        std::thread::available_parallelism()
            .map(usize::from)
            .unwrap_or(1),
    );
    if threads <= 1 {
        return read_with(walk, options, None);
    }
    std::thread::scope(|scope| {
        read_with(
            walk,
            options,
            Some(builder::DecodePool::start(scope, options, threads)),
        )
    })
}

fn read_with(
    walk: impl FnOnce(&mut dyn FnMut(Record<'_>) -> Result<(), IngestError>) -> Walked,
    options: &IngestOptions,
    pool: Option<builder::DecodePool<'_>>,
) -> Result<Log, IngestError> {
    let mut b = Builder::new(options, pool);
    let (container, (ending, bytes_read)) = walk(&mut |record| b.on_record(record))?;
    b.finish(container, ending, bytes_read)
}

/// Walks the records of a log in a streamed container (MCAP, or a ROS 1 bag as the MCAP
/// records it would convert to), told apart by their first bytes.
fn for_each_record<R: Read>(
    mut input: R,
    on_record: impl FnMut(Record<'_>) -> Result<(), IngestError>,
) -> Result<(Container, (Ending, u64)), IngestError> {
    let mut head = [0u8; 16];
    let got = reader::read_up_to(&mut input, &mut head)?;
    let head = &head[..got];
    let container = Container::of(head);
    let input = std::io::Cursor::new(head).chain(input);
    let read = match container {
        Container::Mcap => reader::for_each_record(input, on_record)?,
        Container::Ros1Bag => bag::for_each_record(input, on_record)?,
        Container::Ros2Sqlite => return Err(IngestError::SqliteFromStream),
    };
    Ok((container, read))
}

/// Container-level totals of a log, without decoding messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanTotals {
    pub messages: u64,
    /// Sum of message payload sizes (the JSON text).
    pub payload_bytes: u64,
    pub ending: Ending,
}

/// Walks the container (decompressing chunks) and counts messages without decoding them:
/// the floor under any full read, used by `hindsight bench` to show where the time goes.
pub fn scan<R: Read>(input: R) -> Result<ScanTotals, IngestError> {
    scan_with(|on_record| for_each_record(input, on_record))
}

/// [`scan`] of the log at `path`, in any container [`read_log`] reads.
pub fn scan_log(path: &Path) -> Result<ScanTotals, IngestError> {
    if let Some(bag) = sqlite::bag_at(path)? {
        return scan_with(|on_record| {
            Ok((
                Container::Ros2Sqlite,
                sqlite::for_each_record(&bag, on_record)?,
            ))
        });
    }
    let file = std::fs::File::open(path)?;
    scan(std::io::BufReader::with_capacity(1 << 20, file))
}

fn scan_with(
    walk: impl FnOnce(&mut dyn FnMut(Record<'_>) -> Result<(), IngestError>) -> Walked,
) -> Result<ScanTotals, IngestError> {
    let (mut messages, mut payload_bytes, mut in_summary) = (0u64, 0u64, false);
    let (_, (ending, _)) = walk(&mut |record| {
        match record {
            Record::Message { data, .. } if !in_summary => {
                messages += 1;
                payload_bytes += data.len() as u64;
            }
            Record::DataEnd(_) => in_summary = true,
            _ => {}
        }
        Ok(())
    })?;
    Ok(ScanTotals {
        messages,
        payload_bytes,
        ending,
    })
}
