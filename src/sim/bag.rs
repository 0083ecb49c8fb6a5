//! A log's standard-type streams written as a ROS 1 bag (format 2.0) or as a ROS 2 bag in
//! sqlite3 storage, as Humble writes it: for `hindsight bench --as bag|db3` and for tests of
//! the readers. The bag has what a reader needs and `rosbag` writes (bag header with the
//! index position, chunks with connection and message records, connections again in the
//! index section); its per-chunk index records are left out.

use super::ros::{for_each_ros_message, RosMessage};
use crate::ingest::ros::map::{Convention, RosSettings};
use crate::ingest::ros::msg::Dialect;
use crate::ingest::Log;
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

/// Why a bag could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BagWriteError {
    #[error("writing the bag: {0}")]
    Io(#[from] std::io::Error),
    #[error("writing the sqlite3 bag: {0}")]
    Sqlite(#[from] rusqlite::Error),
}

/// Uncompressed bytes a chunk holds before it is closed (rosbag's default).
const CHUNK_BYTES: usize = 768 * 1024;

/// Appends one record: its header fields, then its data.
fn record(out: &mut Vec<u8>, fields: &[(&str, &[u8])], data: &[u8]) {
    let header_len: usize = fields.iter().map(|(k, v)| 4 + k.len() + 1 + v.len()).sum();
    out.extend((header_len as u32).to_le_bytes());
    for (k, v) in fields {
        out.extend(((k.len() + 1 + v.len()) as u32).to_le_bytes());
        out.extend(k.as_bytes());
        out.push(b'=');
        out.extend(*v);
    }
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(data);
}

/// A connection record's data: its type, checksum and definition.
fn connection_data(topic: &str, m: &RosMessage<'_>) -> Vec<u8> {
    let mut data = Vec::new();
    let fields: [(&str, &[u8]); 4] = [
        ("topic", topic.as_bytes()),
        ("type", m.type_name.as_bytes()),
        ("md5sum", b"*"),
        ("message_definition", m.definition.as_bytes()),
    ];
    for (k, v) in fields {
        data.extend(((k.len() + 1 + v.len()) as u32).to_le_bytes());
        data.extend(k.as_bytes());
        data.push(b'=');
        data.extend(v);
    }
    data
}

/// Writes the ROS 1 bag of `log` at `path`, chunks lz4-compressed. Returns the messages.
pub fn write_ros1_bag(
    log: &Log,
    convention: Convention,
    settings: &RosSettings,
    path: &Path,
) -> Result<u64, BagWriteError> {
    let mut chunks: Vec<Vec<u8>> = Vec::new();
    let mut chunk = Vec::new();
    let mut connections: HashMap<usize, (u32, Vec<u8>)> = HashMap::new();
    let written = for_each_ros_message(log, Dialect::Ros1, convention, settings, |m| {
        let next = connections.len() as u32;
        let topic = &log.streams[m.stream].topic;
        let (conn, _) = connections.entry(m.stream).or_insert_with(|| {
            let data = connection_data(topic, &m);
            (next, data)
        });
        let conn = *conn;
        if conn == next {
            let (_, data) = &connections[&m.stream];
            record(
                &mut chunk,
                &[
                    ("op", &[7]),
                    ("conn", &conn.to_le_bytes()),
                    ("topic", topic.as_bytes()),
                ],
                data,
            );
        }
        let (sec, nsec) = (m.log_time_ns / 1_000_000_000, m.log_time_ns % 1_000_000_000);
        let mut time = (sec as u32).to_le_bytes().to_vec();
        time.extend((nsec as u32).to_le_bytes());
        record(
            &mut chunk,
            &[("op", &[2]), ("conn", &conn.to_le_bytes()), ("time", &time)],
            &m.data,
        );
        if chunk.len() >= CHUNK_BYTES {
            chunks.push(std::mem::take(&mut chunk));
        }
        Ok::<(), BagWriteError>(())
    })?;
    if !chunk.is_empty() {
        chunks.push(chunk);
    }
    let mut body = Vec::new();
    for c in &chunks {
        let mut encoder = lz4::EncoderBuilder::new().build(Vec::new())?;
        encoder.write_all(c)?;
        let (compressed, finished) = encoder.finish();
        finished?;
        let size = (c.len() as u32).to_le_bytes();
        record(
            &mut body,
            &[("op", &[5]), ("compression", b"lz4"), ("size", &size)],
            &compressed,
        );
    }
    // The index section: the connections again.
    let mut index = Vec::new();
    let mut by_id: Vec<_> = connections.iter().collect();
    by_id.sort_by_key(|(_, (conn, _))| *conn);
    for (&stream, (conn, data)) in by_id {
        let topic = log.streams[stream].topic.as_bytes();
        record(
            &mut index,
            &[
                ("op", &[7]),
                ("conn", &conn.to_le_bytes()),
                ("topic", topic),
            ],
            data,
        );
    }
    // The bag header record fills 4096 bytes from its start, as rosbag pads it.
    let magic = crate::ingest::bag::MAGIC;
    let index_pos = (magic.len() + 4096 + body.len()) as u64;
    let conn_count = (connections.len() as u32).to_le_bytes();
    let chunk_count = (chunks.len() as u32).to_le_bytes();
    let fields: [(&str, &[u8]); 4] = [
        ("op", &[3]),
        ("index_pos", &index_pos.to_le_bytes()),
        ("conn_count", &conn_count),
        ("chunk_count", &chunk_count),
    ];
    let mut header = Vec::new();
    record(&mut header, &fields, &[]);
    let padding = vec![b' '; 4096 - header.len()];
    header.clear();
    record(&mut header, &fields, &padding);
    let mut file = std::io::BufWriter::new(std::fs::File::create(path)?);
    file.write_all(magic)?;
    file.write_all(&header)?;
    file.write_all(&body)?;
    file.write_all(&index)?;
    file.flush()?;
    Ok(written)
}

/// Writes the ROS 2 sqlite3 bag of `log` into the folder `dir` (made if missing): one
/// `.db3` file with Humble's tables (no definitions) and a `metadata.yaml`. Returns the
/// messages.
pub fn write_sqlite_bag(
    log: &Log,
    convention: Convention,
    settings: &RosSettings,
    dir: &Path,
) -> Result<u64, BagWriteError> {
    std::fs::create_dir_all(dir)?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bag".into());
    let db_path = dir.join(format!("{name}_0.db3"));
    let _ = std::fs::remove_file(&db_path);
    let mut db = rusqlite::Connection::open(&db_path)?;
    db.execute_batch(
        "PRAGMA journal_mode = OFF; PRAGMA synchronous = OFF;
         CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         INSERT INTO schema VALUES (3, 'humble');
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
             timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )?;
    let tx = db.transaction()?;
    let mut topics: HashMap<usize, i64> = HashMap::new();
    let written = {
        let mut add_topic = tx.prepare("INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')")?;
        let mut add =
            tx.prepare("INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)")?;
        for_each_ros_message(log, Dialect::Ros2, convention, settings, |m| {
            let next = topics.len() as i64 + 1;
            let id = *topics.entry(m.stream).or_insert(next);
            if id == next {
                add_topic.execute(rusqlite::params![
                    id,
                    log.streams[m.stream].topic,
                    m.type_name
                ])?;
            }
            add.execute(rusqlite::params![id, m.log_time_ns as i64, m.data])?;
            Ok::<(), BagWriteError>(())
        })?
    };
    tx.commit()?;
    drop(db);
    std::fs::write(
        dir.join("metadata.yaml"),
        format!(
            "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  \
             relative_file_paths:\n    - {name}_0.db3\n  message_count: {written}\n  \
             compression_format: \"\"\n  compression_mode: \"\"\n"
        ),
    )?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::Streams;
    use crate::ingest::{read_log, read_log_from, Container, IngestOptions};
    use crate::sim::writer::{to_bytes, WriterOptions};

    /// A bag and a sqlite3 bag of the same survey read back as its ROS MCAP recordings do.
    #[test]
    fn bags_read_back_as_the_same_recordings_in_mcap() {
        let json = to_bytes(WriterOptions::default(), |w| {
            let spec = crate::sim::synthetic::SurveySpec {
                duration_s: 20.0,
                ..Default::default()
            };
            crate::sim::synthetic::write_survey(w, &spec)
        })
        .unwrap();
        let log = read_log_from(&json[..], &IngestOptions::default()).unwrap();
        let settings = RosSettings::default();
        let dir = std::env::temp_dir().join(format!("hindsight-sim-bag-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bag_path = dir.join("survey.bag");
        let db3_path = dir.join("survey_db3");
        let n = write_ros1_bag(&log, Convention::Rep103, &settings, &bag_path).unwrap();
        let m = write_sqlite_bag(&log, Convention::Rep103, &settings, &db3_path).unwrap();
        assert!(n > 2000 && n == m);
        let bag = read_log(&bag_path, &IngestOptions::default()).unwrap();
        let db3 = read_log(&db3_path, &IngestOptions::default()).unwrap();
        assert_eq!(bag.file.container, Container::Ros1Bag);
        assert_eq!(bag.file.ending, crate::ingest::Ending::Complete);
        assert_eq!(db3.file.container, Container::Ros2Sqlite);
        assert_eq!(bag.message_count(), n);
        let (j, b, d) = (Streams::of(&log), Streams::of(&bag), Streams::of(&db3));
        assert!(!j.imu.is_empty());
        assert_eq!(j.imu, b.imu);
        assert_eq!(j.imu, d.imu);
        assert_eq!(j.mag, b.mag);
        assert_eq!(b.depth.len(), j.depth.len());
        assert_eq!(b.dvl, d.dvl);
        split_in_two(&db3_path);
        let split = read_log(&db3_path, &IngestOptions::default()).unwrap();
        assert_eq!(split.message_count(), n, "both files read");
        let s = Streams::of(&split);
        assert_eq!((s.imu, s.dvl, s.depth), (d.imu, d.dvl, d.depth));
        assert!(split.streams.iter().all(|s| s.counts.out_of_order == 0));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Splits a one-file sqlite3 bag in two at its middle time, as rosbag2 splits a long
    /// recording (`--max-bag-duration`): `_0.db3` holds the first half, `_1.db3` the rest,
    /// and `metadata.yaml` lists both.
    fn split_in_two(dir: &Path) {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let (first, second) = (format!("{name}_0.db3"), format!("{name}_1.db3"));
        std::fs::copy(dir.join(&first), dir.join(&second)).unwrap();
        let db = rusqlite::Connection::open(dir.join(&first)).unwrap();
        let middle: i64 = db
            .query_row(
                "SELECT (MIN(timestamp) + MAX(timestamp)) / 2 FROM messages",
                [],
                |r| r.get(0),
            )
            .unwrap();
        db.execute("DELETE FROM messages WHERE timestamp > ?1", [middle])
            .unwrap();
        let db = rusqlite::Connection::open(dir.join(&second)).unwrap();
        db.execute("DELETE FROM messages WHERE timestamp <= ?1", [middle])
            .unwrap();
        let metadata = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
        let listed = format!("    - {first}\n");
        assert!(metadata.contains(&listed));
        let both = format!("{listed}    - {second}\n");
        std::fs::write(dir.join("metadata.yaml"), metadata.replace(&listed, &both)).unwrap();
    }
}
