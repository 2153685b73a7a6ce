//! Typed errors of the `neuralvis` crate: a weights file that cannot be used says which file
//! and why (missing, truncated, foreign, another format version, corrupt, inconsistent), never
//! a panic and never a silent fallback to other weights.

use std::path::PathBuf;

/// Why a weights file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum WeightsError {
    /// The file does not exist or cannot be read.
    #[error("cannot read the weights file {path}: {reason}")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The system's reason.
        reason: String,
    },
    /// Not a weights file of this method (its first bytes are not the magic number).
    #[error("{path} is not a neuralvis weights file (it does not start with the magic bytes)")]
    Foreign {
        /// The file.
        path: PathBuf,
    },
    /// A format version this build does not read.
    #[error("{path} has weights format version {found}; this build reads version {supported}")]
    Version {
        /// The file.
        path: PathBuf,
        /// Its version.
        found: u32,
        /// The one read here.
        supported: u32,
    },
    /// Shorter than its header says.
    #[error("{path} is truncated: {expected} bytes expected, {found} present")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Bytes the header announces.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// The SHA-256 at its end does not match its content.
    #[error("{path} is corrupt: its checksum does not match its content")]
    Checksum {
        /// The file.
        path: PathBuf,
    },
    /// Readable but not a network this build can run (a missing tensor, a wrong shape, a
    /// configuration outside what is implemented).
    #[error("{path} cannot be used: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Why the method could not run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The weights.
    #[error(transparent)]
    Weights(#[from] WeightsError),
    /// Invalid input caught by the `cloud` crate (non-finite points).
    #[error(transparent)]
    Cloud(#[from] cloud::Error),
    /// An empty cloud or another input the network cannot take.
    #[error("invalid input: {0}")]
    Input(String),
    /// A parameter out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Its name.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of the `neuralvis` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
