//! Typed errors of ingest. Each names what is wrong and where; the binary adds the file name.

use crate::time;

/// A problem with one message: which topic, when it was logged, which field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MessageIssue {
    pub topic: String,
    /// MCAP `log_time` of the message (the stamp may be the broken part).
    pub log_time_ns: u64,
    /// JSON path of the field at fault.
    pub field: String,
    pub reason: String,
}

impl std::fmt::Display for MessageIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = i64::try_from(self.log_time_ns).unwrap_or(i64::MAX);
        write!(
            f,
            "topic {} at log time {} ({} ns): field `{}`: {}",
            self.topic,
            time::format_utc(t),
            self.log_time_ns,
            self.field,
            self.reason
        )
    }
}

/// A log time as UTC with its nanoseconds.
fn at(log_time_ns: u64) -> String {
    let t = i64::try_from(log_time_ns).unwrap_or(i64::MAX);
    format!("{} ({log_time_ns} ns)", time::format_utc(t))
}

/// Why a log could not be read.
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    #[error("read failed")]
    Io(#[from] std::io::Error),

    #[error("the file is empty (0 bytes), not an MCAP log")]
    Empty,

    #[error("not an MCAP file: it starts with {found} where the MCAP magic 89 4D 43 41 50 30 0D 0A belongs (hindsight also reads ROS 1 bags, ROS 2 sqlite3 bags, and CSV files through `hindsight import csv`)")]
    NotMcap { found: String },

    #[error("ROS 1 bag corrupt at byte {offset}: {reason}")]
    CorruptBag { offset: u64, reason: String },

    #[error(
        "a ROS 2 bag in sqlite3 storage is read from its folder or its .db3 file, not a stream"
    )]
    SqliteFromStream,

    #[error("ROS 2 bag {path}: {reason}")]
    Sqlite { path: String, reason: String },

    #[error("the log holds no decodable message")]
    NoMessages,

    #[error("corrupt MCAP record at byte {offset}: {detail}")]
    Corrupt { offset: u64, detail: String },

    #[error(
        "topic {topic} at log time {}: no decoder for schema `{schema}` with message encoding \
         `{encoding}` (hindsight reads the `json` encoding of: {known}; and in `cdr` the ROS 2 \
         types of docs/guide/logs.md)",
        at(*log_time_ns)
    )]
    UnknownSchema {
        topic: String,
        schema: String,
        encoding: String,
        known: String,
        /// MCAP `log_time` of the topic's first message.
        log_time_ns: u64,
    },

    #[error(transparent)]
    Role(#[from] super::roles::RoleError),

    #[error("topic {topic} ({schema}, cdr) at log time {}: {reason}", at(*log_time_ns))]
    Ros2Schema {
        topic: String,
        schema: String,
        reason: String,
        /// MCAP `log_time` of the topic's first message.
        log_time_ns: u64,
    },

    #[error(
        "{first}; {invalid} of {received} messages on {topic} are invalid, over the allowed \
         fraction {allowed} (see `hindsight info` for all topics)"
    )]
    TooManyInvalid {
        topic: String,
        invalid: u64,
        received: u64,
        allowed: f64,
        first: Box<MessageIssue>,
    },
}
