//! Readers and writers for point cloud and mesh files.
//!
//! - PLY, ASCII and binary of either endianness, read through the maintained `ply-rs-bw` crate,
//!   one element at a time so that a bad header count never drives an allocation ([`ply`]);
//! - OFF, the format of the CGAL data set ([`off`]);
//! - XYZ, whitespace-separated `x y z [nx ny nz]` lines ([`xyz`]);
//! - a binary little-endian PLY writer ([`ply_write`]);
//! - views files: JSON lines of cameras ([`views`]) and COLMAP text models ([`colmap`]).
//!
//! Every reader returns a [`ReadError`](crate::ReadError) that names the file and the line
//! (text) or byte offset (binary) of the problem: empty files, truncated data (a header count
//! larger than the data), non-numeric fields, NaN or infinite coordinates, faces that index
//! missing vertices.

pub mod colmap;
pub mod off;
pub mod ply;
pub mod ply_write;
pub mod views;
pub mod xyz;

use std::io::{self, BufRead, Read};
use std::path::Path;

use crate::error::{Location, ReadError, ReadErrorKind};
use crate::mesh::TriMesh;
use crate::points::PointCloud;

/// What a file holds: points, and the triangles over them when the format has faces.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Loaded {
    /// The vertices, with whatever attributes the file gives.
    pub cloud: PointCloud,
    /// Triangles over the vertices (polygons are split into fans); empty for point formats.
    pub triangles: Vec<[u32; 3]>,
}

impl Loaded {
    /// The triangle mesh over the loaded vertices (texture coordinates carried along).
    pub fn mesh(&self) -> TriMesh {
        TriMesh {
            vertices: self.cloud.positions.clone(),
            triangles: self.triangles.clone(),
            uvs: self.cloud.uvs.clone(),
        }
    }
}

/// Reads a file, choosing the format by its extension (`ply`, `off`, `xyz`/`txt`).
pub fn read(path: &Path) -> Result<Loaded, ReadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("ply") => ply::read_ply(path),
        Some("off") => off::read_off(path),
        Some("xyz") | Some("txt") => xyz::read_xyz(path).map(|cloud| Loaded {
            cloud,
            triangles: Vec::new(),
        }),
        _ => Err(ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Unsupported(format!(
                "unknown extension {:?}: expected .ply, .off or .xyz",
                ext.unwrap_or_default()
            )),
        )),
    }
}

/// Opens a file for buffered reading, mapping failures to a [`ReadError`].
fn open(path: &Path) -> Result<io::BufReader<std::fs::File>, ReadError> {
    std::fs::File::open(path)
        .map(|f| io::BufReader::with_capacity(1 << 16, f))
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))
}

/// A `BufRead` adaptor that counts the bytes consumed, for byte offsets in binary errors.
struct CountingReader<R> {
    inner: R,
    consumed: u64,
}

impl<R> CountingReader<R> {
    fn new(inner: R) -> Self {
        Self { inner, consumed: 0 }
    }
}

impl<R: BufRead> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.consumed += n as u64;
        Ok(n)
    }
}

impl<R: BufRead> BufRead for CountingReader<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        self.consumed += amt as u64;
        self.inner.consume(amt);
    }
}

/// Parses one whitespace-separated numeric field, naming it in the error.
fn parse_f64(token: &str) -> Result<f64, ReadErrorKind> {
    token.parse::<f64>().map_err(|_| ReadErrorKind::NotANumber {
        field: token.to_owned(),
    })
}

/// Capacity to reserve for `count` announced elements: never more than a small bound, so a
/// hostile header cannot make the reader allocate before the data backs the count.
fn capacity_for(count: usize) -> usize {
    count.min(1 << 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_extension_is_an_error() {
        let err = read(Path::new("cloud.las")).unwrap_err();
        assert!(matches!(err.kind, ReadErrorKind::Unsupported(_)), "{err}");
        assert!(err.to_string().contains("cloud.las"), "{err}");
    }

    #[test]
    fn missing_file_names_the_file() {
        let err = read(Path::new("/nonexistent/dir/x.off")).unwrap_err();
        assert!(matches!(err.kind, ReadErrorKind::Io(_)), "{err}");
        assert!(err.to_string().contains("/nonexistent/dir/x.off"), "{err}");
    }
}
