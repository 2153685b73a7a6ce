//! A built QSplat file (`pointsight lod-build`) as an LOD structure: selected from the file
//! through `qsplat::PagedTree`, never loaded whole, so that a cloud of 10^8 points or more can
//! be viewed within a memory limit (issue 27's `lod_file`).
//!
//! [`open_qsplat_file`] checks the header and returns a [`LodBuilt`] whose selectors each open
//! the file with a page cache of the given bytes and traverse it exactly as the in-memory tree
//! is traversed (the same splats; `qsplat::paged`'s tests compare), so the measurement kernel
//! (`kernel::select_lod`) times it like any other structure. The selection time includes the
//! reads of the pages the view needs (the first of a view's timed runs; the repeats find them
//! cached); [`LodSelector::reads`] says how many bytes a view's first selection read and how
//! much the cache held. [`LodData::none`] is the input such a structure is selected
//! on: it was not built from points in memory.

use std::path::{Path, PathBuf};

use cloud::Camera;
use cloud::glam::DVec3;
use splat::render::Splat;

use crate::Params;
use crate::error::{Error, Result};
use crate::lod::{LodBuilt, LodSelector, LodSize, Reads, qsplat_params, qsplat_splat};

/// The file's structure: its path, cache, and header.
struct FileBuilt {
    path: PathBuf,
    cache_bytes: u64,
    words: u64,
    file_bytes: u64,
}

struct FileSel {
    tree: qsplat::PagedTree,
    params: qsplat::TraverseParams,
    last: Vec<qsplat::Splat>,
    reads: Reads,
    /// The view of the last selection.
    camera: Option<Camera>,
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
        _input: &'s crate::lod::LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let params = qsplat_params(params)?;
        let tree = qsplat::PagedTree::open(&self.path, self.cache_bytes).map_err(qsplat_err)?;
        Ok(Box::new(FileSel {
            tree,
            params,
            last: Vec::new(),
            reads: Reads::default(),
            camera: None,
        }))
    }
}

impl LodSelector for FileSel {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let before = self.tree.bytes_read;
        self.last =
            qsplat::traverse_nodes(&mut self.tree, camera, &self.params).map_err(qsplat_err)?;
        // A repeat of the same view reads what the first left out of the cache: the first
        // selection of a view is the one its reads are reported for.
        let read = self.tree.bytes_read - before;
        let first = self.camera.as_ref() != Some(camera);
        self.camera = Some(*camera);
        self.reads = Reads {
            bytes_read: if first { read } else { self.reads.bytes_read },
            cache_bytes: self.tree.cache_bytes(),
            selection_bytes: (self.last.len() * size_of::<qsplat::Splat>()) as u64,
        };
        Ok(())
    }
    fn reads(&self) -> Option<Reads> {
        Some(self.reads)
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
