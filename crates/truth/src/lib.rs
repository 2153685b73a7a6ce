//! `truth`: ground-truth visibility computed from the mesh a dataset was sampled from.
//!
//! - [`raster`]: a tile-parallel depth-buffer rasteriser (depth and nearest triangle per pixel);
//! - [`reference`]: the reference visibility every method is scored against (the mesh's depth
//!   buffer at ≥ 2048 pixels on the long side, each point tested against the plane of the
//!   triangle nearest at its pixel);
//! - [`exact`]: the exact segment–triangle test over a BVH that validates the reference;
//! - [`scan`]: simulated scanner captures of the mesh (first hits of a spherical grid of rays
//!   over the same BVH, range noise, several scanners merged).
//!
//! This crate knows the mesh and the camera; it knows nothing of any visibility method, of
//! scoring, files or plots.

pub mod error;
pub mod exact;
pub mod raster;
pub mod reference;
pub mod scan;

pub use error::{Error, Result};
pub use exact::ExactVisibility;
pub use raster::{DepthBuffer, NO_TRIANGLE, rasterize};
pub use reference::{Reference, ReferenceParams, ReferenceView, reference_visibility};
