//! Typed errors of the `raycast` crate.

/// Why a cast could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// No points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// A non-finite coordinate.
    #[error("point {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// A parameter out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The image would not fit in memory (`cloud::memory`).
    #[error("{0}")]
    OutOfMemory(String),
    /// The camera does not match the ray list.
    #[error("the ray list is for {list} but the camera is {camera}")]
    CameraMismatch {
        /// The list's image and model.
        list: String,
        /// The camera's.
        camera: String,
    },
}

/// Result alias of the `raycast` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
