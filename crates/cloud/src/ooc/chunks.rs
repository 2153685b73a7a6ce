//! What the preparation hands on when the cloud did not fit: its chunks on disk (each point
//! with its normal and input index, in the order the split left it) and the tree of splits
//! above them ([`Part`]), with the scratch folder the method's own build goes on writing in.

use std::io;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::error::{Error, Result};
use super::record::{REC, SHORT, position_of, unpack};
use crate::spill::{Scratch, SpillFile, SpillWriter};

/// A range of a scratch file: a set of points in the order the split gives them.
#[derive(Debug, Clone)]
pub(super) struct Set {
    pub(super) file: SpillFile,
    pub(super) start: u64,
    pub(super) count: u64,
    pub(super) bbox: Option<(DVec3, DVec3)>,
    /// Made by halving by position (coincident points): its region is not separated from
    /// its sibling's by a plane.
    pub(super) overlap: bool,
}

/// Points in memory: a chunk, or the whole cloud when it fit.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Points {
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Unit normals (given or estimated).
    pub normals: Vec<Vec3>,
    /// Colours (zero when the input has none).
    pub colors: Vec<[u8; 3]>,
    /// Each point's index in the input.
    pub index: Vec<u64>,
}

/// A node of the tree of splits above the chunks.
#[derive(Debug, Clone)]
pub struct Part {
    /// Its children, or its chunk.
    pub kind: PartKind,
    /// The points' box.
    pub bbox: (DVec3, DVec3),
    /// The largest halo radius (squared) of the chunks below.
    pub(super) halo2: f64,
}

/// What a [`Part`] holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PartKind {
    /// Children: indices of parts (two to four; a group of the split, in order).
    Inner(Vec<usize>),
    /// A chunk (its index in [`Chunks::load`]'s numbering).
    Chunk(usize),
}

/// The prepared chunks on disk, the parts above them and the scratch folder (removed when this
/// is dropped).
#[derive(Debug)]
pub struct Chunks {
    pub(super) scratch: Scratch,
    pub(super) out: PathBuf,
    /// The parts, children before parents.
    pub(super) parts: Vec<Part>,
    /// The root part.
    pub(super) root: usize,
    pub(super) chunks: Vec<Set>,
    /// Bytes of the records [`Chunks::create`] writes: [`REC`], or [`SHORT`] (no normal) before
    /// the normals are estimated.
    pub(super) rec: usize,
}

impl Chunks {
    /// The parts, children before parents.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// The root part's index.
    pub fn root(&self) -> usize {
        self.root
    }

    /// Chunks.
    pub fn len(&self) -> usize {
        self.chunks.len()
    }

    /// Whether there are no chunks (never, once prepared).
    pub fn is_empty(&self) -> bool {
        self.chunks.is_empty()
    }

    /// Points of chunk `c`.
    pub fn points_of(&self, c: usize) -> u64 {
        self.chunks[c].count
    }

    /// The scratch folder, for the method's own files.
    pub fn scratch(&self) -> &Scratch {
        &self.scratch
    }

    /// An I/O error of the scratch files, naming the output and the scratch folder.
    pub fn io(&self, source: io::Error) -> Error {
        Error::Io {
            path: format!(
                "{} (scratch {})",
                self.out.display(),
                self.scratch.dir().display()
            ),
            source,
        }
    }

    /// The output the scratch folder lies beside.
    pub fn out(&self) -> &Path {
        &self.out
    }

    /// Chunk `c`'s points in memory, in the order of the split (the order the in-memory build
    /// of the same points gives them).
    pub fn load(&self, c: usize) -> Result<Points> {
        self.load_set(&self.chunks[c])
    }

    /// Drops chunk `c`'s points (its scratch file goes when nothing else holds it).
    pub fn release(&mut self, c: usize) -> Result<()> {
        // (Short or full records: an empty file has none.)
        let empty = self.create()?.finish().map_err(|e| self.io(e))?;
        let set = &mut self.chunks[c];
        set.file = empty;
        set.start = 0;
        Ok(())
    }

    pub(super) fn create(&self) -> Result<SpillWriter> {
        self.scratch.create(self.rec).map_err(|e| self.io(e))
    }

    /// Writes `rec`'s first [`Chunks::rec`] bytes (a writer of [`Chunks::create`]).
    pub(super) fn push(&self, w: &mut SpillWriter, rec: &[u8; REC]) -> Result<()> {
        w.push(&rec[..self.rec]).map_err(|e| self.io(e))
    }

    pub(super) fn for_each(
        &self,
        set: &Set,
        mut f: impl FnMut(&[u8; REC]) -> Result<()>,
    ) -> Result<()> {
        let mut r = set
            .file
            .reader(set.start, set.count)
            .map_err(|e| self.io(e))?;
        // Short records leave the normal's bytes zero.
        let mut b = [0u8; REC];
        let len = set.file.record();
        if len != REC && len != SHORT {
            return Err(self.io(io::Error::other("scratch file of unknown records")));
        }
        while r.next_into(&mut b[..len]).map_err(|e| self.io(e))? {
            f(&b)?;
        }
        Ok(())
    }

    pub(super) fn bbox(&self, set: &Set) -> Result<(DVec3, DVec3)> {
        if let Some(b) = set.bbox {
            return Ok(b);
        }
        let mut bb = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        self.for_each(set, |r| {
            let p = position_of(r);
            bb = (bb.0.min(p), bb.1.max(p));
            Ok(())
        })?;
        Ok(bb)
    }

    pub(super) fn load_set(&self, set: &Set) -> Result<Points> {
        let m = set.count as usize;
        let mut l = Points {
            positions: Vec::with_capacity(m),
            normals: Vec::with_capacity(m),
            colors: Vec::with_capacity(m),
            index: Vec::with_capacity(m),
        };
        self.for_each(set, |r| {
            let (p, i) = unpack(r);
            l.positions.push(p.position);
            l.normals.push(p.normal);
            l.colors.push(p.color);
            l.index.push(i);
            Ok(())
        })?;
        Ok(l)
    }
}
