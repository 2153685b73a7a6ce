//! LAS and LAZ over the `las` crate (with its `laz-parallel` feature; cargo feature `formats`).
//! LAZ is decoded on every core (`laz`'s `ParLasZipDecompressor`, one chunk per thread) when
//! its chunk table passes [`parallel_safe`]'s checks, else on one thread as before.
//!
//! Reading keeps the scaled coordinates (integer × scale + offset, as the header says), RGB
//! (16-bit channels, kept as their high bytes), intensity, classification, and the normals
//! where the Extra Bytes VLR names them ([`super::las_extra`]; each checked to be a unit
//! vector, [`crate::normals::is_given_normal`], else an error naming the point). Points are read
//! in chunks of [`CHUNK`] into the cloud's own arrays, so the memory held while reading is the
//! cloud plus one chunk (the `las` crate's whole-file `read_all` would hold the raw records
//! too). [`LasOptions::classes`] keeps only the listed classifications (for example 2 for
//! ground, 6 for buildings).
//!
//! Writing ([`write_las`]): LAS 1.4 point format 2 (with colour) or 0, LAZ-compressed when
//! the path ends in `.laz`, the normals (when the cloud has them) as extra bytes `NormalX`,
//! `NormalY`, `NormalZ` (f32). Coordinates are quantised: the offset is the bounding box's centre
//! and the scale the smallest power of ten that keeps the box inside the 32-bit integer range
//! (at least 1e-9), so a round trip moves a point by at most half the scale; the scale is
//! reported.

use std::path::Path;

use glam::{DVec3, Vec3};
use las::{Builder, Color, Point, PointDataBuilder, Reader, Transform, Vector, Writer};

use super::Loaded;
use super::las_extra::ExtraNormals;
use super::las_header::{RawHeader, check_counts_and_scale, check_laz, parallel_safe, raw_header};
use crate::error::{Error, Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Points decoded per chunk.
pub const CHUNK: u64 = 1 << 20;
/// Bytes a [`LasStream`] holds per point of its chunk, at most, beside a record's extra bytes:
/// the decoded records (up to 67 bytes in LAS 1.4's formats without extra bytes) and the
/// compressed ones (a LAZ point takes about 11). [`LasStream::bytes_per_point`] adds the extra
/// bytes.
pub const STREAM_BYTES_PER_POINT: u64 = 80;

/// Options of the LAS reader.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LasOptions {
    /// Keep only points of these classification codes (all when `None`).
    pub classes: Option<Vec<u8>>,
    /// Decode LAZ on one thread even where the parallel decoder would be used (to compare the
    /// two; the answer is the same).
    pub one_thread: bool,
}

/// Reads a LAS or LAZ file whole.
pub fn read_las(path: &Path, options: &LasOptions) -> Result<Loaded, ReadError> {
    let mut stream = LasStream::open(path, options)?;
    let announced = stream.announced;
    let n = announced as usize;
    let path = stream.path.as_path();
    let keep_all = options.classes.is_none();
    let reserve = if keep_all { n } else { 0 };
    // A LAZ header may claim as many points as its file has bytes: check the arrays (position,
    // intensity, classification, colour: 30 bytes a point; normal: 12) against memory before
    // reserving.
    let with_normals = stream.normals.is_some();
    crate::memory::ensure(
        (30 + if with_normals { 12 } else { 0 }) * reserve as u128,
        &format!("the {n} points {} announces", path.display()),
    )
    .map_err(|e| {
        ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Malformed(e.to_string()),
        )
    })?;
    let mut cloud = PointCloud {
        positions: Vec::with_capacity(reserve),
        intensity: Some(Vec::with_capacity(reserve)),
        classification: Some(Vec::with_capacity(reserve)),
        colors: stream.with_color.then(|| Vec::with_capacity(reserve)),
        normals: with_normals.then(|| Vec::with_capacity(reserve)),
        ..PointCloud::default()
    };
    let normal_fields = stream.normals.as_ref().map(ExtraNormals::describe);
    while stream.next_into(&mut cloud)? {}
    let path = stream.path.as_path();
    if cloud.positions.is_empty() {
        return Err(ReadError::new(
            path,
            Location::File,
            if options.classes.is_some() {
                ReadErrorKind::Unsupported(format!(
                    "no point has a classification in {:?}",
                    options.classes
                ))
            } else {
                ReadErrorKind::Empty
            },
        ));
    }
    cloud.positions.shrink_to_fit();
    Ok(Loaded {
        cloud,
        normal_fields,
        ..Loaded::default()
    })
}

/// A LAS or LAZ file read chunk by chunk ([`CHUNK`] points at a time), with every check of
/// [`read_las`]: the memory held is one chunk.
pub struct LasStream {
    path: std::path::PathBuf,
    reader: Reader,
    raw: RawHeader,
    len: u64,
    chunk: las::PointData,
    /// Points decoded per call of [`LasStream::next_into`].
    chunk_points: u64,
    /// Points the header announces.
    pub announced: u64,
    read: u64,
    /// Whether the points have RGB.
    pub with_color: bool,
    /// Whether LAZ is decoded on every core ([`parallel_safe`]).
    pub parallel: bool,
    /// The normals the extra bytes give, if they name them ([`super::las_extra`]).
    pub normals: Option<ExtraNormals>,
    classes: Option<Vec<u8>>,
}

impl LasStream {
    /// Opens `path` and checks its header and (LAZ) chunk table against the file.
    pub fn open(path: &Path, options: &LasOptions) -> Result<Self, ReadError> {
        let len = std::fs::metadata(path)
            .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?
            .len();
        if len == 0 {
            return Err(ReadError::new(path, Location::File, ReadErrorKind::Empty));
        }
        let raw = raw_header(path, len)?;
        if raw.point_data > len {
            return Err(ReadError::new(
                path,
                Location::Byte(len),
                ReadErrorKind::BadHeader(format!(
                    "the point data starts at byte {} but the file ends at byte {len}",
                    raw.point_data
                )),
            ));
        }
        check_counts_and_scale(path, &raw)?;
        // The point count against the file, before the `las` crate multiplies it by the record
        // length (which overflows for absurd counts): uncompressed records must fit in the file;
        // LAZ never compresses below a byte a point.
        let data_bytes = len - raw.point_data;
        let fits = if raw.compressed {
            data_bytes
        } else {
            data_bytes / raw.record.max(1)
        };
        if raw.points > fits {
            return Err(ReadError::new(
                path,
                Location::Byte(if raw.compressed {
                    len
                } else {
                    raw.point_data + fits * raw.record
                }),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: usize::try_from(raw.points).unwrap_or(usize::MAX),
                    found: fits as usize,
                },
            ));
        }
        if raw.compressed {
            check_laz(path, &raw, len)?;
        }
        // LAZ decoded on every core where the chunk table is one the parallel decoder cannot
        // trip on (`laz`'s `ParLasZipDecompressor` asserts where the sequential one returns
        // errors); every other file, and every LAS, the sequential reader as before.
        let parallel = raw.compressed && !options.one_thread && parallel_safe(path, &raw, len);
        let parallelism = if parallel {
            las::LazParallelism::Yes
        } else {
            las::LazParallelism::No
        };
        let file = std::fs::File::open(path)
            .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?;
        let reader = Reader::with_options(
            std::io::BufReader::new(file),
            las::ReaderOptions::default().with_laz_parallelism(parallelism),
        )
        .map_err(|e| {
            ReadError::new(
                path,
                Location::File,
                ReadErrorKind::BadHeader(e.to_string()),
            )
        })?;
        let header = reader.header().clone();
        let announced = header.number_of_points();
        // The same check on the count the crate parsed (it may differ from the raw fields above
        // for headers those fields do not describe).
        let record = raw.record.max(1);
        let plausible = if raw.compressed {
            data_bytes
        } else {
            data_bytes / record
        };
        if announced > plausible {
            return Err(ReadError::new(
                path,
                Location::Byte(if raw.compressed {
                    len
                } else {
                    raw.point_data + plausible * record
                }),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: announced as usize,
                    found: plausible as usize,
                },
            ));
        }
        let format = header.point_format();
        let record_len = usize::from(format.len());
        let normals = super::las_extra::find_normals(
            header.all_vlrs(),
            record_len - usize::from(format.extra_bytes),
            record_len,
        )
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::BadHeader(e)))?;
        let chunk = PointDataBuilder::new().for_header(&header).build();
        Ok(Self {
            path: path.to_owned(),
            reader,
            raw,
            len,
            chunk,
            chunk_points: CHUNK,
            announced,
            read: 0,
            with_color: header.point_format().has_color,
            parallel,
            normals,
            classes: options.classes.clone(),
        })
    }

    /// Bytes the stream holds per point of its chunk, at most: [`STREAM_BYTES_PER_POINT`] and
    /// the records' extra bytes.
    pub fn bytes_per_point(&self) -> u64 {
        STREAM_BYTES_PER_POINT + u64::from(self.reader.header().point_format().extra_bytes)
    }

    /// Decodes `points` points per call of [`LasStream::next_into`] (at least one) instead of
    /// [`CHUNK`]: the memory the stream holds is about [`STREAM_BYTES_PER_POINT`] a point of
    /// it. (A parallel LAZ decoder works on every core only when a call spans as many of the
    /// file's chunks, 50,000 points each as LAStools writes them.)
    pub fn with_chunk(mut self, points: u64) -> Self {
        self.chunk_points = points.max(1);
        self
    }

    /// Points decoded so far.
    pub fn read(&self) -> u64 {
        self.read
    }

    /// The grid every position of the file lies on: per axis `scale · i + offset` with the
    /// header's scale and offset and a 32-bit `i`, the `las` crate's decoding (which
    /// [`LasStream::next_into`] gives).
    pub fn grid(&self) -> crate::ooc::Grid {
        let t = self.reader.header().transforms();
        crate::ooc::Grid {
            scale: [t.x.scale, t.y.scale, t.z.scale],
            offset: [t.x.offset, t.y.offset, t.z.offset],
        }
    }

    /// Appends the next chunk's points (those of the kept classes) to `cloud`'s positions,
    /// intensity, classification, colours and normals (each where `cloud` has the array; the
    /// normals where the file has them too); `false` once every point was read. A file with
    /// fewer points than announced is [`ReadErrorKind::Truncated`], a normal that is not a
    /// unit vector [`ReadErrorKind::BadNormal`].
    pub fn next_into(&mut self, cloud: &mut PointCloud) -> Result<bool, ReadError> {
        let (path, raw, announced, record) = (
            self.path.as_path(),
            &self.raw,
            self.announced,
            self.raw.record.max(1),
        );
        let read = self.read;
        let keep = |c: u8| self.classes.as_ref().is_none_or(|k| k.contains(&c));
        if read >= announced {
            return Ok(false);
        }
        // Where the failing points start: exact for LAS; for LAZ the start of the compressed
        // data, with the point range in the message.
        let malformed = |e: las::Error| {
            let at = if raw.compressed {
                raw.point_data
            } else {
                raw.point_data + read * record
            };
            ReadError::new(
                path,
                Location::Byte(at),
                ReadErrorKind::Malformed(format!(
                    "decoding points {read}.. of {announced}{}: {e}",
                    if raw.compressed {
                        " (corrupt compressed data)"
                    } else {
                        ""
                    }
                )),
            )
        };
        let got = self
            .reader
            .fill_points(self.chunk_points.min(announced - read), &mut self.chunk)
            .map_err(malformed)?;
        if got == 0 {
            return Err(ReadError::new(
                path,
                Location::Byte(self.len),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: announced as usize,
                    found: read as usize,
                },
            ));
        }
        let (lo, hi) = raw.box_with_slack();
        // The columns the stream keeps, read from the records as `las::Point` decodes them
        // (the same scale and offset; an overlap class 12 read as 1, unclassified, as
        // `las::Point::new` clears it), without decoding every field of each point.
        let data = &self.chunk;
        let mut intensity = data.intensity();
        let mut rgb = data.rgb();
        let mut records = data.raw_bytes().chunks_exact(data.record_len());
        let normals = self.normals.as_ref().filter(|_| cloud.normals.is_some());
        let xyz_columns = data.x().zip(data.y()).zip(data.z());
        for (k, (((x, y), z), class)) in xyz_columns.zip(data.classification()).enumerate() {
            let index = (read + k as u64) as usize;
            let at = if raw.compressed {
                Location::File
            } else {
                Location::Byte(raw.point_data + index as u64 * record)
            };
            let intensity = intensity.next().unwrap_or(0);
            let color = rgb.as_mut().and_then(Iterator::next);
            let record = records.next().unwrap_or_default();
            let xyz = [x, y, z];
            if let Some(&value) = xyz.iter().find(|v| !v.is_finite()) {
                return Err(ReadError::new(
                    path,
                    at,
                    ReadErrorKind::NonFinite { index, value },
                ));
            }
            // Every point in the header's box (corrupt data decodes to points anywhere).
            if (0..3).any(|a| !(lo[a] <= xyz[a] && xyz[a] <= hi[a])) {
                let (blo, bhi) = raw.bounds;
                return Err(ReadError::new(
                    path,
                    at,
                    ReadErrorKind::Malformed(format!(
                        "point {index} at ({}, {}, {}) lies outside the header's box \
                         ({}, {}, {}) .. ({}, {}, {}){}",
                        xyz[0],
                        xyz[1],
                        xyz[2],
                        blo[0],
                        blo[1],
                        blo[2],
                        bhi[0],
                        bhi[1],
                        bhi[2],
                        if raw.compressed {
                            " (corrupt compressed data, or a wrong box)"
                        } else {
                            " (corrupt data, or a wrong box)"
                        }
                    )),
                ));
            }
            let class = if class == OVERLAP_CLASS { 1 } else { class };
            if !keep(class) {
                continue;
            }
            cloud.positions.push(DVec3::new(x, y, z));
            if let Some(v) = cloud.intensity.as_mut() {
                v.push(intensity);
            }
            if let Some(v) = cloud.classification.as_mut() {
                v.push(class);
            }
            if let Some(colors) = cloud.colors.as_mut() {
                let (red, green, blue) = color.unwrap_or((0, 0, 0));
                colors.push([(red >> 8) as u8, (green >> 8) as u8, (blue >> 8) as u8]);
            }
            if let (Some(fields), Some(out)) = (normals, cloud.normals.as_mut()) {
                let n: Vec3 = fields.of(record);
                if !crate::normals::is_given_normal(n) {
                    return Err(ReadError::new(
                        path,
                        at,
                        ReadErrorKind::BadNormal {
                            index,
                            normal: n.to_array(),
                            tolerance: crate::normals::GIVEN_LENGTH_TOLERANCE,
                        },
                    ));
                }
                out.push(n);
            }
        }
        self.read += got;
        Ok(true)
    }
}

/// The legacy overlap class, which `las::Point::new` reads as 1 (unclassified).
const OVERLAP_CLASS: u8 = 12;

/// True when `path` ends in `.laz` (any case): the writers compress then.
fn is_laz(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("laz"))
}

/// The scale [`write_las`] uses for points in `min..=max`.
pub fn las_scale(min: DVec3, max: DVec3) -> f64 {
    let half = ((max - min) * 0.5).max_element();
    let mut scale = 1e-9f64;
    while half / scale > 2.0e9 {
        scale *= 10.0;
    }
    scale
}

/// Writes `cloud` as LAS (or LAZ, by the extension), whole or not at all
/// ([`super::atomic`]), its normals (where it has them; each a unit vector, else an error) as
/// extra bytes; returns the scale used.
pub fn write_las(path: &Path, cloud: &PointCloud) -> Result<f64, Error> {
    let compress = is_laz(path);
    super::atomic::write_via(
        path,
        |partial| write_las_to(partial, path, cloud, compress),
        |source| Error::Write {
            path: path.to_owned(),
            source,
        },
    )
}

/// A LAS 1.4 header for points in `min..=max` (point format 0, or 2 with colours; with
/// `normals`, their extra bytes and the VLR that names them, [`super::las_extra`]), and its
/// scale: the coordinates on an integer grid of [`las_scale`] around the box's centre.
fn las_header(
    min: DVec3,
    max: DVec3,
    colors: bool,
    normals: bool,
    compress: bool,
) -> Result<(las::Header, f64), las::Error> {
    let scale = las_scale(min, max);
    let center = (min + max) * 0.5;
    // An offset that is a multiple of the scale keeps every coordinate on the integer grid.
    let offset = (center / scale).round() * scale;
    let mut builder = Builder::from((1, 4));
    builder.point_format = las::point::Format::new(if colors { 2 } else { 0 })?;
    builder.transforms = Vector {
        x: Transform {
            scale,
            offset: offset.x,
        },
        y: Transform {
            scale,
            offset: offset.y,
        },
        z: Transform {
            scale,
            offset: offset.z,
        },
    };
    builder.point_format.is_compressed = compress;
    if normals {
        builder.point_format.extra_bytes = super::las_extra::NORMAL_BYTES;
        builder.vlrs.push(super::las_extra::write_normals_vlr());
    }
    Ok((builder.into_header()?, scale))
}

/// The error of a normal that is not a unit vector, where a writer was given it.
fn bad_normal(path: &Path, index: u64, n: Vec3) -> Error {
    Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(format!(
            "point {index} has the normal {n} of length {}, not a unit vector (within {})",
            n.length(),
            crate::normals::GIVEN_LENGTH_TOLERANCE
        )),
    }
}

/// The extra bytes of a point with normal `n` (none without normals), or the error of a
/// normal that is not a unit vector.
fn extra_bytes(path: &Path, index: u64, n: Option<Vec3>) -> Result<Vec<u8>, Error> {
    match n {
        None => Ok(Vec::new()),
        Some(n) if crate::normals::is_given_normal(n) => Ok(super::las_extra::normal_bytes(n)),
        Some(n) => Err(bad_normal(path, index, n)),
    }
}

/// A batch of points for [`write_las_streamed`]: positions, and as many normals when the file
/// has them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Batch {
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Unit normals, one a position (empty when the file has none).
    pub normals: Vec<Vec3>,
}

impl Batch {
    fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
    }
}

/// Writes positions (and with `normals` their normals, as extra bytes) as LAS (or LAZ, by the
/// extension) without holding them: `next` appends the next batch to the one it is given
/// (cleared) and says whether more follow. Every point must lie in `min..=max` (the header's
/// grid is sized from them; a point outside, or one that is not finite, is an error), and with
/// `normals` have a unit normal. Whole or not at all; returns the scale and the points written.
pub fn write_las_streamed(
    path: &Path,
    min: DVec3,
    max: DVec3,
    normals: bool,
    mut next: impl FnMut(&mut Batch) -> bool,
) -> Result<(f64, u64), Error> {
    let compress = is_laz(path);
    let werr = |e: las::Error| Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(e.to_string()),
    };
    if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
        return Err(Error::Write {
            path: path.to_owned(),
            source: std::io::Error::other(format!("the box {min} .. {max} is not a box")),
        });
    }
    super::atomic::write_via(
        path,
        |partial| {
            let (header, scale) = las_header(min, max, false, normals, compress).map_err(werr)?;
            let file = std::fs::File::create(partial).map_err(|source| Error::Write {
                path: path.to_owned(),
                source,
            })?;
            let mut writer = Writer::new(std::io::BufWriter::with_capacity(1 << 20, file), header)
                .map_err(werr)?;
            let mut batch = Batch::default();
            let mut count = 0u64;
            loop {
                batch.clear();
                let more = next(&mut batch);
                if normals && batch.normals.len() != batch.positions.len() {
                    return Err(Error::Write {
                        path: path.to_owned(),
                        source: std::io::Error::other(format!(
                            "a batch of {} points came with {} normals",
                            batch.positions.len(),
                            batch.normals.len()
                        )),
                    });
                }
                for (k, p) in batch.positions.iter().enumerate() {
                    if !(p.is_finite() && p.cmpge(min).all() && p.cmple(max).all()) {
                        return Err(Error::Write {
                            path: path.to_owned(),
                            source: std::io::Error::other(format!(
                                "point {count} at {p} lies outside the announced box \
                                 {min} .. {max}"
                            )),
                        });
                    }
                    let n = normals.then(|| batch.normals[k]);
                    writer
                        .write_point(Point {
                            x: p.x,
                            y: p.y,
                            z: p.z,
                            extra_bytes: extra_bytes(path, count, n)?,
                            ..Point::default()
                        })
                        .map_err(werr)?;
                    count += 1;
                }
                if !more {
                    break;
                }
            }
            writer.close().map_err(werr)?;
            Ok((scale, count))
        },
        |source| Error::Write {
            path: path.to_owned(),
            source,
        },
    )
}

fn write_las_to(
    partial: &Path,
    path: &Path,
    cloud: &PointCloud,
    compress: bool,
) -> Result<f64, Error> {
    let werr = |e: las::Error| Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(e.to_string()),
    };
    let bbox = cloud.bbox().ok_or(Error::EmptyCloud)?;
    cloud.validate()?;
    let (header, scale) = las_header(
        bbox.min,
        bbox.max,
        cloud.colors.is_some(),
        cloud.normals.is_some(),
        compress,
    )
    .map_err(werr)?;
    let file = std::fs::File::create(partial).map_err(|source| Error::Write {
        path: path.to_owned(),
        source,
    })?;
    let mut writer =
        Writer::new(std::io::BufWriter::with_capacity(1 << 20, file), header).map_err(werr)?;
    for (i, p) in cloud.positions.iter().enumerate() {
        let mut point = Point {
            x: p.x,
            y: p.y,
            z: p.z,
            extra_bytes: extra_bytes(path, i as u64, cloud.normals.as_ref().map(|n| n[i]))?,
            ..Point::default()
        };
        if let Some(v) = &cloud.intensity {
            point.intensity = v[i];
        }
        if let Some(v) = &cloud.classification {
            point.classification = las::point::Classification::new(v[i]).map_err(werr)?;
        }
        if let Some(c) = &cloud.colors {
            let [r, g, b] = c[i];
            point.color = Some(Color::new(
                u16::from(r) << 8 | u16::from(r),
                u16::from(g) << 8 | u16::from(g),
                u16::from(b) << 8 | u16::from(b),
            ));
        }
        writer.write_point(point).map_err(werr)?;
    }
    writer.close().map_err(werr)?;
    Ok(scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_streamed_file_reads_back_like_a_whole_one() {
        let dir = tempfile::tempdir().unwrap();
        let positions: Vec<DVec3> = (0..2500)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                DVec3::new(t.sin() * 3.0, t.cos() * 2.0, t)
            })
            .collect();
        let cloud = PointCloud {
            positions: positions.clone(),
            ..PointCloud::default()
        };
        let bbox = cloud.bbox().unwrap();
        for name in ["s.las", "s.laz"] {
            let whole = dir.path().join(format!("whole-{name}"));
            let streamed = dir.path().join(name);
            write_las(&whole, &cloud).unwrap();
            let mut at = 0;
            let (_, count) = write_las_streamed(&streamed, bbox.min, bbox.max, false, |batch| {
                let end = (at + 1000).min(positions.len());
                batch.positions.extend_from_slice(&positions[at..end]);
                at = end;
                at < positions.len()
            })
            .unwrap();
            assert_eq!(count, 2500);
            let a = read_las(&whole, &LasOptions::default()).unwrap().cloud;
            let b = read_las(&streamed, &LasOptions::default()).unwrap().cloud;
            assert_eq!(a.positions, b.positions);
        }
    }

    /// The columns read from the records equal the `las` crate's own decoding of every point
    /// (positions, intensity, classification with the overlap class as it reads it,
    /// colours), in legacy and extended formats, LAS and LAZ, with and without a class filter.
    #[test]
    fn the_columns_equal_the_las_crates_points() {
        let dir = tempfile::tempdir().unwrap();
        for (format, name) in [
            (1u8, "n.las"),
            (3, "l.las"),
            (3, "l.laz"),
            (7, "e.las"),
            (7, "e.laz"),
        ] {
            let colored = format != 1;
            let path = dir.path().join(name);
            let mut header = Builder::from((1, 4));
            header.point_format = las::point::Format::new(format).unwrap();
            header.point_format.is_compressed = name.ends_with(".laz");
            header.transforms = Vector {
                x: Transform {
                    scale: 0.001,
                    offset: 10.0,
                },
                y: Transform {
                    scale: 0.002,
                    offset: -5.0,
                },
                z: Transform {
                    scale: 0.001,
                    offset: 0.0,
                },
            };
            let mut w = Writer::from_path(&path, header.into_header().unwrap()).unwrap();
            for i in 0..3000u32 {
                let t = f64::from(i);
                let mut p = Point {
                    x: 10.0 + 0.001 * f64::from(i % 977),
                    y: -5.0 + 0.002 * f64::from(i % 131),
                    z: 0.001 * t,
                    intensity: (i * 37 % 65_536) as u16,
                    classification: las::point::Classification::new(
                        [0u8, 2, 5, 31][i as usize % 4],
                    )
                    .unwrap(),
                    color: colored.then(|| {
                        Color::new(
                            (i * 13) as u16,
                            (i * 29 % 65_536) as u16,
                            (i * 7 % 65_536) as u16,
                        )
                    }),
                    gps_time: Some(t),
                    ..Point::default()
                };
                // The overlap class (12 in a legacy format's class bits; the overlap flag in an
                // extended one).
                p.is_overlap = i % 5 == 0;
                if p.is_overlap {
                    p.classification = las::point::Classification::Unclassified;
                }
                w.write_point(p).unwrap();
            }
            w.close().unwrap();
            let mut reader = Reader::from_path(&path).unwrap();
            let data = reader.read_points(3000).unwrap();
            let expected: Vec<Point> = data.points().map(Result::unwrap).collect();
            for classes in [None, Some(vec![1u8, 5]), Some(vec![12])] {
                let options = LasOptions {
                    classes: classes.clone(),
                    ..LasOptions::default()
                };
                let keep = |p: &Point| {
                    classes
                        .as_ref()
                        .is_none_or(|k| k.contains(&u8::from(p.classification)))
                };
                let kept: Vec<&Point> = expected.iter().filter(|p| keep(p)).collect();
                let got = match read_las(&path, &options) {
                    Ok(l) => l.cloud,
                    // No point of class 12 survives the crate's reading, so none of ours.
                    Err(_) if kept.is_empty() => continue,
                    Err(e) => panic!("{name} {classes:?}: {e}"),
                };
                assert!(!kept.is_empty(), "{name} {classes:?}");
                let want: Vec<DVec3> = kept.iter().map(|p| DVec3::new(p.x, p.y, p.z)).collect();
                assert_eq!(got.positions, want, "{name} {classes:?}");
                let want: Vec<u16> = kept.iter().map(|p| p.intensity).collect();
                assert_eq!(got.intensity.unwrap(), want, "{name}");
                let want: Vec<u8> = kept.iter().map(|p| u8::from(p.classification)).collect();
                assert_eq!(got.classification.unwrap(), want, "{name}");
                if !colored {
                    assert!(got.colors.is_none(), "{name}: no colours in format 1");
                    continue;
                }
                let want: Vec<[u8; 3]> = kept
                    .iter()
                    .map(|p| {
                        let c = p.color.unwrap();
                        [
                            (c.red >> 8) as u8,
                            (c.green >> 8) as u8,
                            (c.blue >> 8) as u8,
                        ]
                    })
                    .collect();
                assert_eq!(got.colors.unwrap(), want, "{name}");
            }
        }
    }

    /// LAS 1.4's legacy count of 0 and extended VLRs after the points (COPC's hierarchy) are
    /// legal; the records before the EVLRs are what the count must cover.
    #[test]
    fn extended_vlrs_after_the_points_are_legal() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/formats");
        let mut bytes = std::fs::read(root.join("tiny.las")).unwrap();
        assert_eq!(
            &bytes[107..111],
            &[0, 0, 0, 0],
            "the seed's legacy count is 0"
        );
        let at = bytes.len() as u64;
        // One EVLR: 60-byte header (reserved, user id, record id, length, description), then
        // 16 bytes of payload.
        let mut evlr = vec![0u8; 60];
        evlr[2..7].copy_from_slice(b"copc\0");
        evlr[18..20].copy_from_slice(&1000u16.to_le_bytes());
        evlr[20..28].copy_from_slice(&16u64.to_le_bytes());
        evlr.extend_from_slice(&[7u8; 16]);
        bytes.extend_from_slice(&evlr);
        bytes[235..243].copy_from_slice(&at.to_le_bytes());
        bytes[243..247].copy_from_slice(&1u32.to_le_bytes());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("evlr.las");
        std::fs::write(&path, &bytes).unwrap();
        let cloud = read_las(&path, &LasOptions::default()).unwrap().cloud;
        assert_eq!(cloud.len(), 5);
        // The same file with 3 announced: the 5 records before the EVLRs say otherwise.
        bytes[247..255].copy_from_slice(&3u64.to_le_bytes());
        std::fs::write(&path, &bytes).unwrap();
        let err = read_las(&path, &LasOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("announces 3 points but the point data holds 5 records")
                && err.contains("up to the extended VLRs at byte 545"),
            "{err}"
        );
    }

    #[test]
    fn a_point_outside_the_box_fails_and_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.laz");
        let err = write_las_streamed(&path, DVec3::ZERO, DVec3::ONE, false, |batch| {
            batch.positions.push(DVec3::splat(0.5));
            batch.positions.push(DVec3::new(0.5, 2.0, 0.5));
            false
        })
        .unwrap_err();
        assert!(
            err.to_string().contains("outside the announced box"),
            "{err}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert!(
            write_las_streamed(&path, DVec3::ONE, DVec3::ZERO, false, |_| false).is_err(),
            "an inverted box"
        );
    }
}
