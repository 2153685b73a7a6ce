//! Typed errors of the `cloud` crate.
//!
//! Two families: [`ReadError`] for everything a file reader can meet (it always names the file
//! and, where one exists, the line or byte offset), and [`Error`] for invalid in-memory input
//! (empty or non-finite clouds, degenerate cameras, out-of-range parameters).

use std::fmt;
use std::io;
use std::path::PathBuf;

/// Where in a file a problem was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line number (text formats).
    Line(usize),
    /// A 0-based byte offset (binary formats).
    Byte(u64),
    /// The file as a whole (for example: it is empty).
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(line) => write!(f, "line {line}"),
            Location::Byte(offset) => write!(f, "byte {offset}"),
            Location::File => f.write_str("file"),
        }
    }
}

/// What went wrong while reading a cloud or mesh file.
#[derive(Debug, thiserror::Error)]
pub enum ReadErrorKind {
    /// The operating system could not read the file.
    #[error("i/o error: {0}")]
    Io(#[from] io::Error),
    /// The file holds no bytes, or no data at all.
    #[error("the file is empty")]
    Empty,
    /// The header is not of the expected form.
    #[error("bad header: {0}")]
    BadHeader(String),
    /// The header announces more elements than the file holds.
    #[error("truncated: the header announces {expected} {what} but the data ends after {found}")]
    Truncated {
        /// Which element ("vertices", "faces", ...).
        what: &'static str,
        /// The count the header announced.
        expected: usize,
        /// How many complete elements were found.
        found: usize,
    },
    /// A field that must be a number is not one.
    #[error("not a number: {field:?}")]
    NotANumber {
        /// The offending text.
        field: String,
    },
    /// A line or record holds the wrong number of fields.
    #[error("expected {expected} fields, found {found}")]
    FieldCount {
        /// Fields required.
        expected: usize,
        /// Fields present.
        found: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {index} has a non-finite coordinate ({value})")]
    NonFinite {
        /// 0-based index of the vertex.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A normal the file gives is not a unit vector (NaN, infinite, zero or not normalised:
    /// `normals::is_given_normal`).
    #[error(
        "point {index} has the normal ({}, {}, {}) of length {}: a normal a file gives must be \
         finite and of length 1 (within {})",
        normal[0],
        normal[1],
        normal[2],
        glam::Vec3::from_array(*normal).length(),
        tolerance
    )]
    BadNormal {
        /// 0-based index of the point.
        index: usize,
        /// The normal.
        normal: [f32; 3],
        /// How far from 1 its length may be (`normals::GIVEN_LENGTH_TOLERANCE`).
        tolerance: f32,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {vertex} but there are only {n_vertices} vertices")]
    FaceIndexOutOfRange {
        /// 0-based index of the face.
        face: usize,
        /// The index the face holds.
        vertex: i64,
        /// The number of vertices in the file.
        n_vertices: usize,
    },
    /// A face with fewer than three corners.
    #[error("face {face} has {corners} corners; at least 3 are needed")]
    DegenerateFace {
        /// 0-based index of the face.
        face: usize,
        /// Its corner count.
        corners: usize,
    },
    /// A camera that cannot be built (views files, COLMAP).
    #[error("bad camera: {0}")]
    Camera(String),
    /// A feature of the format this reader does not support.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// The payload does not follow the header (PLY parser message).
    #[error("malformed payload: {0}")]
    Malformed(String),
    /// A text file's columns cannot be told apart, or a column holds what its name forbids
    /// (XYZ: `io::xyz`'s rule).
    #[error("{0}")]
    Columns(String),
}

/// An error from a file reader: the file, where in it, and what.
#[derive(Debug, thiserror::Error)]
#[error("{}: {location}: {kind}", path.display())]
pub struct ReadError {
    /// The file being read.
    pub path: PathBuf,
    /// Where in the file.
    pub location: Location,
    /// What went wrong (part of the message, so not also a `source`: chained printing such as
    /// `{:#}` would say it twice).
    pub kind: ReadErrorKind,
}

impl ReadError {
    /// Builds an error for `path` at `location`.
    pub fn new(path: impl Into<PathBuf>, location: Location, kind: ReadErrorKind) -> Self {
        Self {
            path: path.into(),
            location,
            kind,
        }
    }
}

/// Invalid in-memory input to a `cloud` operation.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading a file failed.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// Writing a file failed.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The file being written.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The cloud has no points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// The cloud cannot describe a surface (normals, spacing): fewer than 3 points, or all at
    /// one position.
    #[error("the point cloud has no surface: {reason}")]
    NoSurface {
        /// Why.
        reason: String,
    },
    /// The mesh has no triangles (or all of them have zero area).
    #[error("the mesh has no triangle of non-zero area")]
    EmptyMesh,
    /// A point has a NaN or infinite coordinate.
    #[error("point {index} has a non-finite coordinate")]
    NonFinite {
        /// 0-based index of the point.
        index: usize,
    },
    /// An attribute array does not have one entry per point.
    #[error("attribute {name} has {found} entries for {expected} points")]
    AttributeLength {
        /// Attribute name.
        name: &'static str,
        /// Points in the cloud.
        expected: usize,
        /// Entries in the attribute.
        found: usize,
    },
    /// The camera cannot be built from these parameters.
    #[error("degenerate camera: {0}")]
    DegenerateCamera(String),
    /// A method does not support the camera's projection model.
    #[error("{method} does not support {model} cameras (it supports: {supported})")]
    UnsupportedCamera {
        /// The method.
        method: String,
        /// The camera's model.
        model: &'static str,
        /// The models it supports.
        supported: String,
    },
    /// An allocation sized by user input would not fit in memory.
    #[error(
        "{what} needs about {needed} of memory but {available} is available: refused before allocating"
    )]
    OutOfMemory {
        /// What would be allocated.
        what: String,
        /// The estimate.
        needed: String,
        /// What the system has.
        available: String,
    },
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
}

/// Result alias of the `cloud` crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
