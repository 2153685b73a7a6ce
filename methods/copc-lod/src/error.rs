//! The program's errors: each names the file or the argument it is about.

use std::path::{Path, PathBuf};

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The points file is not the protocol's PLY.
    #[error("{path}: not the protocol's points PLY: {what}")]
    Ply {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// A COPC file that is not one, or is damaged.
    #[error("{path}: damaged or not a COPC file: {what}")]
    Copc {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// copc_converter failed or could not be started.
    #[error("copc_converter: {0}")]
    Converter(String),
    /// A bad command-line argument or request.
    #[error("{0}")]
    Usage(String),
    /// The LAS writer refused the input it was given.
    #[error("{path}: writing the converter's input: {source}")]
    Las {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: las::Error,
    },
}

/// The program's result.
pub type Result<T> = std::result::Result<T, Error>;

/// An I/O error on `path`.
pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_owned(),
        source,
    }
}

/// A damaged COPC file `path`.
pub fn copc(path: &Path, what: impl Into<String>) -> Error {
    Error::Copc {
        path: path.to_owned(),
        what: what.into(),
    }
}
