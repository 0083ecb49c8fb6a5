//! ROS 2 bags in sqlite3 storage (Foxy to Humble's default): a folder with `metadata.yaml` and
//! one `.db3` file or more, or one `.db3` file alone. Each file's topics and messages are
//! handed on as the MCAP records rosbag2 would have written into MCAP (a schema `ros2msg`,
//! a channel per topic in its serialisation format, each message logged at its
//! `timestamp`), so the one [`super::builder::Builder`] serves every container.
//!
//! The definitions come from the file's `message_definitions` table (Iron and later); before
//! Iron a bag carries none, and the standard types are read with their known definitions
//! ([`super::ros::standard`]). The files are opened read-only and immutable: nothing is
//! written beside them. Messages compressed one by one (`compression_mode: MESSAGE`, zstd)
//! are opened; a bag compressed whole (`.db3.zstd`) must be decompressed first.

use super::error::IngestError;
use super::reader::Ending;
use super::ros::{map::RosType, msg, standard};
use mcap::records::{Channel, MessageHeader, Record, SchemaHeader};
use rusqlite::{Connection, OpenFlags};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// A ROS 2 sqlite3 bag: its files in order, and whether each message is compressed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SqliteBag {
    pub files: Vec<PathBuf>,
    pub message_zstd: bool,
}

/// The bag's error, on one line (SQLite quotes a damaged schema's text, line breaks and all).
fn bad(path: &Path, reason: impl Into<String>) -> IngestError {
    let reason: String = reason.into();
    IngestError::Sqlite {
        path: path.display().to_string(),
        reason: reason.split_whitespace().collect::<Vec<_>>().join(" "),
    }
}

/// The bag at `path` if it is one: a folder with `metadata.yaml` naming sqlite3 storage (or
/// holding `.db3` files), or a file that starts as a SQLite database does.
pub fn bag_at(path: &Path) -> Result<Option<SqliteBag>, IngestError> {
    if path.is_dir() {
        return folder(path).map(Some);
    }
    let mut head = [0u8; 16];
    let got = super::reader::read_up_to(&mut std::fs::File::open(path)?, &mut head)?;
    Ok(head[..got]
        .starts_with(super::log::SQLITE_MAGIC)
        .then(|| SqliteBag {
            files: vec![path.to_path_buf()],
            message_zstd: false,
        }))
}

/// The files of a bag folder: `metadata.yaml`'s `relative_file_paths` in order, else its
/// `.db3` files by name.
fn folder(dir: &Path) -> Result<SqliteBag, IngestError> {
    let metadata = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap_or_default();
    let value = |key: &str| {
        metadata
            .lines()
            .find_map(|l| l.trim().strip_prefix(key)?.trim().strip_prefix(':'))
            .map(|v| v.trim().trim_matches(|c| c == '\'' || c == '"').to_string())
    };
    if let Some(storage) = value("storage_identifier").filter(|s| s != "sqlite3") {
        return Err(bad(
            dir,
            format!("the bag's storage is `{storage}` (sqlite3 is read here; an MCAP bag's .mcap file is read directly)"),
        ));
    }
    let mode = value("compression_mode").unwrap_or_default();
    let format = value("compression_format").unwrap_or_default();
    if mode.eq_ignore_ascii_case("file") {
        return Err(bad(
            dir,
            "the bag is compressed file by file: decompress it first (ros2 bag decompress)",
        ));
    }
    let message_zstd = mode.eq_ignore_ascii_case("message");
    if message_zstd && format != "zstd" {
        return Err(bad(
            dir,
            format!("messages compressed with `{format}` (zstd is read)"),
        ));
    }
    let mut files = relative_file_paths(&metadata)
        .into_iter()
        .map(|f| dir.join(f))
        .collect::<Vec<_>>();
    if files.is_empty() {
        files = std::fs::read_dir(dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "db3"))
            .collect();
        files.sort();
    }
    if files.is_empty() {
        return Err(bad(
            dir,
            "the folder holds no .db3 file (a ROS 2 sqlite3 bag, or give the log's file)",
        ));
    }
    Ok(SqliteBag {
        files,
        message_zstd,
    })
}

/// The list under `relative_file_paths:` in a rosbag2 `metadata.yaml`.
fn relative_file_paths(metadata: &str) -> Vec<String> {
    let mut lines = metadata
        .lines()
        .skip_while(|l| l.trim() != "relative_file_paths:");
    lines.next();
    lines
        .map_while(|l| l.trim().strip_prefix("- "))
        .map(|f| f.trim().trim_matches(|c| c == '\'' || c == '"').to_string())
        .collect()
}

/// Reads every file's topics and messages, in file order and, within a file, in the order
/// written. Returns the ending (always complete: SQLite opens no cut-short database) and the
/// bytes of the files.
pub fn for_each_record(
    bag: &SqliteBag,
    mut on_record: impl FnMut(Record<'_>) -> Result<(), IngestError>,
) -> Result<(Ending, u64), IngestError> {
    on_record(Record::Header(mcap::records::Header {
        profile: "ros2".into(),
        library: String::new(),
    }))?;
    let mut channels = Channels::default();
    let mut messages = Messages {
        zstd: bag
            .message_zstd
            .then(zstd::bulk::Decompressor::new)
            .transpose()?,
        opened: Vec::new(),
        sequence: 0,
    };
    let mut bytes = 0;
    for path in &bag.files {
        bytes += std::fs::metadata(path)?.len();
        let db = open(path)?;
        let topics = channels.of_file(&db, path, &mut on_record)?;
        messages.read(&db, path, &topics, &mut on_record)?;
    }
    Ok((Ending::Complete, bytes))
}

/// Opens a database read-only and immutable (no lock, no journal beside it).
fn open(path: &Path) -> Result<Connection, IngestError> {
    let uri = format!("file:{}?immutable=1", path.display());
    Connection::open_with_flags(
        uri,
        OpenFlags::SQLITE_OPEN_READ_ONLY
            | OpenFlags::SQLITE_OPEN_URI
            | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| bad(path, e.to_string()))
}

/// The channels handed on so far, by (topic, type): a topic in several files is one channel.
#[derive(Default)]
struct Channels {
    by_topic: HashMap<(String, String), u16>,
}

impl Channels {
    /// A file's topics as channels (new ones handed on with their schema): `topic_id` to
    /// channel.
    fn of_file(
        &mut self,
        db: &Connection,
        path: &Path,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<HashMap<i64, u16>, IngestError> {
        let sql = |e: rusqlite::Error| bad(path, e.to_string());
        let definitions = definitions(db).map_err(sql)?;
        let mut statement = db
            .prepare("SELECT id, name, type, serialization_format FROM topics")
            .map_err(sql)?;
        let topics: Vec<(i64, String, String, String)> = statement
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))
            .and_then(|rows| rows.collect())
            .map_err(sql)?;
        let mut of_file = HashMap::new();
        for (id, topic, ty, format) in topics {
            let key = (topic.clone(), ty.clone());
            let channel = match self.by_topic.get(&key) {
                Some(&c) => c,
                None => {
                    let c = u16::try_from(self.by_topic.len() + 1)
                        .map_err(|_| bad(path, "more than 65535 topics"))?;
                    let text = definitions
                        .get(&ty)
                        .cloned()
                        .or_else(|| known_definition(&ty))
                        .unwrap_or_default();
                    on_record(Record::Schema {
                        header: SchemaHeader {
                            id: c,
                            name: ty.clone(),
                            encoding: "ros2msg".into(),
                        },
                        data: Cow::Owned(text.into_bytes()),
                    })?;
                    on_record(Record::Channel(Channel {
                        id: c,
                        schema_id: c,
                        topic,
                        message_encoding: format,
                        metadata: BTreeMap::new(),
                    }))?;
                    self.by_topic.insert(key, c);
                    c
                }
            };
            of_file.insert(id, channel);
        }
        Ok(of_file)
    }
}

/// The file's `message_definitions` (Iron and later) in `ros2msg`, by type; none before.
fn definitions(db: &Connection) -> rusqlite::Result<HashMap<String, String>> {
    let has_table: bool = db.query_row(
        "SELECT EXISTS(SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'message_definitions')",
        [],
        |r| r.get(0),
    )?;
    if !has_table {
        return Ok(HashMap::new());
    }
    let mut statement = db.prepare(
        "SELECT topic_type, encoded_message_definition FROM message_definitions \
         WHERE encoding = 'ros2msg'",
    )?;
    let rows = statement.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?;
    rows.collect()
}

/// The known definition of a standard type named as ROS 2 names it.
fn known_definition(ty: &str) -> Option<String> {
    let name = msg::full_name(ty)?;
    standard::definition(RosType::of(&name)?, msg::Dialect::Ros2)
}

/// Reads the messages of a file.
struct Messages {
    zstd: Option<zstd::bulk::Decompressor<'static>>,
    opened: Vec<u8>,
    sequence: u32,
}

impl Messages {
    fn read(
        &mut self,
        db: &Connection,
        path: &Path,
        topics: &HashMap<i64, u16>,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let sql = |e: rusqlite::Error| bad(path, e.to_string());
        let mut statement = db
            .prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY id")
            .map_err(sql)?;
        let mut rows = statement.query([]).map_err(sql)?;
        while let Some(row) = rows.next().map_err(sql)? {
            let topic_id: i64 = row.get(0).map_err(sql)?;
            let Some(&channel_id) = topics.get(&topic_id) else {
                continue; // a message of no topic
            };
            let log_time = u64::try_from(row.get::<_, i64>(1).map_err(sql)?).unwrap_or(0);
            let data = row
                .get_ref(2)
                .and_then(|v| v.as_blob().map_err(Into::into))
                .map_err(sql)?;
            let data = match self.zstd.as_mut() {
                None => data,
                Some(z) => {
                    self.opened.clear();
                    let size = zstd::zstd_safe::get_frame_content_size(data)
                        .ok()
                        .flatten()
                        .unwrap_or(0)
                        .min(1 << 30) as usize;
                    self.opened.reserve(size.max(data.len()));
                    z.decompress_to_buffer(data, &mut self.opened)
                        .map_err(|e| bad(path, format!("a message does not decompress: {e}")))?;
                    &self.opened[..]
                }
            };
            self.sequence = self.sequence.wrapping_add(1);
            on_record(Record::Message {
                header: MessageHeader {
                    channel_id,
                    sequence: self.sequence,
                    log_time,
                    publish_time: log_time,
                },
                data: Cow::Borrowed(data),
            })?;
        }
        Ok(())
    }
}
