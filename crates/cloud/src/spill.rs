//! Spilling to disk for out-of-core builds: a scratch directory beside the output file, removed
//! with everything in it when the build ends (also after an error or a panic; on a signal
//! through [`crate::scratch`]'s registry; after a crash by the next run beside the same
//! output), and files of fixed-size records in it, written once and read back by range.
//!
//! A [`Scratch`] can be told to fail its writes after a number of bytes
//! ([`Scratch::fail_after`]), which is how tests play a disk that fills: the error is the one a
//! full disk gives (`StorageFull`), and the caller's clean-up path is the real one.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// A scratch directory, removed with its contents on drop.
#[derive(Debug)]
pub struct Scratch {
    dir: PathBuf,
    _registered: crate::scratch::Registered,
    next: AtomicU64,
    written: Arc<AtomicU64>,
    usage: Arc<Usage>,
    fail_after: Option<u64>,
}

/// Points per chunk an out-of-core build can hold under `memory_limit`, when it needs
/// `reserve` bytes beside its chunk and `per_point` bytes a point of it; `Err` (the reason,
/// naming the least limit) when that is below `min_chunk` points.
pub fn chunk_capacity(
    memory_limit: u64,
    reserve: u64,
    per_point: u64,
    min_chunk: u64,
) -> Result<u64, String> {
    let cap = memory_limit.saturating_sub(reserve) / per_point.max(1);
    if cap < min_chunk {
        return Err(format!(
            "{} is below what the out-of-core build can work in ({}: {} of buffers and \
             chunks of at least {min_chunk} points at {per_point} bytes a point)",
            crate::memory::human(u128::from(memory_limit)),
            crate::memory::human(u128::from(reserve + min_chunk * per_point)),
            crate::memory::human(u128::from(reserve)),
        ));
    }
    Ok(cap)
}

/// Bytes in the scratch files now, and the most there were at once.
#[derive(Debug, Default)]
struct Usage {
    live: AtomicU64,
    peak: AtomicU64,
}

impl Scratch {
    /// Creates `.NAME.chunks-HOST-PID-K/` beside `out` (the disk the output goes to), after
    /// removing the stale scratch of this host's dead processes there
    /// ([`crate::scratch::remove_stale_in`]).
    pub fn beside(out: &Path) -> io::Result<Self> {
        if let Some(parent) = out.parent() {
            let parent = if parent.as_os_str().is_empty() {
                Path::new(".")
            } else {
                parent
            };
            crate::scratch::remove_stale_in(parent);
        }
        let dir = crate::scratch::beside(out, "chunks");
        let registered = crate::scratch::register(&dir);
        std::fs::create_dir(&dir)?;
        Ok(Self {
            dir,
            _registered: registered,
            next: AtomicU64::new(0),
            written: Arc::new(AtomicU64::new(0)),
            usage: Arc::new(Usage::default()),
            fail_after: None,
        })
    }

    /// A second scratch directory beside `out` whose files count with `other`'s: the bytes
    /// written, the bytes held at once and the failing writes of [`Scratch::fail_after`] are
    /// those of both together (a build that reads another's scratch files while it writes its
    /// own, as the SPT build reads the preparation's chunks).
    pub fn beside_counted_with(out: &Path, other: &Scratch) -> io::Result<Self> {
        let mut s = Self::beside(out)?;
        s.written = Arc::clone(&other.written);
        s.usage = Arc::clone(&other.usage);
        s.fail_after = other.fail_after;
        Ok(s)
    }

    /// Makes every write fail (as a full disk does) once `bytes` have been written in total.
    pub fn fail_after(mut self, bytes: u64) -> Self {
        self.fail_after = Some(bytes);
        self
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Bytes written to the scratch files so far.
    pub fn bytes_written(&self) -> u64 {
        self.written.load(Ordering::Relaxed)
    }

    /// The most bytes the scratch files held at once (records pushed, less the files removed
    /// since): what the disk must have room for, where [`Scratch::bytes_written`] counts every
    /// byte ever written.
    pub fn peak_bytes(&self) -> u64 {
        self.usage.peak.load(Ordering::Relaxed)
    }

    /// A new file of records of `record` bytes.
    pub fn create(&self, record: usize) -> io::Result<SpillWriter> {
        self.create_buffered(record, 1 << 20)
    }

    /// [`Scratch::create`] with a write buffer of `buffer` bytes (for many files at once).
    pub fn create_buffered(&self, record: usize, buffer: usize) -> io::Result<SpillWriter> {
        let k = self.next.fetch_add(1, Ordering::Relaxed);
        let path = self.dir.join(format!("{k}.bin"));
        let file = File::create(&path)?;
        Ok(SpillWriter {
            out: BufWriter::with_capacity(buffer.max(record), file),
            file: Arc::new(Removed {
                path,
                bytes: AtomicU64::new(0),
                usage: Arc::clone(&self.usage),
            }),
            record,
            count: 0,
            written: Arc::clone(&self.written),
            pending: 0,
            fail_after: self.fail_after,
        })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A path removed when the last handle goes, its bytes then taken off the scratch's usage.
#[derive(Debug)]
struct Removed {
    path: PathBuf,
    bytes: AtomicU64,
    usage: Arc<Usage>,
}

impl Drop for Removed {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
        self.usage
            .live
            .fetch_sub(self.bytes.load(Ordering::Relaxed), Ordering::Relaxed);
    }
}

/// Appends records to a scratch file.
#[derive(Debug)]
pub struct SpillWriter {
    out: BufWriter<File>,
    file: Arc<Removed>,
    record: usize,
    count: u64,
    written: Arc<AtomicU64>,
    /// Bytes pushed but not yet counted in the scratch's usage (counted by the MiB, so that
    /// the shared counters are not touched per record).
    pending: u64,
    fail_after: Option<u64>,
}

/// Bytes a writer pushes between updates of the scratch's usage.
const USAGE_STEP: u64 = 1 << 20;

impl SpillWriter {
    /// Adds the pending bytes to the file's and the scratch's usage.
    fn count_usage(&mut self) {
        if self.pending == 0 {
            return;
        }
        let usage = &self.file.usage;
        let live = usage.live.fetch_add(self.pending, Ordering::Relaxed) + self.pending;
        usage.peak.fetch_max(live, Ordering::Relaxed);
        self.file.bytes.fetch_add(self.pending, Ordering::Relaxed);
        self.pending = 0;
    }

    /// Appends one record (`bytes.len()` must be the record size).
    pub fn push(&mut self, bytes: &[u8]) -> io::Result<()> {
        debug_assert_eq!(bytes.len(), self.record);
        self.push_all(bytes)
    }

    /// Appends whole records at once (`bytes.len()` a multiple of the record size): with a
    /// buffer smaller than them, they go to the file directly.
    pub fn push_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        debug_assert_eq!(bytes.len() % self.record, 0);
        let total = self
            .written
            .fetch_add(bytes.len() as u64, Ordering::Relaxed)
            + bytes.len() as u64;
        if self.fail_after.is_some_and(|limit| total > limit) {
            return Err(io::Error::new(
                io::ErrorKind::StorageFull,
                "no space left on device (injected)",
            ));
        }
        self.out.write_all(bytes)?;
        self.count += (bytes.len() / self.record) as u64;
        self.pending += bytes.len() as u64;
        if self.pending >= USAGE_STEP {
            self.count_usage();
        }
        Ok(())
    }

    /// Records written so far.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// Whether nothing was written.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Flushes what is buffered (so that a reader sees every record pushed so far).
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Finishes the file.
    pub fn finish(mut self) -> io::Result<SpillFile> {
        self.out.flush()?;
        self.count_usage();
        Ok(SpillFile {
            file: Arc::clone(&self.file),
            record: self.record,
            count: self.count,
        })
    }

    /// A reader of this file while it is still being written (records up to those flushed).
    pub fn reader_from(&self, start: u64) -> io::Result<SpillReader> {
        open_reader(&self.file.path, self.record, start, u64::MAX, 1 << 20)
    }
}

impl Drop for SpillWriter {
    fn drop(&mut self) {
        // Bytes pushed count until the file is removed, finished or not.
        self.count_usage();
    }
}

/// A finished scratch file of records; removed from disk when the last clone goes.
#[derive(Debug, Clone)]
pub struct SpillFile {
    file: Arc<Removed>,
    record: usize,
    count: u64,
}

impl SpillFile {
    /// Bytes of a record.
    pub fn record(&self) -> usize {
        self.record
    }

    /// Number of records.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// Whether the file has no records.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Reads records `start..start + count`.
    pub fn reader(&self, start: u64, count: u64) -> io::Result<SpillReader> {
        self.reader_buffered(start, count, 1 << 20)
    }

    /// [`SpillFile::reader`] with a read buffer of `buffer` bytes (for many files at once).
    pub fn reader_buffered(
        &self,
        start: u64,
        count: u64,
        buffer: usize,
    ) -> io::Result<SpillReader> {
        if start.checked_add(count).is_none_or(|end| end > self.count) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "records {start}..+{count} past the end of a scratch file of {}",
                    self.count
                ),
            ));
        }
        open_reader(&self.file.path, self.record, start, count, buffer)
    }
}

fn open_reader(
    path: &Path,
    record: usize,
    start: u64,
    count: u64,
    buffer: usize,
) -> io::Result<SpillReader> {
    let mut file = File::open(path)?;
    file.seek(SeekFrom::Start(start * record as u64))?;
    Ok(SpillReader {
        input: BufReader::with_capacity(buffer.max(record), file),
        pos: start,
        left: count,
        record: record as u64,
    })
}

/// Reads records in order from a range of a scratch file.
#[derive(Debug)]
pub struct SpillReader {
    input: BufReader<File>,
    pos: u64,
    left: u64,
    record: u64,
}

impl SpillReader {
    /// Reads the next record into `buf` (the record size); `false` at the end of the range.
    pub fn next_into(&mut self, buf: &mut [u8]) -> io::Result<bool> {
        if self.left == 0 {
            return Ok(false);
        }
        self.input.read_exact(buf)?;
        self.left -= 1;
        self.pos += 1;
        Ok(true)
    }

    /// Appends every record left in the range to `out`, at once.
    pub fn read_rest(&mut self, out: &mut Vec<u8>) -> io::Result<()> {
        let bytes = usize::try_from(self.left * self.record)
            .map_err(|_| io::Error::other("a scratch range larger than memory"))?;
        let from = out.len();
        out.resize(from + bytes, 0);
        self.input.read_exact(&mut out[from..])?;
        self.pos += self.left;
        self.left = 0;
        Ok(())
    }

    /// Moves to record `index` (a no-op when already there).
    pub fn seek_to(&mut self, index: u64) -> io::Result<()> {
        if index != self.pos {
            let delta = (index as i64 - self.pos as i64) * self.record as i64;
            self.input.seek_relative(delta)?;
            self.left = self.left.saturating_add(self.pos).saturating_sub(index);
            self.pos = index;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_counts_what_is_on_disk_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let scratch = Scratch::beside(&dir.path().join("x.qsplat")).unwrap();
        let fill = |mib: u64| {
            let mut w = scratch.create(1024).unwrap();
            for _ in 0..mib * 1024 {
                w.push(&[7u8; 1024]).unwrap();
            }
            w
        };
        let a = fill(3).finish().unwrap();
        let b = fill(2);
        assert_eq!(scratch.peak_bytes(), 5 << 20);
        drop(a);
        drop(b); // unfinished: its bytes count until it goes
        let c = fill(4).finish().unwrap();
        assert_eq!(scratch.bytes_written(), 9 << 20);
        assert_eq!(scratch.peak_bytes(), 5 << 20);
        let d = fill(2).finish().unwrap();
        assert_eq!(scratch.peak_bytes(), 6 << 20);
        drop((c, d));
        assert_eq!(scratch.usage.live.load(Ordering::Relaxed), 0);
    }

    #[test]
    fn a_scratch_counted_with_another_counts_both_and_fails_with_it() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.spt");
        let first = Scratch::beside(&out).unwrap().fail_after(40);
        let second = Scratch::beside_counted_with(&out, &first).unwrap();
        assert_ne!(first.dir(), second.dir());
        let mut a = first.create(4).unwrap();
        for _ in 0..4 {
            a.push(&[1; 4]).unwrap();
        }
        let a = a.finish().unwrap();
        let mut b = second.create(4).unwrap();
        for _ in 0..5 {
            b.push(&[2; 4]).unwrap();
        }
        let b = b.finish().unwrap();
        // Both files at once, written and held, seen from either.
        for s in [&first, &second] {
            assert_eq!((s.bytes_written(), s.peak_bytes()), (36, 36));
        }
        drop(a);
        // The disk fills for both: 36 written, the next 8 cross 40.
        let mut c = second.create(4).unwrap();
        c.push(&[3; 4]).unwrap();
        assert_eq!(
            c.push(&[3; 4]).unwrap_err().kind(),
            io::ErrorKind::StorageFull
        );
        drop((b, c));
        let second_dir = second.dir().to_path_buf();
        drop(second);
        assert!(!second_dir.exists());
        assert!(first.dir().exists());
    }

    /// Records `from..from + n` of a file of u32 records.
    fn u32s(f: &SpillFile, from: u64, n: u64) -> Vec<u32> {
        let mut r = f.reader(from, n).unwrap();
        let mut b = [0u8; 4];
        let mut got = Vec::new();
        while r.next_into(&mut b).unwrap() {
            got.push(u32::from_le_bytes(b));
        }
        got
    }

    #[test]
    fn records_round_trip_and_everything_is_removed() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.qsplat");
        let scratch = Scratch::beside(&out).unwrap();
        let mut w = scratch.create(4).unwrap();
        for i in 0u32..1000 {
            w.push(&i.to_le_bytes()).unwrap();
        }
        let f = w.finish().unwrap();
        assert_eq!(u32s(&f, 10, 5), vec![10, 11, 12, 13, 14]);
        assert!(f.reader(999, 2).is_err());
        drop(f);
        assert_eq!(std::fs::read_dir(scratch.dir()).unwrap().count(), 0);
        drop(scratch);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn an_injected_full_disk_fails_the_write() {
        let dir = tempfile::tempdir().unwrap();
        let scratch = Scratch::beside(&dir.path().join("x"))
            .unwrap()
            .fail_after(8);
        let mut w = scratch.create(4).unwrap();
        w.push(&[0; 4]).unwrap();
        w.push(&[0; 4]).unwrap();
        let e = w.push(&[0; 4]).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::StorageFull);
        // Records pushed many at once count against the same disk.
        let mut w = scratch.create_buffered(4, 4).unwrap();
        let e = w.push_all(&[0; 12]).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::StorageFull);
    }

    #[test]
    fn records_pushed_at_once_read_back_as_pushed_one_by_one() {
        let dir = tempfile::tempdir().unwrap();
        let scratch = Scratch::beside(&dir.path().join("x")).unwrap();
        // A buffer of one record, as the halo files have: the batches go to the file whole.
        let mut w = scratch.create_buffered(4, 4).unwrap();
        let mut want = Vec::new();
        for batch in [0u32..3, 3..3, 3..700, 700..701] {
            let bytes: Vec<u8> = batch.clone().flat_map(u32::to_le_bytes).collect();
            w.push_all(&bytes).unwrap();
            w.flush().unwrap();
            want.extend(batch);
        }
        w.push(&701u32.to_le_bytes()).unwrap();
        want.push(701);
        assert_eq!(w.len(), 702);
        let f = w.finish().unwrap();
        assert_eq!(u32s(&f, 0, 702), want);
    }
}
