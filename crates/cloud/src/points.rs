//! The point cloud type shared by every method.
//!
//! Positions are `f64` (`glam::DVec3`): the hull of a spherically flipped cloud needs the
//! precision, and the real datasets keep their source coordinates, which for the dragon are
//! around 1,000 units from the origin. Optional attributes (normals, colours, texture
//! coordinates, surface provenance) have one entry per point when present. Methods borrow the
//! arrays (`&[DVec3]`), so nothing is copied between crates.

use glam::{DVec3, Vec2, Vec3};

use crate::bbox::Aabb;
use crate::error::{Error, Result};

/// Where a sampled point came from on its mesh: the triangle and barycentric weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSample {
    /// Index of the source triangle in the mesh.
    pub triangle: u32,
    /// Barycentric weights of the triangle's three corners (they sum to 1).
    pub barycentric: [f64; 3],
}

/// A set of points with optional per-point attributes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointCloud {
    /// Point positions.
    pub positions: Vec<DVec3>,
    /// Unit normals, if known.
    pub normals: Option<Vec<Vec3>>,
    /// 8-bit RGB colours, if known.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Texture coordinates, if known.
    pub uvs: Option<Vec<Vec2>>,
    /// Surface provenance of sampled points, if the cloud was sampled from a mesh.
    pub samples: Option<Vec<SurfaceSample>>,
    /// Return intensity (LAS, E57, PCD), if known.
    pub intensity: Option<Vec<u16>>,
    /// LAS classification code, if known.
    pub classification: Option<Vec<u8>>,
    /// Index of the scan (scanner position) each point came from, for merged scans.
    pub scan: Option<Vec<u16>>,
}

impl PointCloud {
    /// A cloud of bare positions; fails on a non-finite coordinate.
    pub fn from_positions(positions: Vec<DVec3>) -> Result<Self> {
        let cloud = Self {
            positions,
            ..Self::default()
        };
        cloud.validate()?;
        Ok(cloud)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Checks that every coordinate is finite and every attribute has one entry per point.
    pub fn validate(&self) -> Result<()> {
        check_finite(&self.positions)?;
        let n = self.positions.len();
        check_len("normals", n, self.normals.as_ref().map(Vec::len))?;
        check_len("colors", n, self.colors.as_ref().map(Vec::len))?;
        check_len("uvs", n, self.uvs.as_ref().map(Vec::len))?;
        check_len("samples", n, self.samples.as_ref().map(Vec::len))?;
        check_len("intensity", n, self.intensity.as_ref().map(Vec::len))?;
        check_len(
            "classification",
            n,
            self.classification.as_ref().map(Vec::len),
        )?;
        check_len("scan", n, self.scan.as_ref().map(Vec::len))?;
        Ok(())
    }

    /// Axis-aligned bounding box; `None` for an empty cloud.
    pub fn bbox(&self) -> Option<Aabb> {
        Aabb::from_points(&self.positions)
    }

    /// The sub-cloud of the given indices, attributes carried along.
    pub fn select(&self, indices: &[u32]) -> Self {
        fn pick<T: Copy>(values: &Option<Vec<T>>, indices: &[u32]) -> Option<Vec<T>> {
            values
                .as_ref()
                .map(|v| indices.iter().map(|&i| v[i as usize]).collect())
        }
        Self {
            positions: indices
                .iter()
                .map(|&i| self.positions[i as usize])
                .collect(),
            normals: pick(&self.normals, indices),
            colors: pick(&self.colors, indices),
            uvs: pick(&self.uvs, indices),
            samples: pick(&self.samples, indices),
            intensity: pick(&self.intensity, indices),
            classification: pick(&self.classification, indices),
            scan: pick(&self.scan, indices),
        }
    }
}

/// Fails with [`Error::NonFinite`] at the first point with a NaN or infinite coordinate.
pub fn check_finite(positions: &[DVec3]) -> Result<()> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(index) => Err(Error::NonFinite { index }),
        None => Ok(()),
    }
}

fn check_len(name: &'static str, expected: usize, found: Option<usize>) -> Result<()> {
    match found {
        Some(found) if found != expected => Err(Error::AttributeLength {
            name,
            expected,
            found,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_position_is_rejected_with_its_index() {
        let err = PointCloud::from_positions(vec![DVec3::ZERO, DVec3::new(0.0, f64::NAN, 0.0)])
            .unwrap_err();
        assert!(matches!(err, Error::NonFinite { index: 1 }), "{err}");
    }

    #[test]
    fn attribute_of_wrong_length_is_rejected() {
        let mut cloud = PointCloud::from_positions(vec![DVec3::ZERO; 3]).unwrap();
        cloud.normals = Some(vec![Vec3::Z; 2]);
        let err = cloud.validate().unwrap_err();
        assert!(
            matches!(
                err,
                Error::AttributeLength {
                    name: "normals",
                    expected: 3,
                    found: 2
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn select_carries_attributes() {
        let mut cloud = PointCloud::from_positions(vec![DVec3::X, DVec3::Y, DVec3::Z]).unwrap();
        cloud.colors = Some(vec![[1, 1, 1], [2, 2, 2], [3, 3, 3]]);
        let sub = cloud.select(&[2, 0]);
        assert_eq!(sub.positions, vec![DVec3::Z, DVec3::X]);
        assert_eq!(sub.colors, Some(vec![[3, 3, 3], [1, 1, 1]]));
    }
}
