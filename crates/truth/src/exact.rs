//! The exact visibility check: a segment–triangle test from the eye to each point.
//!
//! A point p is hidden when some triangle of the mesh meets the segment from the eye to p at a
//! parameter t < 1 − 1e-7 (t = 1 is p itself; the margin keeps p's own triangle and its
//! neighbours, which meet the segment at t = 1 up to rounding, from hiding it). The segment
//! test runs over `parry3d-f64`'s triangle-mesh BVH (`TriMesh::cast_local_ray`, non-solid) in
//! double precision; points are processed in parallel. It is the slow, obviously-correct check
//! that the z-buffer [`crate::reference`] is validated against. The same BVH gives each point's
//! distance to the surface ([`ExactVisibility::distances`]): a real scan registered to a mesh
//! does not lie on it, and points farther than a tolerance are scored apart.

use cloud::TriMesh;
use cloud::glam::DVec3;
use parry3d_f64::query::{PointQuery, Ray, RayCast};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Relative segment margin before the point.
pub const SEGMENT_MARGIN: f64 = 1e-7;

/// A mesh prepared for segment queries.
pub struct ExactVisibility {
    mesh: parry3d_f64::shape::TriMesh,
}

impl std::fmt::Debug for ExactVisibility {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExactVisibility")
            .field("triangles", &self.mesh.num_triangles())
            .finish()
    }
}

impl ExactVisibility {
    /// Builds the BVH over `mesh`.
    pub fn new(mesh: &TriMesh) -> Result<Self> {
        if mesh.triangles.is_empty() {
            return Err(Error::EmptyMesh);
        }
        mesh.validate()?;
        let mesh = parry3d_f64::shape::TriMesh::new(mesh.vertices.clone(), mesh.triangles.clone())
            .map_err(|e| Error::Bvh(format!("{e:?}")))?;
        Ok(Self { mesh })
    }

    /// Is the segment from `eye` to `p` free of the surface (before p)?
    pub fn is_visible(&self, eye: DVec3, p: DVec3) -> bool {
        self.is_visible_with_margin(eye, p, SEGMENT_MARGIN)
    }

    /// Is the segment from `eye` to `p` free of the surface up to 1 − `margin` of its length?
    pub fn is_visible_with_margin(&self, eye: DVec3, p: DVec3, margin: f64) -> bool {
        let ray = Ray::new(eye, p - eye);
        self.mesh
            .cast_local_ray(&ray, 1.0 - margin, false)
            .is_none()
    }

    /// The first surface point along the ray from `origin` in direction `dir` (any length)
    /// within `max_distance` of the origin: its distance and the surface normal there.
    pub fn first_hit(&self, origin: DVec3, dir: DVec3, max_distance: f64) -> Option<(f64, DVec3)> {
        let dir = dir.normalize_or_zero();
        if dir == DVec3::ZERO {
            return None;
        }
        self.mesh
            .cast_local_ray_and_get_normal(&Ray::new(origin, dir), max_distance, false)
            .map(|hit| (hit.time_of_impact, hit.normal))
    }

    /// How many times the ray from `origin` in direction `dir` crosses the surface: every hit
    /// along it, each next one searched from just past the last (a hit within 10^-9 of the
    /// mesh's extent of the last is the same crossing, as through an edge two triangles share).
    /// At most 100,000 crossings are counted.
    pub fn crossings(&self, origin: DVec3, dir: DVec3) -> usize {
        let dir = dir.normalize_or_zero();
        if dir == DVec3::ZERO {
            return 0;
        }
        let aabb = self.mesh.local_aabb();
        let extent = (aabb.maxs - aabb.mins).length();
        let step = 1e-9 * extent.max(f64::MIN_POSITIVE);
        let mut from = origin;
        let mut n = 0;
        while n < 100_000 {
            match self
                .mesh
                .cast_local_ray(&Ray::new(from, dir), f64::MAX, false)
            {
                Some(t) => {
                    n += 1;
                    from += dir * (t + step);
                }
                None => break,
            }
        }
        n
    }

    /// Is `p` inside the surface? The majority of seven rays in fixed, irregular directions
    /// cross it an odd number of times (a closed mesh: each ray alone; an open surface, such as
    /// a floor, leaves most rays even).
    pub fn is_inside(&self, p: DVec3) -> bool {
        let odd = cloud::synth::fibonacci_sphere(7)
            .iter()
            .map(|&d| self.crossings(p, d + DVec3::new(0.0123, -0.0271, 0.0077)))
            .filter(|n| n % 2 == 1)
            .count();
        odd >= 4
    }

    /// Distance from `p` to the surface (the nearest point of any triangle).
    pub fn distance(&self, p: DVec3) -> f64 {
        (self.mesh.project_local_point(p, false).point - p).length()
    }

    /// Distance of every point to the surface, in parallel.
    pub fn distances(&self, points: &[DVec3]) -> Result<Vec<f64>> {
        cloud::points::check_finite(points)?;
        Ok(points.par_iter().map(|&p| self.distance(p)).collect())
    }

    /// Visibility of every point from `eye`.
    pub fn visibility(&self, eye: DVec3, points: &[DVec3]) -> Result<Vec<bool>> {
        cloud::points::check_finite(points)?;
        Ok(points
            .par_iter()
            .map(|&p| self.is_visible(eye, p))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use cloud::synth::{sphere_plane_scene, sphere_point_visible, sphere_scene};

    use super::*;

    #[test]
    fn matches_the_analytic_sphere_and_occluder() {
        let scene = sphere_scene(5_000);
        let exact = ExactVisibility::new(&scene.mesh).unwrap();
        let eye = DVec3::new(0.3, -0.2, 3.0);
        // The icosphere is inscribed: points on the true sphere are outside its faces, so the
        // only disagreements are in a thin band at the silhouette.
        let vis = exact.visibility(eye, &scene.cloud.positions).unwrap();
        let agree = scene
            .cloud
            .positions
            .iter()
            .zip(&vis)
            .filter(|&(&p, &v)| sphere_point_visible(DVec3::ZERO, p, eye) == v)
            .count();
        assert!(agree as f64 / 5_000.0 > 0.995, "{agree}");

        let (scene, g) = sphere_plane_scene(2_000, 4_000, 3);
        let exact = ExactVisibility::new(&scene.mesh).unwrap();
        for eye in [
            DVec3::new(0.5, 0.5, 6.0),
            DVec3::new(3.0, -1.0, 0.5),
            DVec3::new(0.0, 0.1, -4.0),
        ] {
            let vis = exact.visibility(eye, &scene.cloud.positions).unwrap();
            let agree = scene
                .cloud
                .positions
                .iter()
                .zip(&vis)
                .filter(|&(&p, &v)| g.visible(p, eye) == v)
                .count();
            assert!(agree as f64 / 6_000.0 > 0.995, "{agree} for {eye}");
        }
    }

    #[test]
    fn distances_to_the_surface() {
        let scene = sphere_scene(500);
        let exact = ExactVisibility::new(&scene.mesh).unwrap();
        // Points on the sphere lie within the icosphere's sag of its faces; 2 and 0.5 from the
        // centre are 1 and 0.5 from the surface.
        let d = exact
            .distances(&[
                scene.cloud.positions[7],
                DVec3::new(0.0, 0.0, 2.0),
                DVec3::new(0.5, 0.0, 0.0),
            ])
            .unwrap();
        assert!(d[0] < 1e-3, "{d:?}");
        assert!(
            (d[1] - 1.0).abs() < 1e-3 && (d[2] - 0.5).abs() < 1e-3,
            "{d:?}"
        );
    }

    #[test]
    fn a_point_is_inside_a_closed_mesh_and_not_beside_an_open_floor() {
        let scene = sphere_scene(500);
        let exact = ExactVisibility::new(&scene.mesh).unwrap();
        assert!(exact.is_inside(DVec3::new(0.1, -0.2, 0.3)));
        assert!(!exact.is_inside(DVec3::new(0.0, 0.0, 1.5)));
        assert_eq!(exact.crossings(DVec3::new(0.0, 0.0, 3.0), -DVec3::Z), 2);
        // The ball over its square (open): inside the ball still inside, above the square not.
        let (scene, _) = sphere_plane_scene(200, 200, 1);
        let exact = ExactVisibility::new(&scene.mesh).unwrap();
        assert!(exact.is_inside(DVec3::new(0.0, 0.05, 0.9)));
        assert!(!exact.is_inside(DVec3::new(1.5, 1.5, 0.5)));
    }

    #[test]
    fn empty_mesh_is_an_error() {
        assert!(matches!(
            ExactVisibility::new(&TriMesh::default()),
            Err(Error::EmptyMesh)
        ));
    }
}
