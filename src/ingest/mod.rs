//! Reads a recorded log (MCAP, JSON messages) into typed, time-sorted streams with a report of
//! everything that was wrong with it.
//!
//! The file is streamed ([`reader`]); each message is decoded by the decoder registered for its
//! schema name ([`decode`]), validated, and appended to its topic's typed store. Nothing of the
//! raw file is kept. At the end each stream is sorted by `stamp_ns` (stably), duplicates are
//! dropped, and its timing statistics are computed ([`stats`]).
//!
//! May import: `contract`, `time`, `mcap`, `serde_json`.

mod builder;
pub mod decode;
mod error;
mod log;
mod mission;
mod reader;
pub mod roles;
pub mod ros;
mod samples;
pub mod stats;

pub use error::{IngestError, MessageIssue};
pub use mission::{Mission, MissionDefaults, MissionError};
pub use reader::Ending;
pub use roles::{RoleChoice, RoleError, RoleSource};
pub use samples::Samples;

pub use log::{
    FileReport, Held, IngestOptions, LayoutCheck, Log, SkippedTopic, Stream, StreamCounts,
};

use builder::Builder;
use mcap::records::Record;
use std::io::Read;
use std::path::Path;

/// Reads the log at `path`.
pub fn read_log(path: &Path, options: &IngestOptions) -> Result<Log, IngestError> {
    let file = std::fs::File::open(path)?;
    read_log_from(std::io::BufReader::with_capacity(1 << 20, file), options)
}

/// Reads a log from any byte source (a file, a slice in tests).
///
/// With more than one core, the messages are decoded on other threads (up to
/// [`IngestOptions::decode_threads`]) while this one reads and decompresses the next chunks;
/// the log read is the same.
pub fn read_log_from<R: Read>(input: R, options: &IngestOptions) -> Result<Log, IngestError> {
    let threads = options.decode_threads.min(
        std::thread::available_parallelism()
            .map(usize::from)
            .unwrap_or(1),
    );
    if threads <= 1 {
        return read_with(input, options, None);
    }
    std::thread::scope(|scope| {
        read_with(
            input,
            options,
            Some(builder::DecodePool::start(scope, options, threads)),
        )
    })
}

fn read_with<R: Read>(
    input: R,
    options: &IngestOptions,
    pool: Option<builder::DecodePool<'_>>,
) -> Result<Log, IngestError> {
    let mut b = Builder::new(options, pool);
    let (ending, bytes_read) = reader::for_each_record(input, |record| b.on_record(record))?;
    b.finish(ending, bytes_read)
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
    let (mut messages, mut payload_bytes, mut in_summary) = (0u64, 0u64, false);
    let (ending, _) = reader::for_each_record(input, |record| {
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
