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
//! 1. to 3. `cloud::ooc::prepare`: the input streamed to scratch; split as [`crate::build`]
//!    splits (the midpoint of a set's box's longest axis, two levels of splits a group of two
//!    to four, as [`crate::build`]'s `groups`) down to chunks, each point written to its chunk
//!    (first to a subset's file where its set is larger than memory), in input order: the
//!    order the in-memory build's stable partition gives every set;
//!    normals and the leaf radius with halos, the in-memory ones bit for bit;
//! 4. each chunk's root is computed in memory (the same splits and parents as the build, the
//!    nodes below the root counted, not stored), and the parents above the chunks are made
//!    from the roots ([`encode`]);
//! 5. encoding is top-down, so each chunk is rebuilt once its parent's decoded sphere is known,
//!    quantised and its sibling groups written level by level to a scratch file ([`encode`]);
//! 6. the file is assembled breadth first through `cloud::io::atomic` (whole or not at all)
//!    ([`assemble`]).
//!
//! Deviations: none in the output. Each chunk is split twice (once for its root, once to
//! encode it), which costs time but no memory or disk; the first time stores no nodes.
//!
//! Memory: a chunk of m points needs about [`BYTES_PER_POINT`] · m bytes at its peak (the
//! hierarchy's nodes twice during the parallel build, then the encoder's arrays); scratch
//! buffers, the sample and the top tree need `cloud::ooc::RESERVE` more. The limit sets the
//! chunk size; a chunk and its halo must fit in it for the neighbour searches.

mod assemble;
mod encode;
#[cfg(test)]
mod tests;

use std::path::Path;

use cloud::glam::{DVec3, Vec3};
use cloud::ooc::{Normals, Point, Prepared, Radius, Summary};

use self::encode::Builder;
use crate::Result;
use crate::tree::{self, QTree};

/// Peak bytes of the in-memory build and encoding per point of a chunk.
pub const BYTES_PER_POINT: u64 = 640;

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
    /// The grid the input's positions lie on, where it declares one (LAS, LAZ): the scratch
    /// records keep integers (`cloud::ooc::Records`).
    pub grid: Option<cloud::ooc::Grid>,
    /// Tests: scratch writes fail (as on a full disk) after this many bytes.
    pub fail_after_bytes: Option<u64>,
}

impl Options {
    /// The preparation's options: these, with QSplat's chunks of [`BYTES_PER_POINT`].
    pub fn prepare(&self) -> cloud::ooc::Options {
        cloud::ooc::Options {
            memory_limit: self.memory_limit,
            bytes_per_point: BYTES_PER_POINT,
            normals: self.normals,
            radius: self.radius,
            // Colours the build drops need no place on the disk either.
            records: cloud::ooc::Records {
                grid: self.grid,
                colors: self.colors,
            },
            fail_after_bytes: self.fail_after_bytes,
        }
    }
}

/// The build's stages, for progress reports (each with a count of points, or levels for
/// [`Stage::Write`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// The preparation's (reading, splitting into chunks, normals and spacing).
    Prepare(cloud::ooc::Stage),
    /// Building the chunks' roots.
    Build,
    /// Encoding the chunks.
    Encode,
    /// Writing the file (levels).
    Write,
}

/// Points per chunk under `memory_limit`, or the error naming why the limit is too small.
pub fn chunk_capacity(memory_limit: u64) -> Result<u64> {
    cloud::ooc::chunk_capacity(memory_limit, BYTES_PER_POINT)
}

/// The in-memory build the out-of-core one equals: normals and leaf radius by the rules of
/// `opts` (`cloud::ooc::prepare_in_memory`), then [`crate::build_tree`]; returns the tree and
/// the leaf radius.
pub fn in_memory(
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    colors: Option<Vec<[u8; 3]>>,
    opts: &Options,
) -> Result<(QTree, f64)> {
    let (normals, radius) = cloud::ooc::prepare_in_memory(&positions, normals, &opts.prepare())?;
    let cloud = cloud::PointCloud {
        positions,
        normals: Some(normals),
        colors: if opts.colors { colors } else { None },
        ..cloud::PointCloud::default()
    };
    Ok((crate::build_tree(&cloud, radius)?, radius))
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
    let (prepared, mut summary) =
        cloud::ooc::prepare(source, &opts.prepare(), out, &mut |stage, count| {
            progress(Stage::Prepare(stage), count)
        })?;
    let chunks = match prepared {
        Prepared::Whole(whole) => {
            // It fit: the in-memory build.
            progress(Stage::Encode, 0);
            let cloud = cloud::PointCloud {
                positions: whole.positions,
                normals: Some(whole.normals),
                colors: opts.colors.then_some(whole.colors),
                ..cloud::PointCloud::default()
            };
            let tree = crate::build_tree(&cloud, summary.leaf_radius)?;
            crate::file::write(&tree, out)?;
            return Ok(summary);
        }
        Prepared::Chunked(chunks) => chunks,
    };
    let root = chunks.root();
    let mut b = Builder::new(chunks, opts, summary.leaf_radius, progress);
    // 4. The chunks' roots and the top tree above them (children come before parents).
    b.build_top()?;
    // 5. Encode top-down.
    let root_node = b.nodes[root].clone();
    let root_decoded = (root_node.center, root_node.radius);
    let root_word = tree::word_for(&root_node, 0, b.grand(root)).pack();
    b.done = 0;
    b.encode(root, root_decoded)?;
    // 6. Assemble.
    b.assemble(root, root_word, out)?;
    summary.scratch_bytes = b.chunks.scratch().bytes_written();
    summary.scratch_peak_bytes = b.chunks.scratch().peak_bytes();
    Ok(summary)
}
