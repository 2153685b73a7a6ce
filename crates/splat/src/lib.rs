//! `splat`: point splatting on the CPU.
//!
//! - [`visibility`]: the point-only z-buffer baseline for visibility (project, splat, keep the
//!   points within a depth tolerance of the nearest splat at their pixel);
//! - [`sprite`]: its other rule, a GPU point renderer's (square sprites, one world tolerance
//!   along the view axis: VTK's `vtkSelectVisiblePoints`);
//! - [`render`]: a shaded splat renderer (discs, depth buffer, Lambert), the images of the
//!   level-of-detail methods and their reference.
//!
//! This crate knows points and cameras; it knows nothing of meshes, ground truth, scoring or
//! files.

pub mod error;
pub mod render;
pub mod sprite;
pub mod visibility;

pub use error::{Error, Result};
pub use visibility::{
    Rule, SplatParams, SplatScratch, SplatVisibility, Splatter, splat_visibility,
};
