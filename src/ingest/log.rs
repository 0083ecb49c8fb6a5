//! What ingest returns: the decoded log, its streams, counts and report.

use super::error::MessageIssue;
use super::mission::{Mission, MissionError};
use super::reader::Ending;
use super::samples::Samples;
use super::stats;
use crate::contract::{Message, Streams};
use std::collections::BTreeMap;

/// What ingest tolerates.
#[derive(Debug, Clone, PartialEq)]
pub struct IngestOptions {
    /// Topics whose schema/encoding has no decoder are counted and skipped instead of failing.
    pub skip_unknown: bool,
    /// Largest fraction of invalid messages per topic that is dropped with a warning; above it,
    /// reading fails. `1.0` never fails (what `info` uses).
    pub max_invalid_fraction: f64,
    /// Keep the decoded messages. `false` still decodes and checks every message but keeps
    /// only stamps and counts (what `info` needs): memory then stays at 8 bytes per message
    /// and the streams hold no messages.
    pub keep_messages: bool,
    /// How ROS 2 messages are converted (pressure to depth, fixes without a covariance).
    pub ros2: crate::ingest::ros2::map::Ros2Settings,
    /// A topic's frame convention, where its `frame_id` should not decide it.
    pub frame_conventions: std::collections::BTreeMap<String, crate::ingest::ros2::map::Convention>,
}

impl Default for IngestOptions {
    fn default() -> Self {
        IngestOptions {
            skip_unknown: false,
            max_invalid_fraction: 0.01,
            keep_messages: true,
            ros2: Default::default(),
            frame_conventions: Default::default(),
        }
    }
}

/// Counters of one topic.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StreamCounts {
    /// Messages in the file on this topic.
    pub received: u64,
    /// Messages that failed decoding or validation (dropped).
    pub invalid: u64,
    /// Messages whose stamp repeats an earlier one (dropped).
    pub duplicates: u64,
    /// Messages stamped earlier than one already received (kept, sorted into place).
    pub out_of_order: u64,
    /// Valid messages with distinct stamps: `received - invalid - duplicates`.
    pub kept: u64,
}

/// One topic of the log, decoded and sorted by `stamp_ns`.
#[derive(Debug)]
pub struct Stream {
    pub topic: String,
    pub schema_name: String,
    pub message_encoding: String,
    /// The decoded messages, strictly increasing in `stamp_ns`.
    pub samples: Box<dyn Samples>,
    /// MCAP `log_time` of each message in `samples`.
    pub log_time_ns: Vec<u64>,
    pub counts: StreamCounts,
    pub timing: stats::Timing,
    /// The first few invalid messages.
    pub issues: Vec<MessageIssue>,
}

impl Stream {
    /// The typed messages, if this stream holds `T`.
    pub fn messages<T: Message>(&self) -> Option<&[T]> {
        self.samples.as_slice::<T>()
    }
}

/// A topic that was counted but not decoded (no decoder for its schema).
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedTopic {
    pub topic: String,
    pub schema_name: String,
    pub message_encoding: String,
    pub messages: u64,
}

/// How the file itself read.
#[derive(Debug, Clone, PartialEq)]
pub struct FileReport {
    /// Bytes read from the input.
    pub bytes_read: u64,
    pub ending: Ending,
    /// MCAP header: the writing library.
    pub library: String,
    pub profile: String,
    /// Whether a summary section was present.
    pub has_summary: bool,
    /// Messages on channels never defined (corrupt writer).
    pub orphan_messages: u64,
}

impl FileReport {
    /// One line for a cut-short file: how much was recovered.
    pub fn truncation_warning(&self, messages: u64) -> Option<String> {
        match self.ending {
            Ending::Complete => None,
            Ending::Truncated {
                whole_records_end,
                partial_chunk_messages,
            } => Some(format!(
                "the log is cut short (no footer): recovered {messages} messages, up to the last \
                 whole record: {whole_records_end} of {} bytes ({:.1} %) in whole records{}",
                self.bytes_read,
                100.0 * whole_records_end as f64 / self.bytes_read.max(1) as f64,
                if partial_chunk_messages > 0 {
                    format!(", then {partial_chunk_messages} messages from the cut-off chunk")
                } else {
                    String::new()
                }
            )),
        }
    }
}

/// A decoded log.
#[derive(Debug)]
pub struct Log {
    /// Decoded topics, in the order their channels appear in the file.
    pub streams: Vec<Stream>,
    pub skipped: Vec<SkippedTopic>,
    /// All metadata records by name (later records of the same name win).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    pub file: FileReport,
}

impl Log {
    /// The contract's `mission` metadata.
    pub fn mission(&self) -> Result<Mission, MissionError> {
        Mission::parse(self.metadata.get("mission").ok_or(MissionError::Absent)?)
    }

    /// The stream on `topic`.
    pub fn stream(&self, topic: &str) -> Option<&Stream> {
        self.streams.iter().find(|s| s.topic == topic)
    }

    /// The typed messages on `topic`, if it exists and holds `T`.
    pub fn messages<T: Message>(&self, topic: &str) -> Option<&[T]> {
        self.stream(topic)?.messages::<T>()
    }

    /// The messages of type `T` at the contract's default topic (none when absent).
    pub fn at_default_topic<T: Message>(&self) -> &[T] {
        self.messages(T::DEFAULT_TOPIC).unwrap_or_default()
    }

    /// Messages kept over all streams.
    pub fn message_count(&self) -> u64 {
        self.streams.iter().map(|s| s.samples.len() as u64).sum()
    }

    /// One-line warnings a person should see (truncation, dropped messages, skipped topics).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let recovered = self.streams.iter().map(|s| s.counts.received).sum::<u64>()
            + self.skipped.iter().map(|s| s.messages).sum::<u64>();
        out.extend(self.file.truncation_warning(recovered));
        for s in &self.streams {
            let c = &s.counts;
            if c.invalid > 0 {
                let first = s
                    .issues
                    .first()
                    .map(|i| format!(": first: {i}"))
                    .unwrap_or_default();
                out.push(format!(
                    "{}: dropped {} invalid of {} messages{first}",
                    s.topic, c.invalid, c.received
                ));
            }
            if c.duplicates > 0 {
                out.push(format!(
                    "{}: dropped {} duplicated stamps",
                    s.topic, c.duplicates
                ));
            }
        }
        for s in &self.skipped {
            out.push(format!(
                "{}: skipped {} messages of schema `{}` (encoding `{}`): no decoder",
                s.topic, s.messages, s.schema_name, s.message_encoding
            ));
        }
        if self.file.orphan_messages > 0 {
            out.push(format!(
                "{} messages on undefined channels were skipped",
                self.file.orphan_messages
            ));
        }
        out
    }
}

impl<'a> Streams<'a> {
    /// The log's streams at the contract's default topics.
    pub fn of(log: &'a Log) -> Self {
        Streams {
            imu: log.at_default_topic(),
            mag: log.at_default_topic(),
            dvl: log.at_default_topic(),
            altimeter: log.at_default_topic(),
            eml: log.at_default_topic(),
            depth: log.at_default_topic(),
            gnss: log.at_default_topic(),
            fixes: log.at_default_topic(),
            rpm: log.at_default_topic(),
            fins: log.at_default_topic(),
            truth: log.at_default_topic(),
        }
    }
}
