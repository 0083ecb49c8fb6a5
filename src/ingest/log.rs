//! What ingest returns: the decoded log, its streams, counts and report.

use super::error::MessageIssue;
use super::mission::{Mission, MissionDefaults, MissionError};
use super::reader::Ending;
use super::roles::{RoleChoice, RoleError};
use super::samples::Samples;
use super::stats;
use crate::contract::{Beacon, GnssFix, Message, Streams, Truth};
use crate::ingest::ros::map::Convention;
use std::collections::BTreeMap;

crate::config::with_defaults! {
    /// What ingest tolerates.
    #[derive(Debug, Clone, PartialEq)]
    pub struct IngestOptions {
        /// Topics whose schema/encoding has no decoder are counted and skipped instead of failing.
        pub skip_unknown: bool = false,
        /// Largest fraction of invalid messages per topic that is dropped with a warning; above it,
        /// reading fails. `1.0` never fails (what `info` uses).
        pub max_invalid_fraction: f64 = 0.01,
        /// Keep the decoded messages. `false` still decodes and checks every message but keeps
        /// only stamps and counts (what `info` needs): memory then stays at 8 bytes per message
        /// and the streams hold no messages.
        pub keep_messages: bool = true,
        /// Keep each message's log time ([`Stream::log_time_ns`]; what `export` writes). `false`
        /// saves 8 bytes per message (a reconstruction does not need them).
        pub keep_log_times: bool = true,
        /// Threads that decode messages beside the one reading the file (at most the machine's
        /// cores; `1` decodes on the reading thread).
        pub decode_threads: usize = 2,
        /// How ROS 2 messages are converted (pressure to depth, fixes without a covariance).
        pub ros2: crate::ingest::ros::map::RosSettings = Default::default(),
        /// A topic's frame convention, where its `frame_id` should not decide it.
        pub frame_conventions: BTreeMap<String, Convention> = BTreeMap::new(),
        /// Walk the messages of cdr topics hindsight does not map through the layout of their
        /// schema text, counting those that do not fit (what `info` does).
        pub check_layouts: bool = false,
        /// Topics named for roles (role -> topic), over the default topics and the types.
        pub topics: BTreeMap<String, String> = BTreeMap::new(),
        /// A role that cannot be resolved (ambiguous, or named for a topic that is not there)
        /// fails the read. `false` keeps it as a warning (what `info` uses).
        pub strict_roles: bool = true,
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
    /// Messages that say they are not usable (a DVL reading without bottom lock).
    pub flagged: u64,
    /// The longest stretch of messages that repeat their predecessor's values (in file
    /// order): a sensor that samples and holds, or is stuck.
    pub held: Held,
}

/// A stretch of messages repeating one value.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Held {
    /// Messages that repeat the one before them.
    pub repeats: u64,
    /// Stamp of the first message holding the value, and of the last repeat.
    pub from_ns: i64,
    pub to_ns: i64,
}

impl Held {
    pub fn seconds(&self) -> f64 {
        (self.to_ns - self.from_ns) as f64 * 1e-9
    }
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
    /// For a cdr topic walked through its schema's layout ([`IngestOptions::check_layouts`]).
    pub layout: Option<LayoutCheck>,
}

impl SkippedTopic {
    /// The role this topic's type is read for when the topic is named for it (an odometry:
    /// the truth role), if its messages are ROS ones.
    pub fn role_to_name(&self) -> Option<&'static str> {
        crate::ingest::decode::ros_dialect(&self.message_encoding)?;
        let name = crate::ingest::ros::msg::full_name(&self.schema_name)?;
        crate::ingest::ros::map::RosType::of(&name)?.only_when_named_for()
    }
}

/// What walking a skipped cdr topic's messages through its schema's layout found.
#[derive(Debug, Clone, PartialEq)]
pub enum LayoutCheck {
    /// The schema text gives no layout (it does not parse, or is a service's `.srv` text).
    NoLayout(String),
    /// Messages that do not fit the layout, and the first of them.
    Checked {
        misfits: u64,
        first: Option<MessageIssue>,
    },
}

/// The container a log came in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Container {
    Mcap,
    /// A ROS 1 bag, format 2.0.
    Ros1Bag,
    /// A ROS 2 bag in sqlite3 storage (`.db3` files and `metadata.yaml`).
    Ros2Sqlite,
}

impl Container {
    /// The container whose magic bytes `head` (a file's first 16 bytes, or all of a shorter
    /// one) begins with; MCAP unless another's magic is there.
    pub fn of(head: &[u8]) -> Container {
        if head.starts_with(super::bag::MAGIC) {
            Container::Ros1Bag
        } else if head.starts_with(SQLITE_MAGIC) {
            Container::Ros2Sqlite
        } else {
            Container::Mcap
        }
    }

    /// What a log of this container cut short lacks.
    pub fn missing_end(self) -> &'static str {
        match self {
            Container::Mcap => "no footer",
            Container::Ros1Bag => "not closed: no index",
            Container::Ros2Sqlite => "incomplete database",
        }
    }

    /// How a user calls it.
    pub fn name(self) -> &'static str {
        match self {
            Container::Mcap => "MCAP",
            Container::Ros1Bag => "ROS 1 bag",
            Container::Ros2Sqlite => "ROS 2 bag (sqlite3)",
        }
    }
}

/// The first bytes of every SQLite database.
pub const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";

/// How the file itself read.
#[derive(Debug, Clone, PartialEq)]
pub struct FileReport {
    pub container: Container,
    /// Bytes read from the input.
    pub bytes_read: u64,
    pub ending: Ending,
    /// The writing library (MCAP header), or what a bag says of its format.
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
                "the log is cut short ({}): recovered {messages} messages, up to the last \
                 whole record: {whole_records_end} of {} bytes ({:.1} %) in whole records{}",
                self.container.missing_end(),
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
    /// The topic of each role the log has.
    pub roles: Vec<RoleChoice>,
    /// Roles that could not be resolved (only when reading was not strict about roles).
    pub role_problems: Vec<RoleError>,
    /// The beacons of the `beacons` metadata record ...
    pub beacons: Vec<Beacon>,
    /// ... and what was wrong with those left out.
    pub beacon_problems: Vec<String>,
}

impl Log {
    /// The contract's `mission` metadata.
    pub fn mission(&self) -> Result<Mission, MissionError> {
        Mission::parse(self.metadata.get("mission").ok_or(MissionError::Absent)?)
    }

    /// The `mission` metadata, or where the log has none (a ROS 2 recording), a mission from
    /// `defaults` and the first GNSS fix (see [`Mission::standing_in`]).
    pub fn mission_or(&self, defaults: &MissionDefaults) -> Result<Mission, MissionError> {
        match self.metadata.get("mission") {
            Some(record) => Mission::parse(record),
            None => Mission::standing_in(
                defaults,
                self.role::<GnssFix>()
                    .first()
                    .map(|f| (f.latitude_deg, f.longitude_deg)),
            ),
        }
    }

    /// The mission (as [`Log::mission_or`] gives it), with every reference track read from
    /// a ROS odometry placed on its origin: their latitude and longitude follow from their
    /// north and east only once the origin is known.
    /// Also returns a warning for each track placed on an origin the log took from its
    /// first GNSS fix, which the track's own frame need not share.
    pub fn settle_mission(
        &mut self,
        defaults: &MissionDefaults,
    ) -> Result<(Mission, Vec<String>), MissionError> {
        let mut notes = Vec::new();
        let mission = self.mission_or(defaults)?;
        let origin_deg = (mission.origin_latitude_deg, mission.origin_longitude_deg);
        let origin_given = self.metadata.contains_key("mission")
            || defaults.origin_latitude_deg.is_some() && defaults.origin_longitude_deg.is_some();
        for s in &mut self.streams {
            // A truth converted from another type (a ROS odometry) has its position only in
            // its own frame; the contract's `/truth` carries its latitude and longitude.
            let converted = s.schema_name != Truth::SCHEMA_NAME;
            let track = s.samples.as_any_mut().downcast_mut::<Vec<Truth>>();
            if let (true, Some(track)) = (converted, track) {
                crate::ingest::ros::map::place_on_origin(track, origin_deg);
                if !origin_given {
                    notes.push(format!(
                        "{}: the reference track's world frame is placed on the origin taken \
                         from the first GNSS fix; if its frame has another origin (the fix's \
                         error, a surveyed datum), give the origin, or the scores carry the \
                         difference",
                        s.topic
                    ));
                }
            }
        }
        Ok((mission, notes))
    }

    /// The stream on `topic`.
    pub fn stream(&self, topic: &str) -> Option<&Stream> {
        self.streams.iter().find(|s| s.topic == topic)
    }

    /// The typed messages on `topic`, if it exists and holds `T`.
    pub fn messages<T: Message>(&self, topic: &str) -> Option<&[T]> {
        self.stream(topic)?.messages::<T>()
    }

    /// The topic playing the role of message type `T` (see [`super::roles`]).
    pub fn role_topic<T: Message>(&self) -> Option<&str> {
        self.roles
            .iter()
            .find(|c| c.schema_name == T::SCHEMA_NAME)
            .map(|c| c.topic.as_str())
    }

    /// Moves the messages of the role of type `T` out of the log, for a caller that holds
    /// them elsewhere (a long mission's truth or magnetometer need not be held twice). The
    /// stream keeps its counts and timing; its messages are gone.
    pub fn take_role<T: Message>(&mut self) -> Vec<T> {
        let Some(topic) = self.role_topic::<T>().map(str::to_owned) else {
            return Vec::new();
        };
        self.streams
            .iter_mut()
            .find(|s| s.topic == topic)
            .and_then(|s| s.samples.as_any_mut().downcast_mut::<Vec<T>>())
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// The messages of the role of type `T`: at the topic named for it, its default topic,
    /// or the one topic of its type (none when absent).
    pub fn role<T: Message>(&self) -> &[T] {
        self.role_topic::<T>()
            .and_then(|t| self.messages(t))
            .unwrap_or_default()
    }

    /// Messages kept over all streams.
    pub fn message_count(&self) -> u64 {
        self.streams.iter().map(|s| s.samples.len() as u64).sum()
    }

    /// One line for every topic skipped for want of a decoder (a recording's tf, cameras,
    /// diagnostics): how many, and the first few by name, type and count.
    fn skipped_summary(&self) -> Option<String> {
        const NAMED: usize = 4;
        let skipped: Vec<&SkippedTopic> = self
            .skipped
            .iter()
            .filter(|s| s.messages > 0 && s.role_to_name().is_none())
            .collect();
        if skipped.is_empty() {
            return None;
        }
        let messages: u64 = skipped.iter().map(|s| s.messages).sum();
        let named: Vec<String> = skipped
            .iter()
            .take(NAMED)
            .map(|s| {
                format!(
                    "{} (`{}` in {}, {})",
                    s.topic, s.schema_name, s.message_encoding, s.messages
                )
            })
            .collect();
        let more = match skipped.len().saturating_sub(NAMED) {
            0 => String::new(),
            n => format!(" and {n} more"),
        };
        let topics = if skipped.len() == 1 {
            "topic"
        } else {
            "topics"
        };
        Some(format!(
            "skipped {} {topics} of types hindsight does not read ({messages} messages): {}{more}",
            skipped.len(),
            named.join(", ")
        ))
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
        out.extend(self.skipped_summary());
        out.extend(self.skipped.iter().filter_map(|s| {
            let role = s.role_to_name()?;
            Some(format!(
                "{} (`{}`, {} messages) was not read: a topic of this type is read only when \
                 it is named for the {role} role",
                s.topic, s.schema_name, s.messages
            ))
        }));
        out.extend(self.role_problems.iter().map(|p| p.to_string()));
        out.extend(self.beacon_problems.iter().cloned());
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
    /// The log's streams by role (see [`super::roles`]).
    pub fn of(log: &'a Log) -> Self {
        Streams {
            imu: log.role(),
            mag: log.role(),
            dvl: log.role(),
            altimeter: log.role(),
            eml: log.role(),
            depth: log.role(),
            gnss: log.role(),
            fixes: log.role(),
            rpm: log.role(),
            fins: log.role(),
            truth: log.role(),
            acoustic_fixes: log.role(),
            usbl: log.role(),
            ship: log.role(),
            lbl: log.role(),
            beacons: &log.beacons,
        }
    }
}
