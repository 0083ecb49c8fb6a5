//! Reads a recorded log (MCAP, JSON messages) into typed, time-sorted streams with a report of
//! everything that was wrong with it.
//!
//! The file is streamed ([`reader`]); each message is decoded by the decoder registered for its
//! schema name ([`decode`]), validated, and appended to its topic's typed store. Nothing of the
//! raw file is kept. At the end each stream is sorted by `stamp_ns` (stably), duplicates are
//! dropped, and its timing statistics are computed ([`stats`]).
//!
//! May import: `contract`, `time`, `mcap`, `serde_json`.

pub mod decode;
mod error;
mod mission;
mod reader;
mod samples;
pub mod stats;

pub use error::{IngestError, MessageIssue};
pub use mission::{Mission, MissionError};
pub use reader::Ending;
pub use samples::Samples;

use crate::contract::Message;
use decode::Decoder;
use mcap::records::Record;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

/// How many issues are kept per topic for the report (all are counted).
const ISSUES_KEPT_PER_TOPIC: usize = 5;

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
}

impl Default for IngestOptions {
    fn default() -> Self {
        IngestOptions {
            skip_unknown: false,
            max_invalid_fraction: 0.01,
            keep_messages: true,
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

/// Reads the log at `path`.
pub fn read_log(path: &Path, options: &IngestOptions) -> Result<Log, IngestError> {
    let file = std::fs::File::open(path)?;
    read_log_from(std::io::BufReader::with_capacity(1 << 20, file), options)
}

/// Reads a log from any byte source (a file, a slice in tests).
pub fn read_log_from<R: Read>(input: R, options: &IngestOptions) -> Result<Log, IngestError> {
    let mut b = Builder::new(options);
    let (ending, bytes_read) = reader::for_each_record(input, |record| b.on_record(record))?;
    b.finish(ending, bytes_read)
}

/// Accumulates records into streams.
struct Builder<'o> {
    options: &'o IngestOptions,
    schemas: HashMap<u16, (String, String)>,
    /// Slot of each channel id (a channel id is a u16: a direct table beats hashing).
    channel_to_slot: Vec<Option<usize>>,
    slots: Vec<Slot>,
    metadata: BTreeMap<String, BTreeMap<String, String>>,
    library: String,
    profile: String,
    in_summary: bool,
    summary_records: u64,
    orphan_messages: u64,
}

/// One topic being read.
struct Slot {
    topic: String,
    schema_name: String,
    message_encoding: String,
    decoder: Option<&'static dyn Decoder>,
    samples: Option<Box<dyn Samples>>,
    stamps_ns: Vec<i64>,
    log_time_ns: Vec<u64>,
    counts: StreamCounts,
    latest_stamp_ns: i64,
    issues: Vec<MessageIssue>,
}

impl<'o> Builder<'o> {
    fn new(options: &'o IngestOptions) -> Self {
        Builder {
            options,
            schemas: HashMap::new(),
            channel_to_slot: vec![None; usize::from(u16::MAX) + 1],
            slots: Vec::new(),
            metadata: BTreeMap::new(),
            library: String::new(),
            profile: String::new(),
            in_summary: false,
            summary_records: 0,
            orphan_messages: 0,
        }
    }

    fn on_record(&mut self, record: Record<'_>) -> Result<(), IngestError> {
        if self.in_summary && !matches!(record, Record::Footer(_)) {
            self.summary_records += 1;
        }
        match record {
            Record::Header(h) => {
                self.library = h.library;
                self.profile = h.profile;
            }
            Record::Schema { header, .. } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding));
            }
            Record::Channel(c) => self.on_channel(c)?,
            Record::Message { header, data } if !self.in_summary => {
                self.on_message(header.channel_id, header.log_time, &data)
            }
            Record::Metadata(m) => {
                self.metadata.insert(m.name, m.metadata);
            }
            Record::DataEnd(_) => self.in_summary = true,
            _ => {}
        }
        Ok(())
    }

    fn on_channel(&mut self, c: mcap::records::Channel) -> Result<(), IngestError> {
        if self.channel_to_slot[usize::from(c.id)].is_some() {
            return Ok(()); // repeated in the summary, or re-announced
        }
        let schema_name = self
            .schemas
            .get(&c.schema_id)
            .map(|(name, _)| name.clone())
            .unwrap_or_default();
        let slot = match self
            .slots
            .iter()
            .position(|s| s.topic == c.topic && s.schema_name == schema_name)
        {
            Some(i) => i,
            None => {
                let decoder = decode::find(&schema_name, &c.message_encoding);
                if decoder.is_none() && !self.options.skip_unknown {
                    return Err(IngestError::UnknownSchema {
                        topic: c.topic,
                        schema: schema_name,
                        encoding: c.message_encoding,
                        known: crate::contract::all_kinds()
                            .iter()
                            .map(|k| k.schema_name())
                            .collect::<Vec<_>>()
                            .join(", "),
                    });
                }
                self.slots.push(Slot {
                    topic: c.topic,
                    schema_name,
                    message_encoding: c.message_encoding,
                    decoder,
                    samples: decoder.map(|d| d.new_samples()),
                    stamps_ns: Vec::new(),
                    log_time_ns: Vec::new(),
                    counts: StreamCounts::default(),
                    latest_stamp_ns: i64::MIN,
                    issues: Vec::new(),
                });
                self.slots.len() - 1
            }
        };
        self.channel_to_slot[usize::from(c.id)] = Some(slot);
        Ok(())
    }

    fn on_message(&mut self, channel_id: u16, log_time_ns: u64, data: &[u8]) {
        let Some(slot) = self.channel_to_slot[usize::from(channel_id)] else {
            self.orphan_messages += 1;
            return;
        };
        let s = &mut self.slots[slot];
        s.counts.received += 1;
        let (Some(decoder), Some(samples)) = (s.decoder, s.samples.as_mut()) else {
            return;
        };
        match decoder.decode_into(data, samples.as_mut()) {
            Ok(()) => {
                let stamp = samples.stamp_ns(samples.len() - 1);
                if !self.options.keep_messages {
                    samples.clear();
                }
                if stamp < s.latest_stamp_ns {
                    s.counts.out_of_order += 1;
                }
                s.latest_stamp_ns = s.latest_stamp_ns.max(stamp);
                s.stamps_ns.push(stamp);
                s.log_time_ns.push(log_time_ns);
            }
            Err(issue) => {
                s.counts.invalid += 1;
                if s.issues.len() < ISSUES_KEPT_PER_TOPIC {
                    s.issues.push(MessageIssue {
                        topic: s.topic.clone(),
                        log_time_ns,
                        field: issue.field,
                        reason: issue.reason,
                    });
                }
            }
        }
    }

    fn finish(self, ending: Ending, bytes_read: u64) -> Result<Log, IngestError> {
        let mut streams = Vec::new();
        let mut skipped = Vec::new();
        for slot in self.slots {
            let Some(mut samples) = slot.samples else {
                skipped.push(SkippedTopic {
                    topic: slot.topic,
                    schema_name: slot.schema_name,
                    message_encoding: slot.message_encoding,
                    messages: slot.counts.received,
                });
                continue;
            };
            let mut counts = slot.counts;
            if counts.invalid > 0
                && counts.invalid as f64
                    > self.options.max_invalid_fraction * counts.received as f64
            {
                return Err(IngestError::TooManyInvalid {
                    topic: slot.topic,
                    invalid: counts.invalid,
                    received: counts.received,
                    allowed: self.options.max_invalid_fraction,
                    first: Box::new(slot.issues[0].clone()),
                });
            }
            let stamps = slot.stamps_ns;
            let (order, duplicates) = stats::sorted_unique_order(&stamps);
            counts.duplicates = duplicates;
            counts.kept = order.len() as u64;
            let in_order =
                order.iter().enumerate().all(|(k, &i)| k == i) && order.len() == stamps.len();
            let (mut log_time_ns, sorted) = if in_order {
                (slot.log_time_ns, stamps)
            } else {
                if self.options.keep_messages {
                    samples.permute(&order);
                }
                (
                    order.iter().map(|&i| slot.log_time_ns[i]).collect(),
                    order.iter().map(|&i| stamps[i]).collect(),
                )
            };
            if !self.options.keep_messages {
                log_time_ns = Vec::new();
            }
            streams.push(Stream {
                topic: slot.topic,
                schema_name: slot.schema_name,
                message_encoding: slot.message_encoding,
                samples,
                log_time_ns,
                counts,
                timing: stats::timing(&sorted),
                issues: slot.issues,
            });
        }
        Ok(Log {
            streams,
            skipped,
            metadata: self.metadata,
            file: FileReport {
                bytes_read,
                ending,
                library: self.library,
                profile: self.profile,
                has_summary: self.summary_records > 0,
                orphan_messages: self.orphan_messages,
            },
        })
    }
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
