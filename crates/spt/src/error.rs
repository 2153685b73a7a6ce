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
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A file of an older format version (1: before the block checksums; 2: splats as floats).
    #[error(
        "{path}: written by an older pointsight (sequential point tree file format version \
         {version}, this reads version {current}: checksums since 2, quantised splats since 3); \
         rebuild it with `pointsight lod-build`"
    )]
    OldVersion {
        /// The file.
        path: String,
        /// Its version.
        version: u32,
        /// The version this reads.
        current: u32,
    },
    /// A block whose checksum does not match: the file was damaged after it was written.
    #[error(
        "{path}: checksum mismatch in {block} (bytes {offset}..{end}): the file is damaged; \
         rebuild it with `pointsight lod-build`"
    )]
    Checksum {
        /// The file.
        path: String,
        /// Which block ("the header", "entry block 3").
        block: String,
        /// The block's first byte.
        offset: u64,
        /// One past its last byte.
        end: u64,
    },
    /// The file is not a sequential point tree or is damaged.
    #[error("{path}: corrupt sequential point tree file at byte {offset}: {reason}")]
    Corrupt {
        /// The file.
        path: String,
        /// Byte offset of the problem.
        offset: u64,
        /// What is wrong.
        reason: String,
    },
}

/// Result alias of the `spt` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The out-of-core preparation's errors (its chunks read by [`crate::ooc::build_prepared`]) as
/// this crate's of the same meaning.
impl From<cloud::ooc::error::Error> for Error {
    fn from(e: cloud::ooc::error::Error) -> Self {
        use cloud::ooc::error::Error as E;
        match e {
            E::Cloud(e) => Error::Cloud(e),
            E::EmptyCloud => Error::EmptyCloud,
            E::MissingNormals => Error::MissingNormals,
            E::InvalidParameter { name, reason } => Error::InvalidParameter { name, reason },
            E::Io { path, source } => Error::Io { path, source },
        }
    }
}
