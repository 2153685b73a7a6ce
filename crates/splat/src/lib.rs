//! `splat`: point splatting on the CPU.
//!
//! - [`visibility`]: the point-only z-buffer baseline for visibility (project, splat, keep the
//!   points within a depth tolerance of the nearest splat at their pixel);
//! - [`splatter`]: what both rules share (the prepared cloud, its projection, parameters,
//!   buffers);
//! - [`sprite`]: its other rule, a GPU point renderer's (square sprites, one world tolerance
//!   along the view axis: VTK's `vtkSelectVisiblePoints`);
//! - [`render`]: a shaded splat renderer (discs, depth buffer, Lambert), the images of the
//!   level-of-detail methods and their reference.
//!
//! This crate knows points and cameras; it knows nothing of meshes, ground truth, scoring or
//! files.

pub mod error;
pub mod render;
pub mod splatter;
pub mod sprite;
pub mod visibility;

pub use error::{Error, Result};
pub use splatter::{Rule, SplatParams, SplatScratch, SplatVisibility, Splatter};
pub use visibility::splat_visibility;
