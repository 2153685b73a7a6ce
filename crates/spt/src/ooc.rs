//! The out-of-core build of a sequential point tree's file ([`crate::file`]): the same bytes as
//! the in-memory build ([`in_memory`], then [`crate::file::to_bytes`]) for clouds larger than
//! memory, within a memory limit, with scratch files on the disk beside the output
//! (`cloud::spill`).
//!
//! The hierarchy is an octree (seed 002 §5.3.1, [`crate::hierarchy`]), so its chunks are octree
//! cells, found as PotreeConverter 2 finds them (Schütz et al. 2020: a counting pass into a
//! grid, cells merged into chunks of bounded size, points distributed to per-chunk files, each
//! chunk built in memory, the top levels merged):
//!
//! 1. the points are pushed ([`Builder::push`]) into a scratch file, with their bounding box
//!    (which fixes the root cube and the hierarchy's local origin, as [`crate::build`] has
//!    them);
//! 2. counting passes: each adds [`REFINE`] octree levels of counts below the cells that hold
//!    more points than a chunk, descending by the very comparisons of
//!    [`hierarchy::build_cell`]; the first also takes the box of the leaf discs, which gives
//!    the 16-bit grid ([`crate::list::Grid`]) before any chunk is built;
//! 3. the top of the tree is planned as [`hierarchy::build_cell`] would recurse: a cell of
//!    more points than a chunk with one occupied octant is collapsed (its collapse budget
//!    spent), one with two or more is a top node, a cell that fits is a chunk, built later
//!    by the same call with the budget left; chunks follow in the arena's order (children
//!    before parents, octants in order), consecutive ones gathered into bins of at most a
//!    chunk's points;
//! 4. one pass distributes the points to their bins' files;
//! 5. each bin is loaded, its points put back in input order (the points carry their index in
//!    the input, so they may come in any order), each chunk built in memory, its nodes
//!    quantised on the global grid and numbered as in the whole arena, and its sibling groups
//!    (parent's box, e_g², arena index; children's entries, splats and colours) sorted as
//!    [`crate::list::SequentialList::new`] sorts them (e_g² descending, then arena index) into
//!    a run file; the top nodes are made from the chunks' roots by the same
//!    [`hierarchy::parent_of_kids`];
//! 6. the runs are merged into the file, written through `cloud::io::atomic` (whole or not at
//!    all), its four sections at once.
//!
//! Deviations: none in the output. A cloud whose densest spot holds more than a chunk's points
//! within 2^-64 of the root cube is refused (the in-memory build would halve it by position).
//!
//! Memory: a chunk of m points needs about [`BYTES_PER_POINT`] · m bytes at its peak (records,
//! the hierarchy's nodes twice while subtrees are joined, the quantised groups of the run);
//! buffers, counts and the planned top need [`RESERVE`] more.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use cloud::glam::{DVec3, Vec3};
use cloud::spill::{Scratch, SpillFile, SpillReader, SpillWriter};

use crate::Spt;
use crate::error::{Error, Result};
use crate::file::{self, Header};
use crate::hierarchy::{self, COLLAPSE, Node};
use crate::list::{Entry, Grid, Group, QBox};

/// Peak bytes per point of a chunk while it is built and its groups sorted.
pub const BYTES_PER_POINT: u64 = 700;
/// Memory the build needs beside its chunk (buffers, counts, the planned top).
pub const RESERVE: u64 = 48 << 20;
/// The smallest chunk worth building (a limit that allows fewer points per chunk is refused).
pub const MIN_CHUNK: u64 = 4_096;
/// Octree levels one counting pass adds below a cell.
pub const REFINE: u32 = 6;
/// Cells one counting pass refines (each holds 8^[`REFINE`] counts).
const TARGETS: usize = 16;
/// Buffer bytes of each bin's writer and each run's readers.
const SMALL_BUFFER: usize = 64 << 10;
const NONE: u32 = u32::MAX;

/// One input point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Position.
    pub position: DVec3,
    /// Normal.
    pub normal: Vec3,
    /// Colour (ignored without [`Options::colors`]).
    pub color: [u8; 3],
    /// Its place in the input order (the points must be a permutation of 0..n).
    pub index: u64,
}

/// How the build may use memory and disk, and what it builds.
#[derive(Debug, Clone)]
pub struct Options {
    /// Peak memory the build may use, bytes.
    pub memory_limit: u64,
    /// Colours kept.
    pub colors: bool,
    /// Tests: scratch writes fail (as on a full disk) after this many bytes.
    pub fail_after_bytes: Option<u64>,
}

/// What a build did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    /// Points.
    pub points: u64,
    /// Chunks built in memory (1 when the cloud fit at once).
    pub chunks: u64,
    /// Largest chunk, points.
    pub largest_chunk: u64,
    /// Points per chunk the limit allows.
    pub chunk_capacity: u64,
    /// Nodes of the tree above the chunks.
    pub top_nodes: u64,
    /// Counting passes over the input.
    pub count_passes: u32,
    /// Sorted runs merged into the file.
    pub runs: u64,
    /// Bytes written to scratch files.
    pub scratch_bytes: u64,
    /// The most bytes the scratch files held at once.
    pub scratch_peak_bytes: u64,
}

/// The build's stages, for progress reports (each with a count of points).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Counting points into octree cells.
    Count,
    /// Distributing points to chunks.
    Distribute,
    /// Building chunks.
    Build,
    /// Merging the sorted runs into the file (groups written).
    Merge,
}

/// Points per chunk under `memory_limit`, or the error naming why the limit is too small.
pub fn chunk_capacity(memory_limit: u64) -> Result<u64> {
    cloud::spill::chunk_capacity(memory_limit, RESERVE, BYTES_PER_POINT, MIN_CHUNK).map_err(
        |reason| Error::InvalidParameter {
            name: "memory_limit",
            reason,
        },
    )
}

/// The in-memory build the out-of-core one equals: [`crate::build`] on the points in order.
pub fn in_memory(
    positions: Vec<DVec3>,
    normals: Vec<Vec3>,
    colors: Option<Vec<[u8; 3]>>,
    leaf_diameter: f64,
) -> Result<Spt> {
    let cloud = cloud::PointCloud {
        positions,
        normals: Some(normals),
        colors,
        ..cloud::PointCloud::default()
    };
    crate::build(&cloud, leaf_diameter)
}

/// Bytes of a point on disk: position, normal, colour, input index.
const REC: usize = 24 + 12 + 3 + 8;
/// A distributed point: the record and its chunk.
const DREC: usize = REC + 4;

fn pack(p: &Point, b: &mut [u8]) {
    for k in 0..3 {
        b[8 * k..8 * k + 8].copy_from_slice(&p.position[k].to_le_bytes());
        b[24 + 4 * k..28 + 4 * k].copy_from_slice(&p.normal[k].to_le_bytes());
    }
    b[36..39].copy_from_slice(&p.color);
    b[39..47].copy_from_slice(&p.index.to_le_bytes());
}

fn unpack(b: &[u8]) -> Point {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    let g = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap_or([0; 4]));
    Point {
        position: DVec3::new(f(0), f(8), f(16)),
        normal: Vec3::new(g(24), g(28), g(32)),
        color: [b[36], b[37], b[38]],
        index: u64::from_le_bytes(b[39..47].try_into().unwrap_or([0; 8])),
    }
}

fn position_of(b: &[u8]) -> DVec3 {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    DVec3::new(f(0), f(8), f(16))
}

/// A cell of the counted octree.
struct Cell {
    center: DVec3,
    half: f64,
    count: u64,
    /// Whether the children are known (all of the cell's points counted one level down).
    counted: bool,
    kids: [u32; 8],
    /// The chunk this cell is, if it is one.
    chunk: u32,
}

impl Cell {
    fn new(center: DVec3, half: f64) -> Self {
        Self {
            center,
            half,
            count: 0,
            counted: false,
            kids: [NONE; 8],
            chunk: NONE,
        }
    }
}

/// A bin in memory: its number, its points with their chunks, the next chunk's first point.
type LoadedBin = (u32, Vec<(Point, u32)>, usize);

/// A planned node above or at the chunks, in arena order.
enum Top {
    Chunk {
        center: DVec3,
        half: f64,
        budget: u32,
        count: u64,
    },
    Inner {
        kids: Vec<usize>,
    },
}

/// Streams points in, then builds the file.
pub struct Builder {
    opts: Options,
    out: PathBuf,
    cap: u64,
    scratch: Scratch,
    writer: Option<SpillWriter>,
    n: u64,
    max_index: u64,
    /// Sums of the indices and their squares (wrapping): a permutation of 0..n has known ones.
    index_sums: (u64, u64),
    bbox: (DVec3, DVec3),
    rec: Vec<u8>,
    leaf_diameter: f64,
}

impl Builder {
    /// A build of `out` under `opts`; scratch files go to a directory beside `out`, removed
    /// at the end, also after an error.
    pub fn new(opts: &Options, out: &Path) -> Result<Self> {
        let cap = chunk_capacity(opts.memory_limit)?;
        let io = |source| Error::Io {
            path: out.display().to_string(),
            source,
        };
        let mut scratch = Scratch::beside(out).map_err(io)?;
        if let Some(b) = opts.fail_after_bytes {
            scratch = scratch.fail_after(b);
        }
        let writer = scratch.create(REC).map_err(io)?;
        Ok(Self {
            opts: opts.clone(),
            out: out.to_path_buf(),
            cap,
            scratch,
            writer: Some(writer),
            n: 0,
            max_index: 0,
            index_sums: (0, 0),
            bbox: (DVec3::INFINITY, DVec3::NEG_INFINITY),
            rec: vec![0; REC],
            leaf_diameter: 0.0,
        })
    }

    fn io(&self, source: io::Error) -> Error {
        Error::Io {
            path: if source.kind() == io::ErrorKind::StorageFull {
                format!("{} (scratch files)", self.scratch.dir().display())
            } else {
                self.out.display().to_string()
            },
            source,
        }
    }

    /// Adds points.
    pub fn push(&mut self, points: &[Point]) -> Result<()> {
        for p in points {
            if !p.position.is_finite() {
                return Err(Error::Cloud(cloud::Error::NonFinite {
                    index: p.index as usize,
                }));
            }
            if !p.normal.is_finite() {
                return Err(Error::InvalidParameter {
                    name: "normals",
                    reason: format!("point {} has a non-finite normal", p.index),
                });
            }
            self.bbox = (self.bbox.0.min(p.position), self.bbox.1.max(p.position));
            self.max_index = self.max_index.max(p.index);
            self.index_sums = (
                self.index_sums.0.wrapping_add(p.index),
                self.index_sums
                    .1
                    .wrapping_add(p.index.wrapping_mul(p.index)),
            );
            pack(p, &mut self.rec);
            let w = self.writer.as_mut().ok_or(Error::InvalidParameter {
                name: "builder",
                reason: "points pushed after the build".into(),
            })?;
            if let Err(e) = w.push(&self.rec) {
                return Err(self.io(e));
            }
            self.n += 1;
        }
        Ok(())
    }

    /// Builds the file of the points pushed with leaf discs of `leaf_diameter` (known only
    /// once every point is in when it comes from their spacing); `progress` hears each
    /// stage's count.
    pub fn finish(
        mut self,
        leaf_diameter: f64,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<Summary> {
        if !(leaf_diameter > 0.0) || !leaf_diameter.is_finite() {
            return Err(Error::InvalidParameter {
                name: "leaf_diameter",
                reason: format!("must be positive, got {leaf_diameter}"),
            });
        }
        self.leaf_diameter = leaf_diameter;
        let writer = self.writer.take().ok_or(Error::EmptyCloud)?;
        let all = writer.finish().map_err(|e| self.io(e))?;
        let n = self.n;
        if n == 0 {
            return Err(Error::EmptyCloud);
        }
        if n > u64::from(u32::MAX / 2) {
            return Err(Error::InvalidParameter {
                name: "cloud",
                reason: format!("{n} points is too many"),
            });
        }
        if self.max_index >= n {
            return Err(Error::InvalidParameter {
                name: "index",
                reason: format!(
                    "point index {} among {n} points: the indices must be 0..{n}",
                    self.max_index
                ),
            });
        }
        // Σi = n(n-1)/2 and Σi² = (n-1)n(2n-1)/6 for 0..n (n < 2^31: exact in u128).
        let m = u128::from(n);
        let sums = (
            (m * (m - 1) / 2) as u64,
            ((m - 1) * m * (2 * m - 1) / 6) as u64,
        );
        if self.index_sums != sums {
            return Err(Error::InvalidParameter {
                name: "index",
                reason: format!(
                    "the points' indices are not 0..{n} each once (an index given twice or \
                     missing)"
                ),
            });
        }
        let mut summary = Summary {
            points: n,
            chunk_capacity: self.cap,
            ..Summary::default()
        };
        if n <= self.cap {
            let pts = self.load(&all, 0, n, false)?;
            drop(all);
            let mut positions = Vec::with_capacity(pts.len());
            let mut normals = Vec::with_capacity(pts.len());
            let mut colors = Vec::with_capacity(if self.opts.colors { pts.len() } else { 0 });
            for (p, _) in &pts {
                positions.push(p.position);
                normals.push(p.normal);
                if self.opts.colors {
                    colors.push(p.color);
                }
            }
            drop(pts);
            let spt = in_memory(
                positions,
                normals,
                self.opts.colors.then_some(colors),
                self.leaf_diameter,
            )?;
            file::write(&spt, &self.out)?;
            summary.chunks = 1;
            summary.largest_chunk = n;
            summary.scratch_bytes = self.scratch.bytes_written();
            summary.scratch_peak_bytes = self.scratch.peak_bytes();
            return Ok(summary);
        }
        // 2. Counting passes, the leaf discs' box with the first.
        let aabb = cloud::Aabb {
            min: self.bbox.0,
            max: self.bbox.1,
        };
        let origin = aabb.center();
        let (rc, rh) = hierarchy::root_cell(&aabb);
        let mut cells = vec![Cell::new(rc, rh)];
        cells[0].count = n;
        let mut leaf_box = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let half32 = 0.5 * self.leaf_diameter as f32;
        let tops = loop {
            let mut tops = Vec::new();
            let mut missing = Vec::new();
            plan(&cells, self.cap, 0, &mut tops, &mut missing)?;
            if missing.is_empty() && summary.count_passes > 0 {
                break tops;
            }
            if summary.count_passes == 0 {
                missing = vec![0];
            }
            missing.truncate(TARGETS);
            let first = summary.count_passes == 0;
            self.count_pass(
                &all,
                &mut cells,
                &missing,
                first.then_some((origin, half32, &mut leaf_box)),
                progress,
            )?;
            summary.count_passes += 1;
        };
        let grid = Grid::new(origin, leaf_box.0, leaf_box.1);
        // 3. Chunks and their bins.
        let mut chunks: Vec<(usize, u32)> = Vec::new(); // (top index, bin)
        let mut bin_points = 0u64;
        let mut bins = 0u32;
        for (t, top) in tops.iter().enumerate() {
            if let Top::Chunk { count, .. } = top {
                if bins == 0 || bin_points + count > self.cap {
                    bins += 1;
                    bin_points = 0;
                }
                bin_points += count;
                chunks.push((t, bins - 1));
                summary.largest_chunk = summary.largest_chunk.max(*count);
            }
        }
        summary.chunks = chunks.len() as u64;
        summary.top_nodes = (tops.len() - chunks.len()) as u64;
        mark_chunks(&mut cells, self.cap, 0, &mut 0)?;
        // 4. Distribution.
        let bin_files = self.distribute(&all, &cells, &chunks, bins, progress)?;
        drop(all);
        // 5. Chunks, the top and their runs.
        let runs = self.build_runs(&tops, &chunks, bin_files, origin, &grid, progress)?;
        summary.runs = runs.runs.len() as u64;
        // 6. The file.
        self.merge(runs, n, origin, &grid, progress)?;
        summary.scratch_bytes = self.scratch.bytes_written();
        summary.scratch_peak_bytes = self.scratch.peak_bytes();
        Ok(summary)
    }

    /// Records `start..start + count` of `file` (plain or distributed), with their chunk,
    /// sorted by (chunk, input index); a repeated index is an error.
    fn load(
        &self,
        file: &SpillFile,
        start: u64,
        count: u64,
        distributed: bool,
    ) -> Result<Vec<(Point, u32)>> {
        let size = if distributed { DREC } else { REC };
        let mut r = file.reader(start, count).map_err(|e| self.io(e))?;
        let mut buf = vec![0u8; size];
        let mut out = Vec::with_capacity(count as usize);
        while r.next_into(&mut buf).map_err(|e| self.io(e))? {
            let chunk = if distributed {
                u32::from_le_bytes(buf[REC..DREC].try_into().unwrap_or([0; 4]))
            } else {
                0
            };
            out.push((unpack(&buf), chunk));
        }
        out.sort_unstable_by_key(|(p, c)| (*c, p.index));
        if let Some(w) = out.windows(2).find(|w| w[0].0.index == w[1].0.index) {
            return Err(Error::InvalidParameter {
                name: "index",
                reason: format!("point index {} given twice", w[0].0.index),
            });
        }
        Ok(out)
    }

    /// One counting pass: [`REFINE`] levels of counts below each of `targets`.
    fn count_pass(
        &self,
        all: &SpillFile,
        cells: &mut Vec<Cell>,
        targets: &[u32],
        mut leaf_box: Option<(DVec3, f32, &mut (Vec3, Vec3))>,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<()> {
        let width = 1usize << (3 * REFINE);
        let mut slot = vec![NONE; cells.len()];
        for (t, &x) in targets.iter().enumerate() {
            slot[x as usize] = t as u32;
        }
        let mut counts = vec![vec![0u32; width]; targets.len()];
        let mut r = all.reader(0, all.len()).map_err(|e| self.io(e))?;
        let mut buf = [0u8; REC];
        let mut seen = 0u64;
        while r.next_into(&mut buf).map_err(|e| self.io(e))? {
            let p = position_of(&buf);
            if let Some((origin, half, b)) = leaf_box.as_mut() {
                let c = (p - *origin).as_vec3();
                b.0 = b.0.min(c - *half);
                b.1 = b.1.max(c + *half);
            }
            let mut x = 0usize;
            loop {
                let cell = &cells[x];
                if slot[x] != NONE {
                    let (mut c, mut h) = (cell.center, cell.half);
                    let mut code = 0usize;
                    for _ in 0..REFINE {
                        let o = hierarchy::octant(p, c);
                        code = code * 8 + o;
                        c = hierarchy::octant_center(c, h, o);
                        h *= 0.5;
                    }
                    counts[slot[x] as usize][code] += 1;
                    break;
                }
                if !cell.counted {
                    break;
                }
                let k = cell.kids[hierarchy::octant(p, cell.center)];
                if k == NONE {
                    return Err(internal("a point outside the counted cells"));
                }
                x = k as usize;
            }
            seen += 1;
            if seen.is_multiple_of(1 << 20) {
                progress(Stage::Count, seen);
            }
        }
        progress(Stage::Count, seen);
        for (t, &x) in targets.iter().enumerate() {
            for (code, &k) in counts[t].iter().enumerate() {
                if k == 0 {
                    continue;
                }
                let mut at = x as usize;
                for level in (0..REFINE).rev() {
                    let o = (code >> (3 * level)) & 7;
                    cells[at].counted = true;
                    let next = cells[at].kids[o];
                    at = if next == NONE {
                        let (c, h) = (cells[at].center, cells[at].half);
                        let id = cells.len() as u32;
                        cells.push(Cell::new(hierarchy::octant_center(c, h, o), 0.5 * h));
                        cells[at].kids[o] = id;
                        id as usize
                    } else {
                        next as usize
                    };
                    cells[at].count += u64::from(k);
                }
            }
        }
        Ok(())
    }

    /// Distributes the points to their bins' files (records tagged with their chunk).
    fn distribute(
        &self,
        all: &SpillFile,
        cells: &[Cell],
        chunks: &[(usize, u32)],
        bins: u32,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<Vec<SpillFile>> {
        let mut writers = Vec::with_capacity(bins as usize);
        for _ in 0..bins {
            writers.push(
                self.scratch
                    .create_buffered(DREC, SMALL_BUFFER)
                    .map_err(|e| self.io(e))?,
            );
        }
        let mut r = all.reader(0, all.len()).map_err(|e| self.io(e))?;
        let mut buf = [0u8; DREC];
        let mut seen = 0u64;
        while r.next_into(&mut buf[..REC]).map_err(|e| self.io(e))? {
            let p = position_of(&buf);
            let mut x = 0usize;
            while cells[x].chunk == NONE {
                let k = cells[x].kids[hierarchy::octant(p, cells[x].center)];
                if k == NONE {
                    return Err(internal("a point outside the planned chunks"));
                }
                x = k as usize;
            }
            let c = cells[x].chunk;
            buf[REC..].copy_from_slice(&c.to_le_bytes());
            let bin = chunks[c as usize].1 as usize;
            writers[bin].push(&buf).map_err(|e| self.io(e))?;
            seen += 1;
            if seen.is_multiple_of(1 << 20) {
                progress(Stage::Distribute, seen);
            }
        }
        progress(Stage::Distribute, seen);
        writers
            .into_iter()
            .map(|w| w.finish().map_err(|e| self.io(e)))
            .collect()
    }

    /// Builds every chunk and top node in arena order, writing the sorted runs.
    fn build_runs(
        &self,
        tops: &[Top],
        chunks: &[(usize, u32)],
        bin_files: Vec<SpillFile>,
        origin: DVec3,
        grid: &Grid,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<Runs> {
        let mut runs = Runs::default();
        let mut batch = Batch::default();
        // Per top: its node (children cleared), box and error, arena index.
        let mut made: Vec<Option<(Node, QBox, f32, u64)>> = vec![None; tops.len()];
        let mut counter = 0u64;
        let mut bin_files: Vec<Option<SpillFile>> = bin_files.into_iter().map(Some).collect();
        // The bin in memory: its number, its points, the next chunk's first point.
        let mut loaded: Option<LoadedBin> = None;
        let mut chunk_id = 0usize;
        let mut done = 0u64;
        for (t, top) in tops.iter().enumerate() {
            match top {
                Top::Chunk {
                    center,
                    half,
                    budget,
                    count,
                } => {
                    let bin = chunks[chunk_id].1;
                    if loaded.as_ref().is_none_or(|l| l.0 != bin) {
                        if loaded.is_some() {
                            self.write_run(&mut batch, &mut runs)?;
                        }
                        let file = bin_files[bin as usize]
                            .take()
                            .ok_or(internal("a bin loaded twice"))?;
                        let pts = self.load(&file, 0, file.len(), true)?;
                        drop(file);
                        loaded = Some((bin, pts, 0));
                    }
                    let (_, pts, at) = loaded.as_mut().ok_or(internal("no bin"))?;
                    let m = *count as usize;
                    let mine = &pts[*at..*at + m];
                    if mine.iter().any(|(_, c)| *c as usize != chunk_id) {
                        return Err(internal("a chunk's points out of place"));
                    }
                    *at += m;
                    let positions: Vec<DVec3> = mine.iter().map(|(p, _)| p.position).collect();
                    let normals: Vec<Vec3> = mine.iter().map(|(p, _)| p.normal).collect();
                    let colors: Vec<[u8; 3]> = if self.opts.colors {
                        mine.iter().map(|(p, _)| p.color).collect()
                    } else {
                        Vec::new()
                    };
                    let input = hierarchy::Input {
                        positions: &positions,
                        normals: &normals,
                        colors: self.opts.colors.then_some(&colors[..]),
                        leaf_diameter: self.leaf_diameter,
                    };
                    let mut items: Vec<u32> = (0..m as u32).collect();
                    let nodes =
                        hierarchy::build_cell(&input, origin, &mut items, *center, *half, *budget);
                    drop(items);
                    let boxes: Vec<QBox> = nodes.iter().map(|n| grid.qbox(n)).collect();
                    let e2: Vec<f32> = nodes.iter().map(|n| grid.e2(n)).collect();
                    for (i, node) in nodes.iter().enumerate() {
                        if node.children.is_empty() {
                            continue;
                        }
                        batch.group(boxes[i], e2[i], counter + i as u64, node.children.len());
                        for &k in &node.children {
                            let k = k as usize;
                            batch.entry(&boxes[k], e2[k], &nodes[k], self.opts.colors);
                        }
                    }
                    let last = nodes.len() - 1;
                    let mut root = nodes[last].clone();
                    root.children = Vec::new();
                    made[t] = Some((root, boxes[last], e2[last], counter + last as u64));
                    counter += nodes.len() as u64;
                    chunk_id += 1;
                    done += *count;
                    progress(Stage::Build, done);
                }
                Top::Inner { kids } => {
                    let kid_nodes: Vec<&(Node, QBox, f32, u64)> = kids
                        .iter()
                        .map(|&k| {
                            made[k]
                                .as_ref()
                                .ok_or(internal("a top node before its child"))
                        })
                        .collect::<Result<_>>()?;
                    let refs: Vec<&Node> = kid_nodes.iter().map(|k| &k.0).collect();
                    let children = kid_nodes.iter().map(|k| k.3 as u32).collect();
                    let node = hierarchy::parent_of_kids(&refs, children);
                    let (b, e) = (grid.qbox(&node), grid.e2(&node));
                    batch.group(b, e, counter, kids.len());
                    for k in &kid_nodes {
                        batch.entry(&k.1, k.2, &k.0, self.opts.colors);
                    }
                    let mut node = node;
                    node.children = Vec::new();
                    made[t] = Some((node, b, e, counter));
                    counter += 1;
                }
            }
        }
        self.write_run(&mut batch, &mut runs)?;
        let root = made.pop().flatten().ok_or(internal("no root"))?;
        let mut bytes = Vec::with_capacity(ENTRY_REC);
        push_entry_rec(&mut bytes, &root.1, root.2, &root.0, self.opts.colors);
        runs.root = (root.1, bytes);
        runs.nodes = counter;
        Ok(runs)
    }

    /// Sorts the batch's groups and writes them as a run.
    fn write_run(&self, batch: &mut Batch, runs: &mut Runs) -> Result<()> {
        if batch.groups.is_empty() {
            return Ok(());
        }
        batch
            .groups
            .sort_unstable_by(|a, b| key_order(a.e2, a.gid, b.e2, b.gid));
        let mut g = self.scratch.create(GREC).map_err(|e| self.io(e))?;
        let mut e = self.scratch.create(ENTRY_REC).map_err(|e| self.io(e))?;
        let mut rec = Vec::with_capacity(GREC);
        for gr in &batch.groups {
            rec.clear();
            file::push_box(&mut rec, &gr.b);
            rec.extend_from_slice(&gr.e2.to_le_bytes());
            rec.extend_from_slice(&gr.gid.to_le_bytes());
            rec.push(gr.count as u8);
            g.push(&rec).map_err(|e| self.io(e))?;
            let s = gr.first * ENTRY_REC;
            for k in 0..gr.count {
                let at = s + k * ENTRY_REC;
                e.push(&batch.entries[at..at + ENTRY_REC])
                    .map_err(|e| self.io(e))?;
            }
        }
        runs.groups += batch.groups.len() as u64;
        runs.runs.push((
            g.finish().map_err(|e| self.io(e))?,
            e.finish().map_err(|e| self.io(e))?,
        ));
        batch.groups.clear();
        batch.entries.clear();
        batch.groups.shrink_to(1 << 16);
        batch.entries.shrink_to(1 << 20);
        Ok(())
    }

    /// Merges the runs into the file.
    fn merge(
        &self,
        runs: Runs,
        n: u64,
        origin: DVec3,
        grid: &Grid,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<()> {
        let header = Header {
            colors: self.opts.colors,
            points: n,
            groups: runs.groups + 1,
            entries: runs.nodes,
            local: origin,
            grid_origin: grid.origin,
            cell: grid.cell,
            leaf_diameter: self.leaf_diameter,
            root: runs.root.0,
        };
        let sections = header.sections();
        let out = self.out.clone();
        let colors = self.opts.colors;
        let fill = |partial: &Path| -> Result<()> {
            let io = |source| Error::Io {
                path: out.display().to_string(),
                source,
            };
            let open = |at: u64| -> io::Result<BufWriter<File>> {
                let mut f = File::options().write(true).open(partial)?;
                f.seek(SeekFrom::Start(at))?;
                Ok(BufWriter::with_capacity(1 << 20, f))
            };
            File::create(partial).map_err(io)?;
            let mut gw = open(0).map_err(io)?;
            let mut ew = open(sections[1]).map_err(io)?;
            let mut sw = open(sections[2]).map_err(io)?;
            let mut cw = if colors {
                Some(open(sections[3]).map_err(io)?)
            } else {
                None
            };
            gw.write_all(&header.to_bytes()).map_err(io)?;
            let mut bytes = Vec::with_capacity(file::GROUP);
            let put_entry = |rec: &[u8],
                             ew: &mut BufWriter<File>,
                             sw: &mut BufWriter<File>,
                             cw: &mut Option<BufWriter<File>>|
             -> io::Result<()> {
                ew.write_all(&rec[..file::ENTRY])?;
                sw.write_all(&rec[file::ENTRY..file::ENTRY + file::SPLAT])?;
                if let Some(c) = cw {
                    c.write_all(&rec[file::ENTRY + file::SPLAT..])?;
                }
                Ok(())
            };
            file::push_group(
                &mut bytes,
                &Group {
                    b: runs.root.0,
                    e2: f32::INFINITY,
                    start: 0,
                    end: 1,
                },
            );
            gw.write_all(&bytes).map_err(io)?;
            put_entry(&runs.root.1, &mut ew, &mut sw, &mut cw).map_err(io)?;
            let mut next_entry = 1u32;
            let mut heads = BinaryHeap::new();
            let mut readers: Vec<(SpillReader, SpillReader)> = Vec::with_capacity(runs.runs.len());
            let mut grec = [0u8; GREC];
            for (i, (g, e)) in runs.runs.iter().enumerate() {
                let mut gr = g.reader_buffered(0, g.len(), SMALL_BUFFER).map_err(io)?;
                let er = e.reader_buffered(0, e.len(), SMALL_BUFFER).map_err(io)?;
                if gr.next_into(&mut grec).map_err(io)? {
                    heads.push(Head::of(&grec, i));
                }
                readers.push((gr, er));
            }
            let mut erec = vec![0u8; ENTRY_REC];
            let mut written = 0u64;
            while let Some(h) = heads.pop() {
                let (gr, er) = &mut readers[h.run];
                bytes.clear();
                file::push_group(
                    &mut bytes,
                    &Group {
                        b: h.b,
                        e2: h.e2,
                        start: next_entry,
                        end: next_entry + u32::from(h.count),
                    },
                );
                gw.write_all(&bytes).map_err(io)?;
                for _ in 0..h.count {
                    if !er.next_into(&mut erec).map_err(io)? {
                        return Err(internal("a run's entries end early"));
                    }
                    put_entry(&erec, &mut ew, &mut sw, &mut cw).map_err(io)?;
                }
                next_entry += u32::from(h.count);
                if gr.next_into(&mut grec).map_err(io)? {
                    heads.push(Head::of(&grec, h.run));
                }
                written += 1;
                if written.is_multiple_of(1 << 20) {
                    progress(Stage::Merge, written);
                }
            }
            if u64::from(next_entry) != header.entries {
                return Err(internal("the runs' entries do not add up"));
            }
            for w in [Some(gw), Some(ew), Some(sw), cw].into_iter().flatten() {
                w.into_inner()
                    .map_err(|e| io(e.into_error()))?
                    .sync_all()
                    .map_err(io)?;
            }
            progress(Stage::Merge, written);
            Ok(())
        };
        cloud::io::atomic::write_via(&self.out, fill, |source| Error::Io {
            path: self.out.display().to_string(),
            source,
        })
    }
}

fn internal(what: &str) -> Error {
    Error::InvalidParameter {
        name: "out-of-core build",
        reason: format!("internal inconsistency: {what}"),
    }
}

/// Plans the subtree of cell `x0` as [`hierarchy::build_cell`] recurses (see the module
/// documentation); cells whose children must be counted first go to `missing`.
fn plan(
    cells: &[Cell],
    cap: u64,
    x0: usize,
    tops: &mut Vec<Top>,
    missing: &mut Vec<u32>,
) -> Result<Option<usize>> {
    let mut x = x0;
    let mut budget = COLLAPSE;
    loop {
        let cell = &cells[x];
        if cell.count <= cap {
            tops.push(Top::Chunk {
                center: cell.center,
                half: cell.half,
                budget,
                count: cell.count,
            });
            return Ok(Some(tops.len() - 1));
        }
        if !cell.counted {
            missing.push(x as u32);
            return Ok(None);
        }
        let kids: Vec<usize> = cell
            .kids
            .iter()
            .filter(|&&k| k != NONE)
            .map(|&k| k as usize)
            .collect();
        if kids.len() >= 2 {
            let mut planned = Vec::with_capacity(kids.len());
            for k in kids {
                if let Some(t) = plan(cells, cap, k, tops, missing)? {
                    planned.push(t);
                }
            }
            if !missing.is_empty() {
                return Ok(None);
            }
            tops.push(Top::Inner { kids: planned });
            return Ok(Some(tops.len() - 1));
        }
        budget -= 1;
        if budget == 0 || kids.is_empty() {
            return Err(Error::InvalidParameter {
                name: "memory_limit",
                reason: format!(
                    "{} points lie within a cell of {:e} (2^-64 of the cloud's cube): more \
                     coincident points than a chunk of {cap} holds; raise the limit",
                    cell.count,
                    2.0 * cell.half
                ),
            });
        }
        x = kids[0];
    }
}

/// Marks the chunk cells with their chunk numbers, in the order [`plan`] made them.
fn mark_chunks(cells: &mut [Cell], cap: u64, x: usize, next: &mut u32) -> Result<()> {
    if cells[x].count <= cap {
        cells[x].chunk = *next;
        *next += 1;
        return Ok(());
    }
    let kids = cells[x].kids;
    for k in kids.into_iter().filter(|&k| k != NONE) {
        mark_chunks(cells, cap, k as usize, next)?;
    }
    Ok(())
}

/// Bytes of a group in a run: box, e_g², arena index, entries.
const GREC: usize = 12 + 4 + 8 + 1;
/// Bytes of an entry in a run: the file's entry, splat and colour.
const ENTRY_REC: usize = file::ENTRY + file::SPLAT + file::COLOR;

fn push_entry_rec(b: &mut Vec<u8>, q: &QBox, e2: f32, n: &Node, colors: bool) {
    file::push_entry(b, &Entry { b: *q, e2 });
    file::push_splat(b, n);
    if colors {
        file::push_color(b, n);
    } else {
        b.extend_from_slice(&[0; file::COLOR]);
    }
}

/// The list's order: e_g² descending, then arena index ascending.
fn key_order(ea: f32, ga: u64, eb: f32, gb: u64) -> Ordering {
    eb.total_cmp(&ea).then(ga.cmp(&gb))
}

struct GroupRec {
    b: QBox,
    e2: f32,
    gid: u64,
    first: usize,
    count: usize,
}

#[derive(Default)]
struct Batch {
    groups: Vec<GroupRec>,
    entries: Vec<u8>,
}

impl Batch {
    fn group(&mut self, b: QBox, e2: f32, gid: u64, count: usize) {
        self.groups.push(GroupRec {
            b,
            e2,
            gid,
            first: self.entries.len() / ENTRY_REC,
            count,
        });
    }

    fn entry(&mut self, q: &QBox, e2: f32, n: &Node, colors: bool) {
        push_entry_rec(&mut self.entries, q, e2, n, colors);
    }
}

#[derive(Default)]
struct Runs {
    runs: Vec<(SpillFile, SpillFile)>,
    groups: u64,
    nodes: u64,
    root: (QBox, Vec<u8>),
}

/// The head of a run in the merge (a max-heap: the first in the list's order on top).
struct Head {
    b: QBox,
    e2: f32,
    gid: u64,
    count: u8,
    run: usize,
}

impl Head {
    fn of(r: &[u8; GREC], run: usize) -> Self {
        Self {
            b: file::box_of(r),
            e2: f32::from_le_bytes([r[12], r[13], r[14], r[15]]),
            gid: u64::from_le_bytes(r[16..24].try_into().unwrap_or([0; 8])),
            count: r[24],
            run,
        }
    }
}

impl PartialEq for Head {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Head {}
impl PartialOrd for Head {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Head {
    fn cmp(&self, other: &Self) -> Ordering {
        key_order(other.e2, other.gid, self.e2, self.gid)
    }
}

#[cfg(test)]
mod tests;
