//! Accumulates the records of a log into per-topic typed streams.

use super::decode::{self, TopicDecoder};
use super::error::{IngestError, MessageIssue};
use super::log::{
    FileReport, Held, IngestOptions, LayoutCheck, Log, SkippedTopic, Stream, StreamCounts,
};
use super::reader::Ending;
use super::roles;
use super::samples::Samples;
use super::stats;
use super::Container;
use mcap::records::Record;
use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};

/// How many issues are kept per topic for the report (all are counted).
const ISSUES_KEPT_PER_TOPIC: usize = 5;

/// Accumulates records into streams.
pub(super) struct Builder<'o, 's> {
    options: &'o IngestOptions,
    /// Name, encoding and text of each schema.
    schemas: HashMap<u16, (String, String, Vec<u8>)>,
    /// Slot of each channel id (a channel id is a u16: a direct table beats hashing).
    channel_to_slot: Vec<Option<usize>>,
    /// The topics, each decoded by one thread at a time (in file order).
    slots: Vec<Arc<Mutex<Slot>>>,
    /// Whether each slot refuses its messages (kept here, read per message without a lock).
    refusing: Vec<bool>,
    /// Messages of each slot not yet handed to the decoding threads.
    pending: Vec<Batch>,
    /// The decoding threads (`None`: messages are decoded as they are read).
    pool: Option<DecodePool<'s>>,
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
    decoder: Option<TopicDecoder>,
    samples: Option<Box<dyn Samples>>,
    /// Stamps of the messages read, when the messages themselves are not kept (else their
    /// stamps are read from them).
    stamps_ns: Vec<i64>,
    /// Log times, when kept.
    log_time_ns: Vec<u64>,
    counts: StreamCounts,
    latest_stamp_ns: i64,
    issues: Vec<MessageIssue>,
    /// Why the topic cannot be read: the read fails at its first message (naming its time).
    refusal: Option<Refusal>,
    /// A skipped cdr topic's layout, its messages walked through it.
    layout: Option<Layout>,
    /// The stretch of repeated values being read.
    holding: Held,
    /// The field where a message says whether it is usable.
    valid_property: Option<usize>,
}

impl Slot {
    /// Decodes, validates and counts one message.
    fn on_message(&mut self, options: &IngestOptions, log_time_ns: u64, data: &[u8]) {
        let s = self;
        s.counts.received += 1;
        if let Some(layout) = s.layout.as_mut() {
            layout.check(&s.topic, log_time_ns, data);
        }
        let (Some(decoder), Some(samples)) = (s.decoder.as_ref(), s.samples.as_mut()) else {
            return;
        };
        match decoder.get().decode_into(data, samples.as_mut()) {
            Ok(()) => {
                let last = samples.len() - 1;
                let stamp = samples.stamp_ns(last);
                if let Some(valid) = s.valid_property {
                    s.counts.flagged += u64::from(samples.flagged_invalid(last, valid));
                }
                if last > 0 && samples.same_values(last - 1, last) {
                    s.holding.repeats += 1;
                    s.holding.to_ns = stamp;
                    if s.holding.repeats > s.counts.held.repeats {
                        s.counts.held = s.holding;
                    }
                } else {
                    s.holding = Held {
                        repeats: 0,
                        from_ns: stamp,
                        to_ns: stamp,
                    };
                }
                if !options.keep_messages {
                    // The last message stays, to compare the next with.
                    samples.keep_last();
                }
                if stamp < s.latest_stamp_ns {
                    s.counts.out_of_order += 1;
                }
                s.latest_stamp_ns = s.latest_stamp_ns.max(stamp);
                if !options.keep_messages {
                    s.stamps_ns.push(stamp);
                }
                if options.keep_log_times {
                    s.log_time_ns.push(log_time_ns);
                }
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
}

/// The layout check of a skipped cdr topic.
enum Layout {
    NoLayout(String),
    Plan {
        plan: crate::ingest::ros::cdr::Plan,
        misfits: u64,
        first: Option<MessageIssue>,
    },
}

impl Layout {
    /// The layout `schema_text` gives a message of `schema_name` in the given ROS.
    fn of(
        dialect: crate::ingest::ros::msg::Dialect,
        schema_name: &str,
        schema_text: &[u8],
    ) -> Layout {
        use crate::ingest::ros::{cdr::Plan, msg};
        if msg::full_name(schema_name).is_none() {
            return Layout::NoLayout(format!(
                "`{schema_name}` is not a message type (a service's schema is its .srv text)"
            ));
        }
        let text = String::from_utf8_lossy(schema_text);
        match msg::parse_as(dialect, schema_name, &text).map(|defs| Plan::new(&defs, &[], &[])) {
            Ok(Ok(plan)) => Layout::Plan {
                plan,
                misfits: 0,
                first: None,
            },
            Ok(Err(e)) => Layout::NoLayout(e.to_string()),
            Err(e) => Layout::NoLayout(format!("schema text: {e}")),
        }
    }

    /// Walks one message; a misfit is one the layout does not reach the end of (beyond the
    /// padding of the last alignment) or runs past.
    fn check(&mut self, topic: &str, log_time_ns: u64, data: &[u8]) {
        let Layout::Plan {
            plan,
            misfits,
            first,
        } = self
        else {
            return;
        };
        let reason = match plan.check(data) {
            Ok(used) if data.len() - used < 8 => return,
            Ok(used) => format!("{} bytes after the layout's {used}", data.len() - used),
            Err(e) => e.to_string(),
        };
        *misfits += 1;
        first.get_or_insert_with(|| MessageIssue {
            topic: topic.to_string(),
            log_time_ns,
            field: "(message)".into(),
            reason,
        });
    }

    fn into_check(self) -> LayoutCheck {
        match self {
            Layout::NoLayout(why) => LayoutCheck::NoLayout(why),
            Layout::Plan { misfits, first, .. } => LayoutCheck::Checked { misfits, first },
        }
    }
}

/// Why a topic that must be read cannot be.
enum Refusal {
    /// No decoder for its schema and encoding.
    Unknown,
    /// A ROS 2 type hindsight reads, but its schema text does not serve.
    Schema(String),
}

impl<'o, 's> Builder<'o, 's> {
    pub(super) fn new(options: &'o IngestOptions, pool: Option<DecodePool<'s>>) -> Self {
        Builder {
            options,
            schemas: HashMap::new(),
            channel_to_slot: vec![None; usize::from(u16::MAX) + 1],
            slots: Vec::new(),
            refusing: Vec::new(),
            pending: Vec::new(),
            pool,
            metadata: BTreeMap::new(),
            library: String::new(),
            profile: String::new(),
            in_summary: false,
            summary_records: 0,
            orphan_messages: 0,
        }
    }

    pub(super) fn on_record(&mut self, record: Record<'_>) -> Result<(), IngestError> {
        if self.in_summary && !matches!(record, Record::Footer(_)) {
            self.summary_records += 1;
        }
        match record {
            Record::Header(h) => {
                self.library = h.library;
                self.profile = h.profile;
            }
            Record::Schema { header, data } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(c) => self.on_channel(c)?,
            Record::Message { header, data } if !self.in_summary => {
                self.on_message(header.channel_id, header.log_time, &data)?
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
        let (schema_name, schema_text) = self
            .schemas
            .get(&c.schema_id)
            .map(|(name, _, text)| (name.clone(), text.as_slice()))
            .unwrap_or_default();
        let slot = match self.slots.iter().position(|s| {
            let s = lock(s);
            s.topic == c.topic && s.schema_name == schema_name
        }) {
            Some(i) => i,
            None => {
                let (decoder, refusal) = match decode::for_topic(
                    &c.topic,
                    &schema_name,
                    schema_text,
                    &c.message_encoding,
                    self.options,
                ) {
                    Ok(Some(d)) => (Some(d), None),
                    Ok(None)
                        if self.refuses_unknown(&c.topic, &schema_name, &c.message_encoding) =>
                    {
                        (None, Some(Refusal::Unknown))
                    }
                    Ok(None) => (None, None),
                    Err(e) => (None, Some(Refusal::Schema(e.to_string()))),
                };
                let layout = decode::ros_dialect(&c.message_encoding)
                    .filter(|_| {
                        decoder.is_none() && refusal.is_none() && self.options.check_layouts
                    })
                    .map(|dialect| Layout::of(dialect, &schema_name, schema_text));
                let samples = decoder.as_ref().map(|d| d.get().new_samples());
                self.refusing.push(refusal.is_some());
                self.pending.push(Batch::default());
                self.slots.push(Arc::new(Mutex::new(Slot {
                    topic: c.topic,
                    schema_name,
                    message_encoding: c.message_encoding,
                    valid_property: samples.as_ref().and_then(|s| s.valid_property()),
                    samples,
                    decoder,
                    stamps_ns: Vec::new(),
                    log_time_ns: Vec::new(),
                    counts: StreamCounts::default(),
                    latest_stamp_ns: i64::MIN,
                    issues: Vec::new(),
                    layout,
                    refusal,
                    holding: Held::default(),
                })));
                self.slots.len() - 1
            }
        };
        self.channel_to_slot[usize::from(c.id)] = Some(slot);
        Ok(())
    }

    /// Whether a topic without a decoder fails the read: unless unknown topics are skipped,
    /// a topic a role needs (named for one, at a contract default topic, or of a contract
    /// schema), and any topic of another encoding than ROS's (`cdr`, `ros1`). A ROS
    /// recording's other topics (tf, diagnostics, cameras) are skipped with a warning.
    fn refuses_unknown(&self, topic: &str, schema_name: &str, encoding: &str) -> bool {
        if self.options.skip_unknown {
            return false;
        }
        let needed = self.options.topics.values().any(|t| t == topic)
            || crate::contract::kind_by_schema(schema_name).is_some()
            || crate::contract::all_kinds()
                .iter()
                .any(|k| k.default_topic() == topic);
        needed || decode::ros_dialect(encoding).is_none()
    }

    fn refused(&self, slot: usize, log_time_ns: u64) -> Option<IngestError> {
        let s = lock(&self.slots[slot]);
        Some(match s.refusal.as_ref()? {
            Refusal::Unknown => IngestError::UnknownSchema {
                topic: s.topic.clone(),
                schema: s.schema_name.clone(),
                encoding: s.message_encoding.clone(),
                known: crate::contract::all_kinds()
                    .iter()
                    .map(|k| k.schema_name())
                    .collect::<Vec<_>>()
                    .join(", "),
                log_time_ns,
            },
            Refusal::Schema(reason) => IngestError::Ros2Schema {
                topic: s.topic.clone(),
                schema: s.schema_name.clone(),
                reason: reason.clone(),
                log_time_ns,
            },
        })
    }

    fn on_message(
        &mut self,
        channel_id: u16,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), IngestError> {
        let Some(slot) = self.channel_to_slot[usize::from(channel_id)] else {
            self.orphan_messages += 1;
            return Ok(());
        };
        if self.refusing[slot] {
            if let Some(e) = self.refused(slot, log_time_ns) {
                return Err(e);
            }
        }
        match &self.pool {
            Some(pool) => {
                let batch = &mut self.pending[slot];
                batch.push(log_time_ns, data);
                if batch.data.len() >= BATCH_BYTES {
                    pool.send(slot, self.slots[slot].clone(), std::mem::take(batch));
                }
            }
            None => lock(&self.slots[slot]).on_message(self.options, log_time_ns, data),
        }
        Ok(())
    }

    /// Hands every batch still pending to the decoding threads.
    pub(super) fn flush(&mut self) {
        if let Some(pool) = &self.pool {
            for (slot, batch) in self.pending.iter_mut().enumerate() {
                if !batch.log_times.is_empty() {
                    pool.send(slot, self.slots[slot].clone(), std::mem::take(batch));
                }
            }
        }
    }

    pub(super) fn finish(
        mut self,
        container: Container,
        ending: Ending,
        bytes_read: u64,
    ) -> Result<Log, IngestError> {
        self.flush();
        if let Some(pool) = self.pool.take() {
            pool.finish();
        }
        let mut streams = Vec::new();
        let mut skipped = Vec::new();
        for slot in self.slots {
            let mut slot = Arc::into_inner(slot)
                .expect("the decoding threads have ended")
                .into_inner()
                .unwrap_or_else(|e| e.into_inner());
            match slot.samples.take() {
                Some(samples) => streams.push(stream_of(slot, samples, self.options)?),
                None => skipped.push(SkippedTopic {
                    topic: slot.topic,
                    schema_name: slot.schema_name,
                    message_encoding: slot.message_encoding,
                    messages: slot.counts.received,
                    layout: slot.layout.map(Layout::into_check),
                }),
            }
        }
        let (roles, role_problems) = roles::resolve(&streams, &self.options.topics);
        if let (true, Some(first)) = (self.options.strict_roles, role_problems.first()) {
            return Err(IngestError::Role(first.clone()));
        }
        let (beacons, beacon_problems) = (self.metadata.get("beacons"))
            .map(crate::contract::beacons::from_record)
            .unwrap_or_default();
        Ok(Log {
            roles,
            role_problems,
            beacons,
            beacon_problems,
            streams,
            skipped,
            metadata: self.metadata,
            file: FileReport {
                container,
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

/// A decoded topic's stream: its messages sorted by stamp without repeats (kept or not as the
/// options say), its counts and timing; refused when too many of its messages were invalid.
fn stream_of(
    slot: Slot,
    mut samples: Box<dyn Samples>,
    options: &IngestOptions,
) -> Result<Stream, IngestError> {
    let mut counts = slot.counts;
    if counts.invalid > 0
        && counts.invalid as f64 > options.max_invalid_fraction * counts.received as f64
    {
        return Err(IngestError::TooManyInvalid {
            topic: slot.topic,
            invalid: counts.invalid,
            received: counts.received,
            allowed: options.max_invalid_fraction,
            first: Box::new(slot.issues[0].clone()),
        });
    }
    let keep = options.keep_messages;
    let n = if keep {
        samples.len()
    } else {
        slot.stamps_ns.len()
    };
    let stamp = |i: usize| {
        if keep {
            samples.stamp_ns(i)
        } else {
            slot.stamps_ns[i]
        }
    };
    // Most streams are already in order without repeats: then no copy of a day's
    // stamps and no index is made.
    let in_order = (1..n).all(|i| stamp(i - 1) < stamp(i));
    let (mut log_time_ns, timing) = if in_order {
        counts.kept = n as u64;
        (slot.log_time_ns, stats::timing_by(n, stamp))
    } else {
        let stamps: Vec<i64> = (0..n).map(stamp).collect();
        let (order, duplicates) = stats::sorted_unique_order(&stamps);
        counts.duplicates = duplicates;
        counts.kept = order.len() as u64;
        if keep {
            samples.permute(&order);
        }
        let sorted: Vec<i64> = order.iter().map(|&i| stamps[i]).collect();
        let log_times = order
            .iter()
            .filter_map(|&i| slot.log_time_ns.get(i).copied())
            .collect();
        (log_times, stats::timing(&sorted))
    };
    if !options.keep_messages {
        log_time_ns = Vec::new();
        samples.clear();
    }
    Ok(Stream {
        topic: slot.topic,
        schema_name: slot.schema_name,
        message_encoding: slot.message_encoding,
        samples,
        log_time_ns,
        counts,
        timing,
        issues: slot.issues,
    })
}

/// Bytes of messages gathered for a slot before they are handed to its decoding thread.
const BATCH_BYTES: usize = 256 * 1024;

/// Batches queued per decoding thread before the reader waits (bounds the memory in flight).
const QUEUED_BATCHES: usize = 8;

/// Messages of one slot, in file order.
#[derive(Debug, Default)]
pub(super) struct Batch {
    log_times: Vec<u64>,
    /// End of each message's bytes in `data`.
    ends: Vec<usize>,
    data: Vec<u8>,
}

impl Batch {
    fn push(&mut self, log_time_ns: u64, data: &[u8]) {
        self.log_times.push(log_time_ns);
        self.data.extend_from_slice(data);
        self.ends.push(self.data.len());
    }

    fn messages(&self) -> impl Iterator<Item = (u64, &[u8])> {
        let starts = std::iter::once(0).chain(self.ends.iter().copied());
        self.log_times
            .iter()
            .zip(starts.zip(&self.ends))
            .map(|(&t, (a, &b))| (t, &self.data[a..b]))
    }
}

type Job = (Arc<Mutex<Slot>>, Batch);

/// Threads that decode the messages while the reader reads and decompresses the next ones.
/// A slot always goes to the same thread, so its messages are decoded in file order.
pub(super) struct DecodePool<'s> {
    queues: Vec<std::sync::mpsc::SyncSender<Job>>,
    threads: Vec<std::thread::ScopedJoinHandle<'s, ()>>,
}

impl<'s> DecodePool<'s> {
    /// `threads` decoding threads in `scope`.
    pub(super) fn start<'e>(
        scope: &'s std::thread::Scope<'s, 'e>,
        options: &'e IngestOptions,
        threads: usize,
    ) -> Self {
        let (queues, threads) = (0..threads.max(1))
            .map(|_| {
                let (queue, jobs) = std::sync::mpsc::sync_channel::<Job>(QUEUED_BATCHES);
                let thread = scope.spawn(move || {
                    for (slot, batch) in jobs {
                        let mut slot = lock(&slot);
                        for (log_time_ns, data) in batch.messages() {
                            slot.on_message(options, log_time_ns, data);
                        }
                    }
                });
                (queue, thread)
            })
            .unzip();
        DecodePool { queues, threads }
    }

    fn send(&self, slot: usize, to: Arc<Mutex<Slot>>, batch: Batch) {
        // A thread ends only when its queue closes, so the send cannot fail while the pool
        // lives; were it to, the thread panicked, which `finish` passes on.
        let _ = self.queues[slot % self.queues.len()].send((to, batch));
    }

    /// Closes the queues and waits for the threads to decode what was queued.
    fn finish(self) {
        drop(self.queues);
        for t in self.threads {
            if let Err(panic) = t.join() {
                std::panic::resume_unwind(panic);
            }
        }
    }
}

/// Locks a slot (a poisoned lock still holds what was decoded).
fn lock(slot: &Mutex<Slot>) -> std::sync::MutexGuard<'_, Slot> {
    slot.lock().unwrap_or_else(|e| e.into_inner())
}
