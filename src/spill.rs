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
use std::io;
use std::marker::PhantomData;
use std::ops::Range;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

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

/// Records `0..on_file` on the file, then whole blocks kept in memory, then the tail.
///
/// Whole blocks are written by a thread of their own while the caller goes on pushing (the
/// copy into the system's cache is as costly as the work that makes a filter's records); a
/// read first waits for the writes in flight.
#[derive(Debug)]
pub struct Spilled<T> {
    /// Records not yet a whole block, encoded.
    tail: Vec<u8>,
    /// Where the whole blocks are, and the writes in flight.
    store: Mutex<Store>,
    /// Records per block.
    block: usize,
    spill: bool,
    record_type: PhantomData<fn() -> T>,
}

/// The whole blocks of a [`Spilled`].
#[derive(Debug, Default)]
struct Store {
    file: Option<Arc<TempFile>>,
    /// Records on the file, or handed to the writer for it.
    on_file: usize,
    /// Encoded whole blocks after those on the file (a write failed, or spilling is off).
    kept: Vec<Vec<u8>>,
    writer: Option<Writer>,
    failure: Option<String>,
}

/// The thread that writes blocks to the file, in order, from `from_offset`.
#[derive(Debug)]
struct Writer {
    to_write: SyncSender<Vec<u8>>,
    /// Buffers written, for reuse.
    written: Receiver<Vec<u8>>,
    done: JoinHandle<WriterEnd>,
}

/// What a writer did: the blocks it wrote, and the first error with the blocks it then kept.
#[derive(Debug, Default)]
struct WriterEnd {
    blocks_written: usize,
    error: Option<io::Error>,
    unwritten: Vec<Vec<u8>>,
}

impl Writer {
    fn start(file: Arc<TempFile>, from_offset: u64) -> Writer {
        // One block waits while another is written and the next fills, and one buffer comes
        // back for reuse: at most four blocks in memory (a 27 h run's peak grew 6 MB against
        // a writer that takes each block only when free, and its forward pass got 5 % faster).
        let (to_write, blocks) = sync_channel::<Vec<u8>>(1);
        let (give_back, written) = sync_channel(1);
        let done = std::thread::spawn(move || {
            let (mut end, mut offset) = (WriterEnd::default(), from_offset);
            for block in blocks {
                if end.error.is_some() {
                    end.unwritten.push(block);
                    continue;
                }
                match write_all_at(&file.file, &block, offset) {
                    Ok(()) => {
                        offset += block.len() as u64;
                        end.blocks_written += 1;
                        let _ = give_back.try_send(block);
                    }
                    Err(e) => {
                        end.error = Some(e);
                        end.unwritten.push(block);
                    }
                }
            }
            end
        });
        Writer {
            to_write,
            written,
            done,
        }
    }
}

impl Store {
    /// The writer of the file, started (and the file made) if need be; `None` once writing
    /// has failed.
    fn writer(&mut self, record_bytes: usize) -> Option<&Writer> {
        if self.failure.is_some() {
            return None;
        }
        if self.writer.is_none() {
            let file = match &self.file {
                Some(f) => Arc::clone(f),
                None => match TempFile::create() {
                    Ok(f) => Arc::clone(self.file.insert(Arc::new(f))),
                    Err(e) => {
                        self.failure = Some(failure_text(&e));
                        return None;
                    }
                },
            };
            let from_offset = (self.on_file * record_bytes) as u64;
            self.writer = Some(Writer::start(file, from_offset));
        }
        self.writer.as_ref()
    }

    /// Waits for the writes in flight; blocks a write failed on stay in memory.
    fn settle(&mut self, record_bytes: usize) {
        let Some(writer) = self.writer.take() else {
            return;
        };
        let Writer { to_write, done, .. } = writer;
        drop(to_write);
        let end = done.join().unwrap_or_else(|_| WriterEnd {
            error: Some(io::Error::other("the writing thread stopped")),
            ..WriterEnd::default()
        });
        if let Some(e) = end.error {
            // Blocks handed over but not written: count them back into memory.
            let unwritten_records: usize =
                end.unwritten.iter().map(Vec::len).sum::<usize>() / record_bytes.max(1);
            self.on_file -= unwritten_records;
            let mut kept = end.unwritten;
            kept.append(&mut self.kept);
            self.kept = kept;
            self.failure = Some(failure_text(&e));
        }
    }
}

/// What a failed temporary file is reported as.
fn failure_text(e: &io::Error) -> String {
    format!("temporary file in {}: {e}", temp_dir().display())
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
            store: Mutex::default(),
            block: records.max(1),
            spill: true,
            record_type: PhantomData,
        }
    }

    fn store(&self) -> MutexGuard<'_, Store> {
        let mut store = self.store.lock().unwrap_or_else(|e| e.into_inner());
        store.settle(T::BYTES);
        store
    }

    pub fn len(&self) -> usize {
        // Counted without waiting for the writer: a block it fails on moves from the file's
        // count to memory's.
        let store = self.store.lock().unwrap_or_else(|e| e.into_inner());
        store.on_file + store.kept.len() * self.block + self.tail.len() / T::BYTES
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Records on the temporary file.
    pub fn on_file(&self) -> usize {
        self.store().on_file
    }

    /// Why the records could not be written out (they are then kept in memory).
    pub fn spill_failure(&self) -> Option<String> {
        self.store().failure.clone()
    }

    pub fn push(&mut self, record: T) {
        if self.tail.capacity() == 0 {
            self.tail.reserve_exact(self.block * T::BYTES);
        }
        let mut out = Encoder(std::mem::take(&mut self.tail));
        record.encode(&mut out);
        self.tail = out.0;
        if self.tail.len() >= self.block * T::BYTES {
            self.hand_over_tail();
        }
    }

    /// Hands the tail, a whole block, to the file's writer (or keeps it in memory).
    fn hand_over_tail(&mut self) {
        let (block, bytes) = (self.block, self.block * T::BYTES);
        let store = self.store.get_mut().unwrap_or_else(|e| e.into_inner());
        let Some(writer) = self.spill.then(|| store.writer(T::BYTES)).flatten() else {
            let full = std::mem::replace(&mut self.tail, Vec::with_capacity(bytes));
            store.kept.push(full);
            return;
        };
        let mut next = writer.written.try_recv().unwrap_or_default();
        next.clear();
        next.reserve_exact(bytes);
        let full = std::mem::replace(&mut self.tail, next);
        // A writer that has stopped keeps nothing: the settle that follows says why.
        if writer.to_write.send(full).is_ok() {
            store.on_file += block;
        }
    }

    /// Appends the encoded records `range` (checked by the caller) to `out`.
    fn read_bytes(&self, store: &Store, range: Range<usize>, out: &mut Vec<u8>) -> io::Result<()> {
        let from_file = range.start.min(store.on_file)..range.end.min(store.on_file);
        if !from_file.is_empty() {
            let file = store.file.as_ref().expect("records on file have a file");
            let at = out.len();
            out.resize(at + from_file.len() * T::BYTES, 0);
            read_exact_at(
                &file.file,
                &mut out[at..],
                (from_file.start * T::BYTES) as u64,
            )?;
        }
        let mut k = range.start.max(store.on_file);
        while k < range.end {
            let in_memory = k - store.on_file;
            let (block, within) = (in_memory / self.block, in_memory % self.block);
            let bytes = store.kept.get(block).unwrap_or(&self.tail);
            let take = (self.block - within).min(range.end - k);
            out.extend_from_slice(&bytes[within * T::BYTES..(within + take) * T::BYTES]);
            k += take;
        }
        Ok(())
    }

    fn check(&self, range: &Range<usize>, len: usize) -> io::Result<()> {
        if range.start > range.end || range.end > len {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("records {range:?} of {len}"),
            ));
        }
        Ok(())
    }

    /// Records `range`, in order.
    pub fn read(&self, range: Range<usize>) -> io::Result<Vec<T>> {
        self.check(&range, self.len())?;
        let mut bytes = Vec::new();
        self.read_bytes(&self.store(), range, &mut bytes)?;
        Ok(bytes
            .chunks_exact(T::BYTES)
            .map(|c| T::decode(&mut Decoder(c)))
            .collect())
    }

    /// Record `k`.
    pub fn get(&self, k: usize) -> io::Result<T> {
        Ok(self.read(k..k + 1)?.remove(0))
    }

    pub fn last(&self) -> io::Result<Option<T>> {
        self.len().checked_sub(1).map(|k| self.get(k)).transpose()
    }

    /// The blocks of records from the first to the last: `(start, records)`.
    pub fn blocks(&self) -> impl Iterator<Item = io::Result<(usize, Vec<T>)>> + '_ {
        let n = self.len();
        (0..n.div_ceil(self.block)).map(move |b| {
            let start = b * self.block;
            self.read(start..(start + self.block).min(n))
                .map(|r| (start, r))
        })
    }

    /// The blocks of records from the last to the first, each in order: `(start, records)`.
    pub fn blocks_rev(&self) -> impl Iterator<Item = io::Result<(usize, Vec<T>)>> + '_ {
        let n = self.len();
        (0..n.div_ceil(self.block)).rev().map(move |b| {
            let start = b * self.block;
            self.read(start..(start + self.block).min(n))
                .map(|r| (start, r))
        })
    }

    /// Every record in order, read a block at a time; a failed read ends it with its error.
    pub fn iter(&self) -> Records<'_, T> {
        Records::new(self, false)
    }

    /// Every record from the last to the first, read a block at a time.
    pub fn iter_rev(&self) -> Records<'_, T> {
        Records::new(self, true)
    }

    /// Every record in memory (for short sequences and tests).
    pub fn to_vec(&self) -> io::Result<Vec<T>> {
        self.read(0..self.len())
    }
}

/// The records of a [`Spilled`] one at a time, forwards or backwards, read a block at a time
/// into one buffer and decoded as they are taken.
#[derive(Debug)]
pub struct Records<'a, T> {
    source: &'a Spilled<T>,
    /// Blocks not yet read.
    blocks: Range<usize>,
    rev: bool,
    /// The block read last, encoded, and the records in it not yet taken.
    bytes: Vec<u8>,
    left: Range<usize>,
    len: usize,
    failed: bool,
}

impl<'a, T: Fixed> Records<'a, T> {
    fn new(source: &'a Spilled<T>, rev: bool) -> Self {
        let len = source.len();
        Records {
            source,
            blocks: 0..len.div_ceil(source.block),
            rev,
            bytes: Vec::new(),
            left: 0..0,
            len,
            failed: false,
        }
    }
}

impl<T: Fixed> Iterator for Records<'_, T> {
    type Item = io::Result<T>;

    fn next(&mut self) -> Option<io::Result<T>> {
        if self.failed {
            return None;
        }
        if self.left.is_empty() {
            let b = if self.rev {
                self.blocks.next_back()?
            } else {
                self.blocks.next()?
            };
            let start = b * self.source.block;
            let range = start..(start + self.source.block).min(self.len);
            self.bytes.clear();
            let store = self.source.store();
            if let Err(e) = self
                .source
                .read_bytes(&store, range.clone(), &mut self.bytes)
            {
                self.failed = true;
                return Some(Err(e));
            }
            self.left = 0..range.len();
        }
        let i = if self.rev {
            self.left.next_back()?
        } else {
            self.left.next()?
        };
        let bytes = &self.bytes[i * T::BYTES..(i + 1) * T::BYTES];
        Some(Ok(T::decode(&mut Decoder(bytes))))
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
fn write_all_at(file: &File, buf: &[u8], offset: u64) -> io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(file, buf, offset)
}

#[cfg(windows)]
fn write_all_at(file: &File, mut buf: &[u8], mut offset: u64) -> io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buf.is_empty() {
        match file.seek_write(buf, offset)? {
            0 => return Err(io::ErrorKind::WriteZero.into()),
            n => {
                buf = &buf[n..];
                offset += n as u64;
            }
        }
    }
    Ok(())
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

    #[cfg(unix)]
    #[test]
    fn blocks_a_write_fails_on_stay_in_memory_in_order() {
        let mut s = Spilled::with_block(7);
        // A file open for reading only: every write to it fails.
        let read_only = File::open("/dev/null").unwrap();
        s.store.get_mut().unwrap().file = Some(Arc::new(TempFile {
            file: read_only,
            path: None,
        }));
        for p in pairs(50) {
            s.push(p);
        }
        assert_eq!(s.to_vec().unwrap(), pairs(50));
        assert!(s.spill_failure().is_some());
        assert_eq!(s.on_file(), 0);
        let backwards: Vec<Pair> = s.iter_rev().map(Result::unwrap).collect();
        assert_eq!(backwards, pairs(50).into_iter().rev().collect::<Vec<_>>());
        // Pushed after the failure: kept in memory too, after the others.
        for p in pairs(60).into_iter().skip(50) {
            s.push(p);
        }
        assert_eq!(s.to_vec().unwrap(), pairs(60));
    }
}
