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
//!    them); or, prepared by `cloud::ooc::prepare` ([`build_prepared`]), read where they lie
//!    each pass (the prepared chunks, or the whole cloud in memory), the box their parts', the
//!    indices and the box checked by the first counting pass; no copy is written;
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
//! 4. one pass distributes the points to their bins' files (removing each prepared chunk once
//!    read), each as a record of [`record::Layout`] (a LAS or LAZ input's positions as the
//!    integers of its grid, the colour only where kept: 32 bytes a point instead of 51);
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
//! Modules: [`record`] (a point on disk), [`plan`] (steps 2 to 4), [`runs`] (step 5), [`merge`]
//! (step 6).
//!
//! Deviations: none in the output. A cloud whose densest spot holds more than a chunk's points
//! within 2^-64 of the root cube is refused (the in-memory build would halve it by position).
//!
//! Memory: a chunk of m points needs about [`BYTES_PER_POINT`] · m bytes at its peak (records,
//! the hierarchy's nodes twice while subtrees are joined, the quantised groups of the run);
//! buffers, counts and the planned top need [`RESERVE`] more. The counting passes and the
//! distribution of prepared points hold one prepared chunk (or the whole prepared cloud) in
//! memory, about 48 bytes a point of a chunk the preparation sized at
//! [`PREPARE_BYTES_PER_POINT`]: a tenth of what a chunk's build takes, and no chunk is built
//! then.

mod merge;
mod plan;
mod record;
mod runs;
#[cfg(test)]
mod tests;

use std::io;
use std::path::{Path, PathBuf};

use cloud::glam::{DVec3, Vec3};
use cloud::spill::{Scratch, SpillFile, SpillWriter};

use self::plan::{Cell, Top, mark_chunks, plan};
use self::record::{Layout, REC, pack, unpack};
use crate::Spt;
use crate::file;
use crate::hierarchy;
use crate::list::Grid;
use crate::{Error, Result};

/// Peak bytes per point of a chunk while it is built and its groups sorted.
pub const BYTES_PER_POINT: u64 = 700;
/// Bytes per point the out-of-core preparation (`cloud::ooc::prepare`, normals and leaf radius)
/// sizes its chunks at for this build: its chunks need only their neighbour searches, and this
/// is the size the preparation was measured at for SPT (reports/scale, 10^7 and 10^8 points).
pub const PREPARE_BYTES_PER_POINT: u64 = 640;
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
    /// Tests: scratch writes fail (as on a full disk) after this many bytes (with
    /// [`build_prepared`] of prepared chunks, the preparation's bytes counted too).
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

/// Streams points in, then builds the file.
pub struct Builder {
    opts: Options,
    out: PathBuf,
    cap: u64,
    scratch: Scratch,
    writer: Option<SpillWriter>,
    /// The points pushed so far, what they add up to (their count is the build's); for
    /// prepared points, what the preparation says they are.
    tally: Tally,
    rec: Vec<u8>,
    leaf_diameter: f64,
    /// The layout of the distributed points (positions on the prepared chunks' grid where
    /// they have one).
    drec: Layout,
}

/// Where a build reads its points from, once per pass.
enum Input {
    /// The records [`Builder::push`] wrote to a scratch file.
    Pushed(SpillFile),
    /// The chunks `cloud::ooc::prepare` wrote, read where they lie
    /// ([`build_prepared`]).
    Prepared(cloud::ooc::Chunks),
    /// The points `cloud::ooc::prepare` kept in memory, as they are ([`build_prepared`]).
    Whole(cloud::ooc::Points),
}

/// The checks of a set of points: their box, largest input index and the (wrapping) sums of
/// their indices and of the indices' squares (a permutation of 0..n has known ones).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Tally {
    n: u64,
    bbox: (DVec3, DVec3),
    max_index: u64,
    index_sums: (u64, u64),
}

impl Default for Tally {
    fn default() -> Self {
        Tally {
            n: 0,
            bbox: (DVec3::INFINITY, DVec3::NEG_INFINITY),
            max_index: 0,
            index_sums: (0, 0),
        }
    }
}

impl Tally {
    /// Adds `p`, refusing a non-finite position or normal.
    fn add(&mut self, p: &Point) -> Result<()> {
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
        self.n += 1;
        self.bbox = (self.bbox.0.min(p.position), self.bbox.1.max(p.position));
        self.max_index = self.max_index.max(p.index);
        self.index_sums = (
            self.index_sums.0.wrapping_add(p.index),
            self.index_sums
                .1
                .wrapping_add(p.index.wrapping_mul(p.index)),
        );
        Ok(())
    }

    /// Fails unless the points are some (at most 2^31 - 1) and their indices are 0..n, each
    /// once.
    fn check(&self) -> Result<()> {
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
        Ok(())
    }
}

/// Builds the file of the points `cloud::ooc::prepare` prepared (normals and all) into `out`,
/// with leaf discs of `leaf_diameter`, reading the prepared chunks where they lie instead of
/// copying them to a scratch file of its own ([`Builder::push`]): each counting pass and the
/// distribution read them, and the distribution removes each chunk once it is read. Its own
/// scratch files count with the preparation's ([`Scratch::beside_counted_with`]): the
/// summary's scratch bytes are both builds' together. A cloud the preparation held in memory
/// at once ([`cloud::ooc::Prepared::Whole`]) is read from there (built in memory when it fits
/// this build's limit too). The same bytes as [`Builder::push`] of the same points, then
/// [`Builder::finish`].
pub fn build_prepared(
    prepared: cloud::ooc::Prepared,
    opts: &Options,
    out: &Path,
    leaf_diameter: f64,
    progress: &mut dyn FnMut(Stage, u64),
) -> Result<Summary> {
    let cap = chunk_capacity(opts.memory_limit)?;
    let io = |source| Error::Io {
        path: out.display().to_string(),
        source,
    };
    // The points and their box as the preparation counted them (its chunks' boxes are those
    // of the positions it wrote); the first pass over them checks both.
    let mut tally = Tally::default();
    let (input, scratch) = match prepared {
        cloud::ooc::Prepared::Whole(points) => {
            tally.n = points.positions.len() as u64;
            for p in &points.positions {
                tally.bbox = (tally.bbox.0.min(*p), tally.bbox.1.max(*p));
            }
            (Input::Whole(points), Scratch::beside(out).map_err(io)?)
        }
        cloud::ooc::Prepared::Chunked(chunks) => {
            for part in chunks.parts() {
                if let cloud::ooc::PartKind::Chunk(c) = part.kind {
                    tally.n += chunks.points_of(c);
                    tally.bbox = (tally.bbox.0.min(part.bbox.0), tally.bbox.1.max(part.bbox.1));
                }
            }
            let scratch = Scratch::beside_counted_with(out, chunks.scratch()).map_err(io)?;
            (Input::Prepared(chunks), scratch)
        }
    };
    let scratch = match opts.fail_after_bytes {
        Some(b) => scratch.fail_after(b),
        None => scratch,
    };
    let grid = match &input {
        Input::Prepared(chunks) => chunks.grid(),
        Input::Pushed(_) | Input::Whole(_) => None,
    };
    let b = Builder {
        opts: opts.clone(),
        out: out.to_path_buf(),
        cap,
        scratch,
        writer: None,
        tally,
        rec: vec![0; REC],
        leaf_diameter: 0.0,
        drec: Layout::new(grid, opts.colors),
    };
    b.build(input, leaf_diameter, progress)
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
            tally: Tally::default(),
            rec: vec![0; REC],
            leaf_diameter: 0.0,
            drec: Layout::new(None, opts.colors),
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
            self.tally.add(p)?;
            pack(p, &mut self.rec);
            let w = self.writer.as_mut().ok_or(Error::InvalidParameter {
                name: "builder",
                reason: "points pushed after the build".into(),
            })?;
            if let Err(e) = w.push(&self.rec) {
                return Err(self.io(e));
            }
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
        let writer = self.writer.take().ok_or(Error::EmptyCloud)?;
        let all = writer.finish().map_err(|e| self.io(e))?;
        self.build(Input::Pushed(all), leaf_diameter, progress)
    }

    /// Steps 2 to 6 of the module doc on `input`.
    fn build(
        mut self,
        mut input: Input,
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
        let n = self.tally.n;
        // Pushed points were checked as they came; prepared ones are by the first pass over
        // them.
        let prepared = !matches!(input, Input::Pushed(_));
        if !prepared {
            self.tally.check()?;
        }
        let mut summary = Summary {
            points: n,
            chunk_capacity: self.cap,
            ..Summary::default()
        };
        if n <= self.cap {
            progress(Stage::Build, 0);
            let mut tally = Tally::default();
            let mut pts = Vec::with_capacity(n as usize);
            self.for_each_point(&mut input, false, |p| {
                if prepared {
                    tally.add(p)?;
                }
                pts.push(*p);
                Ok(())
            })?;
            drop(input);
            if prepared {
                self.check_prepared(&tally)?;
            }
            pts.sort_unstable_by_key(|p| p.index);
            let positions = pts.iter().map(|p| p.position).collect();
            let normals = pts.iter().map(|p| p.normal).collect();
            let colors = self
                .opts
                .colors
                .then(|| pts.iter().map(|p| p.color).collect());
            drop(pts);
            let spt = in_memory(positions, normals, colors, self.leaf_diameter)?;
            file::write(&spt, &self.out)?;
            summary.chunks = 1;
            summary.largest_chunk = n;
            summary.scratch_bytes = self.scratch.bytes_written();
            summary.scratch_peak_bytes = self.scratch.peak_bytes();
            return Ok(summary);
        }
        // 2. Counting passes, the leaf discs' box with the first.
        let aabb = cloud::Aabb {
            min: self.tally.bbox.0,
            max: self.tally.bbox.1,
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
            let mut tally = Tally::default();
            self.count_pass(
                &mut input,
                &mut cells,
                &missing,
                first.then_some((origin, half32, &mut leaf_box)),
                (first && prepared).then_some(&mut tally),
                progress,
            )?;
            if first && prepared {
                self.check_prepared(&tally)?;
            }
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
        // 4. Distribution (the prepared chunks removed as they are read).
        let bin_files = self.distribute(&mut input, &cells, &chunks, bins, progress)?;
        drop(input);
        // 5. Chunks, the top and their runs.
        let runs = self.build_runs(&tops, &chunks, bin_files, origin, &grid, progress)?;
        summary.runs = runs.runs.len() as u64;
        // 6. The file.
        self.merge(runs, n, origin, &grid, progress)?;
        summary.scratch_bytes = self.scratch.bytes_written();
        summary.scratch_peak_bytes = self.scratch.peak_bytes();
        Ok(summary)
    }

    /// For prepared points, fails unless `tally` (of a pass over all of them) holds valid
    /// indices and the count and box the preparation gave.
    fn check_prepared(&self, tally: &Tally) -> Result<()> {
        tally.check()?;
        if tally.n != self.tally.n || tally.bbox != self.tally.bbox {
            return Err(internal(&format!(
                "the prepared chunks hold {} points in {:?}, their parts say {} in {:?}",
                tally.n, tally.bbox, self.tally.n, self.tally.bbox
            )));
        }
        Ok(())
    }

    /// `f` on every point of `input`, in the order of its files; with `release`, each
    /// prepared chunk is removed once read.
    fn for_each_point(
        &self,
        input: &mut Input,
        release: bool,
        mut f: impl FnMut(&Point) -> Result<()>,
    ) -> Result<()> {
        match input {
            Input::Pushed(all) => {
                let mut r = all.reader(0, all.len()).map_err(|e| self.io(e))?;
                let mut buf = [0u8; REC];
                while r.next_into(&mut buf).map_err(|e| self.io(e))? {
                    f(&unpack(&buf))?;
                }
            }
            Input::Prepared(chunks) => {
                for c in 0..chunks.len() {
                    each_of(&chunks.load(c)?, &mut f)?;
                    if release {
                        chunks.release(c)?;
                    }
                }
            }
            Input::Whole(pts) => each_of(pts, &mut f)?,
        }
        Ok(())
    }

    /// Records `start..start + count` of a distributed `file`, with their chunk, sorted by
    /// (chunk, input index); a repeated index is an error.
    fn load(&self, file: &SpillFile, start: u64, count: u64) -> Result<Vec<(Point, u32)>> {
        use rayon::prelude::*;
        let mut r = file.reader(start, count).map_err(|e| self.io(e))?;
        // The records read at once (a chunk's build later takes over ten times their bytes),
        // then decoded by all threads in order.
        let mut bytes = Vec::new();
        r.read_rest(&mut bytes).map_err(|e| self.io(e))?;
        let mut out = Vec::with_capacity(count as usize);
        out.par_extend(
            bytes
                .par_chunks_exact(self.drec.len())
                .map(|b| self.drec.unpack(b)),
        );
        drop(bytes);
        // (The keys are distinct unless an index is repeated, refused below: any sort gives
        // the one order.)
        out.par_sort_unstable_by_key(|(p, c)| (*c, p.index));
        if let Some(w) = out
            .par_windows(2)
            .find_first(|w| w[0].0.index == w[1].0.index)
        {
            return Err(Error::InvalidParameter {
                name: "index",
                reason: format!("point index {} given twice", w[0].0.index),
            });
        }
        Ok(out)
    }
}

/// `f` on each of the prepared points `pts`, in their order.
fn each_of(pts: &cloud::ooc::Points, f: &mut impl FnMut(&Point) -> Result<()>) -> Result<()> {
    for i in 0..pts.positions.len() {
        f(&Point {
            position: pts.positions[i],
            normal: pts.normals[i],
            color: pts.colors[i],
            index: pts.index[i],
        })?;
    }
    Ok(())
}

/// An error that only a bug in this build can cause.
fn internal(what: &str) -> Error {
    Error::InvalidParameter {
        name: "out-of-core build",
        reason: format!("internal inconsistency: {what}"),
    }
}
