//! Typed errors of the `screenspace` crate: bad parameters, absurd image sizes (refused before
//! anything is allocated), degenerate clouds and views.

/// Why a screen-space operator could not run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input caught by the `cloud` crate (non-finite points, an empty cloud).
    #[error(transparent)]
    Cloud(#[from] cloud::Error),
    /// A parameter is out of range (zero, negative, NaN, too large).
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The image would be larger than [`crate::depth::MAX_PIXELS`].
    #[error("a {width} x {height} image has more than {max} pixels; refused before allocating")]
    ImageTooLarge {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
        /// The limit.
        max: u64,
    },
    /// No point of the cloud projects into the image (all behind the camera or outside the
    /// frustum): there is nothing to decide.
    #[error(
        "no point of the {points}-point cloud projects into the {model} image (all behind the camera or outside the view)"
    )]
    NothingInView {
        /// Points in the cloud.
        points: usize,
        /// The camera model.
        model: &'static str,
    },
}

/// Result alias of the `screenspace` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
