//! The project's MCAP writer: contract messages as JSON, with their JSON Schemas embedded.
//!
//! Every MCAP hindsight writes goes through here, so the schemas in `schemas/` travel with
//! every log. The options cover what the contract allows readers to meet: chunked or not,
//! uncompressed/lz4/zstd, with or without a summary section.

use crate::contract::Message;
use crate::ingest::Mission;
use mcap::records::MessageHeader;
use std::collections::{BTreeMap, HashMap};
use std::io::{Seek, Write};

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    None,
    Lz4,
    Zstd,
}

crate::config::with_defaults! {
    /// Container layout of a written log.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct WriterOptions {
        /// Messages in chunks (compressible, indexable) or directly in the data section.
        pub chunked: bool = true,
        /// Chunk compression (ignored when not chunked).
        pub compression: Compression = Compression::Zstd,
        /// Write the summary section (schemas, channels, statistics, indexes).
        pub summary: bool = true,
        /// Target uncompressed chunk size in bytes.
        pub chunk_size: u64 = 1 << 20,
    }
}

/// Error of the writer (I/O or MCAP encoding).
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("MCAP write failed: {0}")]
    Mcap(#[from] mcap::McapError),
    #[error("message encoding failed: {0}")]
    Json(#[from] serde_json::Error),
}

/// Writes contract messages to an MCAP stream.
pub struct LogWriter<W: Write + Seek> {
    inner: mcap::Writer<W>,
    /// (topic, schema name) -> channel id
    channels: HashMap<(String, String), u16>,
    schemas: HashMap<String, u16>,
    sequence: u32,
    messages: u64,
}

impl<W: Write + Seek> LogWriter<W> {
    /// Starts a log.
    pub fn new(out: W, options: WriterOptions) -> Result<Self, WriteError> {
        let compression = match options.compression {
            Compression::None => None,
            Compression::Lz4 => Some(mcap::Compression::Lz4),
            Compression::Zstd => Some(mcap::Compression::Zstd),
        };
        let opts = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("hindsight/", env!("CARGO_PKG_VERSION")))
            .use_chunks(options.chunked)
            .compression(if options.chunked { compression } else { None })
            .chunk_size(Some(options.chunk_size))
            .emit_summary_records(options.summary)
            .emit_summary_offsets(options.summary)
            .emit_message_indexes(options.chunked && options.summary);
        Ok(LogWriter {
            inner: opts.create(out)?,
            channels: HashMap::new(),
            schemas: HashMap::new(),
            sequence: 0,
            messages: 0,
        })
    }

    /// Writes the contract's `mission` metadata record.
    pub fn write_mission(&mut self, mission: &Mission) -> Result<(), WriteError> {
        self.write_metadata("mission", mission.to_map())
    }

    /// Writes a metadata record.
    pub fn write_metadata(
        &mut self,
        name: &str,
        map: BTreeMap<String, String>,
    ) -> Result<(), WriteError> {
        self.inner.write_metadata(&mcap::records::Metadata {
            name: name.to_string(),
            metadata: map,
        })?;
        Ok(())
    }

    /// Writes a contract message on `topic`, logged at `log_time_ns`.
    pub fn write<T: Message>(
        &mut self,
        topic: &str,
        msg: &T,
        log_time_ns: u64,
    ) -> Result<(), WriteError> {
        let data = serde_json::to_vec(msg)?;
        self.write_raw(
            topic,
            T::SCHEMA_NAME,
            T::SCHEMA_JSON,
            "json",
            &data,
            log_time_ns,
        )
    }

    /// Writes a message as given bytes under any schema (its text: a JSON Schema, or a ROS
    /// message definition for `cdr` and `ros1`): for binary messages, tests of bad input and
    /// messages of other tools.
    pub fn write_raw(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema_text: &str,
        message_encoding: &str,
        data: &[u8],
        log_time_ns: u64,
    ) -> Result<(), WriteError> {
        let channel_id = self.channel(topic, schema_name, schema_text, message_encoding)?;
        self.sequence = self.sequence.wrapping_add(1);
        self.messages += 1;
        self.inner.write_to_known_channel(
            &MessageHeader {
                channel_id,
                sequence: self.sequence,
                log_time: log_time_ns,
                publish_time: log_time_ns,
            },
            data,
        )?;
        Ok(())
    }

    fn channel(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema_text: &str,
        message_encoding: &str,
    ) -> Result<u16, WriteError> {
        if let Some(&id) = self
            .channels
            .get(&(topic.to_string(), schema_name.to_string()))
        {
            return Ok(id);
        }
        let schema_id = match self.schemas.get(schema_name) {
            Some(&id) => id,
            None => {
                // cdr and ros1 messages are described by ROS message definitions.
                let encoding = match message_encoding {
                    "cdr" => "ros2msg",
                    "ros1" => "ros1msg",
                    _ => "jsonschema",
                };
                let id = self
                    .inner
                    .add_schema(schema_name, encoding, schema_text.as_bytes())?;
                self.schemas.insert(schema_name.to_string(), id);
                id
            }
        };
        let id = self
            .inner
            .add_channel(schema_id, topic, message_encoding, &BTreeMap::new())?;
        self.channels
            .insert((topic.to_string(), schema_name.to_string()), id);
        Ok(id)
    }

    /// The messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// Writes the summary and footer and returns the output.
    pub fn finish(mut self) -> Result<W, WriteError> {
        self.inner.finish()?;
        Ok(self.inner.into_inner())
    }
}

/// Writes a whole log into memory: handy for tests.
pub fn to_bytes(
    options: WriterOptions,
    fill: impl FnOnce(&mut LogWriter<std::io::Cursor<Vec<u8>>>) -> Result<(), WriteError>,
) -> Result<Vec<u8>, WriteError> {
    let mut w = LogWriter::new(std::io::Cursor::new(Vec::new()), options)?;
    fill(&mut w)?;
    Ok(w.finish()?.into_inner())
}
