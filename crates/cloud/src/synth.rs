//! Synthetic scenes generated in code: no download, exact geometry, analytic visibility.
//!
//! - [`sphere_scene`]: points exactly on the unit sphere (Fibonacci lattice), the mesh an
//!   icosphere; from any eye outside, a point is visible exactly when it faces the eye
//!   ([`sphere_point_visible`]). The convex case every visibility method must get right.
//! - [`sphere_plane_scene`]: a ball in front of a square: occlusion with an analytic answer
//!   ([`SpherePlane::visible`]).
//! - [`torus_scene`]: a torus with texture coordinates (u around the ring, v around the tube).
//! - [`vase_scene`]: a vase-like surface of revolution with texture coordinates.

use std::collections::HashMap;

use glam::{DVec3, Vec2, Vec3};

use crate::error::Result;
use crate::mesh::TriMesh;
use crate::points::PointCloud;
use crate::rng::{RngExt, seeded};
use crate::sample::sample_surface;
use crate::views::fibonacci_direction;

/// `n` points of the Fibonacci lattice on the unit sphere (the same lattice as the views).
pub fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    (0..n).map(|k| fibonacci_direction(k, n)).collect()
}

/// The unit icosphere: an icosahedron subdivided `level` times, vertices on the sphere.
/// Level L has 10·4^L + 2 vertices and 20·4^L triangles, counter-clockwise from outside.
pub fn icosphere(level: u32) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<DVec3>| {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
                (vertices.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    TriMesh {
        vertices,
        triangles,
        uvs: None,
    }
}

/// True when the point `p` of the sphere (`center`, any radius) faces `eye`: visible from an
/// eye outside the sphere. Points on the exact silhouette (tangent rays) count as hidden.
pub fn sphere_point_visible(center: DVec3, p: DVec3, eye: DVec3) -> bool {
    (p - center).dot(eye - p) > 0.0
}

/// A synthetic scene: its points and the mesh they lie on (or approximate).
#[derive(Debug, Clone)]
pub struct Scene {
    /// The points methods see.
    pub cloud: PointCloud,
    /// The surface the ground truth renders.
    pub mesh: TriMesh,
}

/// `n` points on the unit sphere at the origin (Fibonacci lattice, outward normals); the mesh
/// is the level-6 icosphere (81,920 triangles, inscribed: at most 1.2e-4 inside the sphere).
pub fn sphere_scene(n: usize) -> Scene {
    let positions = fibonacci_sphere(n);
    let normals = positions.iter().map(|p| p.as_vec3()).collect();
    Scene {
        cloud: PointCloud {
            positions,
            normals: Some(normals),
            ..PointCloud::default()
        },
        mesh: icosphere(7),
    }
}

/// The geometry of [`sphere_plane_scene`], with its analytic visibility.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpherePlane {
    /// Ball centre.
    pub center: DVec3,
    /// Ball radius.
    pub radius: f64,
    /// Half the side of the square, which lies in z = 0 centred on the origin.
    pub half_side: f64,
}

impl Default for SpherePlane {
    fn default() -> Self {
        Self {
            center: DVec3::new(0.0, 0.0, 1.0),
            radius: 0.75,
            half_side: 2.0,
        }
    }
}

impl SpherePlane {
    /// Is the scene point `p` (on the sphere or on the square) visible from `eye`?
    /// Exact up to a relative 1e-9 along the segment, which keeps a point from hiding itself.
    pub fn visible(&self, p: DVec3, eye: DVec3) -> bool {
        let on_sphere = ((p - self.center).length() - self.radius).abs() < 1e-9 * self.radius;
        // Occlusion by the ball.
        let ball_blocks = if on_sphere {
            !sphere_point_visible(self.center, p, eye)
        } else {
            segment_hits_ball(eye, p, self.center, self.radius)
        };
        if ball_blocks {
            return false;
        }
        // Occlusion by the square (z = 0), for points not on it.
        if p.z.abs() > 1e-12 && eye.z.signum() != p.z.signum() {
            let t = eye.z / (eye.z - p.z);
            let hit = eye + t * (p - eye);
            if t < 1.0 - 1e-9 && hit.x.abs() <= self.half_side && hit.y.abs() <= self.half_side {
                return false;
            }
        }
        true
    }
}

/// Does the segment from `a` to `b` pass through the open ball?
fn segment_hits_ball(a: DVec3, b: DVec3, center: DVec3, radius: f64) -> bool {
    let d = b - a;
    let t = ((center - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
    (a + t * d - center).length() < radius
}

/// A ball in front of a square: `n_sphere` lattice points on the ball and `n_plane` uniform
/// random points (seeded) on the square, in that order. The mesh: an icosphere (level 6) and
/// the square as two triangles.
pub fn sphere_plane_scene(n_sphere: usize, n_plane: usize, seed: u64) -> (Scene, SpherePlane) {
    let geometry = SpherePlane::default();
    let mut positions: Vec<DVec3> = fibonacci_sphere(n_sphere)
        .into_iter()
        .map(|d| geometry.center + geometry.radius * d)
        .collect();
    let mut normals: Vec<Vec3> = fibonacci_sphere(n_sphere)
        .into_iter()
        .map(|d| d.as_vec3())
        .collect();
    let mut rng = seeded(seed, "sphere-plane");
    let s = geometry.half_side;
    for _ in 0..n_plane {
        let x = (rng.random::<f64>() * 2.0 - 1.0) * s;
        let y = (rng.random::<f64>() * 2.0 - 1.0) * s;
        positions.push(DVec3::new(x, y, 0.0));
        normals.push(Vec3::Z);
    }
    let mut mesh = icosphere(7);
    for v in &mut mesh.vertices {
        *v = geometry.center + geometry.radius * *v;
    }
    let base = mesh.vertices.len() as u32;
    mesh.vertices.extend([
        DVec3::new(-s, -s, 0.0),
        DVec3::new(s, -s, 0.0),
        DVec3::new(s, s, 0.0),
        DVec3::new(-s, s, 0.0),
    ]);
    mesh.triangles
        .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    (
        Scene {
            cloud: PointCloud {
                positions,
                normals: Some(normals),
                ..PointCloud::default()
            },
            mesh,
        },
        geometry,
    )
}

/// A parametric grid mesh over (u, v) ∈ [0, 1]², seam vertices duplicated so texture
/// coordinates interpolate without wrapping; `f(u, v)` gives the position.
fn parametric_mesh(nu: usize, nv: usize, f: impl Fn(f64, f64) -> DVec3) -> TriMesh {
    let mut vertices = Vec::with_capacity((nu + 1) * (nv + 1));
    let mut uvs = Vec::with_capacity((nu + 1) * (nv + 1));
    for j in 0..=nv {
        for i in 0..=nu {
            let (u, v) = (i as f64 / nu as f64, j as f64 / nv as f64);
            vertices.push(f(u, v));
            uvs.push(Vec2::new(u as f32, v as f32));
        }
    }
    let idx = |i: usize, j: usize| (j * (nu + 1) + i) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            triangles.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            triangles.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    TriMesh {
        vertices,
        triangles,
        uvs: Some(uvs),
    }
}

/// A torus around the z axis (ring radius 1, tube radius 0.35) with texture coordinates
/// (u around the ring, v around the tube), as a 256 × 96 grid mesh, and `n` area-weighted
/// samples of it (seeded) carrying their texture coordinates.
pub fn torus_scene(n: usize, seed: u64) -> Result<Scene> {
    let (ring, tube) = (1.0, 0.35);
    let tau = std::f64::consts::TAU;
    let mesh = parametric_mesh(256, 96, |u, v| {
        let (a, b) = (u * tau, v * tau);
        DVec3::new(
            (ring + tube * b.cos()) * a.cos(),
            (ring + tube * b.cos()) * a.sin(),
            tube * b.sin(),
        )
    });
    let cloud = sample_surface(&mesh, n, seed)?;
    Ok(Scene { cloud, mesh })
}

/// A vase-like surface of revolution around the y axis (height 2, radius profile
/// 0.45 + 0.25 sin(1.5πv + 0.3)), closed at neither end, as a 192 × 128 grid mesh with texture
/// coordinates (u around, v up), and `n` area-weighted samples of it.
pub fn vase_scene(n: usize, seed: u64) -> Result<Scene> {
    let tau = std::f64::consts::TAU;
    let mesh = parametric_mesh(192, 128, |u, v| {
        let radius = 0.45 + 0.25 * (1.5 * std::f64::consts::PI * v + 0.3).sin();
        let a = u * tau;
        // Clockwise in (x, z) as u grows keeps the grid's triangles facing outwards.
        DVec3::new(radius * a.cos(), 2.0 * v - 1.0, -radius * a.sin())
    });
    let cloud = sample_surface(&mesh, n, seed)?;
    Ok(Scene { cloud, mesh })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts_and_orientation() {
        let m = icosphere(3);
        assert_eq!(m.vertices.len(), 10 * 64 + 2);
        assert_eq!(m.triangles.len(), 20 * 64);
        for t in 0..m.triangles.len() {
            let [a, b, c] = m.corners(t);
            assert!(
                m.face_normal(t).dot((a + b + c) / 3.0) > 0.0,
                "triangle {t} faces inwards"
            );
        }
    }

    #[test]
    fn sphere_visibility_is_the_front_cap() {
        let eye = DVec3::new(0.0, 0.0, 3.0);
        // The visible cap from distance 3 is z > 1/3.
        for p in fibonacci_sphere(500) {
            assert_eq!(
                sphere_point_visible(DVec3::ZERO, p, eye),
                p.z > 1.0 / 3.0,
                "{p}"
            );
        }
    }

    #[test]
    fn ball_hides_the_plane_behind_it() {
        let (scene, g) = sphere_plane_scene(100, 100, 1);
        let eye = DVec3::new(0.0, 0.0, 5.0);
        assert!(!g.visible(DVec3::new(0.0, 0.0, 0.0), eye));
        assert!(g.visible(DVec3::new(1.9, 1.9, 0.0), eye));
        // From below, the square hides the whole ball.
        let below = DVec3::new(0.1, 0.2, -5.0);
        assert!(
            scene.cloud.positions[..100]
                .iter()
                .all(|&p| !g.visible(p, below))
        );
        // ... and nothing hides the square's points.
        assert!(
            scene.cloud.positions[100..]
                .iter()
                .all(|&p| g.visible(p, below))
        );
    }

    #[test]
    fn torus_and_vase_carry_uvs_and_face_outwards() {
        let torus = torus_scene(2000, 5).unwrap();
        assert!(
            torus
                .cloud
                .uvs
                .as_ref()
                .unwrap()
                .iter()
                .all(|uv| { (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y) })
        );
        // Outward: the normal points away from the tube's centre line.
        for (p, n) in torus
            .cloud
            .positions
            .iter()
            .zip(torus.cloud.normals.as_ref().unwrap())
        {
            let ring_point = DVec3::new(p.x, p.y, 0.0).normalize();
            assert!(n.as_dvec3().dot(*p - ring_point) > 0.0);
        }
        let vase = vase_scene(2000, 5).unwrap();
        for (p, n) in vase
            .cloud
            .positions
            .iter()
            .zip(vase.cloud.normals.as_ref().unwrap())
        {
            assert!(n.as_dvec3().dot(DVec3::new(p.x, 0.0, p.z)) > 0.0);
        }
    }
}
