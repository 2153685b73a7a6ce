//! What the preparation hands on when the cloud did not fit: its chunks on disk (each point
//! with its normal and input index, in input order; estimated normals in files of their own)
//! and the tree of splits above them ([`Part`]), with the scratch folder the method's own build
//! goes on writing in.

use std::io;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::record::{Layout, REC};
use crate::lod_file::{Error, Result};
use crate::spill::{Scratch, SpillFile, SpillWriter};

/// A range of a scratch file: a set of points in input order (with its normals' files).
#[derive(Debug, Clone)]
pub(super) struct Set {
    pub(super) file: SpillFile,
    pub(super) start: u64,
    pub(super) count: u64,
    pub(super) bbox: Option<(DVec3, DVec3)>,
    /// Made by halving by position (coincident points): its region is not separated from
    /// its sibling's by a plane.
    pub(super) overlap: bool,
    /// Where the normals are estimated: the normals, one a point in the set's order
    /// ([`NORMAL`] bytes each; NaN where [`Set::patch`] has it).
    pub(super) normals: Option<SpillFile>,
    /// The normals [`Set::normals`] lacks: the point's place in the set (32 bits) and its
    /// normal ([`PATCH`] bytes each), in that order.
    pub(super) patch: Option<SpillFile>,
}

/// Bytes of a normal on disk.
pub(super) const NORMAL: usize = 12;
/// Bytes of a patched normal on disk: place, normal.
pub(super) const PATCH: usize = 4 + NORMAL;

/// A normal's bytes.
pub(super) fn normal_bytes(n: Vec3) -> [u8; NORMAL] {
    let mut b = [0u8; NORMAL];
    for (a, v) in n.to_array().iter().enumerate() {
        b[4 * a..4 * a + 4].copy_from_slice(&v.to_le_bytes());
    }
    b
}

/// The normal of [`normal_bytes`].
pub(super) fn normal_of(b: &[u8]) -> Vec3 {
    let v = |a: usize| f32::from_le_bytes([b[4 * a], b[4 * a + 1], b[4 * a + 2], b[4 * a + 3]]);
    Vec3::new(v(0), v(1), v(2))
}

impl Set {
    /// All of `file`, without a known box.
    pub(super) fn whole(file: SpillFile) -> Self {
        Set {
            start: 0,
            count: file.len(),
            file,
            bbox: None,
            overlap: false,
            normals: None,
            patch: None,
        }
    }
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
    /// The layout of the records [`Chunks::create`] writes (no normal where the normals are
    /// estimated: they go to files of their own).
    pub(super) layout: Layout,
}

impl Chunks {
    /// The parts, children before parents.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// The grid every prepared position lies on (the input's, a LAS or LAZ file's), if any:
    /// a later pass may keep positions as its integers too.
    pub fn grid(&self) -> Option<crate::ooc::Grid> {
        self.layout.grid()
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

    /// Chunk `c`'s points in memory, in input order (the order QSplat's in-memory build gives
    /// the same points, its split being a stable partition).
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
        set.normals = None;
        set.patch = None;
        Ok(())
    }

    pub(super) fn create(&self) -> Result<SpillWriter> {
        self.scratch
            .create(self.layout.len())
            .map_err(|e| self.io(e))
    }

    /// Writes `rec`'s first [`Layout::len`] bytes (a writer of [`Chunks::create`]).
    pub(super) fn push(&self, w: &mut SpillWriter, rec: &[u8; REC]) -> Result<()> {
        w.push(&rec[..self.layout.len()]).map_err(|e| self.io(e))
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
        let mut b = [0u8; REC];
        let len = set.file.record();
        if len != self.layout.len() {
            return Err(self.io(io::Error::other("scratch file of unknown records")));
        }
        while r.next_into(&mut b[..len]).map_err(|e| self.io(e))? {
            f(&b)?;
        }
        Ok(())
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
            let (p, i) = self.layout.unpack(r);
            l.positions.push(p.position);
            l.normals.push(p.normal);
            l.colors.push(p.color);
            l.index.push(i);
            Ok(())
        })?;
        if let Some(f) = &set.normals {
            let mut r = f.reader(0, f.len()).map_err(|e| self.io(e))?;
            let mut b = [0u8; NORMAL];
            for n in &mut l.normals {
                if !r.next_into(&mut b).map_err(|e| self.io(e))? {
                    return Err(self.io(io::Error::other("scratch normals shorter than the set")));
                }
                *n = normal_of(&b);
            }
        }
        if let Some(f) = &set.patch {
            let mut r = f.reader(0, f.len()).map_err(|e| self.io(e))?;
            let mut b = [0u8; PATCH];
            while r.next_into(&mut b).map_err(|e| self.io(e))? {
                let at = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize;
                let n = l.normals.get_mut(at).ok_or_else(|| {
                    self.io(io::Error::other("scratch normal patch past the set's end"))
                })?;
                *n = normal_of(&b[4..]);
            }
        }
        Ok(l)
    }
}
