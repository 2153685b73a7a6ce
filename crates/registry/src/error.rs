//! Typed errors of the registry: parameters, method lookup, and the method crates' own errors.
//!
//! The messages speak of parameter names and values only: the command line (`--set`) and the
//! Python package (keyword arguments) add their own framing.

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
    /// HPR.
    #[error(transparent)]
    Hpr(#[from] hpr::HprError),
    /// The robust operator (Mehra et al. 2010).
    #[error(transparent)]
    Robust(#[from] robustvis::RobustError),
    /// A hull implementation.
    #[error(transparent)]
    Hull(#[from] hull::HullError),
    /// The ray cast.
    #[error(transparent)]
    Raycast(#[from] raycast::Error),
    /// The splat baseline.
    #[error(transparent)]
    Splat(#[from] splat::Error),
    /// The screen-space operators.
    #[error(transparent)]
    Screenspace(#[from] screenspace::Error),
    /// The ground truth.
    #[error(transparent)]
    Truth(#[from] truth::Error),
}

/// Result alias of the registry.
pub type Result<T, E = Error> = std::result::Result<T, E>;
