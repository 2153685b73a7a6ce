//! `screenspace`: point visibility decided in the image, from a depth buffer of the points
//! alone (no normals, no surface, no density assumption), on the CPU, for every camera model
//! of `cloud::Camera` (pinhole, orthographic, spherical equirectangular).
//!
//! - [`pintus`]: Pintus, Gobbetti, Agus (VAST 2011): the open solid angle a pixel's
//!   neighbours leave towards the viewer, over a multi-level pyramid.
//! - [`vardensity`] (the method `vardensity`): Biasutti, Bugeau, Aujol, Brédif (VISAPP 2019): a depth-relative score over
//!   a screen-space k-nearest neighbourhood that grows where the projection is sparse.
//!
//! Shared: [`depth`] (the per-model depth buffer and the direction towards the viewer),
//! [`pyramid`] (the nearest-point image pyramid), [`select`] (per-pixel verdicts to points).
//! Each method module's doc names its sources, its rule and every deviation; in particular
//! neither paper's full text could be read here, which both docs state.
//!
//! Depends on `cloud` only; knows nothing of meshes, ground truth or scoring.

pub mod depth;
pub mod error;
pub mod pintus;
pub mod pyramid;
pub mod select;
#[cfg(test)]
mod testutil;
pub mod vardensity;

pub use error::{Error, Result};
pub use pintus::PintusParams;
pub use select::Verdict;
pub use vardensity::VardensityParams;
