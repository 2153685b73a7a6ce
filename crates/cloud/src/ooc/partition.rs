//! Step 2 of the preparation: the input split into chunks as a binary space partition splits
//! it (the midpoint of a set's box's longest axis, points below it to the left; two levels of
//! splits make a group of two to four sets; a set that fits a chunk is a chunk), each point
//! written to scratch once, into its chunk's file.
//!
//! The split of a set needs its box, and a set's box is known only once its parent's split is:
//! so the tree of splits is found level by level, each level by a pass over the input (in
//! input order, read, not written) that sends every point down the splits known so far and
//! gathers the count and box of the sets it reaches. A set once known to be a chunk takes its
//! points, in input order, in the last pass (its count and box are known once its parent's
//! split is: a first split of a group with no more points than a chunk makes two chunks). A set whose
//! points all lie on one side of its midpoint (coincident points) is halved by position: its
//! first half in input order to the left, counted in the pass. The input is kept in segments,
//! and the last pass, the only one that writes, removes each once read, so the input and the
//! chunks are not on the disk at once (the most scratch at once is the input's records and a
//! segment).
//!
//! This is the partition of the in-memory build's (QSplat's `build`, whose split is a stable
//! partition): the same sets, each in input order. As in PotreeConverter 2 (Schütz et al.
//! 2020, count, then distribute), the passes before the last only count.

use glam::DVec3;

use super::chunks::{Part, PartKind, Set};
use super::error::Result;
use super::record::REC;
use super::{Preparer, Stage};
use crate::spill::{SpillFile, SpillWriter};

/// Records of an input segment.
pub(super) const SEGMENT: u64 = 1 << 20;
/// Write-buffer bytes shared by the chunks one pass writes.
const WRITE_BUFFERS: usize = 32 << 20;

/// What is known of a set of the tree of splits.
#[derive(Debug)]
enum State {
    /// Its count and box are gathered by this pass.
    Pending,
    /// Split at `mid` on `axis` (points below it to `kids[0]`).
    Split {
        axis: usize,
        mid: f64,
        kids: [usize; 2],
    },
    /// Halved by position: its first `h` points (in input order) to `kids[0]`.
    Halve { h: u64, kids: [usize; 2] },
    /// A chunk: its writer during the pass that writes it, then its file.
    Chunk {
        writer: Option<SpillWriter>,
        file: Option<SpillFile>,
    },
}

/// A set of the tree of splits.
#[derive(Debug)]
struct Node {
    /// Splits above it (even: a set [`Preparer::partition`]'s recursion sees; odd: a first
    /// split's half, split again when it has two points or more).
    depth: u32,
    count: u64,
    bbox: (DVec3, DVec3),
    overlap: bool,
    /// Points seen so far this pass (a halved set's rank).
    seen: u64,
    state: State,
}

const EMPTY: (DVec3, DVec3) = (DVec3::INFINITY, DVec3::NEG_INFINITY);

impl Node {
    fn new(depth: u32, overlap: bool, state: State) -> Self {
        Node {
            depth,
            count: 0,
            bbox: EMPTY,
            overlap,
            seen: 0,
            state,
        }
    }

    /// Whether this pass gathers its count and box.
    fn gathers(&self) -> bool {
        matches!(self.state, State::Pending | State::Chunk { file: None, .. })
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
        let mut root = Node::new(0, false, State::Pending);
        root.count = n;
        root.bbox = bbox;
        let mut nodes = vec![root];
        self.decide(&mut nodes, 0);
        self.done = 0;
        while nodes.iter().any(Node::gathers) {
            let last = !nodes.iter().any(|v| matches!(v.state, State::Pending));
            let writers = nodes
                .iter()
                .filter(|v| matches!(v.state, State::Chunk { file: None, .. }))
                .count();
            let buffer = (WRITE_BUFFERS / writers.max(1)).clamp(64 << 10, 1 << 20);
            for v in nodes.iter_mut() {
                v.seen = 0;
                if v.gathers() {
                    v.count = 0;
                    v.bbox = EMPTY;
                }
                // Chunks are written in the last pass only, so the input's segments (removed
                // as that pass reads them) and the chunks are never on the disk at once.
                if let State::Chunk {
                    writer: w @ None,
                    file: None,
                } = &mut v.state
                    && last
                {
                    *w = Some(
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
                if let State::Chunk { writer, file } = &mut v.state
                    && let Some(w) = writer.take()
                {
                    *file = Some(w.finish().map_err(|e| self.store.io(e))?);
                    self.done += v.count;
                }
            }
            (self.progress)(Stage::Split, self.done);
            for v in 0..nodes.len() {
                if matches!(nodes[v].state, State::Pending) {
                    self.decide(&mut nodes, v);
                }
            }
        }
        drop(segments);
        self.emit(&mut nodes, 0)
    }

    /// Sends record `r` down the splits to the set that gathers it (a chunk also writes it in
    /// the last pass).
    fn place(&self, nodes: &mut [Node], r: &[u8; REC]) -> Result<()> {
        let p = self.store.layout.position_of(r);
        let mut v = 0;
        loop {
            let node = &mut nodes[v];
            v = match &mut node.state {
                State::Split { axis, mid, kids } => {
                    if p[*axis] < *mid {
                        kids[0]
                    } else {
                        kids[1]
                    }
                }
                State::Halve { h, kids } => {
                    let rank = node.seen;
                    node.seen += 1;
                    if rank < *h { kids[0] } else { kids[1] }
                }
                State::Pending => {
                    node.count += 1;
                    node.bbox = (node.bbox.0.min(p), node.bbox.1.max(p));
                    return Ok(());
                }
                State::Chunk { writer, .. } => {
                    // A chunk gathers its count and box in every pass (none is written before
                    // the last), and takes its points in the last.
                    node.count += 1;
                    node.bbox = (node.bbox.0.min(p), node.bbox.1.max(p));
                    if let Some(w) = writer {
                        self.store.push(w, r)?;
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
            nodes[v].state = State::Chunk {
                writer: None,
                file: None,
            };
            return;
        }
        let (axis, mid) = split_plane(bbox);
        // Every point to the right (none below the midpoint) or to the left.
        let degenerate = !(bbox.0[axis] < mid) || bbox.1[axis] < mid;
        // The halves of a group's first split that fits are chunks.
        let kid = || {
            if !even && n <= self.cap {
                State::Chunk {
                    writer: None,
                    file: None,
                }
            } else {
                State::Pending
            }
        };
        let kids = [nodes.len(), nodes.len() + 1];
        for _ in 0..2 {
            nodes.push(Node::new(depth + 1, overlap || degenerate, kid()));
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
        let kids_of = |x: &Node| match x.state {
            State::Split { kids, .. } | State::Halve { kids, .. } => Some(kids),
            _ => None,
        };
        let Some(halves) = kids_of(&nodes[v]) else {
            let x = &mut nodes[v];
            let file = match &mut x.state {
                State::Chunk { file, .. } => file.take(),
                _ => None,
            };
            let file = file.ok_or_else(|| {
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
            match kids_of(&nodes[h]) {
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
