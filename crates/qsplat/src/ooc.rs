//! The out-of-core build: the same file as the in-memory build ([`in_memory`]: normals,
//! leaf radius, [`crate::build_tree`], [`crate::file::to_bytes`]), byte for byte, for clouds
//! larger than memory, within a memory limit, with scratch files on the disk beside the output
//! (`cloud::spill`).
//!
//! Modelled on PotreeConverter 2's chunking (Schütz et al. 2020: points distributed to
//! per-chunk files, each chunk's tree built in memory, the top levels merged), but the chunks
//! are not cells of a fixed grid: QSplat's split (§3.1, [`crate::build`]) is at the midpoint of
//! the *points'* bounding box, so the top of the tree is made by the very same splits, streamed:
//!
//! 1. the input is streamed once into a scratch file (input order), with its bounding box, the
//!    centroid (summed in input order, as `cloud::normals` sums it) and a strided sample;
//! 2. a set of more points than a chunk holds is split as [`crate::build`] splits it: the
//!    midpoint of its box's longest axis, Lomuto's partition streamed (the left points in
//!    order to one file; the right ones through a first-in-first-out file that replays the
//!    in-memory partition's swaps exactly, so that every set keeps the order the in-memory
//!    build gives it, which decides how coincident points are halved), each half split again:
//!    two to four groups; a group that fits a chunk is a chunk, a larger one is split again;
//! 3. where the input has no normals, or the leaf radius is the density spacing, each chunk's
//!    neighbourhoods are completed by a *halo*: every point of the chunk gets an upper bound
//!    of its k-th neighbour distance (from the chunk, or from the sample for a chunk of fewer
//!    than k points); the chunk's halo radius is the largest bound of the points whose ball
//!    leaves the chunk's box (balls inside it hold no other chunk's point, the regions being
//!    separated by the split planes); one pass over all chunks sends every point within a
//!    chunk's halo radius of its box to that chunk's halo file. The k nearest neighbours
//!    over chunk + halo are then the true ones, taken in `cloud::knn`'s
//!    order (which no tree changes), so the normals and the spacing sample's distances are
//!    the in-memory ones, bit for bit; when the normals' k is the halo's, the first pass's
//!    query already gives the normal of every point whose ball lies inside its chunk (the same
//!    neighbours in the same order), kept in a scratch file, and the halo pass searches only
//!    the points near the borders;
//! 4. each chunk is built in memory ([`crate::build::build`] on the chunk in its order: the
//!    very subtree of the in-memory build) for its root, and the parents above the chunks
//!    are made from the roots;
//! 5. encoding is top-down, so each chunk is rebuilt once its parent's decoded sphere is known,
//!    quantised ([`crate::tree`]'s encoder, offsets relative to the chunk) and its sibling
//!    groups written level by level to a scratch file;
//! 6. the file is assembled breadth first through `cloud::io::atomic` (whole or not at all):
//!    each level is, left to right, the top nodes' groups and the chunks' segments of that
//!    level, their offsets moved to their place.
//!
//! [`prepare`] stops after step 3 and hands every point with its normal (and the leaf radius)
//! to a sink instead: the preparation another method's out-of-core build starts from (the
//! harness pipes it into `spt::ooc`).
//!
//! Deviations: none in the output. Each chunk is built twice (once for its root, once to
//! encode it), which costs time but no memory or disk.
//!
//! Memory: a chunk of m points needs about [`BYTES_PER_POINT`] · m bytes at its peak (the
//! hierarchy's nodes twice during the parallel build, then the encoder's arrays); scratch
//! buffers, the sample and the top tree need [`RESERVE`] more. The limit sets the chunk size;
//! a chunk and its halo must fit in it for the neighbour searches.

use std::collections::HashMap;
use std::io;
use std::num::NonZero;
use std::path::Path;

use cloud::glam::{DVec3, Vec3};
use cloud::kiddo::{ImmutableKdTree, SquaredEuclidean};
use cloud::spill::{Scratch, SpillFile, SpillReader, SpillWriter};

use crate::build::{self, Node};
use crate::error::{Error, Result};
use crate::tree::{self, QTree};

/// Peak bytes of the in-memory build and encoding per point of a chunk.
pub const BYTES_PER_POINT: u64 = 640;
/// Bytes per point of a chunk and its halo during the neighbour searches.
pub const NEIGHBOUR_BYTES_PER_POINT: u64 = 160;
/// Memory the out-of-core build needs beside its chunk (scratch buffers, sample, top tree).
pub const RESERVE: u64 = 48 << 20;
/// The smallest chunk worth building (a limit that allows fewer points per chunk is refused).
pub const MIN_CHUNK: u64 = 4_096;
/// Points of the sample that bounds small chunks' neighbour distances.
const SAMPLE: usize = 1 << 15;
/// Bytes of halo records buffered before they are appended to their files.
const HALO_BUFFER: usize = 16 << 20;

/// One input point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Position.
    pub position: DVec3,
    /// Unit normal (ignored when the build estimates normals).
    pub normal: Vec3,
    /// Colour (ignored when the build has none).
    pub color: [u8; 3],
}

/// Where the normals come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normals {
    /// The input's.
    Given,
    /// `cloud::normals::estimate_normals` with `k.min(n)` neighbours, oriented away from the
    /// centroid.
    Estimate {
        /// Neighbours.
        k: usize,
    },
}

/// The leaf radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Radius {
    /// This radius.
    Fixed(f64),
    /// `factor` × `cloud::spacing::density_spacing(positions, k, sample, seed)`.
    DensitySpacing {
        /// Neighbour rank.
        k: usize,
        /// Sample size.
        sample: usize,
        /// Seed of the sample.
        seed: u64,
        /// Spacings per leaf radius.
        factor: f64,
    },
}

/// How the build may use memory and disk, and what it builds.
#[derive(Debug, Clone)]
pub struct Options {
    /// Peak memory the build may use, bytes.
    pub memory_limit: u64,
    /// Colours kept (RGB565), as [`crate::build_tree`] keeps a cloud's colours.
    pub colors: bool,
    /// Normals.
    pub normals: Normals,
    /// Leaf radius.
    pub radius: Radius,
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
    /// Largest halo, points.
    pub largest_halo: u64,
    /// Points per chunk the limit allows.
    pub chunk_capacity: u64,
    /// Levels of the tree above the chunks.
    pub top_levels: u32,
    /// The leaf radius used.
    pub leaf_radius: f64,
    /// Bytes written to scratch files.
    pub scratch_bytes: u64,
    /// The most bytes the scratch files held at once (`cloud::spill::Scratch::peak_bytes`).
    pub scratch_peak_bytes: u64,
}

/// The build's stages, for progress reports (each with a count of points, or levels for
/// [`Stage::Write`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Reading the input.
    Read,
    /// Splitting into chunks (points placed in chunks).
    Split,
    /// Neighbourhoods: normals and spacing (points done).
    Neighbours,
    /// Building the chunks' roots.
    Build,
    /// Encoding the chunks.
    Encode,
    /// Writing the file (levels).
    Write,
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

/// The in-memory build the out-of-core one equals: normals and leaf radius by the rules of
/// `opts` ([`prepare_in_memory`]), then [`crate::build_tree`]; returns the tree and the leaf
/// radius.
pub fn in_memory(
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    colors: Option<Vec<[u8; 3]>>,
    opts: &Options,
) -> Result<(QTree, f64)> {
    let (normals, radius) = prepare_in_memory(&positions, normals, opts)?;
    let cloud = cloud::PointCloud {
        positions,
        normals: Some(normals),
        colors: if opts.colors { colors } else { None },
        ..cloud::PointCloud::default()
    };
    Ok((crate::build_tree(&cloud, radius)?, radius))
}

/// The normals and the leaf radius of a cloud in memory by the rules of `opts`: the given
/// normals or `cloud::normals::estimate_normals`, the fixed radius or the density spacing's.
pub fn prepare_in_memory(
    positions: &[DVec3],
    normals: Option<Vec<Vec3>>,
    opts: &Options,
) -> Result<(Vec<Vec3>, f64)> {
    if positions.is_empty() {
        return Err(Error::EmptyCloud);
    }
    cloud::points::check_finite(positions)?;
    let normals = match opts.normals {
        Normals::Given => normals.ok_or(Error::MissingNormals)?,
        Normals::Estimate { k } => cloud::normals::estimate_normals(
            positions,
            k.min(positions.len()),
            cloud::normals::Orientation::AwayFromCentroid,
        )?,
    };
    let radius = match opts.radius {
        Radius::Fixed(r) => r,
        Radius::DensitySpacing {
            k,
            sample,
            seed,
            factor,
        } => factor * cloud::spacing::density_spacing(positions, k, sample, seed)?,
    };
    Ok((normals, radius))
}

/// Where prepared points go: a batch of points (their normals set) and their indices in the
/// input.
pub type Sink<'a> = &'a mut dyn FnMut(&[Point], &[u64]) -> Result<()>;

/// Steps 1 to 3 of [`build_file`] alone: every point of `source` with its normal (given or
/// estimated, the very normals the QSplat build uses) handed to `sink` chunk by chunk (in no
/// particular order, with its index in the input), and the leaf radius in the summary. What
/// another method's out-of-core build (the harness pipes it into `spt::ooc`) needs from the
/// same preparation; within the same memory limit and with the same scratch rules.
pub fn prepare(
    source: &mut dyn FnMut(&mut Vec<Point>) -> Result<bool>,
    opts: &Options,
    out: &Path,
    progress: &mut dyn FnMut(Stage, u64),
    sink: Sink<'_>,
) -> Result<Summary> {
    run(source, opts, out, progress, Some(sink))
}

/// Builds the QSplat file of the points `source` yields (batches into the vector it is given,
/// `Ok(false)` at the end), writing `out` whole or not at all; scratch files go to a directory
/// beside `out`, removed at the end, also after an error. `progress` hears each stage's count.
pub fn build_file(
    source: &mut dyn FnMut(&mut Vec<Point>) -> Result<bool>,
    opts: &Options,
    out: &Path,
    progress: &mut dyn FnMut(Stage, u64),
) -> Result<Summary> {
    run(source, opts, out, progress, None)
}

/// [`build_file`], or [`prepare`] with a sink.
fn run(
    source: &mut dyn FnMut(&mut Vec<Point>) -> Result<bool>,
    opts: &Options,
    out: &Path,
    progress: &mut dyn FnMut(Stage, u64),
    mut sink: Option<Sink<'_>>,
) -> Result<Summary> {
    if let Radius::Fixed(r) = opts.radius
        && (!(r > 0.0) || !r.is_finite())
    {
        return Err(Error::InvalidParameter {
            name: "leaf_radius",
            reason: format!("must be positive, got {r}"),
        });
    }
    let cap = chunk_capacity(opts.memory_limit)?;
    let mut scratch = Scratch::beside(out).map_err(|source| Error::Io {
        path: out.display().to_string(),
        source,
    })?;
    if let Some(b) = opts.fail_after_bytes {
        scratch = scratch.fail_after(b);
    }
    let mut b = Builder {
        scratch: &scratch,
        cap,
        opts,
        leaf_radius: 0.0,
        top: Vec::new(),
        chunks: Vec::new(),
        done: 0,
        progress,
        out,
    };
    // 1. The input, in order, to the first scratch file.
    let mut w = b.create()?;
    let mut batch = Vec::new();
    let mut bbox = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut sum = DVec3::ZERO;
    let mut sample: Vec<(DVec3, u64)> = Vec::new();
    let mut stride = 1u64;
    let mut rec = [0u8; REC];
    let mut n: u64 = 0;
    loop {
        batch.clear();
        let more = source(&mut batch)?;
        for p in &batch {
            if !p.position.is_finite() {
                return Err(Error::Cloud(cloud::Error::NonFinite { index: n as usize }));
            }
            if opts.normals == Normals::Given && !p.normal.is_finite() {
                return Err(Error::InvalidParameter {
                    name: "normals",
                    reason: format!("point {n} has a non-finite normal"),
                });
            }
            bbox = (bbox.0.min(p.position), bbox.1.max(p.position));
            sum += p.position;
            if n.is_multiple_of(stride) {
                sample.push((p.position, n));
                if sample.len() >= 2 * SAMPLE {
                    stride *= 2;
                    sample.retain(|s| s.1.is_multiple_of(stride));
                }
            }
            pack(p, n, &mut rec);
            w.push(&rec).map_err(|e| b.io(e))?;
            n += 1;
        }
        (b.progress)(Stage::Read, n);
        if !more {
            break;
        }
    }
    if n == 0 {
        return Err(Error::EmptyCloud);
    }
    // Estimated normals and the density spacing need a surface (as `prepare_in_memory`'s).
    if (matches!(opts.normals, Normals::Estimate { .. })
        || matches!(opts.radius, Radius::DensitySpacing { .. }))
        && (n < 3 || bbox.0 == bbox.1)
    {
        return Err(Error::Cloud(cloud::normals::no_surface(n, bbox.0)));
    }
    if n > u64::from(u32::MAX) {
        return Err(Error::InvalidParameter {
            name: "points",
            reason: format!("{n} points; the tree counts leaves in 32 bits"),
        });
    }
    let all = Set {
        file: w.finish().map_err(|e| b.io(e))?,
        start: 0,
        count: n,
        bbox: Some(bbox),
        overlap: false,
    };
    let mut summary = Summary {
        points: n,
        chunk_capacity: cap,
        ..Summary::default()
    };
    if n <= cap {
        // It fits: the in-memory build.
        let chunk = b.load_file(&all)?;
        drop(all);
        let radius = if let Some(sink) = sink.as_mut() {
            let (normals, radius) = prepare_in_memory(&chunk.positions, Some(chunk.normals), opts)?;
            emit(
                sink,
                &chunk.positions,
                &normals,
                &chunk.colors,
                &chunk.index,
            )?;
            radius
        } else {
            let (tree, radius) = in_memory(
                chunk.positions,
                Some(chunk.normals),
                Some(chunk.colors),
                opts,
            )?;
            crate::file::write(&tree, out)?;
            radius
        };
        summary.chunks = 1;
        summary.largest_chunk = n;
        summary.leaf_radius = radius;
        summary.scratch_bytes = scratch.bytes_written();
        summary.scratch_peak_bytes = scratch.peak_bytes();
        return Ok(summary);
    }
    // 2. Split down to chunks.
    let (root, levels) = b.partition(all)?;
    summary.top_levels = levels;
    // 3. Neighbourhoods.
    let centroid = sum / n as f64;
    let mut spacing_d = Vec::new();
    let picks = match opts.radius {
        Radius::DensitySpacing {
            k, sample, seed, ..
        } => {
            if n as usize <= k {
                return Err(Error::Cloud(cloud::Error::InvalidParameter {
                    name: "k",
                    reason: format!("need 0 < k < {n} points, got {k}"),
                }));
            }
            let mut p: Vec<u64> = cloud::spacing::sample_picks(
                n as usize,
                sample,
                seed,
                cloud::spacing::DENSITY_PURPOSE,
            )
            .into_iter()
            .map(|i| i as u64)
            .collect();
            p.sort_unstable();
            Some((p, k))
        }
        Radius::Fixed(_) => None,
    };
    let estimate = match opts.normals {
        Normals::Estimate { k } => Some(k.min(n as usize).max(1)),
        Normals::Given => None,
    };
    if estimate.is_some() || picks.is_some() {
        let k_halo = estimate
            .unwrap_or(0)
            .max(picks.as_ref().map_or(0, |p| p.1 + 1));
        summary.largest_halo = b.neighbourhoods(
            root,
            &sample,
            k_halo,
            estimate,
            centroid,
            picks.as_ref(),
            &mut spacing_d,
        )?;
    }
    b.leaf_radius = match opts.radius {
        Radius::Fixed(r) => r,
        Radius::DensitySpacing { k, factor, .. } => {
            let median =
                cloud::spacing::median_of(&mut spacing_d).ok_or(Error::InvalidParameter {
                    name: "sample",
                    reason: "no point to measure".into(),
                })?;
            cloud::spacing::check_median(median, k, spacing_d.len())?;
            factor * cloud::spacing::density_from_kth(median, k)
        }
    };
    if !(b.leaf_radius > 0.0) || !b.leaf_radius.is_finite() {
        return Err(Error::InvalidParameter {
            name: "leaf_radius",
            reason: format!("must be positive, got {}", b.leaf_radius),
        });
    }
    summary.leaf_radius = b.leaf_radius;
    if let Some(sink) = sink.as_mut() {
        for c in &b.chunks {
            let l = b.load_file(&c.set)?;
            emit(sink, &l.positions, &l.normals, &l.colors, &l.index)?;
        }
        summary.chunks = b.chunks.len() as u64;
        summary.largest_chunk = b.chunks.iter().map(|c| c.set.count).max().unwrap_or(0);
        summary.scratch_bytes = scratch.bytes_written();
        summary.scratch_peak_bytes = scratch.peak_bytes();
        return Ok(summary);
    }
    // 4. The chunks' roots and the top tree above them (children come before parents).
    b.done = 0;
    b.build_top()?;
    // 5. Encode top-down.
    let root_node = b.top[root].node.clone();
    let root_decoded = (root_node.center, root_node.radius);
    let root_word = tree::word_for(&root_node, 0, b.grand(root)).pack();
    b.done = 0;
    b.encode(root, root_decoded)?;
    summary.chunks = b.chunks.len() as u64;
    summary.largest_chunk = b.chunks.iter().map(|c| c.set.count).max().unwrap_or(0);
    // 6. Assemble.
    b.assemble(root, root_word, out)?;
    summary.scratch_bytes = scratch.bytes_written();
    summary.scratch_peak_bytes = scratch.peak_bytes();
    Ok(summary)
}

/// Hands prepared points (with their input indices) to a [`prepare`] sink.
fn emit(
    sink: &mut Sink<'_>,
    positions: &[DVec3],
    normals: &[Vec3],
    colors: &[[u8; 3]],
    index: &[u64],
) -> Result<()> {
    let pts: Vec<Point> = (0..positions.len())
        .map(|i| Point {
            position: positions[i],
            normal: normals[i],
            color: colors[i],
        })
        .collect();
    sink(&pts, index)
}

/// Bytes of a point on disk: position, normal, colour, index in the input.
const REC: usize = 24 + 12 + 3 + 8;

fn pack(p: &Point, index: u64, b: &mut [u8; REC]) {
    for k in 0..3 {
        b[8 * k..8 * k + 8].copy_from_slice(&p.position[k].to_le_bytes());
        b[24 + 4 * k..28 + 4 * k].copy_from_slice(&p.normal[k].to_le_bytes());
    }
    b[36..39].copy_from_slice(&p.color);
    b[39..47].copy_from_slice(&index.to_le_bytes());
}

fn unpack(b: &[u8; REC]) -> (Point, u64) {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    let g = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap_or([0; 4]));
    (
        Point {
            position: DVec3::new(f(0), f(8), f(16)),
            normal: Vec3::new(g(24), g(28), g(32)),
            color: [b[36], b[37], b[38]],
        },
        u64::from_le_bytes(b[39..47].try_into().unwrap_or([0; 8])),
    )
}

fn position_of(b: &[u8; REC]) -> DVec3 {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    DVec3::new(f(0), f(8), f(16))
}

/// Squared distance from `p` to the box `(lo, hi)`.
fn box_dist2(p: DVec3, (lo, hi): (DVec3, DVec3)) -> f64 {
    let d = (lo - p).max(DVec3::ZERO).max(p - hi);
    d.length_squared()
}

/// A range of a scratch file: a set of points in the order the in-memory build has them.
#[derive(Debug, Clone)]
struct Set {
    file: SpillFile,
    start: u64,
    count: u64,
    bbox: Option<(DVec3, DVec3)>,
    /// Made by halving by position (coincident points): its region is not separated from
    /// its sibling's by a plane.
    overlap: bool,
}

/// A chunk's points in memory.
struct Loaded {
    positions: Vec<DVec3>,
    normals: Vec<Vec3>,
    colors: Vec<[u8; 3]>,
    index: Vec<u64>,
}

impl Loaded {
    fn input(&self, leaf_radius: f64, colors: bool) -> build::Input<'_> {
        build::Input {
            positions: &self.positions,
            normals: &self.normals,
            colors: colors.then_some(&self.colors[..]),
            leaf_radius,
        }
    }
}

/// A node of the top tree (above the chunks).
struct Top {
    node: Node,
    kind: TopKind,
    /// Its sphere index relative to its parent's decoded sphere (set by the encoding).
    sphere: u16,
    /// The points' box, and the largest halo radius (squared) of the chunks below.
    bbox: (DVec3, DVec3),
    halo2: f64,
}

enum TopKind {
    /// Children: top nodes.
    Inner(Vec<usize>),
    /// A chunk's root.
    Chunk(usize),
}

/// A chunk: its points, then (after encoding) its groups level by level in a scratch file of
/// (word, colour, is-offset) records with offsets relative to the chunk's words.
struct Chunk {
    set: Set,
    encoded: Option<SpillFile>,
    level_starts: Vec<usize>,
    root_word: u32,
    root_color: u16,
}

/// Bytes of an encoded word on disk: word, colour, offset flag.
const WREC: usize = 4 + 2 + 1;

struct Builder<'a> {
    scratch: &'a Scratch,
    cap: u64,
    opts: &'a Options,
    leaf_radius: f64,
    top: Vec<Top>,
    chunks: Vec<Chunk>,
    done: u64,
    progress: &'a mut dyn FnMut(Stage, u64),
    out: &'a Path,
}

/// The right-hand side of a streamed Lomuto partition: a first-in-first-out file. Lomuto's
/// loop keeps the right points in `items[k..j]`; a left point at `j` swaps with `items[k]`,
/// which moves the first right point to the back. Replaying that on a FIFO (push every right
/// point; on a left point, pop the front and push it again) leaves the right half, in order,
/// as the records from the pop position to the end.
struct Fifo {
    writer: SpillWriter,
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
                self.writer.push(r)?;
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
        if !reader.next_into(&mut b)? {
            return Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "scratch queue read past its end",
            ));
        }
        Ok(b)
    }

    fn finish(mut self) -> io::Result<(SpillFile, u64, u64)> {
        for r in &self.tail {
            self.writer.push(r)?;
        }
        let file = self.writer.finish()?;
        Ok((file, self.popped, self.pushed - self.popped))
    }
}

impl Builder<'_> {
    fn io(&self, source: io::Error) -> Error {
        Error::Io {
            path: format!(
                "{} (scratch {})",
                self.out.display(),
                self.scratch.dir().display()
            ),
            source,
        }
    }

    fn create(&self) -> Result<SpillWriter> {
        self.scratch.create(REC).map_err(|e| self.io(e))
    }

    fn for_each(&self, set: &Set, mut f: impl FnMut(&[u8; REC]) -> Result<()>) -> Result<()> {
        let mut r = set
            .file
            .reader(set.start, set.count)
            .map_err(|e| self.io(e))?;
        let mut b = [0u8; REC];
        while r.next_into(&mut b).map_err(|e| self.io(e))? {
            f(&b)?;
        }
        Ok(())
    }

    fn bbox(&self, set: &Set) -> Result<(DVec3, DVec3)> {
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

    fn load_file(&self, set: &Set) -> Result<Loaded> {
        let m = set.count as usize;
        let mut l = Loaded {
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

    /// [`crate::build`]'s `split`, streamed: the two halves in the in-memory order.
    fn split(&self, set: Set) -> Result<(Set, Set)> {
        let (lo, hi) = self.bbox(&set)?;
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = 0.5 * (lo[axis] + hi[axis]);
        let mut left = self.create()?;
        let mut fifo = Fifo {
            writer: self.create()?,
            tail: Vec::new(),
            flushed: 0,
            pushed: 0,
            popped: 0,
            reader: None,
        };
        let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut lb, mut rb) = (empty, empty);
        self.for_each(&set, |r| {
            let p = position_of(r);
            if p[axis] < mid {
                lb = (lb.0.min(p), lb.1.max(p));
                left.push(r).map_err(|e| self.io(e))?;
                if fifo.pushed > fifo.popped {
                    let front = fifo.pop().map_err(|e| self.io(e))?;
                    fifo.push(front).map_err(|e| self.io(e))?;
                }
            } else {
                rb = (rb.0.min(p), rb.1.max(p));
                fifo.push(*r).map_err(|e| self.io(e))?;
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
            file: left.finish().map_err(|e| self.io(e))?,
            start: 0,
            count: k,
            bbox: Some(lb),
            overlap: set.overlap,
        };
        let (file, start, count) = fifo.finish().map_err(|e| self.io(e))?;
        let right = Set {
            file,
            start,
            count,
            bbox: Some(rb),
            overlap: set.overlap,
        };
        Ok((left, right))
    }

    /// [`crate::build`]'s `groups`, streamed.
    fn groups(&self, set: Set) -> Result<Vec<Set>> {
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
    fn partition(&mut self, set: Set) -> Result<(usize, u32)> {
        if set.count <= self.cap {
            let bbox = self.bbox(&set)?;
            let set = Set {
                bbox: Some(bbox),
                ..set
            };
            self.done += set.count;
            (self.progress)(Stage::Split, self.done);
            self.chunks.push(Chunk {
                set,
                encoded: None,
                level_starts: Vec::new(),
                root_word: 0,
                root_color: 0,
            });
            self.top.push(Top {
                node: placeholder(),
                kind: TopKind::Chunk(self.chunks.len() - 1),
                sphere: 0,
                bbox,
                halo2: 0.0,
            });
            return Ok((self.top.len() - 1, 0));
        }
        let bbox = self.bbox(&set)?;
        let groups = self.groups(set)?;
        let mut kids = Vec::with_capacity(groups.len());
        let mut levels = 0;
        for g in groups {
            let (k, l) = self.partition(g)?;
            kids.push(k);
            levels = levels.max(l + 1);
        }
        self.top.push(Top {
            node: placeholder(),
            kind: TopKind::Inner(kids),
            sphere: 0,
            bbox,
            halo2: 0.0,
        });
        Ok((self.top.len() - 1, levels))
    }

    /// Normals and the spacing sample's distances, chunk by chunk with halos (module doc,
    /// step 3); returns the largest halo.
    #[allow(clippy::too_many_arguments)]
    fn neighbourhoods(
        &mut self,
        root: usize,
        sample: &[(DVec3, u64)],
        k_halo: usize,
        estimate: Option<usize>,
        centroid: DVec3,
        picks: Option<&(Vec<u64>, usize)>,
        spacing_d: &mut Vec<f64>,
    ) -> Result<u64> {
        let kk = NonZero::new(k_halo.max(1)).ok_or(Error::InvalidParameter {
            name: "k",
            reason: "zero".into(),
        })?;
        let sample_entries: Vec<[f64; 3]> = sample.iter().map(|s| s.0.to_array()).collect();
        let sample_tree = kd_tree(&sample_entries)?;
        // (a) Every chunk's halo radius. When the normals' k is the halo's, the one query per
        // point also gives the normal of every point whose ball lies inside its chunk's box:
        // its neighbours are its true ones, in `canonical_knn`'s order, so the normal is the
        // one (c) would compute (bit for bit); it is kept in a scratch file (NaN: left to (c),
        // which then searches only the points near the borders).
        let single = estimate == Some(kk.get());
        let mut halo2 = vec![0.0f64; self.chunks.len()];
        let mut early: Vec<Option<SpillFile>> = (0..self.chunks.len()).map(|_| None).collect();
        for (c, r2) in halo2.iter_mut().enumerate() {
            let set = self.chunks[c].set.clone();
            let l = self.load_file(&set)?;
            let own = (l.positions.len() >= kk.get())
                .then(|| cloud::knn::Knn::new(&l.positions, |item| l.index[item as usize]))
                .transpose()?;
            let bbox = set.bbox.unwrap_or((DVec3::ZERO, DVec3::ZERO));
            let overlap = set.overlap;
            let inside = |p: DVec3, d: f64| {
                !overlap && (0..3).all(|a| p[a] - bbox.0[a] > d && bbox.1[a] - p[a] > d)
            };
            let per_point = cloud::normals::per_point_in_spatial_order(&l.positions, |i| {
                let p = l.positions[i];
                match own.as_ref().filter(|_| single) {
                    Some(knn) => {
                        let nb = knn.canonical_knn(p, kk);
                        let d2 = nb.last().map_or(f64::INFINITY, |x| x.0);
                        if inside(p, d2.sqrt()) {
                            let n = cloud::normals::covariance_normal(
                                nb.iter().map(|x| l.positions[x.1 as usize]),
                            );
                            (0.0, Some(cloud::normals::orient(n, p - centroid)))
                        } else {
                            (d2, None)
                        }
                    }
                    None => {
                        let d2 = match own.as_ref() {
                            Some(knn) => knn.kth_distance2(p, kk),
                            None => sample_tree
                                .query(&p.to_array())
                                .nearest_n::<SquaredEuclidean<f64>>(kk)
                                .execute()
                                .last()
                                .map_or(f64::INFINITY, |x| x.distance),
                        };
                        (if inside(p, d2.sqrt()) { 0.0 } else { d2 }, None)
                    }
                }
            });
            *r2 = per_point.iter().map(|x| x.0).fold(0.0, f64::max);
            if single && own.is_some() {
                let mut w = self.scratch.create(12).map_err(|e| self.io(e))?;
                for (_, n) in &per_point {
                    let n = n.unwrap_or(Vec3::NAN);
                    let mut rec = [0u8; 12];
                    for (a, v) in n.to_array().iter().enumerate() {
                        rec[4 * a..4 * a + 4].copy_from_slice(&v.to_le_bytes());
                    }
                    w.push(&rec).map_err(|e| self.io(e))?;
                }
                early[c] = Some(w.finish().map_err(|e| self.io(e))?);
            }
        }
        // Slack for the rounding of box distances against point distances.
        let slack = |r2: f64| r2 * (1.0 + 1e-9) + f64::MIN_POSITIVE;
        for t in 0..self.top.len() {
            self.top[t].halo2 = match &self.top[t].kind {
                TopKind::Chunk(c) => slack(halo2[*c]),
                TopKind::Inner(kids) => kids.iter().map(|&k| self.top[k].halo2).fold(0.0, f64::max),
            };
        }
        // (b) One pass sending every point to the halos it lies in.
        let mut halos: Vec<Option<SpillWriter>> = (0..self.chunks.len()).map(|_| None).collect();
        let mut buffered: HashMap<usize, Vec<[u8; REC]>> = HashMap::new();
        let mut buffered_bytes = 0usize;
        let mut stack = Vec::new();
        for d in 0..self.chunks.len() {
            let set = self.chunks[d].set.clone();
            self.for_each(&set, |r| {
                let p = position_of(r);
                stack.clear();
                stack.push(root);
                while let Some(t) = stack.pop() {
                    let top = &self.top[t];
                    if box_dist2(p, top.bbox) > top.halo2 {
                        continue;
                    }
                    match &top.kind {
                        TopKind::Inner(kids) => stack.extend(kids.iter().copied()),
                        TopKind::Chunk(c) if *c != d => {
                            buffered.entry(*c).or_default().push(*r);
                            buffered_bytes += REC;
                        }
                        TopKind::Chunk(_) => {}
                    }
                }
                if buffered_bytes >= HALO_BUFFER {
                    self.flush_halos(&mut buffered, &mut halos)?;
                    buffered_bytes = 0;
                }
                Ok(())
            })?;
        }
        self.flush_halos(&mut buffered, &mut halos)?;
        // (c) Each chunk with its halo: normals and the spacing sample's distances.
        let budget = self.cap * BYTES_PER_POINT / NEIGHBOUR_BYTES_PER_POINT;
        let mut largest = 0u64;
        self.done = 0;
        for (c, halo) in halos.into_iter().enumerate() {
            let set = self.chunks[c].set.clone();
            let mut l = self.load_file(&set)?;
            let m = l.positions.len();
            let halo = match halo {
                Some(w) => Some(w.finish().map_err(|e| self.io(e))?),
                None => None,
            };
            let h = halo.as_ref().map_or(0, SpillFile::len);
            largest = largest.max(h);
            if (m as u64 + h) > budget {
                return Err(Error::InvalidParameter {
                    name: "memory_limit",
                    reason: format!(
                        "a chunk of {m} points needs a halo of {h} points for its neighbour \
                         searches, more than the limit holds ({budget} points); the cloud is \
                         too sparse around that chunk, or holds many copies of a point there, \
                         for this limit"
                    ),
                });
            }
            let mut positions = l.positions.clone();
            let mut index = l.index.clone();
            if let Some(hf) = &halo {
                let hs = Set {
                    file: hf.clone(),
                    start: 0,
                    count: h,
                    bbox: None,
                    overlap: false,
                };
                self.for_each(&hs, |r| {
                    let (p, i) = unpack(r);
                    positions.push(p.position);
                    index.push(i);
                    Ok(())
                })?;
            }
            drop(halo);
            let knn = cloud::knn::Knn::new(&positions, |item| index[item as usize])?;
            if let Some(k) = estimate {
                let k = NonZero::new(k).unwrap_or(kk);
                let chunk = &l.positions[..m];
                // The normals (a) found (NaN where it left them to this pass).
                let known: Vec<Vec3> = match early[c].take() {
                    Some(f) => {
                        let mut r = f.reader(0, m as u64).map_err(|e| self.io(e))?;
                        let mut rec = [0u8; 12];
                        let mut out = Vec::with_capacity(m);
                        while r.next_into(&mut rec).map_err(|e| self.io(e))? {
                            let v = |a: usize| {
                                f32::from_le_bytes([
                                    rec[4 * a],
                                    rec[4 * a + 1],
                                    rec[4 * a + 2],
                                    rec[4 * a + 3],
                                ])
                            };
                            out.push(Vec3::new(v(0), v(1), v(2)));
                        }
                        out
                    }
                    None => vec![Vec3::NAN; m],
                };
                l.normals = cloud::normals::per_point_in_spatial_order(chunk, |i| {
                    if let Some(&n) = known.get(i).filter(|n| !n.x.is_nan()) {
                        return n;
                    }
                    let p = chunk[i];
                    let nb = knn.canonical_knn(p, k);
                    let n = cloud::normals::covariance_normal(
                        nb.iter().map(|x| positions[x.1 as usize]),
                    );
                    cloud::normals::orient(n, p - centroid)
                });
            }
            if let Some((picks, ks)) = picks {
                let k1 = NonZero::new(ks + 1).unwrap_or(kk);
                for i in 0..m {
                    let g = l.index[i];
                    let lo = picks.partition_point(|&x| x < g);
                    let hi = picks.partition_point(|&x| x <= g);
                    if hi > lo {
                        let d = knn.kth_distance2(l.positions[i], k1).sqrt();
                        spacing_d.extend(std::iter::repeat_n(d, hi - lo));
                    }
                }
            }
            drop((knn, positions, index));
            if estimate.is_some() {
                // The chunk again, with its normals.
                let mut w = self.create()?;
                let mut rec = [0u8; REC];
                for i in 0..m {
                    let p = Point {
                        position: l.positions[i],
                        normal: l.normals[i],
                        color: l.colors[i],
                    };
                    pack(&p, l.index[i], &mut rec);
                    w.push(&rec).map_err(|e| self.io(e))?;
                }
                let file = w.finish().map_err(|e| self.io(e))?;
                let chunk = &mut self.chunks[c];
                chunk.set = Set {
                    file,
                    start: 0,
                    count: m as u64,
                    bbox: set.bbox,
                    overlap: set.overlap,
                };
            }
            self.done += m as u64;
            (self.progress)(Stage::Neighbours, self.done);
        }
        Ok(largest)
    }

    fn flush_halos(
        &self,
        buffered: &mut HashMap<usize, Vec<[u8; REC]>>,
        halos: &mut [Option<SpillWriter>],
    ) -> Result<()> {
        for (c, recs) in buffered.drain() {
            let w = match &mut halos[c] {
                Some(w) => w,
                None => halos[c].insert(self.scratch.create(REC).map_err(|e| self.io(e))?),
            };
            for r in &recs {
                w.push(r).map_err(|e| self.io(e))?;
            }
            // Release the writer's buffer until more arrives.
            w.flush().map_err(|e| self.io(e))?;
        }
        Ok(())
    }

    /// The chunks' roots, then the top nodes (children are before parents in `top`).
    fn build_top(&mut self) -> Result<()> {
        for t in 0..self.top.len() {
            let node = match &self.top[t].kind {
                TopKind::Chunk(c) => {
                    let set = self.chunks[*c].set.clone();
                    let chunk = self.load_file(&set)?;
                    let h = build::build(&chunk.input(self.leaf_radius, self.opts.colors));
                    self.done += set.count;
                    (self.progress)(Stage::Build, self.done);
                    h.nodes[h.root()].clone()
                }
                TopKind::Inner(kids) => {
                    let refs: Vec<&Node> = kids.iter().map(|&k| &self.top[k].node).collect();
                    let ids: Vec<u32> = (0..kids.len() as u32).collect();
                    build::parent_from(&refs, &ids)
                }
            };
            self.top[t].node = node;
        }
        Ok(())
    }

    fn has_kids(&self, t: usize) -> bool {
        self.top[t].node.n_children > 0
    }

    /// Whether some child of top node `t` has children.
    fn grand(&self, t: usize) -> bool {
        match &self.top[t].kind {
            TopKind::Inner(kids) => kids.iter().any(|&k| self.has_kids(k)),
            TopKind::Chunk(_) => false,
        }
    }

    /// Encodes the children of top node `t` (decoded sphere `decoded`) and below.
    fn encode(&mut self, t: usize, decoded: (DVec3, f64)) -> Result<()> {
        let TopKind::Inner(kids) = &self.top[t].kind else {
            return Ok(());
        };
        for k in kids.clone() {
            let node = &self.top[k].node;
            let (sphere, own) = tree::child_sphere(node.center, node.radius, decoded);
            match self.top[k].kind {
                TopKind::Inner(_) => {
                    self.top[k].sphere = sphere;
                    self.encode(k, own)?;
                }
                TopKind::Chunk(c) => self.encode_chunk(c, sphere, own)?,
            }
        }
        Ok(())
    }

    fn encode_chunk(&mut self, c: usize, sphere: u16, own: (DVec3, f64)) -> Result<()> {
        let set = self.chunks[c].set.clone();
        let chunk = self.load_file(&set)?;
        let h = build::build(&chunk.input(self.leaf_radius, self.opts.colors));
        drop(chunk);
        let (parts, decoded) = tree::encode_parts(&h, sphere, own, self.opts.colors, true);
        drop((h, decoded));
        let mut w = self.scratch.create(WREC).map_err(|e| self.io(e))?;
        let mut offsets = parts.offsets.iter().peekable();
        let mut rec = [0u8; WREC];
        for (i, &word) in parts.words.iter().enumerate() {
            let is_offset = offsets.next_if(|&&o| o == i).is_some();
            rec[..4].copy_from_slice(&word.to_le_bytes());
            let col = parts.colors.get(i).copied().unwrap_or(0);
            rec[4..6].copy_from_slice(&col.to_le_bytes());
            rec[6] = u8::from(is_offset);
            w.push(&rec).map_err(|e| self.io(e))?;
        }
        let encoded = w.finish().map_err(|e| self.io(e))?;
        let empty = self.create()?.finish().map_err(|e| self.io(e))?;
        let chunk = &mut self.chunks[c];
        chunk.encoded = Some(encoded);
        chunk.level_starts = parts.level_starts;
        chunk.root_word = parts.root_word;
        chunk.root_color = parts.root_color;
        // The points are no longer needed.
        chunk.set.file = empty;
        chunk.set.start = 0;
        self.done += set.count;
        (self.progress)(Stage::Encode, self.done);
        Ok(())
    }

    /// The word and colour of top node `k` as a child.
    fn child_word(&self, k: usize) -> (u32, u16) {
        match self.top[k].kind {
            TopKind::Inner(_) => {
                let node = &self.top[k].node;
                (
                    tree::word_for(node, self.top[k].sphere, self.grand(k)).pack(),
                    tree::node_color(node),
                )
            }
            TopKind::Chunk(c) => (self.chunks[c].root_word, self.chunks[c].root_color),
        }
    }

    /// Writes the file: breadth first, each level the top groups and chunk segments in order.
    fn assemble(&mut self, root: usize, root_word: u32, out: &Path) -> Result<()> {
        #[derive(Clone, Copy)]
        enum Entry {
            Top(usize),
            Chunk(usize, usize),
        }
        let chunk_levels = |c: &Chunk| c.level_starts.len().saturating_sub(1);
        // The entries that start groups at the next level, in order.
        let children = |e: Entry| -> Vec<Entry> {
            match e {
                Entry::Top(p) => match &self.top[p].kind {
                    TopKind::Inner(kids) => {
                        kids.iter()
                            .filter_map(|&k| match self.top[k].kind {
                                TopKind::Inner(_) => Some(Entry::Top(k)),
                                TopKind::Chunk(c) => (chunk_levels(&self.chunks[c]) > 0)
                                    .then_some(Entry::Chunk(c, 0)),
                            })
                            .collect()
                    }
                    TopKind::Chunk(_) => Vec::new(),
                },
                Entry::Chunk(c, d) => {
                    if d + 1 < chunk_levels(&self.chunks[c]) {
                        vec![Entry::Chunk(c, d + 1)]
                    } else {
                        Vec::new()
                    }
                }
            }
        };
        let mut levels: Vec<Vec<Entry>> = vec![vec![Entry::Top(root)]];
        loop {
            let next: Vec<Entry> = levels
                .last()
                .into_iter()
                .flatten()
                .flat_map(|&e| children(e))
                .collect();
            if next.is_empty() {
                break;
            }
            levels.push(next);
        }
        let size = |e: Entry| -> usize {
            match e {
                Entry::Top(p) => match &self.top[p].kind {
                    TopKind::Inner(kids) => kids.len() + usize::from(self.grand(p)),
                    TopKind::Chunk(_) => 0,
                },
                Entry::Chunk(c, d) => {
                    let s = &self.chunks[c].level_starts;
                    s[d + 1] - s[d]
                }
            }
        };
        let mut starts: Vec<Vec<usize>> = Vec::with_capacity(levels.len());
        let mut total = 0usize;
        for l in &levels {
            starts.push(
                l.iter()
                    .map(|&e| {
                        let s = total;
                        total += size(e);
                        s
                    })
                    .collect(),
            );
        }
        if total > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                reason: format!("{total} words; offsets are 32-bit"),
            });
        }
        // Each entry's first child entry's start in the next level.
        let mut child_start: Vec<Vec<Option<usize>>> = Vec::with_capacity(levels.len());
        for (l, level) in levels.iter().enumerate() {
            let mut seen = 0usize;
            child_start.push(
                level
                    .iter()
                    .map(|&e| {
                        let n = children(e).len();
                        let s = (n > 0).then(|| starts[l + 1][seen]);
                        seen += n;
                        s
                    })
                    .collect(),
            );
        }
        let root_node = self.top[root].node.clone();
        let colors = self.opts.colors;
        let me = &*self;
        let mut written_levels = 0u64;
        let result = cloud::io::atomic::write_with(out, |o| {
            use std::io::Write;
            o.write_all(&crate::file::header_bytes(
                colors,
                u64::from(root_node.leaves),
                total as u64,
                root_node.center,
                root_node.radius,
                root_word,
            ))?;
            // Words first, then (after the root's) the colours: two sweeps.
            for sweep in 0..1 + usize::from(colors) {
                let want_color = sweep == 1;
                if want_color {
                    o.write_all(&tree::node_color(&root_node).to_le_bytes())?;
                }
                for (l, level) in levels.iter().enumerate() {
                    for (g, &e) in level.iter().enumerate() {
                        match e {
                            Entry::Top(p) => {
                                let TopKind::Inner(kids) = &me.top[p].kind else {
                                    continue;
                                };
                                if me.grand(p) {
                                    let s = child_start[l][g].ok_or_else(|| {
                                        io::Error::other("a top group lost its children")
                                    })?;
                                    if want_color {
                                        o.write_all(&0u16.to_le_bytes())?;
                                    } else {
                                        o.write_all(&(s as u32).to_le_bytes())?;
                                    }
                                }
                                for &k in kids {
                                    let (w, c) = me.child_word(k);
                                    if want_color {
                                        o.write_all(&c.to_le_bytes())?;
                                    } else {
                                        o.write_all(&w.to_le_bytes())?;
                                    }
                                }
                            }
                            Entry::Chunk(c, d) => {
                                let chunk = &me.chunks[c];
                                let s = &chunk.level_starts;
                                let Some(file) = &chunk.encoded else {
                                    return Err(io::Error::other("chunk not encoded"));
                                };
                                let mut r = file.reader(s[d] as u64, (s[d + 1] - s[d]) as u64)?;
                                // Offsets point into the chunk's words: its next level moves
                                // to the start of its next entry.
                                let shift = child_start[l][g].map(|n| n as i64 - s[d + 1] as i64);
                                let mut rec = [0u8; WREC];
                                while r.next_into(&mut rec)? {
                                    if want_color {
                                        o.write_all(&rec[4..6])?;
                                        continue;
                                    }
                                    let mut w =
                                        u32::from_le_bytes([rec[0], rec[1], rec[2], rec[3]]);
                                    if rec[6] == 1 {
                                        let shift = shift.ok_or_else(|| {
                                            io::Error::other("offset word without a next level")
                                        })?;
                                        w = u32::try_from(i64::from(w) + shift).map_err(|_| {
                                            io::Error::other("offset beyond 32 bits")
                                        })?;
                                    }
                                    o.write_all(&w.to_le_bytes())?;
                                }
                            }
                        }
                    }
                    written_levels += 1;
                }
            }
            Ok(written_levels)
        });
        match result {
            Ok(levels) => {
                (self.progress)(Stage::Write, levels);
                Ok(())
            }
            Err(source) => Err(Error::Io {
                path: out.display().to_string(),
                source,
            }),
        }
    }
}

fn placeholder() -> Node {
    Node {
        center: DVec3::ZERO,
        radius: 0.0,
        normal: DVec3::Z,
        cone: 0.0,
        color: Vec3::ZERO,
        leaves: 0,
        kids: [0; 4],
        n_children: 0,
        point: None,
    }
}

fn kd_tree(entries: &[[f64; 3]]) -> Result<ImmutableKdTree<f64, 3>> {
    ImmutableKdTree::<f64, 3>::new_from_slice(entries).map_err(|e| Error::InvalidParameter {
        name: "positions",
        reason: format!("cannot build a k-d tree: {e:?}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::rng::{RngExt, seeded};

    /// A cloud with clusters of coincident points (different normals and colours) and
    /// points one ulp apart, which exercise the halving by position, on a wavy sheet, and
    /// some far outliers (chunks of fewer points than the neighbour count).
    pub(crate) fn cloud(n: usize, seed: u64) -> Vec<Point> {
        let mut rng = seeded(seed, "ooc-test");
        let mut pts = Vec::with_capacity(n);
        while pts.len() < n {
            let (x, y) = (rng.random::<f64>(), rng.random::<f64>());
            let mut p = DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos());
            if rng.random::<f64>() < 0.0005 {
                p += DVec3::new(0.0, 0.0, 3.0 + rng.random::<f64>());
            }
            let copies = if rng.random::<f64>() < 0.02 { 5 } else { 1 };
            for c in 0..copies {
                let normal = Vec3::new(rng.random(), rng.random(), 1.0).normalize();
                let q = if c == 4 {
                    DVec3::new(p.x.next_up(), p.y, p.z)
                } else {
                    p
                };
                pts.push(Point {
                    position: q,
                    normal,
                    color: [rng.random(), rng.random(), (c * 50) as u8],
                });
            }
        }
        pts.truncate(n);
        pts
    }

    fn in_memory_bytes(pts: &[Point], opts: &Options) -> Vec<u8> {
        let (tree, _) = in_memory(
            pts.iter().map(|p| p.position).collect(),
            Some(pts.iter().map(|p| p.normal).collect()),
            Some(pts.iter().map(|p| p.color).collect()),
            opts,
        )
        .unwrap();
        crate::file::to_bytes(&tree)
    }

    fn out_of_core(pts: &[Point], opts: &Options, out: &Path) -> Result<Summary> {
        let mut at = 0;
        let mut source = |batch: &mut Vec<Point>| -> Result<bool> {
            let end = (at + 10_000).min(pts.len());
            batch.extend_from_slice(&pts[at..end]);
            at = end;
            Ok(at < pts.len())
        };
        build_file(&mut source, opts, out, &mut |_, _| {})
    }

    fn limit(chunk: u64) -> u64 {
        RESERVE + chunk * BYTES_PER_POINT
    }

    fn options(chunk: u64, colors: bool, normals: Normals, radius: Radius) -> Options {
        Options {
            memory_limit: limit(chunk),
            colors,
            normals,
            radius,
            fail_after_bytes: None,
        }
    }

    const DENSITY: Radius = Radius::DensitySpacing {
        k: 8,
        sample: 2_000,
        seed: 1,
        factor: 1.5,
    };

    fn same_bytes(pts: &[Point], normals: Normals, radius: Radius, colors: bool, chunks: &[u64]) {
        let dir = tempfile::tempdir().unwrap();
        let want = in_memory_bytes(pts, &options(1 << 30, colors, normals, radius));
        for &chunk in chunks {
            let out = dir.path().join("t.qsplat");
            let opts = options(chunk, colors, normals, radius);
            let s = out_of_core(pts, &opts, &out).unwrap();
            if (chunk as usize) < pts.len() {
                assert!(s.chunks >= 5 && s.top_levels >= 2, "{s:?}");
            } else {
                assert_eq!(s.chunks, 1);
            }
            let got = std::fs::read(&out).unwrap();
            assert_eq!(
                got.len(),
                want.len(),
                "{normals:?} {radius:?} chunk {chunk}"
            );
            let first = got.iter().zip(&want).position(|(a, b)| a != b);
            assert_eq!(first, None, "{normals:?} {radius:?} chunk {chunk}: {s:?}");
            // Only the output is left beside it.
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
            crate::file::read(&out).unwrap();
        }
    }

    #[test]
    fn the_same_bytes_with_given_normals_and_radius() {
        let pts = cloud(50_000, 1);
        for colors in [true, false] {
            same_bytes(
                &pts,
                Normals::Given,
                Radius::Fixed(0.002),
                colors,
                &[MIN_CHUNK, 9_000, 100_000],
            );
        }
    }

    #[test]
    fn the_same_bytes_with_estimated_normals_and_density_spacing() {
        let pts = cloud(40_000, 2);
        same_bytes(
            &pts,
            Normals::Estimate { k: 16 },
            DENSITY,
            true,
            &[MIN_CHUNK, 7_000],
        );
        same_bytes(&pts, Normals::Given, DENSITY, false, &[MIN_CHUNK]);
    }

    #[test]
    fn a_full_disk_is_an_error_and_leaves_nothing() {
        let pts = cloud(30_000, 2);
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.qsplat");
        for after in [1_000u64, 500_000, 3_000_000, 9_000_000] {
            let opts = Options {
                fail_after_bytes: Some(after),
                ..options(MIN_CHUNK, true, Normals::Estimate { k: 16 }, DENSITY)
            };
            let e = out_of_core(&pts, &opts, &out).unwrap_err();
            match &e {
                Error::Io { source, .. } => {
                    assert_eq!(source.kind(), io::ErrorKind::StorageFull, "{e}");
                }
                other => panic!("{other}"),
            }
            assert!(e.to_string().contains("no space left"), "{e}");
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        }
    }

    #[test]
    fn bad_limits_and_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.qsplat");
        let small = Options {
            memory_limit: 16 << 20,
            ..options(0, false, Normals::Given, Radius::Fixed(0.01))
        };
        let e = out_of_core(&cloud(100, 3), &small, &out).unwrap_err();
        assert!(
            matches!(
                e,
                Error::InvalidParameter {
                    name: "memory_limit",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("below what"), "{e}");
        let opts = options(MIN_CHUNK, false, Normals::Given, Radius::Fixed(0.01));
        assert!(matches!(
            out_of_core(&[], &opts, &out),
            Err(Error::EmptyCloud)
        ));
        let mut pts = cloud(100, 3);
        pts[7].position.y = f64::NAN;
        assert!(matches!(
            out_of_core(&pts, &opts, &out),
            Err(Error::Cloud(cloud::Error::NonFinite { index: 7 }))
        ));
        // A source that fails midway (a truncated file) fails the build.
        let mut calls = 0;
        let mut source = |batch: &mut Vec<Point>| -> Result<bool> {
            calls += 1;
            if calls == 3 {
                return Err(Error::Corrupt {
                    path: "in.las".into(),
                    offset: 1234,
                    reason: "truncated".into(),
                });
            }
            batch.extend(cloud(5_000, calls));
            Ok(true)
        };
        let e = build_file(&mut source, &opts, &out, &mut |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("truncated"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
