//! Append-only sequences of fixed-size records that stay in memory up to one block and go to
//! an unlinked temporary file beyond it: what a long mission keeps per filter epoch (the
//! smoother's records, the solutions) then costs disk, not memory.
//!
//! - A sequence shorter than one block never touches the disk.
//! - The file is created in the system's temporary directory (`TMPDIR` on Unix) and unlinked
//!   at once where the system allows it, so nothing is left behind, even by a crash.
//! - When the file cannot be created or written (a full disk), the records stay in memory
//!   and [`Spilled::spill_failure`] says why: the run goes on, only its memory is unbounded.
//!
//! Records are encoded field by field as little-endian numbers ([`Fixed`]), so the layout
//! is explicit and needs no `unsafe`.

use std::fs::File;
use std::io::{self, Write};
use std::ops::Range;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes of records kept in memory before they are written out.
pub const BLOCK_BYTES: usize = 8 << 20;

/// A record of a fixed number of bytes.
pub trait Fixed: Sized {
    /// Encoded size, bytes.
    const BYTES: usize;
    /// Appends exactly [`Fixed::BYTES`] bytes.
    fn encode(&self, out: &mut Encoder);
    /// Decodes what [`Fixed::encode`] wrote.
    fn decode(bytes: &mut Decoder<'_>) -> Self;
}

/// Writes numbers little-endian.
#[derive(Debug, Default)]
pub struct Encoder(Vec<u8>);

impl Encoder {
    pub fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn i64(&mut self, v: i64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64s(&mut self, vs: &[f64]) {
        for &v in vs {
            self.f64(v);
        }
    }
    pub fn into_bytes(self) -> Vec<u8> {
        self.0
    }
}

/// Reads what an [`Encoder`] wrote, in the same order.
#[derive(Debug)]
pub struct Decoder<'a>(&'a [u8]);

impl<'a> Decoder<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Decoder(bytes)
    }
    pub fn f64(&mut self) -> f64 {
        let (head, rest) = self.0.split_at(8);
        self.0 = rest;
        f64::from_le_bytes(head.try_into().expect("8 bytes"))
    }
    pub fn i64(&mut self) -> i64 {
        let (head, rest) = self.0.split_at(8);
        self.0 = rest;
        i64::from_le_bytes(head.try_into().expect("8 bytes"))
    }
    pub fn f64s<const K: usize>(&mut self) -> [f64; K] {
        std::array::from_fn(|_| self.f64())
    }
}

/// Records `0..on_file` on the file, the rest in memory.
#[derive(Debug)]
pub struct Spilled<T> {
    tail: Vec<T>,
    file: Option<TempFile>,
    on_file: usize,
    /// Records per block.
    block: usize,
    spill: bool,
    failure: Option<String>,
}

impl<T: Fixed> Default for Spilled<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Fixed> Spilled<T> {
    /// An empty sequence that spills beyond [`BLOCK_BYTES`].
    pub fn new() -> Self {
        Self::with_block(BLOCK_BYTES / T::BYTES.max(1))
    }

    /// An empty sequence that never spills (short runs that are dropped at once).
    pub fn in_memory() -> Self {
        Spilled {
            spill: false,
            ..Self::new()
        }
    }

    /// An empty sequence that spills beyond `records` records (tests use small blocks).
    pub fn with_block(records: usize) -> Self {
        Spilled {
            tail: Vec::new(),
            file: None,
            on_file: 0,
            block: records.max(1),
            spill: true,
            failure: None,
        }
    }

    pub fn len(&self) -> usize {
        self.on_file + self.tail.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Records on the temporary file.
    pub fn on_file(&self) -> usize {
        self.on_file
    }

    /// Why the records could not be written out (they are then all in memory).
    pub fn spill_failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }

    pub fn push(&mut self, record: T) {
        self.tail.push(record);
        if self.spill && self.tail.len() >= self.block {
            if let Err(e) = self.write_tail() {
                self.spill = false;
                self.failure = Some(format!("temporary file in {}: {e}", temp_dir().display()));
            }
        }
    }

    fn write_tail(&mut self) -> io::Result<()> {
        let file = match &mut self.file {
            Some(f) => f,
            None => self.file.insert(TempFile::create()?),
        };
        let mut out = Encoder(Vec::with_capacity(self.tail.len() * T::BYTES));
        for r in &self.tail {
            r.encode(&mut out);
        }
        debug_assert_eq!(out.0.len(), self.tail.len() * T::BYTES);
        file.file.write_all(&out.0)?;
        self.on_file += self.tail.len();
        self.tail.clear();
        Ok(())
    }

    /// Records `range`, in order.
    pub fn read(&self, range: Range<usize>) -> io::Result<Vec<T>>
    where
        T: Clone,
    {
        if range.start > range.end || range.end > self.len() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("records {range:?} of {}", self.len()),
            ));
        }
        let mut out = Vec::with_capacity(range.len());
        let from_file = range.start.min(self.on_file)..range.end.min(self.on_file);
        if !from_file.is_empty() {
            let file = self.file.as_ref().expect("records on file have a file");
            let mut bytes = vec![0u8; from_file.len() * T::BYTES];
            read_exact_at(&file.file, &mut bytes, (from_file.start * T::BYTES) as u64)?;
            out.extend(
                bytes
                    .chunks_exact(T::BYTES)
                    .map(|c| T::decode(&mut Decoder(c))),
            );
        }
        let in_memory = range.start.max(self.on_file)..range.end.max(self.on_file);
        out.extend_from_slice(
            &self.tail[in_memory.start - self.on_file..in_memory.end - self.on_file],
        );
        Ok(out)
    }

    /// Record `k`.
    pub fn get(&self, k: usize) -> io::Result<T>
    where
        T: Clone,
    {
        if let Some(r) = k.checked_sub(self.on_file).and_then(|i| self.tail.get(i)) {
            return Ok(r.clone());
        }
        Ok(self.read(k..k + 1)?.remove(0))
    }

    pub fn last(&self) -> io::Result<Option<T>>
    where
        T: Clone,
    {
        self.len().checked_sub(1).map(|k| self.get(k)).transpose()
    }

    /// The blocks of records from the first to the last: `(start, records)`.
    pub fn blocks(&self) -> impl Iterator<Item = io::Result<(usize, Vec<T>)>> + '_
    where
        T: Clone,
    {
        let n = self.len();
        (0..n.div_ceil(self.block)).map(move |b| {
            let start = b * self.block;
            self.read(start..(start + self.block).min(n))
                .map(|r| (start, r))
        })
    }

    /// The blocks of records from the last to the first, each in order: `(start, records)`.
    pub fn blocks_rev(&self) -> impl Iterator<Item = io::Result<(usize, Vec<T>)>> + '_
    where
        T: Clone,
    {
        let n = self.len();
        (0..n.div_ceil(self.block)).rev().map(move |b| {
            let start = b * self.block;
            self.read(start..(start + self.block).min(n))
                .map(|r| (start, r))
        })
    }

    /// Every record in order, read a block at a time; a failed read ends it with its error.
    pub fn iter(&self) -> impl Iterator<Item = io::Result<T>> + '_
    where
        T: Clone,
    {
        self.blocks().flat_map(|b| flatten(b, false))
    }

    /// Every record from the last to the first, read a block at a time.
    pub fn iter_rev(&self) -> impl Iterator<Item = io::Result<T>> + '_
    where
        T: Clone,
    {
        self.blocks_rev().flat_map(|b| flatten(b, true))
    }

    /// Every record in memory (for short sequences and tests).
    pub fn to_vec(&self) -> io::Result<Vec<T>>
    where
        T: Clone,
    {
        self.read(0..self.len())
    }
}

impl<T: Fixed> FromIterator<T> for Spilled<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut s = Spilled::new();
        for r in iter {
            s.push(r);
        }
        s
    }
}

/// A block's records as items, reversed when `rev`.
type Items<T> = std::iter::Chain<
    std::iter::Map<std::vec::IntoIter<T>, fn(T) -> io::Result<T>>,
    std::option::IntoIter<io::Result<T>>,
>;

/// A block's records as items (reversed when `rev`), or its error as the one item.
fn flatten<T>(block: io::Result<(usize, Vec<T>)>, rev: bool) -> Items<T> {
    let (mut records, error) = match block {
        Ok((_, records)) => (records, None),
        Err(e) => (Vec::new(), Some(Err(e))),
    };
    if rev {
        records.reverse();
    }
    records
        .into_iter()
        .map(Ok as fn(T) -> io::Result<T>)
        .chain(error)
}

/// Where temporary files go.
fn temp_dir() -> PathBuf {
    std::env::temp_dir()
}

/// A temporary file, unlinked at creation where the system allows it, else removed on drop.
#[derive(Debug)]
struct TempFile {
    file: File,
    path: Option<PathBuf>,
}

impl TempFile {
    fn create() -> io::Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let path = temp_dir().join(format!(
            ".hindsight-spill-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)?;
        // Unlinked while open: the space is freed when the file is closed, crash or not.
        let path = std::fs::remove_file(&path).is_err().then_some(path);
        Ok(TempFile { file, path })
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(p) = &self.path {
            let _ = std::fs::remove_file(p);
        }
    }
}

#[cfg(unix)]
fn read_exact_at(file: &File, buf: &mut [u8], offset: u64) -> io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
}

#[cfg(windows)]
fn read_exact_at(file: &File, mut buf: &mut [u8], mut offset: u64) -> io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buf.is_empty() {
        match file.seek_read(buf, offset)? {
            0 => return Err(io::ErrorKind::UnexpectedEof.into()),
            n => {
                buf = &mut buf[n..];
                offset += n as u64;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq)]
    struct Pair(i64, f64);

    impl Fixed for Pair {
        const BYTES: usize = 16;
        fn encode(&self, out: &mut Encoder) {
            out.i64(self.0);
            out.f64(self.1);
        }
        fn decode(d: &mut Decoder<'_>) -> Self {
            Pair(d.i64(), d.f64())
        }
    }

    fn pairs(n: usize) -> Vec<Pair> {
        (0..n)
            .map(|k| Pair(k as i64 * 10, k as f64 * 0.5 - 3.0))
            .collect()
    }

    #[test]
    fn spilled_records_read_back_in_any_order() {
        let mut s = Spilled::with_block(7);
        for p in pairs(50) {
            s.push(p);
        }
        assert_eq!(s.len(), 50);
        assert_eq!(s.on_file(), 49, "whole blocks go to the file");
        assert!(s.spill_failure().is_none());
        assert_eq!(s.to_vec().unwrap(), pairs(50));
        assert_eq!(s.read(5..23).unwrap(), pairs(50)[5..23]);
        assert_eq!(s.get(48).unwrap(), pairs(50)[48]);
        assert_eq!(s.get(49).unwrap(), pairs(50)[49]);
        assert_eq!(s.last().unwrap(), Some(pairs(50)[49]));
        assert!(s.get(50).is_err() && s.read(40..51).is_err());
        let seen: Vec<Pair> = s.iter().map(Result::unwrap).collect();
        assert_eq!(seen, pairs(50));
        let backwards: Vec<Pair> = s.iter_rev().map(Result::unwrap).collect();
        assert_eq!(backwards, pairs(50).into_iter().rev().collect::<Vec<_>>());
        let starts: Vec<usize> = s.blocks_rev().map(|b| b.unwrap().0).collect();
        assert_eq!(starts, [49, 42, 35, 28, 21, 14, 7, 0]);
    }

    #[test]
    fn short_and_in_memory_sequences_never_touch_the_disk() {
        let mut short = Spilled::<Pair>::new();
        let mut kept = Spilled::in_memory();
        for p in pairs(1000) {
            short.push(p);
        }
        for p in pairs(100) {
            kept.push(p);
        }
        assert_eq!((short.on_file(), kept.on_file()), (0, 0));
        assert_eq!(kept.to_vec().unwrap(), pairs(100));
        assert!(Spilled::<Pair>::new().last().unwrap().is_none());
        assert_eq!(Spilled::<Pair>::new().blocks_rev().count(), 0);
    }
}
