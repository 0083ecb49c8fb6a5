//! ROS 1 bags (format 2.0, what `rosbag record` writes), read directly: the container is
//! walked here and its connections and messages are handed on as the MCAP records they
//! would be after `mcap convert` (a schema `ros1msg` with the connection's
//! `message_definition`, a channel in `ros1`, each message logged at its bag time), so the
//! one [`super::builder::Builder`] serves both containers.
//!
//! A bag is a sequence of records, each `header_len u32, header, data_len u32, data`; a header
//! is a list of `len u32, name=value` fields with the record's `op`. Read here: the bag header
//! (`op` 3), chunks (5; `none`, `bz2` or `lz4`, with the connection (7) and message data (2)
//! records inside), and connections outside chunks. Index records (4, 6) are skipped: the
//! reader needs no index, so a bag whose recording was cut (its header's `index_pos` still
//! 0: `rosbag reindex` would be needed) is read up to its last whole chunk and reported cut
//! short.

use super::error::IngestError;
use super::reader::Ending;
use mcap::records::{Channel, MessageHeader, Record, SchemaHeader};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;

/// The first bytes of every ROS 1 bag of format 2.0.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Largest record header or (uncompressed) chunk accepted: a corrupt length cannot make the
/// reader allocate more than this.
const MAX_RECORD_BYTES: u64 = 1 << 32;

mod opcode {
    pub const MESSAGE_DATA: u8 = 0x02;
    pub const BAG_HEADER: u8 = 0x03;
    pub const INDEX_DATA: u8 = 0x04;
    pub const CHUNK: u8 = 0x05;
    pub const CHUNK_INFO: u8 = 0x06;
    pub const CONNECTION: u8 = 0x07;
}

/// Why a bag's bytes cannot be read, with where.
fn corrupt(offset: u64, reason: impl Into<String>) -> IngestError {
    IngestError::CorruptBag {
        offset,
        reason: reason.into(),
    }
}

/// A record header's fields by name.
struct Fields<'a>(Vec<(&'a str, &'a [u8])>);

impl<'a> Fields<'a> {
    fn parse(mut bytes: &'a [u8]) -> Result<Self, String> {
        let mut fields = Vec::new();
        while !bytes.is_empty() {
            let len = read_u32(bytes, 0).ok_or("a header field's length is cut")? as usize;
            let field = bytes
                .get(4..4 + len)
                .ok_or("a header field runs past its header")?;
            let eq = field
                .iter()
                .position(|&b| b == b'=')
                .ok_or("a header field without `=`")?;
            let name = std::str::from_utf8(&field[..eq]).map_err(|_| "a field name not UTF-8")?;
            fields.push((name, &field[eq + 1..]));
            bytes = &bytes[4 + len..];
        }
        Ok(Fields(fields))
    }

    fn get(&self, name: &str) -> Option<&'a [u8]> {
        self.0.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }

    fn op(&self) -> Result<u8, String> {
        match self.get("op") {
            Some([op]) => Ok(*op),
            _ => Err("a record without its one-byte `op`".into()),
        }
    }

    fn u32(&self, name: &str) -> Result<u32, String> {
        self.get(name)
            .filter(|v| v.len() == 4)
            .and_then(|v| read_u32(v, 0))
            .ok_or_else(|| format!("`{name}` missing or not 4 bytes"))
    }

    fn text(&self, name: &str) -> Result<&'a str, String> {
        let v = self.get(name).ok_or_else(|| format!("`{name}` missing"))?;
        std::str::from_utf8(v).map_err(|_| format!("`{name}` is not UTF-8"))
    }

    /// A message's `time`: seconds and nanoseconds, as nanoseconds.
    fn time_ns(&self) -> Result<u64, String> {
        match self.get("time") {
            Some(v) if v.len() == 8 => {
                let (sec, nsec) = (read_u32(v, 0).unwrap_or(0), read_u32(v, 4).unwrap_or(0));
                Ok(u64::from(sec) * 1_000_000_000 + u64::from(nsec))
            }
            _ => Err("a message's `time` missing or not 8 bytes".into()),
        }
    }
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at + 4)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The connections seen, as MCAP channel ids (the bag's `conn` is a u32).
#[derive(Default)]
struct Connections {
    channel_of: HashMap<u32, u16>,
}

impl Connections {
    /// Hands on a connection record as a schema and a channel, once per `conn`.
    fn on_connection(
        &mut self,
        header: &Fields<'_>,
        data: &[u8],
        at: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let bad = |e: String| corrupt(at, e);
        let conn = header.u32("conn").map_err(bad)?;
        if self.channel_of.contains_key(&conn) {
            return Ok(()); // repeated in the index section
        }
        let id = u16::try_from(self.channel_of.len() + 1)
            .map_err(|_| bad("more than 65535 connections".into()))?;
        let topic = header.text("topic").map_err(bad)?;
        let info = Fields::parse(data).map_err(bad)?;
        let ty = info.text("type").map_err(bad)?;
        let definition = info.get("message_definition").unwrap_or_default();
        let mut metadata = BTreeMap::new();
        for key in ["md5sum", "callerid", "latching"] {
            if let Ok(v) = info.text(key) {
                metadata.insert(key.to_string(), v.to_string());
            }
        }
        self.channel_of.insert(conn, id);
        let schema = Record::Schema {
            header: SchemaHeader {
                id,
                name: ty.to_string(),
                encoding: "ros1msg".into(),
            },
            data: Cow::Borrowed(definition),
        };
        let channel = Record::Channel(Channel {
            id,
            schema_id: id,
            topic: topic.to_string(),
            message_encoding: "ros1".into(),
            metadata,
        });
        on_record(schema)?;
        on_record(channel)
    }
}

/// Where reading stands: the connections seen, the buffer chunks open into, the messages.
struct BagReader {
    connections: Connections,
    chunk: Vec<u8>,
    messages: u32,
}

/// Reads every connection and message of a ROS 1 bag in file order.
///
/// Returns how reading ended (complete when the bag was closed: its header points to an
/// index) and the bytes read.
pub fn for_each_record<R: Read>(
    mut input: R,
    mut on_record: impl FnMut(Record<'_>) -> Result<(), IngestError>,
) -> Result<(Ending, u64), IngestError> {
    let mut magic = [0u8; MAGIC.len()];
    let got = super::reader::read_up_to(&mut input, &mut magic)?;
    if got < MAGIC.len() || magic != MAGIC {
        return Err(corrupt(0, "not a ROS 1 bag of format 2.0"));
    }
    on_record(Record::Header(mcap::records::Header {
        profile: "ros1".into(),
        library: "format 2.0".into(),
    }))?;
    let mut reader = BagReader {
        connections: Connections::default(),
        chunk: Vec::new(),
        messages: 0,
    };
    let mut offset = MAGIC.len() as u64;
    let mut indexed = false;
    let (mut header, mut data) = (Vec::new(), Vec::new());
    loop {
        let start = offset;
        let truncated = |read: u64| {
            let ending = Ending::Truncated {
                whole_records_end: start,
                partial_chunk_messages: 0,
            };
            Ok((ending, read))
        };
        match read_block(&mut input, &mut header)? {
            Block::End if indexed => return Ok((Ending::Complete, start)),
            Block::End => return truncated(start),
            Block::Cut(n) => return truncated(start + n),
            Block::Whole => {}
        }
        let after_header = start + 4 + header.len() as u64;
        match read_block(&mut input, &mut data)? {
            Block::Whole => {}
            Block::End => return truncated(after_header),
            Block::Cut(n) => return truncated(after_header + n),
        }
        offset = after_header + 4 + data.len() as u64;
        let fields = Fields::parse(&header).map_err(|e| corrupt(start, e))?;
        let op = fields.op().map_err(|e| corrupt(start, e))?;
        match op {
            opcode::CHUNK => reader.chunk(&fields, &data, start, &mut on_record)?,
            // `index_pos` is 0 while a bag is recorded and set when it is closed.
            opcode::BAG_HEADER => {
                indexed = fields
                    .get("index_pos")
                    .is_some_and(|p| p.iter().any(|&b| b != 0))
            }
            opcode::INDEX_DATA | opcode::CHUNK_INFO => {}
            _ => reader.record(op, &fields, &data, start, &mut on_record)?,
        }
    }
}

/// How a length-prefixed block read ended.
enum Block {
    Whole,
    /// No byte left: the file ends between records.
    End,
    /// The file ends inside the block, after this many of its bytes.
    Cut(u64),
}

/// Reads one `len u32, bytes` block into `into`.
fn read_block<R: Read>(input: &mut R, into: &mut Vec<u8>) -> Result<Block, IngestError> {
    let mut len = [0u8; 4];
    let got = super::reader::read_up_to(input, &mut len)?;
    if got == 0 {
        return Ok(Block::End);
    }
    if got < 4 {
        return Ok(Block::Cut(got as u64));
    }
    let len = u64::from(u32::from_le_bytes(len));
    let complete = super::reader::read_body(input, len, into)?;
    Ok(if complete {
        Block::Whole
    } else {
        Block::Cut(4 + into.len() as u64)
    })
}

impl BagReader {
    /// A record outside a chunk, or one inside (`at`: where the record or its chunk starts).
    fn record(
        &mut self,
        op: u8,
        fields: &Fields<'_>,
        data: &[u8],
        at: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let bad = |e: String| corrupt(at, e);
        match op {
            opcode::CONNECTION => self.connections.on_connection(fields, data, at, on_record),
            opcode::MESSAGE_DATA => {
                let conn = fields.u32("conn").map_err(bad)?;
                let channel_id =
                    *self.connections.channel_of.get(&conn).ok_or_else(|| {
                        bad(format!("a message on connection {conn}, never defined"))
                    })?;
                let log_time = fields.time_ns().map_err(bad)?;
                self.messages = self.messages.wrapping_add(1);
                let message = Record::Message {
                    header: MessageHeader {
                        channel_id,
                        sequence: self.messages,
                        log_time,
                        publish_time: log_time,
                    },
                    data: Cow::Borrowed(data),
                };
                on_record(message)
            }
            opcode::BAG_HEADER | opcode::INDEX_DATA | opcode::CHUNK_INFO => Ok(()),
            other => Err(bad(format!("unknown record op {other:#04x}"))),
        }
    }

    /// Opens a chunk and walks its records.
    fn chunk(
        &mut self,
        fields: &Fields<'_>,
        data: &[u8],
        start: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let bad = |e: String| corrupt(start, e);
        let size = u64::from(fields.u32("size").map_err(bad)?);
        if size > MAX_RECORD_BYTES {
            return Err(bad(format!("a chunk claims {size} bytes")));
        }
        let compression = fields.text("compression").map_err(bad)?;
        let mut chunk = std::mem::take(&mut self.chunk);
        chunk.clear();
        let opened = match compression {
            "none" => {
                chunk.extend_from_slice(data);
                Ok(())
            }
            "bz2" => bzip2::read::BzDecoder::new(data)
                .take(size)
                .read_to_end(&mut chunk)
                .map(|_| ()),
            "lz4" => lz4::Decoder::new(data)
                .and_then(|d| d.take(size).read_to_end(&mut chunk))
                .map(|_| ()),
            other => {
                return Err(bad(format!(
                    "chunk compression `{other}` (none, bz2 or lz4 are read)"
                )))
            }
        };
        opened.map_err(|e| bad(format!("the {compression} chunk does not open: {e}")))?;
        if chunk.len() as u64 != size {
            return Err(bad(format!(
                "the chunk opened to {} bytes where its header says {size}",
                chunk.len()
            )));
        }
        let walked = self.walk(&chunk, start, on_record);
        self.chunk = chunk;
        walked
    }

    /// The records of an opened chunk (errors name the chunk's start).
    fn walk(
        &mut self,
        mut bytes: &[u8],
        chunk_start: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let bad = |e: &str| corrupt(chunk_start, format!("in the chunk: {e}"));
        while !bytes.is_empty() {
            let (header, rest) = split_block(bytes).ok_or_else(|| bad("a record is cut"))?;
            let (data, rest) = split_block(rest).ok_or_else(|| bad("a record's data is cut"))?;
            let fields = Fields::parse(header).map_err(|e| bad(&e))?;
            let op = fields.op().map_err(|e| bad(&e))?;
            if op == opcode::CHUNK {
                return Err(bad("a chunk inside a chunk"));
            }
            self.record(op, &fields, data, chunk_start, on_record)?;
            bytes = rest;
        }
        Ok(())
    }
}

/// One `len u32, bytes` block from the front of `bytes`, and the rest.
fn split_block(bytes: &[u8]) -> Option<(&[u8], &[u8])> {
    let len = read_u32(bytes, 0)? as usize;
    let end = 4usize.checked_add(len)?;
    Some((bytes.get(4..end)?, &bytes[end..]))
}
