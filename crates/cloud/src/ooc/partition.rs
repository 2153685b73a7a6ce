//! Step 2 of the preparation: a set of more points than a chunk holds split as a binary space
//! partition splits it, streamed: the midpoint of its box's longest axis, Lomuto's partition
//! replayed on a first-in-first-out file ([`Fifo`]), so that every set keeps the order the
//! in-memory partition gives it (which decides how coincident points are halved); two levels
//! of splits make a group of two to four sets, and a set that fits a chunk is a chunk.

use std::io;

use glam::DVec3;

use super::chunks::{Part, PartKind, Set};
use super::error::Result;
use super::record::{REC, position_of};
use super::{Preparer, Stage};
use crate::spill::{SpillFile, SpillReader, SpillWriter};

/// The right-hand side of a streamed Lomuto partition: a first-in-first-out file. Lomuto's
/// loop keeps the right points in `items[k..j]`; a left point at `j` swaps with `items[k]`,
/// which moves the first right point to the back. Replaying that on a FIFO (push every right
/// point; on a left point, pop the front and push it again) leaves the right half, in order,
/// as the records from the pop position to the end.
struct Fifo {
    writer: SpillWriter,
    /// Bytes of a record in the file (the first of each array).
    rec: usize,
    /// Records pushed but not yet written to the file, from index `flushed`.
    tail: Vec<[u8; REC]>,
    flushed: u64,
    pushed: u64,
    popped: u64,
    reader: Option<SpillReader>,
}

const TAIL: usize = 1 << 14;

impl Fifo {
    fn push(&mut self, rec: [u8; REC]) -> io::Result<()> {
        self.tail.push(rec);
        self.pushed += 1;
        if self.tail.len() >= TAIL {
            for r in &self.tail {
                self.writer.push(&r[..self.rec])?;
            }
            self.writer.flush()?;
            self.flushed += self.tail.len() as u64;
            self.tail.clear();
        }
        Ok(())
    }

    fn pop(&mut self) -> io::Result<[u8; REC]> {
        let i = self.popped;
        self.popped += 1;
        if i >= self.flushed {
            return Ok(self.tail[(i - self.flushed) as usize]);
        }
        let reader = match &mut self.reader {
            Some(r) => r,
            None => self.reader.insert(self.writer.reader_from(i)?),
        };
        reader.seek_to(i)?;
        let mut b = [0u8; REC];
        if !reader.next_into(&mut b[..self.rec])? {
            return Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "scratch queue read past its end",
            ));
        }
        Ok(b)
    }

    fn finish(mut self) -> io::Result<(SpillFile, u64, u64)> {
        for r in &self.tail {
            self.writer.push(&r[..self.rec])?;
        }
        let file = self.writer.finish()?;
        Ok((file, self.popped, self.pushed - self.popped))
    }
}

impl Preparer<'_> {
    /// One split of `set`, streamed: the midpoint of its box's longest axis (points below it
    /// to the left), Lomuto's partition replayed on a FIFO, so the two halves come in the
    /// order an in-memory Lomuto partition leaves them; every point on one side: halves by
    /// position.
    pub(super) fn split(&self, set: Set) -> Result<(Set, Set)> {
        let (lo, hi) = self.store.bbox(&set)?;
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = 0.5 * (lo[axis] + hi[axis]);
        let mut left = self.store.create()?;
        let mut fifo = Fifo {
            writer: self.store.create()?,
            rec: self.store.rec,
            tail: Vec::new(),
            flushed: 0,
            pushed: 0,
            popped: 0,
            reader: None,
        };
        let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut lb, mut rb) = (empty, empty);
        self.store.for_each(&set, |r| {
            let p = position_of(r);
            if p[axis] < mid {
                lb = (lb.0.min(p), lb.1.max(p));
                self.store.push(&mut left, r)?;
                if fifo.pushed > fifo.popped {
                    let front = fifo.pop().map_err(|e| self.store.io(e))?;
                    fifo.push(front).map_err(|e| self.store.io(e))?;
                }
            } else {
                rb = (rb.0.min(p), rb.1.max(p));
                fifo.push(*r).map_err(|e| self.store.io(e))?;
            }
            Ok(())
        })?;
        let k = left.len();
        if k == 0 || k == set.count {
            // Every point on one side: the order is unchanged; halves by position.
            let h = set.count / 2;
            let a = Set {
                file: set.file.clone(),
                start: set.start,
                count: h,
                bbox: None,
                overlap: true,
            };
            let b = Set {
                file: set.file,
                start: set.start + h,
                count: set.count - h,
                bbox: None,
                overlap: true,
            };
            return Ok((a, b));
        }
        let left = Set {
            file: left.finish().map_err(|e| self.store.io(e))?,
            start: 0,
            count: k,
            bbox: Some(lb),
            overlap: set.overlap,
        };
        let (file, start, count) = fifo.finish().map_err(|e| self.store.io(e))?;
        let right = Set {
            file,
            start,
            count,
            bbox: Some(rb),
            overlap: set.overlap,
        };
        Ok((left, right))
    }

    /// Two levels of splits: two to four groups (a half of fewer than two points is not split
    /// again).
    pub(super) fn groups(&self, set: Set) -> Result<Vec<Set>> {
        let (a, b) = self.split(set)?;
        let mut out = Vec::with_capacity(4);
        for half in [a, b] {
            if half.count >= 2 {
                let (c, d) = self.split(half)?;
                out.push(c);
                out.push(d);
            } else {
                out.push(half);
            }
        }
        Ok(out)
    }

    /// Splits `set` down to chunks; returns its top node and the levels above the chunks.
    pub(super) fn partition(&mut self, set: Set) -> Result<(usize, u32)> {
        if set.count <= self.cap {
            let bbox = self.store.bbox(&set)?;
            let set = Set {
                bbox: Some(bbox),
                ..set
            };
            self.done += set.count;
            (self.progress)(Stage::Split, self.done);
            self.store.chunks.push(set);
            self.store.parts.push(Part {
                kind: PartKind::Chunk(self.store.chunks.len() - 1),
                bbox,
                halo2: 0.0,
            });
            return Ok((self.store.parts.len() - 1, 0));
        }
        let bbox = self.store.bbox(&set)?;
        let groups = self.groups(set)?;
        let mut kids = Vec::with_capacity(groups.len());
        let mut levels = 0;
        for g in groups {
            let (k, l) = self.partition(g)?;
            kids.push(k);
            levels = levels.max(l + 1);
        }
        self.store.parts.push(Part {
            kind: PartKind::Inner(kids),
            bbox,
            halo2: 0.0,
        });
        Ok((self.store.parts.len() - 1, levels))
    }
}
