//! `splat`: point splatting on the CPU.
//!
//! - [`visibility`]: the point-only z-buffer baseline for visibility (project, splat, keep the
//!   points within a depth tolerance of the nearest splat at their pixel).
//!
//! This crate knows points and cameras; it knows nothing of meshes, ground truth, scoring or
//! files.

pub mod error;
pub mod visibility;

pub use error::{Error, Result};
pub use visibility::{SplatParams, SplatScratch, SplatVisibility, Splatter, splat_visibility};
