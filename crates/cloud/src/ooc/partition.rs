//! Step 2 of the preparation: the input split into chunks as a binary space partition splits
//! it (the midpoint of a set's box's longest axis, points below it to the left; two levels of
//! splits make a group of two to four sets; a set that fits a chunk is a chunk), each point
//! written to scratch once or twice.
//!
//! The split of a set needs its box, and a set's box is known only once its parent's split is.
//! Sets too large to hold in memory are found level by level, each level by a pass over the
//! input (in input order, read, not written) that sends every point down the splits known so
//! far and gathers the count and box of the sets it reaches. Once every set still to split
//! holds at most what memory holds ([`Preparer::subset_points`]: its parent's count bounds
//! it), one last pass writes each of them, in input order, to a file of its own (a *subset*),
//! and each set known to be a chunk to its chunk's file. Each subset is then split in memory
//! down to its chunks: its records loaded, a stable partition of their indices per split, each
//! chunk written in input order as it is found. An input that fits memory at once is split in
//! memory from the start (each point written once, to its chunk). A set whose points all lie on
//! one side of its midpoint (coincident points) is halved by position: its first half in input
//! order to the left. The input is kept in segments, and the last pass, the only one that
//! writes, removes each once read, so the input and the subsets are not on the disk at once
//! (the most scratch at once is the input's records and a segment).
//!
//! This is the partition of the in-memory build's (QSplat's `build`, whose split is a stable
//! partition): the same sets, each in input order, whichever sets are split in memory. As in
//! PotreeConverter 2 (Schütz et al. 2020, count, then distribute), the passes before the last
//! only count; as in its hierarchical distribution, a pass distributes to subsets that are then
//! split on their own, so the input is not read once per level of the tree (13 passes of 16 GB
//! at 10^9 points before).

use glam::DVec3;
use rayon::prelude::*;

use super::chunks::{Part, PartKind, Set};
use super::{Preparer, Stage};
use crate::lod_file::Result;
use crate::spill::{SpillFile, SpillWriter};

/// Records of an input segment.
pub(super) const SEGMENT: u64 = 1 << 20;
/// Write-buffer bytes shared by the files the last pass over the input writes.
const WRITE_BUFFERS: usize = 32 << 20;
/// The smallest write buffer of a file that pass writes (many files share [`WRITE_BUFFERS`]).
const MIN_WRITE_BUFFER: usize = 4 << 10;
/// Bytes per point beside its record while a subset is split in memory (its index, and its
/// index again in the partition's temporary).
const INDEX_BYTES: u64 = 8;
/// Sets this large are split, sized and written by every thread (smaller ones by one); small
/// in this crate's own tests, so that their clouds take the parallel paths too.
const PARALLEL: usize = if cfg!(test) { 1 << 11 } else { 1 << 16 };
/// Records a large chunk gathers at once before writing them (2^18: about 10 MB at most).
const WINDOW: usize = if cfg!(test) { 1 << 12 } else { 1 << 18 };

#[cfg(test)]
thread_local! {
    /// Tests: the most points of a subset split in memory, in place of the limit's.
    pub(super) static SUBSET_POINTS: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
}

/// What is known of a set of the tree of splits.
#[derive(Debug, Clone, Copy)]
enum State {
    /// Its count and box are gathered by the next pass.
    Pending,
    /// Split at `mid` on `axis` (points below it to `kids[0]`).
    Split {
        axis: usize,
        mid: f64,
        kids: [usize; 2],
    },
    /// Halved by position: its first `h` points (in input order) to `kids[0]`.
    Halve { h: u64, kids: [usize; 2] },
    /// A chunk.
    Chunk,
}

/// A set of the tree of splits.
#[derive(Debug)]
struct Node {
    /// Splits above it (even: a set [`Preparer::partition`]'s recursion sees; odd: a first
    /// split's half, split again when it has two points or more).
    depth: u32,
    /// The most points it can hold (its parent's count).
    bound: u64,
    count: u64,
    bbox: (DVec3, DVec3),
    overlap: bool,
    /// Points seen so far this pass (a halved set's rank).
    seen: u64,
    state: State,
    /// The writer of its points during the pass that writes them (a chunk's or a subset's).
    writer: Option<SpillWriter>,
    /// Its points in input order, once written: a chunk's, or a subset's still to split.
    file: Option<SpillFile>,
}

const EMPTY: (DVec3, DVec3) = (DVec3::INFINITY, DVec3::NEG_INFINITY);

impl Node {
    fn new(depth: u32, bound: u64, overlap: bool, state: State) -> Self {
        Node {
            depth,
            bound,
            count: 0,
            bbox: EMPTY,
            overlap,
            seen: 0,
            state,
            writer: None,
            file: None,
        }
    }

    /// Whether its count and box are still to be gathered.
    fn gathers(&self) -> bool {
        match self.state {
            State::Pending => true,
            State::Chunk => self.file.is_none(),
            State::Split { .. } | State::Halve { .. } => false,
        }
    }

    fn kids(&self) -> Option<[usize; 2]> {
        match self.state {
            State::Split { kids, .. } | State::Halve { kids, .. } => Some(kids),
            State::Pending | State::Chunk => None,
        }
    }
}

/// The axis and midpoint QSplat's split takes for a box.
fn split_plane((lo, hi): (DVec3, DVec3)) -> (usize, f64) {
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    (axis, 0.5 * (lo[axis] + hi[axis]))
}

impl Preparer<'_> {
    /// Splits the input (`segments`, in input order, `n` points of box `bbox`) down to chunks
    /// (module doc); returns the top part and the levels above the chunks.
    pub(super) fn partition(
        &mut self,
        mut segments: Vec<SpillFile>,
        n: u64,
        bbox: (DVec3, DVec3),
    ) -> Result<(usize, u32)> {
        let mut root = Node::new(0, n, false, State::Pending);
        root.count = n;
        root.bbox = bbox;
        let mut nodes = vec![root];
        self.decide(&mut nodes, 0);
        self.done = 0;
        let fits = self.subset_points();
        if n <= fits {
            // All of it in memory at once: split there, each point written once.
            let mut recs = self.records_buffer(n)?;
            for seg in std::mem::take(&mut segments) {
                seg.reader(0, seg.len())
                    .and_then(|mut r| r.read_rest(&mut recs))
                    .map_err(|e| self.store.io(e))?;
                // (The segment goes once read.)
            }
            self.split_in_memory(&mut nodes, 0, &recs)?;
            return self.emit(&mut nodes, 0);
        }
        // Passes over the input on disk, the last writing the subsets and the chunks found.
        while nodes.iter().any(Node::gathers) {
            let last = nodes
                .iter()
                .all(|v| !matches!(v.state, State::Pending) || v.bound <= fits);
            let writes = |v: &Node| last && v.gathers();
            let writers = nodes.iter().filter(|v| writes(v)).count();
            let buffer = (WRITE_BUFFERS / writers.max(1)).clamp(MIN_WRITE_BUFFER, 1 << 20);
            for v in nodes.iter_mut() {
                v.seen = 0;
                if v.gathers() {
                    v.count = 0;
                    v.bbox = EMPTY;
                }
                // Written in the last pass only, so the input's segments (removed as that
                // pass reads them) and the subsets are never on the disk at once.
                if writes(v) {
                    v.writer = Some(
                        self.store
                            .scratch
                            .create_buffered(self.store.layout.len(), buffer)
                            .map_err(|e| self.store.io(e))?,
                    );
                }
            }
            let passing = if last {
                std::mem::take(&mut segments)
            } else {
                segments.clone()
            };
            for seg in passing {
                let set = Set::whole(seg);
                self.store.for_each(&set, |r| self.place(&mut nodes, r))?;
                // (In the last pass, the segment goes once read.)
            }
            for v in nodes.iter_mut() {
                if let Some(w) = v.writer.take() {
                    v.file = Some(w.finish().map_err(|e| self.store.io(e))?);
                }
            }
            for v in 0..nodes.len() {
                if matches!(nodes[v].state, State::Pending) {
                    self.decide(&mut nodes, v);
                }
            }
            self.report(&nodes);
            if last {
                break;
            }
        }
        drop(segments);
        // Each subset split in memory (one that is a chunk keeps its file as the chunk's).
        for v in 0..nodes.len() {
            if nodes[v].file.is_some() && nodes[v].kids().is_some() {
                let mut recs = self.records_buffer(nodes[v].count)?;
                if let Some(file) = nodes[v].file.take() {
                    file.reader(0, file.len())
                        .and_then(|mut r| r.read_rest(&mut recs))
                        .map_err(|e| self.store.io(e))?;
                }
                self.split_in_memory(&mut nodes, v, &recs)?;
            }
        }
        self.emit(&mut nodes, 0)
    }

    /// The most points a subset split in memory may hold: its records and their indices in
    /// three quarters of what a chunk may take.
    fn subset_points(&self) -> u64 {
        #[cfg(test)]
        if let Some(m) = SUBSET_POINTS.get() {
            return m;
        }
        let budget = self.cap.saturating_mul(self.opts.bytes_per_point) / 4 * 3;
        budget / (self.store.layout.len() as u64 + INDEX_BYTES)
    }

    /// An empty buffer for the records of `n` points (at most [`Preparer::subset_points`]),
    /// allocated whole, or the error saying memory is short.
    fn records_buffer(&self, n: u64) -> Result<Vec<u8>> {
        let bytes = n.saturating_mul(self.store.layout.len() as u64);
        let what = || format!("splitting a set of {n} points in memory");
        crate::memory::ensure(u128::from(bytes + n * INDEX_BYTES), &what())?;
        let mut recs = Vec::new();
        recs.try_reserve_exact(usize::try_from(bytes).unwrap_or(usize::MAX))
            .map_err(|_| crate::Error::OutOfMemory {
                what: what(),
                needed: crate::memory::human(u128::from(bytes)),
                available: "less (the allocation failed)".into(),
            })?;
        Ok(recs)
    }

    /// Reports the points placed in chunks so far.
    fn report(&mut self, nodes: &[Node]) {
        self.done = nodes
            .iter()
            .filter(|v| matches!(v.state, State::Chunk) && v.file.is_some())
            .map(|v| v.count)
            .sum();
        (self.progress)(Stage::Split, self.done);
    }

    /// Splits set `top` (decided, split or halved) down to its chunks in memory, each chunk
    /// written to its file as it is found: `recs` its records in input order.
    fn split_in_memory(&mut self, nodes: &mut Vec<Node>, top: usize, recs: &[u8]) -> Result<()> {
        let len = self.store.layout.len();
        let m = recs.len() / len;
        let Ok(m32) = u32::try_from(m) else {
            return Err(super::too_many(m as u64));
        };
        let layout = self.store.layout;
        let pos = |i: u32| layout.position_of(&recs[i as usize * len..(i as usize + 1) * len]);
        let mut idx: Vec<u32> = (0..m32).collect();
        let mut right: Vec<u32> = Vec::new();
        let mut stack = vec![(top, 0usize, m)];
        let mut reported = self.done;
        while let Some((v, a, b)) = stack.pop() {
            if nodes[v].gathers() {
                let grow = |(lo, hi): (DVec3, DVec3), &i: &u32| {
                    let p = pos(i);
                    (lo.min(p), hi.max(p))
                };
                let bbox = if b - a >= PARALLEL {
                    idx[a..b]
                        .par_iter()
                        .fold(|| EMPTY, grow)
                        .reduce(|| EMPTY, |x, y| (x.0.min(y.0), x.1.max(y.1)))
                } else {
                    idx[a..b].iter().fold(EMPTY, grow)
                };
                nodes[v].count = (b - a) as u64;
                nodes[v].bbox = bbox;
                if matches!(nodes[v].state, State::Pending) {
                    self.decide(nodes, v);
                }
            }
            match nodes[v].state {
                State::Chunk => {
                    let mut w = self.store.create()?;
                    let record = |i: u32| &recs[i as usize * len..(i as usize + 1) * len];
                    if b - a >= PARALLEL {
                        // The records gathered in parallel, a window at a time.
                        for window in idx[a..b].chunks(WINDOW) {
                            let pieces: Vec<Vec<u8>> = window
                                .par_chunks(PARALLEL / 4)
                                .map(|ix| {
                                    let mut bytes = Vec::with_capacity(ix.len() * len);
                                    for &i in ix {
                                        bytes.extend_from_slice(record(i));
                                    }
                                    bytes
                                })
                                .collect();
                            for piece in &pieces {
                                w.push_all(piece).map_err(|e| self.store.io(e))?;
                            }
                        }
                    } else {
                        for &i in &idx[a..b] {
                            w.push(record(i)).map_err(|e| self.store.io(e))?;
                        }
                    }
                    nodes[v].file = Some(w.finish().map_err(|e| self.store.io(e))?);
                    self.done += (b - a) as u64;
                    if self.done - reported >= SEGMENT {
                        reported = self.done;
                        (self.progress)(Stage::Split, self.done);
                    }
                }
                State::Split { axis, mid, kids } => {
                    // A stable partition: the left ones in place, in order, then the right.
                    let w = if b - a >= PARALLEL {
                        // Each piece's two sides found in parallel (one vector of the piece's
                        // size: the left side, then the right), then laid out in order: an
                        // index again per point, as `INDEX_BYTES` counts.
                        let sides: Vec<(Vec<u32>, usize)> = idx[a..b]
                            .par_chunks(PARALLEL / 4)
                            .map(|ix| {
                                let mut side = vec![0u32; ix.len()];
                                let (mut l, mut r) = (0, ix.len());
                                for &i in ix {
                                    if pos(i)[axis] < mid {
                                        side[l] = i;
                                        l += 1;
                                    } else {
                                        r -= 1;
                                        side[r] = i;
                                    }
                                }
                                side[l..].reverse();
                                (side, l)
                            })
                            .collect();
                        let mut w = a;
                        for (side, l) in &sides {
                            idx[w..w + l].copy_from_slice(&side[..*l]);
                            w += l;
                        }
                        let left = w;
                        for (side, l) in &sides {
                            idx[w..w + side.len() - l].copy_from_slice(&side[*l..]);
                            w += side.len() - l;
                        }
                        left
                    } else {
                        right.clear();
                        let mut w = a;
                        for j in a..b {
                            let i = idx[j];
                            if pos(i)[axis] < mid {
                                idx[w] = i;
                                w += 1;
                            } else {
                                right.push(i);
                            }
                        }
                        idx[w..b].copy_from_slice(&right);
                        w
                    };
                    stack.push((kids[1], w, b));
                    stack.push((kids[0], a, w));
                }
                State::Halve { h, kids } => {
                    let h = a + h as usize;
                    stack.push((kids[1], h, b));
                    stack.push((kids[0], a, h));
                }
                State::Pending => {
                    return Err(self
                        .store
                        .io(std::io::Error::other("a set of the split left undecided")));
                }
            }
        }
        (self.progress)(Stage::Split, self.done);
        Ok(())
    }

    /// Sends record `r` down the splits to the set that gathers it (and writes it to that
    /// set's file in the last pass).
    fn place(&self, nodes: &mut [Node], r: &[u8]) -> Result<()> {
        let p = self.store.layout.position_of(r);
        let mut v = 0;
        loop {
            let node = &mut nodes[v];
            v = match node.state {
                State::Split { axis, mid, kids } => {
                    if p[axis] < mid {
                        kids[0]
                    } else {
                        kids[1]
                    }
                }
                State::Halve { h, kids } => {
                    let rank = node.seen;
                    node.seen += 1;
                    if rank < h { kids[0] } else { kids[1] }
                }
                State::Pending | State::Chunk => {
                    node.count += 1;
                    node.bbox = (node.bbox.0.min(p), node.bbox.1.max(p));
                    if let Some(w) = &mut node.writer {
                        w.push(&r[..self.store.layout.len()])
                            .map_err(|e| self.store.io(e))?;
                    }
                    return Ok(());
                }
            };
        }
    }

    /// Decides set `v`, whose count and box are known: a chunk (an even depth's set that fits,
    /// an odd depth's of one point), or split (halved by position when every point lies on one
    /// side of the midpoint), its halves new sets to gather, or chunks when they must fit.
    fn decide(&self, nodes: &mut Vec<Node>, v: usize) {
        let (depth, n, bbox, overlap) = {
            let x = &nodes[v];
            (x.depth, x.count, x.bbox, x.overlap)
        };
        let even = depth.is_multiple_of(2);
        if (even && n <= self.cap) || (!even && n < 2) {
            nodes[v].state = State::Chunk;
            return;
        }
        let (axis, mid) = split_plane(bbox);
        // Every point to the right (none below the midpoint) or to the left.
        let degenerate = !(bbox.0[axis] < mid) || bbox.1[axis] < mid;
        // The halves of a group's first split that fits are chunks.
        let kid = if !even && n <= self.cap {
            State::Chunk
        } else {
            State::Pending
        };
        let kids = [nodes.len(), nodes.len() + 1];
        for _ in 0..2 {
            nodes.push(Node::new(depth + 1, n, overlap || degenerate, kid));
        }
        nodes[v].state = if degenerate {
            State::Halve { h: n / 2, kids }
        } else {
            State::Split { axis, mid, kids }
        };
    }

    /// The parts and chunks of the set `v` of an even depth, children before parents, chunks
    /// numbered in the order of a depth-first recursion; returns its part and its levels.
    fn emit(&mut self, nodes: &mut [Node], v: usize) -> Result<(usize, u32)> {
        let Some(halves) = nodes[v].kids() else {
            let x = &mut nodes[v];
            let file = x.file.take().ok_or_else(|| {
                self.store.io(std::io::Error::other(
                    "a chunk of the split was not written",
                ))
            })?;
            self.store.chunks.push(Set {
                file,
                start: 0,
                count: x.count,
                bbox: Some(x.bbox),
                overlap: x.overlap,
                normals: None,
                patch: None,
            });
            self.store.parts.push(Part {
                kind: PartKind::Chunk(self.store.chunks.len() - 1),
                bbox: x.bbox,
                halo2: 0.0,
            });
            return Ok((self.store.parts.len() - 1, 0));
        };
        let mut groups = Vec::with_capacity(4);
        for h in halves {
            match nodes[h].kids() {
                Some(two) => groups.extend(two),
                None => groups.push(h),
            }
        }
        let mut kids = Vec::with_capacity(groups.len());
        let mut levels = 0;
        for g in groups {
            let (k, l) = self.emit(nodes, g)?;
            kids.push(k);
            levels = levels.max(l + 1);
        }
        self.store.parts.push(Part {
            kind: PartKind::Inner(kids),
            bbox: nodes[v].bbox,
            halo2: 0.0,
        });
        Ok((self.store.parts.len() - 1, levels))
    }
}
