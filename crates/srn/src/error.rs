//! Typed errors of the `srn` crate.

/// Why a texture, an importance map or a simplification could not be made.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An image with no pixels or with a pixel buffer of the wrong length.
    #[error("invalid image {width}x{height} with {len} samples")]
    InvalidImage {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// Samples found.
        len: usize,
    },
    /// The points carry no texture coordinates.
    #[error("SRN needs texture coordinates for every point")]
    MissingUvs,
    /// A texture coordinate is NaN or infinite.
    #[error("texture coordinate {index} is not finite: ({u}, {v})")]
    NonFiniteUv {
        /// Point index.
        index: usize,
        /// u.
        u: f32,
        /// v.
        v: f32,
    },
    /// A parameter is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of the `srn` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
