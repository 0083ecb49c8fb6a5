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
//!
//! On Linux the file is read and written past the system's cache (`O_DIRECT`) where its file
//! system allows it: a record is written once and read once, and copying gigabytes through
//! the cache cost as much processor time as the filter that made them. Each block then
//! starts at a multiple of [`ALIGN`] on the file and in memory ([`Aligned`]). Reading a
//! sequence in order reads its next block on a thread of its own ([`Records`]).

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

/// Alignment of direct transfers: of buffers' addresses, of lengths and of file offsets.
const ALIGN: usize = 4096;

/// `bytes` rounded up to a multiple of [`ALIGN`].
fn aligned_len(bytes: usize) -> usize {
    bytes.div_ceil(ALIGN) * ALIGN
}

/// Bytes starting at an address aligned to [`ALIGN`], in a `Vec` with room enough never to
/// move them.
#[derive(Debug, Default)]
struct Aligned {
    buf: Vec<u8>,
    /// Where the bytes start in `buf`.
    start: usize,
}

impl Aligned {
    /// Empty, with room for `bytes` rounded up to [`ALIGN`].
    fn with_room(bytes: usize) -> Self {
        let mut buf = Vec::with_capacity(aligned_len(bytes) + ALIGN);
        let start = (ALIGN - buf.as_ptr() as usize % ALIGN) % ALIGN;
        buf.resize(start, 0);
        Aligned { buf, start }
    }

    fn bytes(&self) -> &[u8] {
        &self.buf[self.start..]
    }

    fn len(&self) -> usize {
        self.buf.len() - self.start
    }

    fn clear(&mut self) {
        self.buf.truncate(self.start);
    }

    /// Exactly `len` bytes (within the room), zero-filled where new.
    fn set_len(&mut self, len: usize) {
        debug_assert!(
            self.start + len <= self.buf.capacity(),
            "would move the bytes"
        );
        self.buf.resize(self.start + len, 0);
    }

    fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.buf[self.start..]
    }

    /// Whether `len` bytes fit without moving, at an aligned address (a `Vec` that grew past
    /// its room has moved).
    fn has_room(&self, len: usize) -> bool {
        (self.buf.as_ptr() as usize + self.start).is_multiple_of(ALIGN)
            && self.start + len <= self.buf.capacity()
    }
}

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
        // Sized once, then filled eight bytes at a time (a plain copy on little-endian).
        let start = self.0.len();
        self.0.resize(start + 8 * vs.len(), 0);
        for (bytes, v) in self.0[start..].chunks_exact_mut(8).zip(vs) {
            bytes.copy_from_slice(&v.to_le_bytes());
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
        let (head, rest) = self.0.split_at(8 * K);
        self.0 = rest;
        let mut out = [0.0; K];
        for (v, bytes) in out.iter_mut().zip(head.chunks_exact(8)) {
            *v = f64::from_le_bytes(bytes.try_into().expect("8 bytes"));
        }
        out
    }
}

/// Records `0..on_file` on the file, then whole blocks kept in memory, then the tail.
///
/// Whole blocks are written by a thread of their own while the caller goes on pushing; a
/// read first waits for the writes in flight.
#[derive(Debug)]
pub struct Spilled<T> {
    /// Records not yet a whole block, encoded.
    tail: Aligned,
    /// Where the whole blocks are, and the writes in flight.
    store: Mutex<Store>,
    /// Records per block.
    block: usize,
    record_type: PhantomData<fn() -> T>,
}

/// The whole blocks of a [`Spilled`].
#[derive(Debug, Default)]
struct Store {
    file: Option<Arc<TempFile>>,
    /// Records on the file, or handed to the writer for it: whole blocks, block `b` at
    /// `b` strides (its bytes rounded up to [`ALIGN`]).
    on_file: usize,
    /// Encoded whole blocks after those on the file (a write failed, or spilling is off).
    kept: Vec<Aligned>,
    writer: Option<Writer>,
    failure: Option<String>,
}

/// The thread that writes blocks to the file, in order, from `from_offset`.
#[derive(Debug)]
struct Writer {
    to_write: SyncSender<Aligned>,
    /// Buffers written, for reuse.
    written: Receiver<Aligned>,
    done: JoinHandle<WriterEnd>,
}

/// What a writer did: the first error, and the blocks it then kept.
#[derive(Debug, Default)]
struct WriterEnd {
    error: Option<io::Error>,
    unwritten: Vec<Aligned>,
}

impl Writer {
    fn start(file: Arc<TempFile>, from_offset: u64) -> Writer {
        // One block waits while another is written and the next fills, and one buffer comes
        // back for reuse: at most four blocks in memory (a 27 h run's peak grew 6 MB against
        // a writer that takes each block only when free, and its forward pass got 5 % faster).
        let (to_write, blocks) = sync_channel::<Aligned>(1);
        let (give_back, written) = sync_channel(1);
        let done = std::thread::spawn(move || {
            let (mut end, mut offset) = (WriterEnd::default(), from_offset);
            for block in blocks {
                if end.error.is_some() {
                    end.unwritten.push(block);
                    continue;
                }
                match write_all_at(&file.file, block.bytes(), offset) {
                    Ok(()) => {
                        offset += block.len() as u64;
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
    /// has failed. Blocks are `block` records, `stride` bytes apart on the file.
    fn writer(&mut self, block: usize, stride: usize) -> Option<&Writer> {
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
            let from_offset = (self.on_file / block * stride) as u64;
            self.writer = Some(Writer::start(file, from_offset));
        }
        self.writer.as_ref()
    }

    /// Waits for the writes in flight; blocks (of `block` records) a write failed on stay in
    /// memory.
    fn settle(&mut self, block: usize) {
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
            self.on_file -= end.unwritten.len() * block;
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

    /// An empty sequence that spills beyond `records` records (tests use small blocks).
    pub fn with_block(records: usize) -> Self {
        Spilled {
            tail: Aligned::default(),
            store: Mutex::default(),
            block: records.max(1),
            record_type: PhantomData,
        }
    }

    /// Bytes from one block's start to the next's, on the file.
    fn stride(&self) -> usize {
        aligned_len(self.block * T::BYTES)
    }

    fn store(&self) -> MutexGuard<'_, Store> {
        let mut store = self.store.lock().unwrap_or_else(|e| e.into_inner());
        store.settle(self.block);
        store
    }

    fn len_in(&self, store: &Store) -> usize {
        store.on_file + store.kept.len() * self.block + self.tail.len() / T::BYTES
    }

    pub fn len(&self) -> usize {
        // Counted without waiting for the writer: a block it fails on moves from the file's
        // count to memory's.
        self.len_in(&self.store.lock().unwrap_or_else(|e| e.into_inner()))
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Records on the temporary file.
    pub fn on_file(&self) -> usize {
        self.store().on_file
    }

    /// Whether the temporary file is read and written past the system's cache.
    pub fn is_direct(&self) -> bool {
        self.store().file.as_ref().is_some_and(|f| f.direct)
    }

    /// Why the records could not be written out (they are then kept in memory).
    pub fn spill_failure(&self) -> Option<String> {
        self.store().failure.clone()
    }

    pub fn push(&mut self, record: T) {
        if self.tail.buf.capacity() == 0 {
            self.tail = Aligned::with_room(self.stride());
        }
        let mut out = Encoder(std::mem::take(&mut self.tail.buf));
        record.encode(&mut out);
        self.tail.buf = out.0;
        if self.tail.len() >= self.block * T::BYTES {
            self.hand_over_tail();
        }
    }

    /// Hands the tail, a whole block, to the file's writer (or keeps it in memory).
    fn hand_over_tail(&mut self) {
        let (block, stride) = (self.block, self.stride());
        let store = self.store.get_mut().unwrap_or_else(|e| e.into_inner());
        let Some(writer) = store.writer(block, stride) else {
            let full = std::mem::replace(&mut self.tail, Aligned::with_room(stride));
            store.kept.push(full);
            return;
        };
        let next = match writer.written.try_recv() {
            Ok(mut b) if b.has_room(stride) => {
                b.clear();
                b
            }
            _ => Aligned::with_room(stride),
        };
        let mut full = std::mem::replace(&mut self.tail, next);
        full.set_len(stride);
        // A writer that has stopped keeps nothing: the settle that follows says why.
        if writer.to_write.send(full).is_ok() {
            store.on_file += block;
        }
    }

    /// Appends the encoded records `range` (checked by the caller) to `out`.
    fn read_bytes(&self, store: &Store, range: Range<usize>, out: &mut Vec<u8>) -> io::Result<()> {
        let from_file = range.start.min(store.on_file)..range.end.min(store.on_file);
        let mut k = from_file.start;
        let mut span = Aligned::default();
        while k < from_file.end {
            let file = store.file.as_ref().expect("records on file have a file");
            let (b, within) = (k / self.block, k % self.block);
            let take = (self.block - within).min(from_file.end - k);
            // The whole pages of block `b` that hold the records.
            let first = within * T::BYTES / ALIGN * ALIGN;
            let end = aligned_len((within + take) * T::BYTES);
            file.read_into(b * self.stride() + first, end - first, &mut span)?;
            let at = within * T::BYTES - first;
            out.extend_from_slice(&span.bytes()[at..at + take * T::BYTES]);
            k += take;
        }
        let mut k = range.start.max(store.on_file);
        while k < range.end {
            let in_memory = k - store.on_file;
            let (block, within) = (in_memory / self.block, in_memory % self.block);
            let bytes = store.kept.get(block).unwrap_or(&self.tail).bytes();
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
        let store = self.store();
        self.check(&range, self.len_in(&store))?;
        let mut bytes = Vec::with_capacity(range.len() * T::BYTES);
        self.read_bytes(&store, range, &mut bytes)?;
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

/// The records of a [`Spilled`] one at a time, forwards or backwards, decoded as they are
/// taken from one block in memory. The blocks on the file are read ahead, in the order they
/// are taken, by a thread of their own ([`ReadAhead`]).
#[derive(Debug)]
pub struct Records<'a, T> {
    source: &'a Spilled<T>,
    /// Blocks not yet taken.
    blocks: Range<usize>,
    rev: bool,
    /// Blocks `0..file_blocks` are on the file.
    file_blocks: usize,
    ahead: Option<ReadAhead>,
    /// The block taken last, encoded, and the records in it not yet taken.
    current: Aligned,
    left: Range<usize>,
    len: usize,
    failed: bool,
}

impl<'a, T: Fixed> Records<'a, T> {
    fn new(source: &'a Spilled<T>, rev: bool) -> Self {
        let store = source.store();
        let len = source.len_in(&store);
        let file_blocks = store.on_file / source.block;
        let ahead = store.file.as_ref().filter(|_| file_blocks > 0).map(|file| {
            let order: Vec<usize> = if rev {
                (0..file_blocks).rev().collect()
            } else {
                (0..file_blocks).collect()
            };
            ReadAhead::start(Arc::clone(file), order, source.stride())
        });
        drop(store);
        Records {
            source,
            blocks: 0..len.div_ceil(source.block),
            rev,
            file_blocks,
            ahead,
            current: Aligned::default(),
            left: 0..0,
            len,
            failed: false,
        }
    }

    /// Makes block `b`, records `range`, the current one.
    fn take_block(&mut self, b: usize, range: Range<usize>) -> io::Result<()> {
        match self.ahead.as_mut().filter(|_| b < self.file_blocks) {
            Some(ahead) => {
                let next = ahead.next_block()?;
                ahead.recycle(std::mem::replace(&mut self.current, next));
            }
            None => {
                self.current.clear();
                let store = self.source.store();
                self.source
                    .read_bytes(&store, range, &mut self.current.buf)?;
            }
        }
        Ok(())
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
            if let Err(e) = self.take_block(b, range.clone()) {
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
        let bytes = &self.current.bytes()[i * T::BYTES..(i + 1) * T::BYTES];
        Some(Ok(T::decode(&mut Decoder(bytes))))
    }
}

/// A thread that reads whole blocks of the file in a given order, one ahead of the reader.
#[derive(Debug)]
struct ReadAhead {
    /// Blocks read (dropped first, so that the thread stops).
    blocks: Option<Receiver<io::Result<Aligned>>>,
    /// Buffers taken, for reuse.
    spare: SyncSender<Aligned>,
    thread: Option<JoinHandle<()>>,
}

impl ReadAhead {
    fn start(file: Arc<TempFile>, order: Vec<usize>, stride: usize) -> Self {
        // A block is handed over when taken: one in use, one read ahead, one spare.
        let (send, blocks) = sync_channel(0);
        let (spare, spares) = sync_channel::<Aligned>(1);
        let thread = std::thread::spawn(move || {
            for b in order {
                let mut buf = spares.try_recv().ok().filter(|s| s.has_room(stride));
                let read = file.read_into(b * stride, stride, buf.get_or_insert_default());
                let failed = read.is_err();
                if send.send(read.map(|()| buf.unwrap_or_default())).is_err() || failed {
                    return;
                }
            }
        });
        ReadAhead {
            blocks: Some(blocks),
            spare,
            thread: Some(thread),
        }
    }

    fn next_block(&mut self) -> io::Result<Aligned> {
        let received = self.blocks.as_ref().and_then(|r| r.recv().ok());
        received.unwrap_or_else(|| Err(io::Error::other("the reading thread stopped")))
    }

    fn recycle(&self, buf: Aligned) {
        let _ = self.spare.try_send(buf);
    }
}

impl Drop for ReadAhead {
    fn drop(&mut self) {
        self.blocks = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
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
    /// Transfers bypass the system's cache (and must be aligned: every one is).
    direct: bool,
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
        let direct = direct::try_enable(&file);
        Ok(TempFile { file, path, direct })
    }

    /// Reads `len` bytes at `offset` (both multiples of [`ALIGN`]) into `into`.
    fn read_into(&self, offset: usize, len: usize, into: &mut Aligned) -> io::Result<()> {
        if !into.has_room(len) {
            *into = Aligned::with_room(len);
        }
        into.set_len(len);
        read_exact_at(&self.file, into.bytes_mut(), offset as u64)
    }
}

/// Transfers past the system's cache (`O_DIRECT`), where the file system takes them.
#[cfg(target_os = "linux")]
mod direct {
    use super::{write_all_at, Aligned, ALIGN};
    use std::fs::File;
    use std::io;
    use std::os::fd::AsRawFd;

    /// Turns direct transfers on if a one-page write then succeeds (some file systems, such
    /// as older tmpfs, refuse them); else leaves the file cached. Whether they are on.
    pub(super) fn try_enable(file: &File) -> bool {
        if set(file, true).is_err() {
            return false;
        }
        let mut page = Aligned::with_room(ALIGN);
        page.set_len(ALIGN);
        if write_all_at(file, page.bytes(), 0).is_ok() {
            return true;
        }
        let _ = set(file, false);
        false
    }

    fn set(file: &File, on: bool) -> io::Result<()> {
        let fd = file.as_raw_fd();
        // SAFETY: `fd` is open (owned by `file`, borrowed for the call); F_GETFL and F_SETFL
        // read and set its status flags and touch no memory of ours.
        let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
        if flags < 0 {
            return Err(io::Error::last_os_error());
        }
        let flags = if on {
            flags | libc::O_DIRECT
        } else {
            flags & !libc::O_DIRECT
        };
        // SAFETY: as above.
        if unsafe { libc::fcntl(fd, libc::F_SETFL, flags) } < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }
}

/// Elsewhere the file goes through the system's cache.
#[cfg(not(target_os = "linux"))]
mod direct {
    pub(super) fn try_enable(_: &std::fs::File) -> bool {
        false
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
    }

    /// Dropping an iteration part way stops its reading thread (the drop joins it).
    #[test]
    fn an_iteration_stopped_part_way_lets_its_reader_go() {
        let mut s = Spilled::with_block(7);
        for p in pairs(200) {
            s.push(p);
        }
        assert_eq!(s.on_file(), 196);
        let first: Vec<Pair> = s.iter().take(10).map(Result::unwrap).collect();
        assert_eq!(first, pairs(10));
        let last: Vec<Pair> = s.iter_rev().take(10).map(Result::unwrap).collect();
        assert_eq!(
            last,
            pairs(200)[190..].iter().rev().copied().collect::<Vec<_>>()
        );
        // Records of the same sequence read while another iteration is under way.
        let mut outer = s.iter();
        assert_eq!(outer.nth(50).unwrap().unwrap(), pairs(200)[50]);
        assert_eq!(s.read(120..130).unwrap(), pairs(200)[120..130]);
        assert_eq!(outer.next().unwrap().unwrap(), pairs(200)[51]);
    }

    #[test]
    fn short_sequences_never_touch_the_disk() {
        let mut short = Spilled::<Pair>::new();
        for p in pairs(1000) {
            short.push(p);
        }
        assert_eq!(short.on_file(), 0);
        assert_eq!(short.to_vec().unwrap(), pairs(1000));
        assert!(Spilled::<Pair>::new().last().unwrap().is_none());
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
            direct: false,
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
