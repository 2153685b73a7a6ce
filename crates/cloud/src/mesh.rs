//! The triangle mesh type: the surface a dataset's points were taken from, and what the ground
//! truth renders.

use glam::{DVec3, Vec2};

use crate::bbox::Aabb;
use crate::error::{Error, Result};
use crate::points::check_finite;

/// An indexed triangle mesh with optional per-vertex texture coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub vertices: Vec<DVec3>,
    /// Triangles as three vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex texture coordinates, if known.
    pub uvs: Option<Vec<Vec2>>,
}

impl TriMesh {
    /// Builds a mesh, checking finite vertices and in-range indices.
    pub fn new(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        let mesh = Self {
            vertices,
            triangles,
            uvs: None,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks finite vertices, in-range indices and the uv array length.
    pub fn validate(&self) -> Result<()> {
        check_finite(&self.vertices)?;
        let n = self.vertices.len();
        if let Some(t) = self
            .triangles
            .iter()
            .position(|t| t.iter().any(|&v| v as usize >= n))
        {
            return Err(Error::InvalidParameter {
                name: "triangles",
                reason: format!("triangle {t} refers to a vertex beyond the {n} vertices"),
            });
        }
        if let Some(uvs) = &self.uvs
            && uvs.len() != n
        {
            return Err(Error::AttributeLength {
                name: "uvs",
                expected: n,
                found: uvs.len(),
            });
        }
        Ok(())
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// Area of triangle `t`.
    pub fn area(&self, t: usize) -> f64 {
        let [a, b, c] = self.corners(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total surface area.
    pub fn total_area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| self.area(t)).sum()
    }

    /// Unit normal of triangle `t` (zero for a degenerate triangle).
    pub fn face_normal(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Area-weighted vertex normals (zero for vertices used by no proper triangle).
    pub fn vertex_normals(&self) -> Vec<DVec3> {
        let mut normals = vec![DVec3::ZERO; self.vertices.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let [a, b, c] = self.corners(t);
            // The cross product's length is twice the area: the weighting is built in.
            let n = (b - a).cross(c - a);
            for &v in tri {
                normals[v as usize] += n;
            }
        }
        normals.iter().map(|n| n.normalize_or_zero()).collect()
    }

    /// Bounding box of the vertices; `None` for a mesh without vertices.
    pub fn bbox(&self) -> Option<Aabb> {
        Aabb::from_points(&self.vertices)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_square() -> TriMesh {
        TriMesh::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn areas_and_normals() {
        let m = unit_square();
        assert!((m.total_area() - 1.0).abs() < 1e-15);
        assert_eq!(m.face_normal(0), DVec3::Z);
        assert!(m.vertex_normals().iter().all(|n| *n == DVec3::Z));
    }

    #[test]
    fn out_of_range_index_is_rejected() {
        let err = TriMesh::new(vec![DVec3::ZERO; 3], vec![[0, 1, 3]]).unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "triangles",
                    ..
                }
            ),
            "{err}"
        );
    }
}
