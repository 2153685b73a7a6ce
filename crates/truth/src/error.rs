//! Typed errors of the `truth` crate.

/// Why a ground truth could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles: a ground truth needs the surface")]
    EmptyMesh,
    /// Invalid input from the `cloud` crate's checks (non-finite points, bad camera, ...).
    #[error(transparent)]
    Cloud(#[from] cloud::Error),
    /// A parameter is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The acceleration structure could not be built.
    #[error("cannot build the triangle BVH: {0}")]
    Bvh(String),
}

/// Result alias of the `truth` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
