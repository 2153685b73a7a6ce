//! The out-of-core preparation an LOD method's out-of-core build starts from: every point of a
//! cloud larger than memory with its normal (given, or estimated as
//! [`crate::normals::estimate_normals`] estimates it) and the leaf radius (fixed, or from the
//! density spacing as [`crate::spacing::density_spacing`] measures it), the very values the
//! in-memory preparation ([`prepare_in_memory`]) gives, bit for bit, within a memory limit, with
//! scratch files on the disk beside the output ([`crate::spill`]). It knows no method: QSplat's
//! out-of-core build goes on from its chunks ([`Chunks`]), SPT's takes its points.
//!
//! Modelled on PotreeConverter 2's chunking (Schütz et al. 2020: points distributed to
//! per-chunk files, each chunk worked on in memory):
//!
//! 1. the input is streamed once into a scratch file (input order, [`record`]), with its
//!    bounding box, a strided sample and, for estimated normals, the orientation's guide
//!    (positions chosen by their hash, [`crate::orient`]: the same set in memory);
//! 2. a set of more points than a chunk holds is split ([`partition`]): the midpoint of its
//!    box's longest axis, a stable partition, two levels of splits a group of two to four
//!    sets; a set that fits a chunk is a chunk, a larger one is split again (QSplat's split,
//!    §3.1 of Rusinkiewicz & Levoy 2000, so QSplat's chunks are subtrees of its in-memory
//!    tree, each in input order); passes over the input find the splits level by level while
//!    the sets are larger than memory, then each set is written to a file of its own and split
//!    in memory, each point written to its chunk (once more on the way where its set was too
//!    large for memory at once);
//! 3. where the normals are estimated, or the leaf radius is the density spacing, each chunk's
//!    neighbourhoods are completed by a halo ([`neighbours`]) and its normals and the spacing
//!    sample's distances computed; each normal takes its sign from the guide (Hoppe's tree
//!    over it, built once between steps 2 and 3), so it is the in-memory normal, bit for bit.
//!    Given normals (each a unit vector, else an error naming the point) are kept as they are:
//!    then only the spacing sample's points are searched.
//!
//! A cloud that fits one chunk is prepared in memory instead ([`Prepared::Whole`]).
//!
//! Memory: a chunk of m points takes the method's bytes per point ([`Options::bytes_per_point`])
//! · m at its peak, [`NEIGHBOUR_BYTES_PER_POINT`] per point of a chunk and its halo during the
//! neighbour searches; scratch buffers, the sample, the orientation's guide (at most
//! [`crate::orient::GUIDE_MAX`] points and the grid its queries use, about 8 MiB, held once the split's write buffers are
//! freed) and the tree of splits need [`RESERVE`] more; building the guide takes
//! [`crate::orient::BUILD_BYTES_PER_POINT`] a guide point, within all of the limit but
//! [`GUIDE_BUILD_RESERVE`], while no chunk is loaded.
//! A chunk and its halo must fit for the neighbour searches.

mod chunks;
mod neighbours;
mod partition;
mod record;
#[cfg(test)]
mod tests;

use std::path::Path;

use glam::{DVec3, Vec3};

use self::chunks::Set;
pub use self::chunks::{Chunks, Part, PartKind, Points};
pub use self::record::{Grid, Layout, REC, Records};
use crate::lod_file::{Error, Result};
use crate::spill::Scratch;

/// Bytes of the reserve in use while the orientation's guide is built (the sample, the tree of
/// splits, the guide's points; the split's write buffers are freed by then).
pub const GUIDE_BUILD_RESERVE: u64 = 16 << 20;
/// Bytes per point of a chunk and its halo during the neighbour searches.
pub const NEIGHBOUR_BYTES_PER_POINT: u64 = 160;
/// Memory the preparation needs beside its chunk (scratch buffers, sample, tree of splits).
pub const RESERVE: u64 = 48 << 20;
/// The smallest chunk worth building (a limit that allows fewer points per chunk is refused).
pub const MIN_CHUNK: u64 = 4_096;
/// Points of the sample that bounds small chunks' neighbour distances.
const SAMPLE: usize = 1 << 15;
/// Bytes of halo records buffered before they are appended to their files (in vectors that
/// may hold twice as much).
const HALO_BUFFER: usize = 8 << 20;

/// One input point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Position.
    pub position: DVec3,
    /// Unit normal (ignored when the normals are estimated).
    pub normal: Vec3,
    /// Colour (zero when the input has none).
    pub color: [u8; 3],
}

/// Where the normals come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normals {
    /// The input's.
    Given,
    /// [`crate::normals::estimate_normals`] with `k.min(n)` neighbours, oriented by
    /// [`crate::normals::Orientation::Propagated`] (Hoppe's tree over the guide of
    /// [`crate::orient`], the same set in memory and out of core).
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
    /// `factor` × [`crate::spacing::density_spacing`]`(positions, k, sample, seed)`.
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

/// How the preparation may use memory and disk, and what it computes.
#[derive(Debug, Clone)]
pub struct Options {
    /// Peak memory the build may use, bytes.
    pub memory_limit: u64,
    /// Peak bytes per point of a chunk while the method's build works on it (at least
    /// [`NEIGHBOUR_BYTES_PER_POINT`]): with the limit, it sets the chunk size
    /// ([`chunk_capacity`]).
    pub bytes_per_point: u64,
    /// Normals.
    pub normals: Normals,
    /// Leaf radius.
    pub radius: Radius,
    /// What the scratch records keep ([`Records::default`]: any input).
    pub records: Records,
    /// Tests: scratch writes fail (as on a full disk) after this many bytes.
    pub fail_after_bytes: Option<u64>,
}

/// What the preparation did (a method's build fills in its own stages' numbers).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    /// Points.
    pub points: u64,
    /// Chunks (1 when the cloud fit at once).
    pub chunks: u64,
    /// Largest chunk, points.
    pub largest_chunk: u64,
    /// Largest halo, points.
    pub largest_halo: u64,
    /// Points per chunk the limit allows.
    pub chunk_capacity: u64,
    /// Levels of splits above the chunks.
    pub top_levels: u32,
    /// The leaf radius used.
    pub leaf_radius: f64,
    /// Bytes written to scratch files.
    pub scratch_bytes: u64,
    /// The most bytes the scratch files held at once ([`Scratch::peak_bytes`]).
    pub scratch_peak_bytes: u64,
    /// Points whose k nearest neighbours were searched, each search counted (the normals'
    /// and the spacing sample's): at least one a point where the normals are estimated, only
    /// the spacing sample's (at most twice each) where they are given.
    pub neighbour_queries: u64,
}

/// The preparation's stages, for progress reports (each with a count of points).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Reading the input.
    Read,
    /// Splitting into chunks (points placed in chunks).
    Split,
    /// Building the orientation's guide (its points; once, when the normals are estimated).
    Guide,
    /// Neighbourhoods within each chunk: normals and spacing of the points whose
    /// neighbourhood lies inside their chunk (points done).
    Neighbours,
    /// Neighbourhoods across the chunks' borders: the halos sent, then the normals and
    /// spacing of the points near a border (points done).
    Halos,
}

/// The prepared cloud.
#[derive(Debug)]
pub enum Prepared {
    /// It fit one chunk: prepared in memory ([`prepare_in_memory`]), in input order.
    Whole(Points),
    /// Its chunks on disk.
    Chunked(Chunks),
}

impl Prepared {
    /// Every point with its normal and input index, chunk by chunk (in no particular order of
    /// the input), to `sink`.
    pub fn for_each_chunk<E: From<Error>>(
        &self,
        mut sink: impl FnMut(&Points) -> Result<(), E>,
    ) -> Result<(), E> {
        match self {
            Prepared::Whole(points) => sink(points),
            Prepared::Chunked(chunks) => {
                for c in 0..chunks.len() {
                    sink(&chunks.load(c)?)?;
                }
                Ok(())
            }
        }
    }
}

/// Points per chunk under `memory_limit` at `bytes_per_point`, or the error naming why the
/// limit is too small.
pub fn chunk_capacity(memory_limit: u64, bytes_per_point: u64) -> Result<u64> {
    crate::spill::chunk_capacity(memory_limit, RESERVE, bytes_per_point, MIN_CHUNK).map_err(
        |reason| Error::InvalidParameter {
            name: "memory_limit",
            reason,
        },
    )
}

/// The normals and the leaf radius of a cloud in memory by the rules of `opts`: the given
/// normals or [`crate::normals::estimate_normals`], the fixed radius or the density spacing's.
pub fn prepare_in_memory(
    positions: &[DVec3],
    normals: Option<Vec<Vec3>>,
    opts: &Options,
) -> Result<(Vec<Vec3>, f64)> {
    if positions.is_empty() {
        return Err(Error::EmptyCloud);
    }
    crate::points::check_finite(positions)?;
    let normals = match opts.normals {
        Normals::Given => {
            let normals = normals.ok_or(Error::MissingNormals)?;
            if normals.len() != positions.len() {
                return Err(Error::Cloud(crate::Error::AttributeLength {
                    name: "normals",
                    expected: positions.len(),
                    found: normals.len(),
                }));
            }
            if let Some((i, n)) = crate::normals::first_bad_normal(&normals) {
                return Err(bad_given_normal(i as u64, n));
            }
            normals
        }
        Normals::Estimate { k } => crate::normals::estimate_normals(
            positions,
            k.min(positions.len()),
            crate::normals::Orientation::Propagated,
        )?,
    };
    let radius = match opts.radius {
        Radius::Fixed(r) => r,
        Radius::DensitySpacing {
            k,
            sample,
            seed,
            factor,
        } => factor * crate::spacing::density_spacing(positions, k, sample, seed)?,
    };
    Ok((normals, radius))
}

/// The error of a given normal that is not a unit vector ([`crate::normals::is_given_normal`]).
fn bad_given_normal(index: u64, n: Vec3) -> Error {
    Error::InvalidParameter {
        name: "normals",
        reason: format!(
            "point {index} has the normal {n} of length {}: a given normal must be finite and of \
             length 1 (within {})",
            n.length(),
            crate::normals::GIVEN_LENGTH_TOLERANCE
        ),
    }
}

/// Neighbour searches of [`prepare_in_memory`] for `n` points by `opts`: one a point for
/// estimated normals, and the spacing sample's.
pub fn in_memory_queries(n: u64, opts: &Options) -> u64 {
    let normals = match opts.normals {
        Normals::Estimate { .. } => n,
        Normals::Given => 0,
    };
    let spacing = match opts.radius {
        Radius::DensitySpacing { sample, .. } => n.min(sample as u64),
        Radius::Fixed(_) => 0,
    };
    normals + spacing
}

/// The error of a cloud of `n` points, more than the trees' 32-bit leaf counts (and the scratch
/// records' 32-bit indices) hold.
fn too_many(n: u64) -> Error {
    Error::InvalidParameter {
        name: "points",
        reason: format!("{n} points or more; the tree counts leaves in 32 bits"),
    }
}

/// The state of a preparation: the chunks made so far and the progress report.
struct Preparer<'a> {
    store: Chunks,
    cap: u64,
    opts: &'a Options,
    done: u64,
    /// Neighbour searches made ([`Summary::neighbour_queries`]).
    queries: u64,
    progress: &'a mut dyn FnMut(Stage, u64),
}

/// Prepares the points `source` yields (batches into the vector it is given, `Ok(false)` at
/// the end; its errors pass through unchanged): steps 1 to 3 of the module doc, with scratch
/// files in a folder beside `out` (removed when the result is dropped, also after an error).
/// `progress` hears each stage's count. Returns the prepared cloud and its summary.
pub fn prepare<E: From<Error>>(
    source: &mut dyn FnMut(&mut Vec<Point>) -> Result<bool, E>,
    opts: &Options,
    out: &Path,
    progress: &mut dyn FnMut(Stage, u64),
) -> Result<(Prepared, Summary), E> {
    if let Radius::Fixed(r) = opts.radius
        && (!(r > 0.0) || !r.is_finite())
    {
        return Err(Error::InvalidParameter {
            name: "leaf_radius",
            reason: format!("must be positive, got {r}"),
        }
        .into());
    }
    let cap = chunk_capacity(opts.memory_limit, opts.bytes_per_point)?;
    let mut scratch = Scratch::beside(out).map_err(|source| Error::Io {
        path: out.display().to_string(),
        source,
    })?;
    if let Some(b) = opts.fail_after_bytes {
        scratch = scratch.fail_after(b);
    }
    let mut b = Preparer {
        store: Chunks {
            scratch,
            out: out.to_path_buf(),
            parts: Vec::new(),
            root: 0,
            chunks: Vec::new(),
            // Estimated normals go to files of their own.
            layout: Layout::new(opts.records, opts.normals == Normals::Given),
        },
        cap,
        opts,
        done: 0,
        queries: 0,
        progress,
    };
    // 1. The input, in order, to scratch files of `partition::SEGMENT` records each.
    let mut segments = Vec::new();
    let mut w = b.store.create()?;
    let mut batch = Vec::new();
    let mut bbox = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut sample: Vec<(DVec3, u64)> = Vec::new();
    let mut stride = 1u64;
    // The orientation's guide: a set of positions, found in this pass.
    let mut guide = matches!(opts.normals, Normals::Estimate { .. })
        .then(|| crate::orient::GuideSampler::new(crate::orient::guide_max()));
    let mut rec = [0u8; REC];
    let mut n: u64 = 0;
    loop {
        batch.clear();
        let more = source(&mut batch)?;
        for p in &batch {
            if !p.position.is_finite() {
                return Err(Error::Cloud(crate::Error::NonFinite { index: n as usize }).into());
            }
            if opts.normals == Normals::Given && !crate::normals::is_given_normal(p.normal) {
                return Err(bad_given_normal(n, p.normal).into());
            }
            bbox = (bbox.0.min(p.position), bbox.1.max(p.position));
            if let Some(g) = guide.as_mut() {
                g.push(p.position);
            }
            if n.is_multiple_of(stride) {
                sample.push((p.position, n));
                if sample.len() >= 2 * SAMPLE {
                    stride *= 2;
                    sample.retain(|s| s.1.is_multiple_of(stride));
                }
            }
            // The records hold 32-bit indices (and the trees count leaves in 32 bits).
            let Ok(index) = u32::try_from(n) else {
                return Err(too_many(n + 1).into());
            };
            b.store.layout.pack(p, index, &mut rec)?;
            if w.len() == partition::SEGMENT {
                let full = std::mem::replace(&mut w, b.store.create()?);
                segments.push(full.finish().map_err(|e| b.store.io(e))?);
            }
            b.store.push(&mut w, &rec)?;
            n += 1;
        }
        (b.progress)(Stage::Read, n);
        if !more {
            break;
        }
    }
    // The read buffer goes before the chunks come.
    drop(batch);
    if n == 0 {
        return Err(Error::EmptyCloud.into());
    }
    // Estimated normals and the density spacing need a surface (as `prepare_in_memory`'s).
    if (matches!(opts.normals, Normals::Estimate { .. })
        || matches!(opts.radius, Radius::DensitySpacing { .. }))
        && (n < 3 || bbox.0 == bbox.1)
    {
        return Err(Error::Cloud(crate::normals::no_surface(n, bbox.0)).into());
    }
    segments.push(w.finish().map_err(|e| b.store.io(e))?);
    let mut summary = Summary {
        points: n,
        chunk_capacity: cap,
        ..Summary::default()
    };
    if n <= cap {
        // It fits: the in-memory preparation (its normals and spacing timed as such).
        (b.progress)(Stage::Neighbours, 0);
        let mut whole = Points {
            positions: Vec::with_capacity(n as usize),
            normals: Vec::with_capacity(n as usize),
            colors: Vec::with_capacity(n as usize),
            index: Vec::with_capacity(n as usize),
        };
        for seg in segments {
            let part = b.store.load_set(&Set::whole(seg))?;
            whole.positions.extend(part.positions);
            whole.normals.extend(part.normals);
            whole.colors.extend(part.colors);
            whole.index.extend(part.index);
        }
        let (normals, radius) = prepare_in_memory(
            &whole.positions,
            Some(std::mem::take(&mut whole.normals)),
            opts,
        )?;
        whole.normals = normals;
        summary.chunks = 1;
        summary.largest_chunk = n;
        summary.leaf_radius = radius;
        summary.neighbour_queries = in_memory_queries(n, opts);
        summary.scratch_bytes = b.store.scratch.bytes_written();
        summary.scratch_peak_bytes = b.store.scratch.peak_bytes();
        return Ok((Prepared::Whole(whole), summary));
    }
    // 2. Split down to chunks.
    let (root, levels) = b.partition(segments, n, bbox)?;
    // The guide's normals and tree, built while no chunk is in memory and the split's write
    // buffers are freed (all of the limit but [`GUIDE_BUILD_RESERVE`] holds it); the guide
    // itself then stays within the reserve.
    let guide = match (guide, opts.normals) {
        (Some(g), Normals::Estimate { k }) => {
            (b.progress)(Stage::Guide, g.len() as u64);
            let need = g.len() as u64 * crate::orient::BUILD_BYTES_PER_POINT;
            if need > opts.memory_limit.saturating_sub(GUIDE_BUILD_RESERVE) {
                return Err(Error::InvalidParameter {
                    name: "memory_limit",
                    reason: format!(
                        "the normals' orientation guide of {} points needs {} to build, more \
                         than the limit leaves beside the {} in use then; raise the limit to {} \
                         or more",
                        g.len(),
                        crate::memory::human(u128::from(need)),
                        crate::memory::human(u128::from(GUIDE_BUILD_RESERVE)),
                        crate::memory::human(u128::from(need + GUIDE_BUILD_RESERVE))
                    ),
                }
                .into());
            }
            Some(crate::orient::Guide::new(g.finish(), k.min(n as usize)).map_err(Error::Cloud)?)
        }
        _ => None,
    };
    b.store.root = root;
    summary.top_levels = levels;
    // 3. Neighbourhoods.
    let mut spacing_d = Vec::new();
    let picks = match opts.radius {
        Radius::DensitySpacing {
            k, sample, seed, ..
        } => {
            if n as usize <= k {
                return Err(Error::Cloud(crate::Error::InvalidParameter {
                    name: "k",
                    reason: format!("need 0 < k < {n} points, got {k}"),
                })
                .into());
            }
            let mut p: Vec<u64> = crate::spacing::sample_picks(
                n as usize,
                sample,
                seed,
                crate::spacing::DENSITY_PURPOSE,
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
            guide.as_ref(),
            picks.as_ref(),
            &mut spacing_d,
        )?;
    }
    let leaf_radius = match opts.radius {
        Radius::Fixed(r) => r,
        Radius::DensitySpacing { k, factor, .. } => {
            let median =
                crate::spacing::median_of(&mut spacing_d).ok_or(Error::InvalidParameter {
                    name: "sample",
                    reason: "no point to measure".into(),
                })?;
            crate::spacing::check_median(median, k, spacing_d.len()).map_err(Error::Cloud)?;
            factor * crate::spacing::density_from_kth(median, k)
        }
    };
    if !(leaf_radius > 0.0) || !leaf_radius.is_finite() {
        return Err(Error::InvalidParameter {
            name: "leaf_radius",
            reason: format!("must be positive, got {leaf_radius}"),
        }
        .into());
    }
    summary.leaf_radius = leaf_radius;
    summary.chunks = b.store.chunks.len() as u64;
    summary.largest_chunk = b.store.chunks.iter().map(|c| c.count).max().unwrap_or(0);
    summary.scratch_bytes = b.store.scratch.bytes_written();
    summary.scratch_peak_bytes = b.store.scratch.peak_bytes();
    summary.neighbour_queries = b.queries;
    Ok((Prepared::Chunked(b.store), summary))
}
