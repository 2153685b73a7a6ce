//! Typed errors of the `spt` crate.

/// Why a sequential point tree could not be built or used.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input caught by the `cloud` crate.
    #[error(transparent)]
    Cloud(#[from] cloud::Error),
    /// No points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// The cloud has no normals, which the error metrics need.
    #[error("sequential point trees need a normal per point")]
    MissingNormals,
    /// A parameter is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of the `spt` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
