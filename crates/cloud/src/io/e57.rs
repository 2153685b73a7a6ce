//! E57 reader over the `e57` crate (pure Rust; cargo feature `formats`).
//!
//! An E57 file holds several scans, each with its pose (a rotation quaternion and a translation
//! from the scan's frame to the file's world frame). Each scan is read with its pose applied
//! (the crate's simple reader; spherical coordinates converted to Cartesian; invalid points and
//! pure directions skipped), with its colours (normalised to 8 bits) and intensities
//! (normalised to 16 bits) where present. Every scan's pose gives a [`Scanner`]: the scanner's
//! position and orientation, which the spherical camera uses as a viewpoint.
//!
//! [`read_e57`] returns the scans one by one; [`E57Scans::merge`] makes one cloud of them,
//! each point keeping its scan index (`PointCloud::scan`).

use std::path::Path;

use e57::{CartesianCoordinate, E57Reader};
use glam::{DQuat, DVec3};

use super::{Loaded, Scanner};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// One scan of an E57 file.
#[derive(Debug, Clone, PartialEq)]
pub struct E57Scan {
    /// The scan's name, if the file gives one.
    pub name: Option<String>,
    /// Its points, in world coordinates.
    pub cloud: PointCloud,
    /// The scanner's pose.
    pub scanner: Scanner,
}

/// The scans of an E57 file.
#[derive(Debug, Clone, PartialEq)]
pub struct E57Scans(pub Vec<E57Scan>);

impl E57Scans {
    /// All scans as one cloud, each point remembering its scan; every scanner kept.
    pub fn merge(self) -> Loaded {
        let mut cloud = PointCloud::default();
        let mut scan = Vec::new();
        let (mut colors, mut intensity) = (Vec::new(), Vec::new());
        let all_colors = self.0.iter().all(|s| s.cloud.colors.is_some());
        let all_intensity = self.0.iter().all(|s| s.cloud.intensity.is_some());
        let mut scanners = Vec::new();
        for (k, s) in self.0.into_iter().enumerate() {
            scan.extend(std::iter::repeat_n(k as u16, s.cloud.len()));
            if let Some(c) = s.cloud.colors {
                colors.extend(c);
            }
            if let Some(i) = s.cloud.intensity {
                intensity.extend(i);
            }
            cloud.positions.extend(s.cloud.positions);
            scanners.push(s.scanner);
        }
        cloud.scan = Some(scan);
        cloud.colors = all_colors.then_some(colors);
        cloud.intensity = all_intensity.then_some(intensity);
        Loaded {
            cloud,
            scanners,
            ..Loaded::default()
        }
    }
}

/// The number of scans of an E57 file (its header and XML only).
pub fn scan_count(path: &Path) -> Result<usize, ReadError> {
    let reader = E57Reader::from_file(path).map_err(|e| open_error(path, &e))?;
    Ok(reader.pointclouds().len())
}

/// E57 pages: 1,024 bytes, the last four a CRC-32C of the rest (ASTM E2807 §8.3).
const PAGE: u64 = 1024;

/// An error opening an E57 file, located where the `e57` crate's message allows: a page whose
/// checksum fails is named by its byte offset, a file that is not a whole number of pages by
/// its length; XML errors keep the crate's "at line:column" of the XML section.
fn open_error(path: &Path, e: &e57::Error) -> ReadError {
    let message = e.to_string();
    let number_after = |key: &str| -> Option<u64> {
        let rest = &message[message.find(key)? + key.len()..];
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        digits.parse().ok()
    };
    let location = if let Some(page) = number_after("for page ") {
        Location::Byte(page * PAGE)
    } else if let Some(size) = number_after("file size ") {
        Location::Byte(size)
    } else {
        Location::File
    };
    ReadError::new(path, location, ReadErrorKind::BadHeader(message))
}

/// Reads every scan of an E57 file.
pub fn read_e57(path: &Path) -> Result<E57Scans, ReadError> {
    let err = |kind| ReadError::new(path, Location::File, kind);
    let len = std::fs::metadata(path)
        .map_err(|e| err(ReadErrorKind::Io(e)))?
        .len();
    if len == 0 {
        return Err(err(ReadErrorKind::Empty));
    }
    let mut reader = E57Reader::from_file(path).map_err(|e| open_error(path, &e))?;
    let pointclouds = reader.pointclouds();
    if pointclouds.is_empty() {
        return Err(err(ReadErrorKind::Empty));
    }
    let mut scans = Vec::with_capacity(pointclouds.len());
    for (k, pc) in pointclouds.iter().enumerate() {
        let scan_err = |e: e57::Error| err(ReadErrorKind::Malformed(format!("scan {k}: {e}")));
        // The header's record count cannot exceed what the file could hold.
        if pc.records > len {
            return Err(err(ReadErrorKind::Truncated {
                what: "points",
                expected: pc.records as usize,
                found: len as usize,
            }));
        }
        let with_color = pc.has_color();
        let with_intensity = pc.has_intensity();
        let mut cloud = PointCloud {
            colors: with_color.then(Vec::new),
            intensity: with_intensity.then(Vec::new),
            ..PointCloud::default()
        };
        let iter = reader.pointcloud_simple(pc).map_err(scan_err)?;
        for p in iter {
            let p = p.map_err(scan_err)?;
            let CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                continue;
            };
            let index = cloud.positions.len();
            if let Some(&value) = [x, y, z].iter().find(|v| !v.is_finite()) {
                return Err(err(ReadErrorKind::NonFinite { index, value }));
            }
            cloud.positions.push(DVec3::new(x, y, z));
            if let Some(c) = cloud.colors.as_mut() {
                let rgb = p.color.map_or([0.0; 3], |c| [c.red, c.green, c.blue]);
                c.push(rgb.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
            }
            if let Some(i) = cloud.intensity.as_mut() {
                i.push((p.intensity.unwrap_or(0.0).clamp(0.0, 1.0) * 65535.0).round() as u16);
            }
        }
        let (rotation, position) = match &pc.transform {
            Some(t) => (
                DQuat::from_xyzw(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w),
                DVec3::new(t.translation.x, t.translation.y, t.translation.z),
            ),
            None => (DQuat::IDENTITY, DVec3::ZERO),
        };
        scans.push(E57Scan {
            name: pc.name.clone(),
            cloud,
            scanner: Scanner {
                position,
                rotation: rotation.normalize(),
            },
        });
    }
    Ok(E57Scans(scans))
}
