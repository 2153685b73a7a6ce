//! Steps 4 and 5 of QSplat's out-of-core build, on the prepared chunks: each chunk's root
//! computed in memory ([`crate::build::build_root`] on the chunk in its order: the root of the
//! very subtree of the in-memory build, its other nodes not stored), the parents above the
//! chunks made from the roots ([`crate::build::parent_from`]); then, top-down, each chunk rebuilt once its parent's
//! decoded sphere is known, quantised ([`crate::tree`]'s encoder, offsets relative to the
//! chunk) and its sibling groups written level by level to a scratch file.

use cloud::glam::DVec3;
use cloud::ooc::{Chunks, PartKind, Points};
use cloud::spill::SpillFile;
use rayon::prelude::*;

use super::{Options, Stage};
use crate::Result;
use crate::build::{self, Node};
use crate::tree;

/// Bytes of an encoded word on disk: word, colour, offset flag.
pub(super) const WREC: usize = 4 + 2 + 1;
/// Words whose records are made at once before they are written (a few MB), and a thread's
/// piece of them (small in the tests, so that their chunks have many).
const WINDOW: usize = if cfg!(test) { 1 << 9 } else { 1 << 18 };
const PIECE: usize = if cfg!(test) { 1 << 6 } else { 1 << 13 };

/// A chunk once encoded: its groups level by level in a scratch file of (word, colour,
/// is-offset) records with offsets relative to the chunk's words.
#[derive(Default)]
pub(super) struct Encoded {
    pub(super) file: Option<SpillFile>,
    pub(super) level_starts: Vec<usize>,
    pub(super) root_word: u32,
    pub(super) root_color: u16,
}

/// QSplat's build over the prepared chunks: a node per part of the tree of splits, an
/// encoding per chunk.
pub(super) struct Builder<'a> {
    pub(super) chunks: Chunks,
    pub(super) opts: &'a Options,
    pub(super) leaf_radius: f64,
    /// Per part: its node (set by [`Builder::build_top`]).
    pub(super) nodes: Vec<Node>,
    /// Per part: its sphere index relative to its parent's decoded sphere (set by the
    /// encoding).
    pub(super) spheres: Vec<u16>,
    /// Per chunk.
    pub(super) encoded: Vec<Encoded>,
    pub(super) done: u64,
    pub(super) progress: &'a mut dyn FnMut(Stage, u64),
}

/// A chunk as [`build::build`] takes it.
fn input(chunk: &Points, leaf_radius: f64, colors: bool) -> build::Input<'_> {
    build::Input {
        positions: &chunk.positions,
        normals: &chunk.normals,
        colors: colors.then_some(&chunk.colors[..]),
        leaf_radius,
    }
}

impl<'a> Builder<'a> {
    pub(super) fn new(
        chunks: Chunks,
        opts: &'a Options,
        leaf_radius: f64,
        progress: &'a mut dyn FnMut(Stage, u64),
    ) -> Self {
        let parts = chunks.parts().len();
        let encoded = (0..chunks.len()).map(|_| Encoded::default()).collect();
        Builder {
            chunks,
            opts,
            leaf_radius,
            nodes: vec![build::BLANK; parts],
            spheres: vec![0; parts],
            encoded,
            done: 0,
            progress,
        }
    }

    /// The chunks' roots, then the top nodes (children are before parents in the parts).
    pub(super) fn build_top(&mut self) -> Result<()> {
        for t in 0..self.nodes.len() {
            let node = match &self.chunks.parts()[t].kind {
                PartKind::Chunk(c) => {
                    let chunk = self.chunks.load(*c)?;
                    let root =
                        build::build_root(&input(&chunk, self.leaf_radius, self.opts.colors));
                    self.done += self.chunks.points_of(*c);
                    (self.progress)(Stage::Build, self.done);
                    root
                }
                PartKind::Inner(kids) => {
                    let refs: Vec<&Node> = kids.iter().map(|&k| &self.nodes[k]).collect();
                    let ids: Vec<u32> = (0..kids.len() as u32).collect();
                    build::parent_from(&refs, &ids)
                }
            };
            self.nodes[t] = node;
        }
        Ok(())
    }

    fn has_kids(&self, t: usize) -> bool {
        self.nodes[t].n_children > 0
    }

    /// Whether some child of top node `t` has children.
    pub(super) fn grand(&self, t: usize) -> bool {
        match &self.chunks.parts()[t].kind {
            PartKind::Inner(kids) => kids.iter().any(|&k| self.has_kids(k)),
            PartKind::Chunk(_) => false,
        }
    }

    /// Encodes the children of top node `t` (decoded sphere `decoded`) and below.
    pub(super) fn encode(&mut self, t: usize, decoded: (DVec3, f64)) -> Result<()> {
        let PartKind::Inner(kids) = &self.chunks.parts()[t].kind else {
            return Ok(());
        };
        for k in kids.clone() {
            let node = &self.nodes[k];
            let (sphere, own) = tree::child_sphere(node.center, node.radius, decoded);
            match self.chunks.parts()[k].kind {
                PartKind::Inner(_) => {
                    self.spheres[k] = sphere;
                    self.encode(k, own)?;
                }
                PartKind::Chunk(c) => self.encode_chunk(c, sphere, own)?,
            }
        }
        Ok(())
    }

    fn encode_chunk(&mut self, c: usize, sphere: u16, own: (DVec3, f64)) -> Result<()> {
        let chunk = self.chunks.load(c)?;
        let h = build::build(&input(&chunk, self.leaf_radius, self.opts.colors));
        drop(chunk);
        let (parts, decoded) = tree::encode_parts(&h, sphere, own, self.opts.colors, true);
        drop((h, decoded));
        let mut w = self
            .chunks
            .scratch()
            .create(WREC)
            .map_err(|e| self.chunks.io(e))?;
        // The records made in parallel, a window of words at a time, each piece's in order.
        let record_of = |i: usize, is_offset: bool| {
            let mut rec = [0u8; WREC];
            rec[..4].copy_from_slice(&parts.words[i].to_le_bytes());
            let col = parts.colors.get(i).copied().unwrap_or(0);
            rec[4..6].copy_from_slice(&col.to_le_bytes());
            rec[6] = u8::from(is_offset);
            rec
        };
        for window in (0..parts.words.len()).step_by(WINDOW) {
            let end = (window + WINDOW).min(parts.words.len());
            let pieces: Vec<Vec<u8>> = (window..end)
                .step_by(PIECE)
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|s| {
                    let e = (s + PIECE).min(end);
                    // The offset words from `s` on (their positions ascend).
                    let mut o = parts.offsets.partition_point(|&x| x < s);
                    let mut bytes = Vec::with_capacity((e - s) * WREC);
                    for i in s..e {
                        let is_offset = parts.offsets.get(o) == Some(&i);
                        o += usize::from(is_offset);
                        bytes.extend_from_slice(&record_of(i, is_offset));
                    }
                    bytes
                })
                .collect();
            for piece in &pieces {
                w.push_all(piece).map_err(|e| self.chunks.io(e))?;
            }
        }
        let file = w.finish().map_err(|e| self.chunks.io(e))?;
        self.encoded[c] = Encoded {
            file: Some(file),
            level_starts: parts.level_starts,
            root_word: parts.root_word,
            root_color: parts.root_color,
        };
        // The points are no longer needed.
        self.chunks.release(c)?;
        self.done += self.chunks.points_of(c);
        (self.progress)(Stage::Encode, self.done);
        Ok(())
    }

    /// The word and colour of top node `k` as a child.
    pub(super) fn child_word(&self, k: usize) -> (u32, u16) {
        match self.chunks.parts()[k].kind {
            PartKind::Inner(_) => {
                let node = &self.nodes[k];
                (
                    tree::word_for(node, self.spheres[k], self.grand(k)).pack(),
                    tree::node_color(node),
                )
            }
            PartKind::Chunk(c) => (self.encoded[c].root_word, self.encoded[c].root_color),
        }
    }
}
