//! Typed errors of the out-of-core preparation ([`super::prepare`]): a method's crate maps each
//! variant to its own of the same meaning.

/// Why the preparation failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input caught by the rest of this crate (a non-finite point, a bad `k`).
    #[error(transparent)]
    Cloud(#[from] crate::Error),
    /// No points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// [`super::Normals::Given`] for a cloud without normals.
    #[error("the points have no normals to take")]
    MissingNormals,
    /// A parameter (or what the input makes of one) is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// A scratch file (or the output beside it) could not be written or read.
    #[error("{path}: {source}")]
    Io {
        /// The file, and the scratch folder.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// Result alias of the preparation.
pub type Result<T, E = Error> = std::result::Result<T, E>;
