//! LAS and LAZ over the `las` crate (with its `laz` feature; cargo feature `formats`).
//!
//! Reading keeps the scaled coordinates (integer × scale + offset, as the header says), RGB
//! (16-bit channels, kept as their high bytes), intensity and classification. Points are read
//! in chunks of [`CHUNK`] into the cloud's own arrays, so the memory held while reading is the
//! cloud plus one chunk (the `las` crate's whole-file `read_all` would hold the raw records
//! too). [`LasOptions::classes`] keeps only the listed classifications (for example 2 for
//! ground, 6 for buildings).
//!
//! Writing ([`write_las`]): LAS 1.4 point format 2 (with colour) or 0, LAZ-compressed when
//! the path ends in `.laz`. Coordinates are quantised: the offset is the bounding box's centre
//! and the scale the smallest power of ten that keeps the box inside the 32-bit integer range
//! (at least 1e-9), so a round trip moves a point by at most half the scale; the scale is
//! reported.

use std::path::Path;

use glam::DVec3;
use las::{Builder, Color, Point, PointDataBuilder, Reader, Transform, Vector, Writer};

use super::Loaded;
use crate::error::{Error, Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Points decoded per chunk.
pub const CHUNK: u64 = 1 << 20;

/// Options of the LAS reader.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LasOptions {
    /// Keep only points of these classification codes (all when `None`).
    pub classes: Option<Vec<u8>>,
}

fn malformed(path: &Path, e: las::Error) -> ReadError {
    ReadError::new(
        path,
        Location::File,
        ReadErrorKind::Malformed(e.to_string()),
    )
}

/// Reads a LAS or LAZ file.
pub fn read_las(path: &Path, options: &LasOptions) -> Result<Loaded, ReadError> {
    let len = std::fs::metadata(path)
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?
        .len();
    if len == 0 {
        return Err(ReadError::new(path, Location::File, ReadErrorKind::Empty));
    }
    let mut reader = Reader::from_path(path).map_err(|e| {
        ReadError::new(
            path,
            Location::File,
            ReadErrorKind::BadHeader(e.to_string()),
        )
    })?;
    let header = reader.header().clone();
    let announced = header.number_of_points();
    // A LAS header cannot claim more points than its file could hold (LAZ compresses, but
    // never below a byte a point).
    let record = u64::from(header.point_format().len());
    let plausible = if header.point_format().is_compressed {
        len
    } else {
        len / record.max(1)
    };
    if announced > plausible {
        return Err(ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Truncated {
                what: "points",
                expected: announced as usize,
                found: plausible as usize,
            },
        ));
    }
    let n = announced as usize;
    let with_color = header.point_format().has_color;
    let keep = |c: u8| options.classes.as_ref().is_none_or(|k| k.contains(&c));
    let reserve = if options.classes.is_some() { 0 } else { n };
    // A LAZ header may claim as many points as its file has bytes: check the arrays (position,
    // intensity, classification, colour: 30 bytes a point) against memory before reserving.
    crate::memory::ensure(
        30 * reserve as u128,
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
        colors: with_color.then(|| Vec::with_capacity(reserve)),
        ..PointCloud::default()
    };
    let mut chunk = PointDataBuilder::new().for_header(&header).build();
    let mut read: u64 = 0;
    while read < announced {
        let got = reader
            .fill_points(CHUNK.min(announced - read), &mut chunk)
            .map_err(|e| malformed(path, e))?;
        if got == 0 {
            break;
        }
        for (k, point) in chunk.points().enumerate() {
            let point = point.map_err(|e| malformed(path, e))?;
            let index = (read + k as u64) as usize;
            let class = u8::from(point.classification);
            if !keep(class) {
                continue;
            }
            if let Some(&value) = [point.x, point.y, point.z].iter().find(|v| !v.is_finite()) {
                return Err(ReadError::new(
                    path,
                    Location::File,
                    ReadErrorKind::NonFinite { index, value },
                ));
            }
            cloud.positions.push(DVec3::new(point.x, point.y, point.z));
            if let Some(v) = cloud.intensity.as_mut() {
                v.push(point.intensity);
            }
            if let Some(v) = cloud.classification.as_mut() {
                v.push(class);
            }
            if let Some(colors) = cloud.colors.as_mut() {
                let c = point.color.unwrap_or(Color::new(0, 0, 0));
                colors.push([
                    (c.red >> 8) as u8,
                    (c.green >> 8) as u8,
                    (c.blue >> 8) as u8,
                ]);
            }
        }
        read += got;
    }
    if read < announced {
        return Err(ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Truncated {
                what: "points",
                expected: n,
                found: read as usize,
            },
        ));
    }
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
        ..Loaded::default()
    })
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

/// Writes `cloud` as LAS (or LAZ, by the extension); returns the scale used.
pub fn write_las(path: &Path, cloud: &PointCloud) -> Result<f64, Error> {
    let werr = |e: las::Error| Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(e.to_string()),
    };
    let bbox = cloud.bbox().ok_or(Error::EmptyCloud)?;
    let scale = las_scale(bbox.min, bbox.max);
    let center = bbox.center();
    // An offset that is a multiple of the scale keeps every coordinate on the integer grid.
    let offset = (center / scale).round() * scale;
    let mut builder = Builder::from((1, 4));
    builder.point_format =
        las::point::Format::new(if cloud.colors.is_some() { 2 } else { 0 }).map_err(werr)?;
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
    let header = builder.into_header().map_err(werr)?;
    let mut writer = Writer::from_path(path, header).map_err(werr)?;
    for (i, p) in cloud.positions.iter().enumerate() {
        let mut point = Point {
            x: p.x,
            y: p.y,
            z: p.z,
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
