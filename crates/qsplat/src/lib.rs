//! `qsplat`: QSplat, "QSplat: A Multiresolution Point Rendering System for Large Meshes"
//! (Szymon Rusinkiewicz and Marc Levoy, SIGGRAPH 2000; seed 002 §5.2).
//!
//! A bounding-sphere hierarchy over the points ([`build`]: split at the midpoint of the longest
//! axis, up to four children; parent sphere, normal, normal cone and colour from the
//! children), quantised as the original does ([`quant`]: 13-bit sphere relative to the parent,
//! 14-bit normal, 2-bit cone, RGB565, 3 tree bits) into a breadth-first node stream
//! ([`tree`]), with a compact file format ([`file`]) and the view-dependent traversal that
//! decides what to draw ([`traverse`]: frustum and back-face culling, recursion while the
//! projected size exceeds a threshold in pixels). [`ooc`] writes the same file out of core,
//! within a memory limit, for clouds larger than memory; [`paged`] selects from a built file
//! without loading it.
//!
//! Points need normals; leaves are spheres of a given radius around the points (the original
//! uses each vertex's distance to its mesh neighbours; a cloud has no mesh, so the harness
//! passes its density spacing). Quantisation rounds outwards: every decoded sphere encloses
//! every leaf sphere below it, which a property test checks.

pub mod build;
pub mod file;
pub mod ooc;
pub mod paged;
pub mod quant;
pub mod traverse;
pub mod tree;

use cloud::PointCloud;

pub use cloud::lod_file::{Error, Result};
pub use paged::PagedTree;
pub use traverse::{Splat, TraverseParams, leaves, traverse, traverse_nodes};
pub use tree::QTree;

/// Builds and quantises the QSplat tree of `cloud` (which must have normals); colours are kept
/// when the cloud has them.
pub fn build_tree(cloud: &PointCloud, leaf_radius: f64) -> Result<QTree> {
    if cloud.is_empty() {
        return Err(Error::EmptyCloud);
    }
    cloud.validate()?;
    let normals = cloud.normals.as_deref().ok_or(Error::MissingNormals)?;
    if !(leaf_radius > 0.0) || !leaf_radius.is_finite() {
        return Err(Error::InvalidParameter {
            name: "leaf_radius",
            reason: format!("must be positive, got {leaf_radius}"),
        });
    }
    let h = build::build(&build::Input {
        positions: &cloud.positions,
        normals,
        colors: cloud.colors.as_deref(),
        leaf_radius,
    });
    Ok(QTree::encode(&h, cloud.colors.is_some()))
}

#[cfg(test)]
mod tests;
