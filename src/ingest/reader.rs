//! Streams the records of an MCAP file from any `Read`, one top-level record at a time, with
//! bounded memory.
//!
//! Only this file knows the container. Top-level framing (opcode u8, length u64 LE, body) is
//! read here; bodies are parsed by the `mcap` crate. A record's body is buffered only as its
//! bytes arrive, so a corrupt length cannot make the reader allocate more than the file holds.
//! A file cut short is read up to its last whole record, including the whole records at the
//! start of a chunk that was being written when the file ended.

use super::error::IngestError;
use mcap::records::{op, ChunkHeader, Record};
use mcap::McapError;
use std::io::Read;

/// Largest single read: a record body grows by at most this much per read.
const READ_BLOCK: usize = 1 << 20;

/// Largest decompressed chunk accepted (a corrupt header could claim petabytes).
const MAX_CHUNK_BYTES: u64 = 1 << 32;

/// Opcode and length prefix of every record.
const RECORD_PREFIX: usize = 9;

/// How reading ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// The footer was read.
    Complete,
    /// The file stops before the footer. Every top-level record up to `whole_records_end`
    /// (bytes from the file start) was read, plus `partial_chunk_messages` messages from the
    /// beginning of a chunk cut off by the end of the file.
    Truncated {
        whole_records_end: u64,
        partial_chunk_messages: u64,
    },
}

/// Reads every record in file order, opening chunks and passing on their records too.
///
/// Returns how reading ended and the number of bytes read.
pub fn for_each_record<R: Read>(
    mut input: R,
    mut on_record: impl FnMut(Record<'_>) -> Result<(), IngestError>,
) -> Result<(Ending, u64), IngestError> {
    let mut magic = [0u8; 8];
    let got = read_up_to(&mut input, &mut magic)?;
    if got == 0 {
        return Err(IngestError::Empty);
    }
    if magic[..got] != mcap::MAGIC[..got] {
        return Err(IngestError::NotMcap {
            found: describe_bytes(&magic[..got]),
        });
    }
    let truncated = |whole_records_end, partial_chunk_messages| Ending::Truncated {
        whole_records_end,
        partial_chunk_messages,
    };
    let mut offset = got as u64; // end of the last whole top-level record
    if got < magic.len() {
        return Ok((truncated(0, 0), offset));
    }
    let mut chunks = ChunkOpener::default();
    let mut body = Vec::new();
    loop {
        let mut prefix = [0u8; RECORD_PREFIX];
        let got = read_up_to(&mut input, &mut prefix)?;
        if got < RECORD_PREFIX {
            return Ok((truncated(offset, 0), offset + got as u64));
        }
        let opcode = prefix[0];
        let len = u64::from_le_bytes(prefix[1..].try_into().expect("8 bytes"));
        let complete = read_body(&mut input, len, &mut body)?;
        let start = offset;
        if !complete {
            let read = start + RECORD_PREFIX as u64 + body.len() as u64;
            let partial = if opcode == op::CHUNK {
                chunks.read_partial(&body, start, &mut on_record)?
            } else {
                0
            };
            return Ok((truncated(start, partial), read));
        }
        offset += RECORD_PREFIX as u64 + len;
        match mcap::parse_record(opcode, &body).map_err(|e| corrupt(start, e))? {
            Record::Chunk { header, data } => chunks.read(&header, &data, start, &mut on_record)?,
            footer @ Record::Footer(_) => {
                on_record(footer)?;
                return Ok((Ending::Complete, offset));
            }
            other => on_record(other)?,
        }
    }
}

/// Reads up to `len` bytes into `body` (replacing its contents), in blocks, so memory follows
/// the bytes that exist. Returns whether all `len` bytes were there.
pub(super) fn read_body<R: Read>(
    input: &mut R,
    len: u64,
    body: &mut Vec<u8>,
) -> std::io::Result<bool> {
    body.clear();
    let mut left = len;
    while left > 0 {
        let block = left.min(READ_BLOCK as u64) as usize;
        let start = body.len();
        body.resize(start + block, 0);
        let got = read_up_to(input, &mut body[start..])?;
        body.truncate(start + got);
        if got < block {
            return Ok(false);
        }
        left -= block as u64;
    }
    Ok(true)
}

/// Opens chunks: decompresses into one reused buffer, checks the CRC, and walks the records
/// in place (no copy or allocation per record).
#[derive(Default)]
struct ChunkOpener {
    buffer: Vec<u8>,
    zstd: Option<zstd::bulk::Decompressor<'static>>,
}

impl ChunkOpener {
    fn read(
        &mut self,
        header: &ChunkHeader,
        compressed: &[u8],
        offset: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<(), IngestError> {
        let bad = |detail: String| IngestError::Corrupt { offset, detail };
        if header.uncompressed_size > MAX_CHUNK_BYTES {
            return Err(bad(format!(
                "chunk claims {} uncompressed bytes (limit {MAX_CHUNK_BYTES})",
                header.uncompressed_size
            )));
        }
        let expected = header.uncompressed_size as usize;
        let records: &[u8] = match header.compression.as_str() {
            "" => compressed,
            "zstd" => {
                self.buffer.clear();
                self.buffer.reserve(expected);
                let dctx = match &mut self.zstd {
                    Some(d) => d,
                    None => self.zstd.insert(
                        zstd::bulk::Decompressor::new().map_err(|e| bad(format!("zstd: {e}")))?,
                    ),
                };
                dctx.decompress_to_buffer(compressed, &mut self.buffer)
                    .map_err(|e| bad(format!("zstd chunk does not decompress: {e}")))?;
                &self.buffer
            }
            "lz4" => {
                self.buffer.clear();
                self.buffer.reserve(expected);
                lz4::Decoder::new(compressed)
                    .and_then(|mut d| d.read_to_end(&mut self.buffer))
                    .map_err(|e| bad(format!("lz4 chunk does not decompress: {e}")))?;
                &self.buffer
            }
            other => return Err(bad(unsupported(other))),
        };
        if records.len() != expected {
            return Err(bad(format!(
                "chunk holds {} bytes after decompression, its header says {expected}",
                records.len()
            )));
        }
        if header.uncompressed_crc != 0 && crc32fast::hash(records) != header.uncompressed_crc {
            return Err(bad("chunk CRC mismatch".into()));
        }
        let (_, complete) = walk_records(records, offset, on_record)?;
        if !complete {
            return Err(bad("chunk ends inside a record".into()));
        }
        Ok(())
    }

    /// Recovers the whole records at the start of a chunk cut off by the end of the file.
    /// Returns the number of messages recovered.
    fn read_partial(
        &mut self,
        body: &[u8],
        offset: u64,
        on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
    ) -> Result<u64, IngestError> {
        let Some((compression, data)) = partial_chunk_parts(body) else {
            return Ok(0);
        };
        self.buffer.clear();
        let records: &[u8] = match compression {
            b"" => data,
            b"zstd" => {
                if let Ok(d) = zstd::stream::read::Decoder::with_buffer(data) {
                    drain_prefix(d, &mut self.buffer);
                }
                &self.buffer
            }
            b"lz4" => {
                if let Ok(d) = lz4::Decoder::new(data) {
                    drain_prefix(d, &mut self.buffer);
                }
                &self.buffer
            }
            _ => return Ok(0),
        };
        let mut messages = 0;
        let mut counting = |r: Record<'_>| {
            messages += u64::from(matches!(r, Record::Message { .. }));
            on_record(r)
        };
        walk_records(records, offset, &mut counting)?;
        Ok(messages)
    }
}

/// Calls `on_record` for each whole record in `records`; returns the bytes walked and whether
/// the slice ended exactly at a record boundary.
fn walk_records(
    records: &[u8],
    offset: u64,
    on_record: &mut impl FnMut(Record<'_>) -> Result<(), IngestError>,
) -> Result<(usize, bool), IngestError> {
    let mut rest = records;
    while rest.len() >= RECORD_PREFIX {
        let opcode = rest[0];
        let len = u64::from_le_bytes(rest[1..RECORD_PREFIX].try_into().expect("8 bytes"));
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| l.checked_add(RECORD_PREFIX))
            .filter(|&end| end <= rest.len())
        else {
            break;
        };
        let body = &rest[RECORD_PREFIX..end];
        let record = match message(opcode, body) {
            Some(m) => m,
            None => mcap::parse_record(opcode, body).map_err(|e| corrupt(offset, e))?,
        };
        on_record(record)?;
        rest = &rest[end..];
    }
    Ok((records.len() - rest.len(), rest.is_empty()))
}

/// A Message record read in place: channel id u16, sequence u32, log time u64, publish time
/// u64 (little-endian), then the data. The hot path of every log (the `mcap` crate's
/// general parser costs a tenth of an ingest); other records, and a body too short to be a
/// message, go to that parser.
#[inline]
fn message(opcode: u8, body: &[u8]) -> Option<Record<'_>> {
    const FIXED: usize = 2 + 4 + 8 + 8;
    if opcode != op::MESSAGE || body.len() < FIXED {
        return None;
    }
    let u64_at = |i: usize| u64::from_le_bytes(body[i..i + 8].try_into().expect("8 bytes"));
    Some(Record::Message {
        header: mcap::records::MessageHeader {
            channel_id: u16::from_le_bytes([body[0], body[1]]),
            sequence: u32::from_le_bytes(body[2..6].try_into().expect("4 bytes")),
            log_time: u64_at(6),
            publish_time: u64_at(14),
        },
        data: std::borrow::Cow::Borrowed(&body[FIXED..]),
    })
}

/// The compression name and the available compressed bytes of a chunk record body cut short:
/// start time u64, end time u64, uncompressed size u64, CRC u32, compression (u32 length +
/// text), records (u64 length + bytes).
fn partial_chunk_parts(body: &[u8]) -> Option<(&[u8], &[u8])> {
    let name_len = u32::from_le_bytes(body.get(28..32)?.try_into().ok()?) as usize;
    let name_end = 32usize.checked_add(name_len)?;
    let name = body.get(32..name_end)?;
    let data = body.get(name_end.checked_add(8)?..)?;
    Some((name, data))
}

/// Reads a decompressor until it ends or fails (the input is cut short), keeping what it gave.
fn drain_prefix(mut decoder: impl Read, out: &mut Vec<u8>) {
    let mut block = vec![0u8; 64 * 1024];
    while let Ok(n) = decoder.read(&mut block) {
        if n == 0 {
            break;
        }
        out.extend_from_slice(&block[..n]);
    }
}

fn unsupported(name: &str) -> String {
    format!("chunk compression `{name}` is not supported (none, lz4 and zstd are)")
}

fn corrupt(offset: u64, e: McapError) -> IngestError {
    IngestError::Corrupt {
        offset,
        detail: e.to_string(),
    }
}

/// Fills `buf` as far as the input allows; returns the count (short only at end of input).
pub(super) fn read_up_to<R: Read>(input: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match input.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// `50 4B 03 04 ("PK..")`: the bytes as hex, and as text with unprintable bytes as dots.
fn describe_bytes(bytes: &[u8]) -> String {
    let hex: Vec<String> = bytes.iter().map(|b| format!("{b:02X}")).collect();
    let text: String = bytes
        .iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                b as char
            } else {
                '.'
            }
        })
        .collect();
    format!("{} (\"{text}\")", hex.join(" "))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_message_read_in_place_is_what_the_mcap_crate_reads() {
        let mut body = Vec::new();
        body.extend(7u16.to_le_bytes());
        body.extend(42u32.to_le_bytes());
        body.extend(1_700_000_000_000_000_123u64.to_le_bytes());
        body.extend(1_700_000_000_000_000_456u64.to_le_bytes());
        body.extend(b"{\"a\":1}");
        let ours = super::message(mcap::records::op::MESSAGE, &body).unwrap();
        let theirs = mcap::parse_record(mcap::records::op::MESSAGE, &body).unwrap();
        assert_eq!(format!("{ours:?}"), format!("{theirs:?}"));
        assert!(super::message(mcap::records::op::MESSAGE, &body[..21]).is_none());
        assert!(super::message(mcap::records::op::CHANNEL, &body).is_none());
    }
}
