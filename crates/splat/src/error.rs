//! Typed errors of the `splat` crate.

/// Why splatting could not run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input caught by the `cloud` crate (non-finite points, bad camera).
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
}

/// Result alias of the `splat` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
