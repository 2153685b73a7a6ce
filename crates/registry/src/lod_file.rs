//! A built LOD file (`pointsight lod-build`) as an LOD structure: selected from the file, never
//! loaded whole, so that a cloud of 10^8 points or more can be viewed within a memory limit
//! (`lod_file`): a QSplat file through `qsplat::PagedTree`, a sequential point
//! tree's through `spt::paged::PagedTree` (the prefix a view needs, read block by block). The
//! method is told by the file's magic ([`file_info`], [`open_file`], [`file_leaves`]).
//!
//! [`open_qsplat_file`] checks the header and returns a [`LodBuilt`] whose selectors each open
//! the file with a page cache of the given bytes and traverse it exactly as the in-memory tree
//! is traversed (the same splats; `qsplat::paged`'s tests compare), so the measurement kernel
//! (`kernel::select_lod`) times it like any other structure, at a setting the file's method's
//! card reads (`qsplat`'s `threshold_px`, `spt`'s `epsilon_px`). The selection time includes the
//! reads of the pages the view needs (the first of a view's timed runs; the repeats find them
//! cached); [`LodSelector::reads`] says how many bytes a view's first selection read and how
//! much the cache held. [`LodData::none`] is the input such a structure is selected
//! on: it was not built from points in memory.

use std::path::{Path, PathBuf};

use cloud::Camera;
use cloud::glam::DVec3;
use splat::render::Splat;

use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodBuilt, LodInput, LodSelector, LodSize, Reads, args_of};
use crate::methods::qsplat::{Args as QsplatArgs, splat_of as qsplat_splat};
use crate::methods::spt::{Args as SptArgs, splat_of as spt_splat};

/// The file's structure: its path, cache, and header.
struct FileBuilt {
    path: PathBuf,
    cache_bytes: u64,
    words: u64,
    file_bytes: u64,
}

struct FileSel<'s> {
    tree: qsplat::PagedTree,
    params: &'s qsplat::TraverseParams,
    last: Vec<qsplat::Splat>,
    reads: ViewReads,
}

/// The reads of the last selection, reported for a view's first selection: a repeat of the
/// same view reads what the first left out of the cache (or, without a cache, reads again).
#[derive(Default)]
struct ViewReads {
    reads: Reads,
    /// The view of the last selection.
    camera: Option<Camera>,
}

impl ViewReads {
    fn record(&mut self, camera: &Camera, read: u64, cache_bytes: u64, selection_bytes: u64) {
        let first = self.camera.as_ref() != Some(camera);
        self.camera = Some(*camera);
        self.reads = Reads {
            bytes_read: if first { read } else { self.reads.bytes_read },
            cache_bytes,
            selection_bytes,
        };
    }
}

fn qsplat_err(e: qsplat::Error) -> Error {
    Error::Unsupported(format!("qsplat file: {e}"))
}

/// What a QSplat file's header says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QsplatFileInfo {
    /// Points (leaves).
    pub n_points: u64,
    /// Words after the root.
    pub words: u64,
    /// The root sphere's centre, world coordinates.
    pub root_center: DVec3,
    /// The root sphere's radius.
    pub root_radius: f64,
}

/// Reads and checks the header of the QSplat file at `path`.
pub fn qsplat_file_info(path: &Path) -> Result<QsplatFileInfo> {
    let tree = qsplat::PagedTree::open(path, 0).map_err(qsplat_err)?;
    let root = qsplat::traverse::Nodes::root(&tree);
    Ok(QsplatFileInfo {
        n_points: tree.n_points(),
        words: tree.n_words(),
        root_center: root.center,
        root_radius: root.radius,
    })
}

/// Opens the QSplat file at `path` for selection with a page cache of `cache_bytes` per
/// selector (at least `qsplat::paged::MIN_CACHE`); the header is checked now, every word as a
/// view reads it.
pub fn open_qsplat_file(path: &Path, cache_bytes: u64) -> Result<Box<dyn LodBuilt>> {
    let tree = qsplat::PagedTree::open(path, cache_bytes).map_err(qsplat_err)?;
    let file_bytes = std::fs::metadata(path)
        .map_err(|e| Error::Unsupported(format!("qsplat file {}: {e}", path.display())))?
        .len();
    Ok(Box::new(FileBuilt {
        path: path.to_owned(),
        cache_bytes: tree.cache_limit(),
        words: tree.n_words(),
        file_bytes,
    }))
}

impl LodBuilt for FileBuilt {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: (1 + self.words) as usize,
            bytes: self.file_bytes as f64,
        }
    }
    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let params = &args_of::<QsplatArgs>(args, "qsplat")?.0;
        let tree = qsplat::PagedTree::open(&self.path, self.cache_bytes).map_err(qsplat_err)?;
        Ok(Box::new(FileSel {
            tree,
            params,
            last: Vec::new(),
            reads: ViewReads::default(),
        }))
    }
}

impl LodSelector for FileSel<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let before = self.tree.bytes_read();
        self.last =
            qsplat::traverse_nodes(&mut self.tree, camera, self.params).map_err(qsplat_err)?;
        self.reads.record(
            camera,
            self.tree.bytes_read() - before,
            self.tree.cache_bytes(),
            (self.last.len() * size_of::<qsplat::Splat>()) as u64,
        );
        Ok(())
    }
    fn reads(&self) -> Option<Reads> {
        Some(self.reads.reads)
    }
    fn splats(&self) -> Vec<Splat> {
        self.last.iter().map(qsplat_splat).collect()
    }
}

/// Every leaf of the QSplat file at `path` as a splat, `batch` at a time, read through a page
/// cache of `cache_bytes` (the full-detail reference of a structure whose points are not in
/// memory; memory: the cache and one batch). Returns the leaves.
pub fn qsplat_file_leaves(
    path: &Path,
    cache_bytes: u64,
    batch: usize,
    mut each: impl FnMut(&[Splat]),
) -> Result<u64> {
    let mut tree = qsplat::PagedTree::open(path, cache_bytes).map_err(qsplat_err)?;
    let batch = batch.max(1);
    let mut buf = Vec::with_capacity(batch);
    let n = qsplat::leaves(&mut tree, |s| {
        buf.push(qsplat_splat(&s));
        if buf.len() == batch {
            each(&buf);
            buf.clear();
        }
    })
    .map_err(qsplat_err)?;
    if !buf.is_empty() {
        each(&buf);
    }
    Ok(n)
}

/// What a built LOD file's header says, whichever method built it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FileInfo {
    /// The method (`qsplat`, `spt`).
    pub method: &'static str,
    /// Points (leaves).
    pub n_points: u64,
    /// Nodes.
    pub nodes: u64,
    /// A box around the object, world coordinates (QSplat: the root sphere's; SPT: the leaf
    /// discs').
    pub bounds: cloud::Aabb,
}

/// The method of the LOD file at `path`, from its magic.
fn method_of(path: &Path) -> Result<&'static str> {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .map_err(|e| Error::Unsupported(format!("LOD file {}: {e}", path.display())))?;
    match &magic {
        b"PSQSPLAT" => Ok("qsplat"),
        m if m == spt::file::MAGIC => Ok("spt"),
        _ => Err(Error::Unsupported(format!(
            "{}: not a QSplat or sequential point tree file (bad magic)",
            path.display()
        ))),
    }
}

fn spt_err(e: spt::Error) -> Error {
    Error::Unsupported(format!("spt file: {e}"))
}

/// Reads and checks the header of the LOD file at `path`.
pub fn file_info(path: &Path) -> Result<FileInfo> {
    match method_of(path)? {
        "qsplat" => {
            let q = qsplat_file_info(path)?;
            let r = DVec3::splat(q.root_radius);
            Ok(FileInfo {
                method: "qsplat",
                n_points: q.n_points,
                nodes: q.words + 1,
                bounds: cloud::Aabb {
                    min: q.root_center - r,
                    max: q.root_center + r,
                },
            })
        }
        _ => {
            let t = spt::paged::PagedTree::open(path).map_err(spt_err)?;
            let h = t.header();
            let corner = |q: [u16; 3]| {
                h.grid_origin + DVec3::new(q[0].into(), q[1].into(), q[2].into()) * h.cell
            };
            Ok(FileInfo {
                method: "spt",
                n_points: h.points,
                nodes: h.entries,
                bounds: cloud::Aabb {
                    min: corner(h.root.lo),
                    max: corner(h.root.hi),
                },
            })
        }
    }
}

/// Opens the LOD file at `path` for selection (a QSplat file with a page cache of
/// `cache_bytes` per selector; a sequential point tree's reads its prefix block by block).
pub fn open_file(path: &Path, cache_bytes: u64) -> Result<Box<dyn LodBuilt>> {
    match method_of(path)? {
        "qsplat" => open_qsplat_file(path, cache_bytes),
        _ => {
            let t = spt::paged::PagedTree::open(path).map_err(spt_err)?;
            let file_bytes = t.header().file_bytes().unwrap_or(0);
            Ok(Box::new(SptFileBuilt {
                path: path.to_owned(),
                entries: t.header().entries,
                file_bytes,
            }))
        }
    }
}

/// Every leaf of the LOD file at `path` as a splat, `batch` at a time (see
/// [`qsplat_file_leaves`]; a sequential point tree's leaves are its cut at ε = 0).
pub fn file_leaves(
    path: &Path,
    cache_bytes: u64,
    batch: usize,
    mut each: impl FnMut(&[Splat]),
) -> Result<u64> {
    match method_of(path)? {
        "qsplat" => qsplat_file_leaves(path, cache_bytes, batch, each),
        _ => {
            let mut t = spt::paged::PagedTree::open(path).map_err(spt_err)?;
            t.leaves(batch, |s| {
                let v: Vec<Splat> = s.iter().map(spt_splat).collect();
                each(&v);
            })
            .map_err(spt_err)
        }
    }
}

struct SptFileBuilt {
    path: PathBuf,
    entries: u64,
    file_bytes: u64,
}

struct SptFileSel {
    tree: spt::paged::PagedTree,
    pixels: f64,
    entries: Vec<u32>,
    last: Vec<spt::Splat>,
    reads: ViewReads,
}

impl LodBuilt for SptFileBuilt {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.entries as usize,
            bytes: self.file_bytes as f64,
        }
    }
    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(SptFileSel {
            tree: spt::paged::PagedTree::open(&self.path).map_err(spt_err)?,
            pixels: args_of::<SptArgs>(args, "spt")?.0,
            entries: Vec::new(),
            last: Vec::new(),
            reads: ViewReads::default(),
        }))
    }
}

impl LodSelector for SptFileSel {
    /// The cut and its splats, both read from the file (the prefix block by block, then the
    /// selected entries' splats): a view's whole cost from the file.
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let before = self.tree.bytes_read();
        let eps = spt::epsilon_for_pixels(camera, self.pixels);
        self.tree
            .cut_into(camera.eye, eps, &mut self.entries)
            .map_err(spt_err)?;
        self.last = self.tree.splats(&self.entries).map_err(spt_err)?;
        // No cache: the operating system's page cache holds what was read.
        self.reads.record(
            camera,
            self.tree.bytes_read() - before,
            0,
            (self.last.len() * size_of::<spt::Splat>()) as u64,
        );
        Ok(())
    }
    fn reads(&self) -> Option<Reads> {
        Some(self.reads.reads)
    }
    fn splats(&self) -> Vec<Splat> {
        self.last.iter().map(spt_splat).collect()
    }
}
