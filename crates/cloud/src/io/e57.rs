//! E57 reader over the `e57` crate (pure Rust; cargo feature `formats`).
//!
//! An E57 file holds several scans, each with its pose (a rotation quaternion and a translation
//! from the scan's frame to the file's world frame). Each scan is read with its pose applied
//! (the crate's simple reader; spherical coordinates converted to Cartesian; invalid points and
//! pure directions skipped), with its colours (normalised to 8 bits) and intensities
//! (normalised to 16 bits) where present, and with its normals where the scan has the surface
//! normals extension's fields (`nor:normalX`, `nor:normalY`, `nor:normalZ`, as CloudCompare
//! and libE57Format write them; read from the raw records beside the simple reader's points,
//! turned by the pose as the positions are, each checked to be a unit vector). Every scan's
//! pose gives a [`Scanner`]: the scanner's position and orientation, which the spherical
//! camera uses as a viewpoint.
//!
//! [`read_e57`] returns the scans one by one; [`E57Scans::merge`] makes one cloud of them,
//! each point keeping its scan index (`PointCloud::scan`), with normals when every scan has
//! them.

use std::path::Path;

use e57::{CartesianCoordinate, E57Reader, RecordName};
use glam::{DQuat, DVec3, Vec3};

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
        let all_normals = self.0.iter().all(|s| s.cloud.normals.is_some());
        let mut normals = Vec::new();
        let mut scanners = Vec::new();
        for (k, s) in self.0.into_iter().enumerate() {
            scan.extend(std::iter::repeat_n(k as u16, s.cloud.len()));
            if let Some(c) = s.cloud.colors {
                colors.extend(c);
            }
            if let Some(i) = s.cloud.intensity {
                intensity.extend(i);
            }
            if let Some(n) = s.cloud.normals {
                normals.extend(n);
            }
            cloud.positions.extend(s.cloud.positions);
            scanners.push(s.scanner);
        }
        cloud.scan = Some(scan);
        cloud.colors = all_colors.then_some(colors);
        cloud.intensity = all_intensity.then_some(intensity);
        cloud.normals = all_normals.then_some(normals);
        Loaded {
            normal_fields: cloud.normals.as_ref().map(|_| NORMAL_FIELDS.to_owned()),
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

/// What [`super::Loaded::normal_fields`] says of an E57 file's normals.
pub const NORMAL_FIELDS: &str = "normalX,normalY,normalZ (E57 surface normals extension)";

/// The surface normals extension's field names.
const NORMAL_NAMES: [&str; 3] = ["normalX", "normalY", "normalZ"];

/// The indices in `prototype` of the normals' fields, if the scan has all three.
fn normal_fields(prototype: &[e57::Record]) -> Option<[usize; 3]> {
    let find = |want: &str| {
        prototype
            .iter()
            .position(|r| matches!(&r.name, RecordName::Unknown { name, .. } if name == want))
    };
    Some([
        find(NORMAL_NAMES[0])?,
        find(NORMAL_NAMES[1])?,
        find(NORMAL_NAMES[2])?,
    ])
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
        let with_normals = normal_fields(&pc.prototype);
        let mut cloud = PointCloud {
            colors: with_color.then(Vec::new),
            intensity: with_intensity.then(Vec::new),
            normals: with_normals.map(|_| Vec::new()),
            ..PointCloud::default()
        };
        let (rotation, position) = match &pc.transform {
            Some(t) => (
                DQuat::from_xyzw(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w),
                DVec3::new(t.translation.x, t.translation.y, t.translation.z),
            ),
            None => (DQuat::IDENTITY, DVec3::ZERO),
        };
        let rotation = rotation.normalize();
        // The normals from the raw records, one a point of the simple reader's, on a reader
        // of their own (the simple reader holds the first).
        let mut normals_reader = match with_normals {
            Some(_) => Some(E57Reader::from_file(path).map_err(|e| open_error(path, &e))?),
            None => None,
        };
        let mut raw = match normals_reader.as_mut() {
            Some(r) => Some(r.pointcloud_raw(pc).map_err(scan_err)?),
            None => None,
        };
        let iter = reader.pointcloud_simple(pc).map_err(scan_err)?;
        for (record, p) in iter.enumerate() {
            let p = p.map_err(scan_err)?;
            let normal = match (raw.as_mut(), with_normals) {
                (Some(raw), Some(fields)) => {
                    let values = raw
                        .next()
                        .ok_or_else(|| {
                            err(ReadErrorKind::Malformed(format!(
                                "scan {k}: the normals end before point {record}"
                            )))
                        })?
                        .map_err(scan_err)?;
                    let mut n = [0f64; 3];
                    for (a, &f) in fields.iter().enumerate() {
                        n[a] = values[f]
                            .to_f64(&pc.prototype[f].data_type)
                            .map_err(scan_err)?;
                    }
                    Some(DVec3::from_array(n))
                }
                _ => None,
            };
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
            if let (Some(out), Some(n)) = (cloud.normals.as_mut(), normal) {
                // In the scan's frame; the pose turns it as it turns the position.
                let world: Vec3 = (rotation * n).as_vec3();
                if !(crate::normals::is_given_normal(n.as_vec3())
                    && crate::normals::is_given_normal(world))
                {
                    let bad = ReadErrorKind::BadNormal {
                        index,
                        normal: n.as_vec3().to_array(),
                        tolerance: crate::normals::GIVEN_LENGTH_TOLERANCE,
                    };
                    return Err(err(ReadErrorKind::Malformed(format!("scan {k}: {bad}"))));
                }
                out.push(world);
            }
        }
        scans.push(E57Scan {
            name: pc.name.clone(),
            cloud,
            scanner: Scanner { position, rotation },
        });
    }
    Ok(E57Scans(scans))
}

#[cfg(test)]
mod tests {
    use e57::{
        E57Writer, Extension, Quaternion, Record, RecordDataType, RecordValue, Transform,
        Translation,
    };

    use super::*;

    /// Writes an E57 file of two scans of the same three points and normals (the `e57`
    /// crate's writer, the surface normals extension as libE57Format names it): scan 0 at the
    /// identity pose, scan 1 turned 90° about z; `bad` replaces scan 1's normal of point 1.
    fn write(path: &Path, bad: Option<[f32; 3]>) {
        let mut w = E57Writer::from_file(path, "guid-file").unwrap();
        w.register_extension(Extension {
            namespace: "nor".into(),
            url: "http://www.libe57.org/E57_EXT_surface_normals.txt".into(),
        })
        .unwrap();
        let normal = |name: &str| Record {
            name: RecordName::Unknown {
                namespace: "nor".into(),
                name: name.into(),
            },
            data_type: RecordDataType::F32,
        };
        let c = std::f64::consts::FRAC_1_SQRT_2;
        for (k, rotation) in [(0, [1.0, 0.0, 0.0, 0.0]), (1, [c, 0.0, 0.0, c])] {
            let prototype = vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
                normal("normalX"),
                normal("normalY"),
                normal("normalZ"),
            ];
            let mut pc = w.add_pointcloud(&format!("guid-{k}"), prototype).unwrap();
            pc.set_transform(Some(Transform {
                rotation: Quaternion {
                    w: rotation[0],
                    x: rotation[1],
                    y: rotation[2],
                    z: rotation[3],
                },
                translation: Translation {
                    x: 10.0 * f64::from(k),
                    y: 0.0,
                    z: 0.0,
                },
            }));
            for (i, n) in [[1.0f32, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]]
                .into_iter()
                .enumerate()
            {
                let n = if k == 1 && i == 1 {
                    bad.unwrap_or(n)
                } else {
                    n
                };
                let p = [i as f64, 2.0 * i as f64, 0.5];
                let values = p
                    .iter()
                    .map(|&v| RecordValue::Double(v))
                    .chain(n.iter().map(|&v| RecordValue::Single(v)))
                    .collect();
                pc.add_point(values).unwrap();
            }
            pc.finalize().unwrap();
        }
        w.finalize().unwrap();
    }

    #[test]
    fn normals_of_the_surface_normals_extension_are_turned_by_the_pose() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("normals.e57");
        write(&path, None);
        let scans = read_e57(&path).unwrap();
        let want = [Vec3::X, Vec3::new(0.0, 0.6, 0.8), Vec3::Z];
        assert_eq!(scans.0[0].cloud.normals.as_deref(), Some(&want[..]));
        // Turned 90° about z: (x, y, z) becomes (-y, x, z).
        let turned = scans.0[1].cloud.normals.clone().unwrap();
        for (got, n) in turned.iter().zip(want) {
            let expect = Vec3::new(-n.y, n.x, n.z);
            assert!((*got - expect).length() < 1e-6, "{got} vs {expect}");
        }
        let merged = scans.merge();
        assert_eq!(merged.cloud.normals.as_ref().map(Vec::len), Some(6));
        assert_eq!(merged.normal_fields.as_deref(), Some(NORMAL_FIELDS));
        // A scan's normal of length zero, or NaN: refused, naming the file, scan and point.
        for bad in [[0.0, 0.0, 0.0], [f32::NAN, 0.0, 1.0]] {
            write(&path, Some(bad));
            let err = read_e57(&path).unwrap_err().to_string();
            assert!(
                err.contains("normals.e57") && err.contains("scan 1: point 1 has the normal"),
                "{err}"
            );
        }
    }
}
