//! Typed errors of the registry: parameters, method lookup, and the method crates' own errors.
//!
//! The messages speak of parameter names and values only: the command line (`--set`) and the
//! Python package (keyword arguments) add their own framing. A method crate's error travels as
//! it is ([`Error::Method`], its message unchanged), so a new method needs no variant here.

/// Why a method could not be prepared or run.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// No method of that name.
    #[error("unknown method {name:?}; known methods: {known}")]
    UnknownMethod {
        /// The name asked for.
        name: String,
        /// The names there are.
        known: String,
    },
    /// A `NAME=VALUE` pair that is not one (an empty name, a name given twice).
    #[error("parameter {pair:?}: {reason}")]
    BadPair {
        /// The pair as given.
        pair: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A parameter value that does not parse or is out of range.
    #[error("parameter {key}={value}: {reason}")]
    BadValue {
        /// Key.
        key: String,
        /// Value as given.
        value: String,
        /// Why.
        reason: String,
    },
    /// Keys the method does not read.
    #[error("unknown parameter{plural} {keys} for method {method}; it accepts: {accepted}")]
    UnknownParams {
        /// "s" or "".
        plural: &'static str,
        /// The unknown keys.
        keys: String,
        /// The method.
        method: String,
        /// The keys it reads.
        accepted: String,
    },
    /// The method cannot run on this input (a missing mesh, an unsupported camera, ...).
    #[error("{0}")]
    Unsupported(String),
    /// A sweeps file (`registry::sweep`) that does not parse.
    #[error("sweeps: {0}")]
    Sweep(String),
    /// Invalid input or camera (`cloud`).
    #[error(transparent)]
    Cloud(#[from] cloud::Error),
    /// A method crate's own error (HPR, a hull, the ray cast, the ground truth...).
    #[error(transparent)]
    Method(Box<dyn std::error::Error + Send + Sync + 'static>),
}

/// Result alias of the registry.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A method crate's error, as it is.
    pub fn method(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Method(Box::new(e))
    }
}
