//! Readers and writers for point cloud and mesh files.
//!
//! - PLY, ASCII and binary of either endianness, read through the maintained `ply-rs-bw` crate,
//!   one element at a time so that a bad header count never drives an allocation ([`ply`]);
//! - OFF, the format of the CGAL data set ([`off`]); OBJ, vertices and faces ([`obj`]);
//! - XYZ, lines of numbers whose columns a header, the caller or a documented rule names
//!   ([`xyz`]: `x y z`, normals, colours);
//! - with the cargo feature `formats` (on for the harness, off for the method crates): LAS and
//!   LAZ (`las`, reader and writer; `las_extra`, the extra bytes that carry normals), E57
//!   (`e57`, every scan with its pose) and PCD (`pcd`, ascii, binary and binary_compressed);
//! - a binary little-endian PLY writer ([`ply_write`]); every writer goes through [`atomic`]
//!   (whole file or none);
//! - block checksums (CRC-32) for the built LOD files ([`checksum`]);
//! - views files: JSON lines of cameras ([`views`]) and COLMAP text models ([`colmap`]).
//!
//! Every reader returns a [`ReadError`](crate::ReadError) that names the file and the line
//! (text) or byte offset (binary) of the problem: empty files, truncated data (a header count
//! larger than the data), non-numeric fields, NaN or infinite coordinates, faces that index
//! missing vertices, normals that are not unit vectors (a file's normals are used as given:
//! each must be finite and of length 1 within `normals::GIVEN_LENGTH_TOLERANCE`, whatever
//! the format).

pub mod atomic;
pub mod checksum;
pub mod colmap;
#[cfg(feature = "formats")]
pub mod e57;
#[cfg(feature = "formats")]
pub mod las;
#[cfg(feature = "formats")]
pub mod las_extra;
#[cfg(feature = "formats")]
mod las_header;
pub mod obj;
pub mod off;
#[cfg(feature = "formats")]
pub mod pcd;
pub mod ply;
pub mod ply_write;
pub mod views;
pub mod xyz;

use std::io::{self, BufRead, Read};
use std::path::Path;

use glam::{DQuat, DVec3};

use crate::camera::{Camera, Model};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::mesh::TriMesh;
use crate::points::PointCloud;

/// A scanner's pose: where a scan was taken from (E57). Its frame's x axis is the azimuth
/// origin and its z axis the vertical, as E57 defines spherical coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scanner {
    /// Scanner position, world coordinates.
    pub position: DVec3,
    /// Rotation from the scanner's frame to the world frame.
    pub rotation: DQuat,
}

impl Scanner {
    /// A spherical (equirectangular) camera at the scanner, looking along its x axis with its z
    /// axis up.
    pub fn camera(&self, width: u32, height: u32) -> crate::Result<Camera> {
        let forward = self.rotation * DVec3::X;
        Camera::look_at(
            self.position,
            self.position + forward,
            self.rotation * DVec3::Z,
            Model::Spherical,
            width,
            height,
        )
    }
}

/// What a file holds: points, and the triangles over them when the format has faces.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Loaded {
    /// The vertices, with whatever attributes the file gives.
    pub cloud: PointCloud,
    /// Triangles over the vertices (polygons are split into fans); empty for point formats.
    pub triangles: Vec<[u32; 3]>,
    /// Scanner poses the file records (E57), in scan order.
    pub scanners: Vec<Scanner>,
    /// The fields the normals were read from, as the file names them, and where they are
    /// (`NormalX,NormalY,NormalZ (LAS extra bytes, f32)`, `nx,ny,nz (PLY float)`); `None`
    /// when the file gives no normals.
    pub normal_fields: Option<String>,
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

/// A file format, chosen from the extension or named (`--format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `.ply`
    Ply,
    /// `.off`
    Off,
    /// `.obj`
    Obj,
    /// `.xyz`, `.txt`
    Xyz,
    /// `.las`, `.laz`
    Las,
    /// `.e57`
    E57,
    /// `.pcd`
    Pcd,
}

impl Format {
    /// Every format, for messages.
    pub const NAMES: &'static str = "ply, off, obj, xyz, las, laz, e57, pcd";

    /// The format a name or extension stands for.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name.to_ascii_lowercase().as_str() {
            "ply" => Format::Ply,
            "off" => Format::Off,
            "obj" => Format::Obj,
            "xyz" | "txt" => Format::Xyz,
            "las" | "laz" => Format::Las,
            "e57" => Format::E57,
            "pcd" => Format::Pcd,
            _ => return None,
        })
    }

    /// The format of `path` by its extension.
    pub fn of_path(path: &Path) -> Option<Self> {
        Self::from_name(path.extension()?.to_str()?)
    }
}

/// How to read a file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// The format (by the extension when `None`).
    pub format: Option<Format>,
    /// LAS/LAZ: keep only these classification codes.
    pub classes: Option<Vec<u8>>,
    /// E57: read only this scan (0-based); all scans merged when `None`.
    pub scan: Option<usize>,
    /// XYZ: what each column holds (else a header line or the rule of [`xyz`]).
    pub columns: Option<xyz::Columns>,
}

/// Reads a file, choosing the format by its extension (`ply`, `off`, `obj`, `xyz`/`txt`, and
/// with the `formats` feature `las`/`laz`, `e57`, `pcd`).
pub fn read(path: &Path) -> Result<Loaded, ReadError> {
    read_with(path, &ReadOptions::default())
}

/// Reads a file with options.
///
/// The third-party parsers underneath (`ply-rs`, `las`/`laz`, `e57`, `pcd-rs`) are trusted to
/// return errors, and the checks before them catch what we found that they do not (see
/// `tests/fuzz_readers.rs`); should one still panic, the panic is caught here and becomes an
/// error naming the file, never a crash.
pub fn read_with(path: &Path, options: &ReadOptions) -> Result<Loaded, ReadError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_unguarded(path, options)
    }))
    .unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".to_owned());
        Err(ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Malformed(format!(
                "the reader panicked ({message}): a bug in the parser, caught; the file is \
                     probably malformed"
            )),
        ))
    })
}

fn read_unguarded(path: &Path, options: &ReadOptions) -> Result<Loaded, ReadError> {
    let format = match options.format.or_else(|| Format::of_path(path)) {
        Some(f) => f,
        None => {
            return Err(ReadError::new(
                path,
                Location::File,
                ReadErrorKind::Unsupported(format!(
                    "unknown extension {:?}: expected one of {} (or name the format)",
                    path.extension()
                        .and_then(|e| e.to_str())
                        .unwrap_or_default(),
                    Format::NAMES
                )),
            ));
        }
    };
    regular_file(path)?;
    atomic::note_input(path);
    match format {
        Format::Ply => ply::read_ply(path),
        Format::Off => off::read_off(path),
        Format::Obj => obj::read_obj(path),
        Format::Xyz => xyz::read_xyz(path, options.columns.as_ref()),
        #[cfg(feature = "formats")]
        Format::Las => las::read_las(
            path,
            &las::LasOptions {
                classes: options.classes.clone(),
                ..las::LasOptions::default()
            },
        ),
        #[cfg(feature = "formats")]
        Format::Pcd => pcd::read_pcd(path),
        #[cfg(feature = "formats")]
        Format::E57 => {
            let scans = e57::read_e57(path)?;
            match options.scan {
                None => Ok(scans.merge()),
                Some(k) => {
                    let n = scans.0.len();
                    let scan = scans.0.into_iter().nth(k).ok_or_else(|| {
                        ReadError::new(
                            path,
                            Location::File,
                            ReadErrorKind::Unsupported(format!(
                                "scan {k} does not exist: the file has scans 0..{}",
                                n.saturating_sub(1)
                            )),
                        )
                    })?;
                    Ok(Loaded {
                        cloud: scan.cloud,
                        scanners: vec![scan.scanner],
                        ..Loaded::default()
                    })
                }
            }
        }
        #[cfg(not(feature = "formats"))]
        Format::Las | Format::Pcd | Format::E57 => Err(ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Unsupported(
                "LAS/LAZ, E57 and PCD need the `formats` feature of the cloud crate".into(),
            ),
        )),
    }
}

/// Opens a file for buffered reading, mapping failures to a [`ReadError`]; notes it as an
/// input ([`atomic::note_input`]). Anything but a regular file (a FIFO, a device, a folder) is
/// refused before it is opened: opening a FIFO blocks until a writer comes.
fn open(path: &Path) -> Result<io::BufReader<std::fs::File>, ReadError> {
    regular_file(path)?;
    atomic::note_input(path);
    std::fs::File::open(path)
        .map(|f| io::BufReader::with_capacity(1 << 16, f))
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))
}

/// Fails unless `path` is a regular file (links followed): a reader opens nothing else.
pub fn regular_file(path: &Path) -> Result<(), ReadError> {
    let meta = std::fs::metadata(path)
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?;
    if meta.is_file() {
        return Ok(());
    }
    Err(ReadError::new(
        path,
        Location::File,
        ReadErrorKind::Unsupported(if meta.is_dir() {
            "not a regular file but a directory".to_owned()
        } else {
            "not a regular file but a FIFO, a socket or a device: not read, since reading one \
             can block forever"
                .to_owned()
        }),
    ))
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
        let err = read(Path::new("cloud.vtk")).unwrap_err();
        assert!(matches!(err.kind, ReadErrorKind::Unsupported(_)), "{err}");
        assert!(err.to_string().contains("cloud.vtk"), "{err}");
    }

    #[test]
    fn missing_file_names_the_file() {
        let err = read(Path::new("/nonexistent/dir/x.off")).unwrap_err();
        assert!(matches!(err.kind, ReadErrorKind::Io(_)), "{err}");
        assert!(err.to_string().contains("/nonexistent/dir/x.off"), "{err}");
    }
}
