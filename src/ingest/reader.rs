//! Streams the records of an MCAP file from any `Read`, chunk by chunk, with bounded memory.
//!
//! Only this file knows the container. It feeds the sans-I/O `mcap` reader at most
//! [`READ_BLOCK`] bytes at a time, opens chunks one at a time, and knows where the last whole
//! top-level record ended, so a file cut short (no footer) is read up to that record.

use super::error::IngestError;
use mcap::records::{ChunkHeader, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::McapError;
use std::io::Read;

/// Largest single read handed to the decoder: bounds memory even when a corrupt record claims
/// an absurd length (the buffer only grows with bytes that really exist).
const READ_BLOCK: usize = 1 << 20;

/// Largest decompressed chunk accepted (a corrupt header could claim petabytes).
const MAX_CHUNK_BYTES: u64 = 1 << 32;

/// How reading ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Footer and closing magic read.
    Complete,
    /// The file stops inside a record, or before the footer; everything up to
    /// `whole_records_end` (bytes from the file start) was read.
    Truncated { whole_records_end: u64 },
}

/// Reads every record, calling `on_record` for each record outside and inside chunks.
///
/// Chunks are opened and their records passed on in order. Returns how reading ended and the
/// number of bytes read.
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
    if got < magic.len() {
        return Ok((
            Ending::Truncated {
                whole_records_end: 0,
            },
            got as u64,
        ));
    }

    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_emit_chunks(true);
    let mut reader = LinearReader::new_with_options(options);
    let mut record_end: u64 = magic.len() as u64; // end of the last whole top-level record
    let mut fed: u64 = magic.len() as u64;
    let mut footer_seen = false;
    let mut chunks = ChunkOpener::default();
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.clamp(1, READ_BLOCK);
                let read = read_up_to(&mut input, reader.insert(n))?;
                fed += read as u64;
                reader.notify_read(read);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let start = record_end;
                record_end += 9 + data.len() as u64;
                let record = mcap::parse_record(opcode, data).map_err(|e| corrupt(start, e))?;
                match record {
                    Record::Chunk { header, data } => {
                        if header.uncompressed_size > MAX_CHUNK_BYTES {
                            return Err(IngestError::Corrupt {
                                offset: start,
                                detail: format!(
                                    "chunk claims {} uncompressed bytes (limit {MAX_CHUNK_BYTES})",
                                    header.uncompressed_size
                                ),
                            });
                        }
                        chunks.read(&header, &data, start, &mut on_record)?;
                    }
                    Record::Footer(_) => {
                        footer_seen = true;
                        on_record(record)?;
                    }
                    other => on_record(other)?,
                }
            }
            Err(McapError::UnexpectedEof) => {
                return Ok((
                    Ending::Truncated {
                        whole_records_end: record_end,
                    },
                    fed,
                ));
            }
            Err(e) => return Err(corrupt(record_end, e)),
        }
    }
    let ending = if footer_seen {
        Ending::Complete
    } else {
        Ending::Truncated {
            whole_records_end: record_end,
        }
    };
    Ok((ending, fed))
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
            other => {
                return Err(bad(format!(
                    "chunk compression `{other}` is not supported (none, lz4, zstd are)"
                )))
            }
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
        let mut rest = records;
        while !rest.is_empty() {
            if rest.len() < 9 {
                return Err(bad("chunk ends inside a record header".into()));
            }
            let opcode = rest[0];
            let len = u64::from_le_bytes(rest[1..9].try_into().expect("8 bytes"));
            let body_end = usize::try_from(len)
                .ok()
                .and_then(|l| l.checked_add(9))
                .filter(|&end| end <= rest.len())
                .ok_or_else(|| bad(format!("record of {len} bytes overruns its chunk")))?;
            let record =
                mcap::parse_record(opcode, &rest[9..body_end]).map_err(|e| corrupt(offset, e))?;
            on_record(record)?;
            rest = &rest[body_end..];
        }
        Ok(())
    }
}

fn corrupt(offset: u64, e: McapError) -> IngestError {
    IngestError::Corrupt {
        offset,
        detail: e.to_string(),
    }
}

/// Fills `buf` as far as the input allows; returns the count (short only at end of input).
fn read_up_to<R: Read>(input: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
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

/// `"PK\x03\x04..." (50 4B 03 04 ...)`: the bytes as hex, and as text when printable.
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
