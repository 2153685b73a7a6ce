//! The reference visibility every method is scored against: a depth buffer of the mesh.
//!
//! The mesh is rasterised ([`crate::raster`]) at the view's resolution times a factor s, the
//! smallest integer that makes the long side at least [`ReferenceParams::min_long_side`]
//! (2048 by default: s = 2 for the 1280 × 720 views). A point p is visible when
//!
//!   depth(p) ≤ surface_depth(p) + tolerance_px · pixel_size(depth(p)),
//!
//! where surface_depth(p) is the depth at which p's own ray (from the eye through p) first meets
//! one of the triangles the buffer shows in the 3 × 3 pixels around p's pixel, and
//! pixel_size(z) = z / focal_px is one reference pixel's footprint at depth z. Testing p's exact
//! ray against the triangles the buffer found (and, before calling p visible, against the
//! triangles around their corners, which catches occluding slivers between pixel centres) (rather than comparing with the depth at the pixel
//! centre, as Mehra et al. 2010 do) removes the slope error of steep and silhouette triangles, so
//! the tolerance only absorbs rounding and creases; half a pixel by default. When the ray meets
//! none of the candidates (p sits on a silhouette between pixel centres), p is visible. Points
//! that project outside the image or behind the eye are not visible. A triangle smaller than a
//! reference pixel that slips between the nine pixel centres and still crosses p's ray is
//! missed: the price of the z-buffer, measured against the exact test.
//!
//! The test in `tests/` checks this against the exact segment test ([`crate::exact`]) on the
//! bunny: at least 99.5% agreement on every view.

use cloud::glam::DVec3;
use cloud::{Camera, TriMesh};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::raster::{DepthBuffer, NO_TRIANGLE, rasterize};

/// Parameters of the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceParams {
    /// The long side of the depth buffer is at least this many pixels.
    pub min_long_side: u32,
    /// Depth tolerance in reference pixels at the point's depth.
    pub tolerance_px: f64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            min_long_side: 2048,
            tolerance_px: 0.5,
        }
    }
}

impl ReferenceParams {
    /// The supersampling factor for a view of `width` × `height`.
    pub fn factor(&self, width: u32, height: u32) -> u32 {
        self.min_long_side.div_ceil(width.max(height)).max(1)
    }
}

/// Per-point visibility from the mesh depth buffer, and the buffer itself.
#[derive(Debug, Clone)]
pub struct Reference {
    /// One flag per point.
    pub visible: Vec<bool>,
    /// The supersampled depth buffer.
    pub buffer: DepthBuffer,
    /// The camera the buffer was rendered with (the view at the supersampled resolution).
    pub camera: Camera,
}

/// Computes the reference visibility of `points` (which should lie on `mesh`) from `camera`.
pub fn reference_visibility(
    mesh: &TriMesh,
    points: &[DVec3],
    camera: &Camera,
    params: &ReferenceParams,
) -> Result<Reference> {
    if mesh.triangles.is_empty() {
        return Err(Error::EmptyMesh);
    }
    if !(params.tolerance_px >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "tolerance_px",
            reason: format!("must be >= 0, got {}", params.tolerance_px),
        });
    }
    cloud::points::check_finite(points)?;
    let s = params.factor(camera.width, camera.height);
    let big = camera.with_resolution(camera.width * s, camera.height * s)?;
    let buffer = rasterize(mesh, &big);
    let rings = VertexRings::new(mesh);
    let visible = points
        .par_iter()
        .map(|&p| point_visible(mesh, &rings, &buffer, &big, p, params.tolerance_px))
        .collect();
    Ok(Reference {
        visible,
        buffer,
        camera: big,
    })
}

fn point_visible(
    mesh: &TriMesh,
    rings: &VertexRings,
    buffer: &DepthBuffer,
    cam: &Camera,
    p: DVec3,
    tol_px: f64,
) -> bool {
    let Some(proj) = cam.project(p) else {
        return false;
    };
    let Some((x, y)) = proj.pixel(buffer.width, buffer.height) else {
        return false;
    };
    // The triangles the buffer shows around p's pixel are the candidates for the first
    // surface along p's own ray.
    let mut candidates = [NO_TRIANGLE; 9];
    let mut n_candidates = 0;
    for yy in y.saturating_sub(1)..=(y + 1).min(buffer.height - 1) {
        for xx in x.saturating_sub(1)..=(x + 1).min(buffer.width - 1) {
            let t = buffer.triangle[buffer.index(xx, yy)];
            if t != NO_TRIANGLE && !candidates[..n_candidates].contains(&t) {
                candidates[n_candidates] = t;
                n_candidates += 1;
            }
        }
    }
    let dir = p - cam.eye;
    let first_hit = |triangles: &mut dyn Iterator<Item = u32>| {
        triangles
            .filter_map(|t| segment_parameter(cam.eye, dir, mesh.corners(t as usize)))
            .fold(f64::INFINITY, f64::min)
    };
    let slack = tol_px * cam.pixel_size_at(proj.depth);
    // `surface` is in units of the eye-to-p segment; compare in depth units.
    let hidden_by = |surface: f64| proj.depth > surface * proj.depth + slack;
    if hidden_by(first_hit(&mut candidates[..n_candidates].iter().copied())) {
        return false;
    }
    // An occluder may be a sliver that covers none of the nine pixel centres: a triangle seen
    // at a grazing angle near a silhouette, crossing p's ray between the centres. Try the
    // triangles around the candidates' corners before calling p visible.
    !hidden_by(first_hit(&mut candidates[..n_candidates].iter().flat_map(|&t| {
        mesh.triangles[t as usize]
            .into_iter()
            .flat_map(|v| rings.around(v).iter().copied())
    })))
}

/// The triangles around each vertex (compressed rows).
struct VertexRings {
    start: Vec<u32>,
    triangles: Vec<u32>,
}

impl VertexRings {
    fn new(mesh: &TriMesh) -> Self {
        let mut start = vec![0u32; mesh.vertices.len() + 1];
        for tri in &mesh.triangles {
            for &v in tri {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..mesh.vertices.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut triangles = vec![0u32; 3 * mesh.triangles.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                triangles[fill[v as usize] as usize] = t as u32;
                fill[v as usize] += 1;
            }
        }
        Self { start, triangles }
    }

    fn around(&self, v: u32) -> &[u32] {
        &self.triangles[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

/// Parameter s > 0 at which the ray `origin + s·dir` meets the triangle (edges included, with
/// a relative slack of 1e-9 in the barycentric test), Möller–Trumbore in f64.
fn segment_parameter(origin: DVec3, dir: DVec3, [a, b, c]: [DVec3; 3]) -> Option<f64> {
    const SLACK: f64 = 1e-9;
    let e1 = b - a;
    let e2 = c - a;
    let pvec = dir.cross(e2);
    let det = e1.dot(pvec);
    if det.abs() <= f64::EPSILON * e1.length() * e2.length() * dir.length() {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = origin - a;
    let u = tvec.dot(pvec) * inv;
    if !(-SLACK..=1.0 + SLACK).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = dir.dot(qvec) * inv;
    if v < -SLACK || u + v > 1.0 + SLACK {
        return None;
    }
    let s = e2.dot(qvec) * inv;
    (s > 0.0).then_some(s)
}

#[cfg(test)]
mod tests {
    use cloud::synth::{sphere_plane_scene, sphere_point_visible, sphere_scene};
    use cloud::views::{ViewSpec, fibonacci_views};

    use super::*;

    fn agreement(a: &[bool], b: &[bool]) -> f64 {
        a.iter().zip(b).filter(|(x, y)| x == y).count() as f64 / a.len() as f64
    }

    #[test]
    fn sphere_matches_the_analytic_answer() {
        let scene = sphere_scene(20_000);
        let bbox = scene.cloud.bbox().unwrap();
        for cam in fibonacci_views(&bbox, &ViewSpec { n_views: 6, ..ViewSpec::default() }).unwrap() {
            let r = reference_visibility(
                &scene.mesh,
                &scene.cloud.positions,
                &cam,
                &ReferenceParams::default(),
            )
            .unwrap();
            let analytic: Vec<bool> = scene
                .cloud
                .positions
                .iter()
                .map(|&p| sphere_point_visible(DVec3::ZERO, p, cam.eye))
                .collect();
            let agree = agreement(&r.visible, &analytic);
            assert!(agree >= 0.995, "agreement {agree} for eye {}", cam.eye);
        }
    }

    #[test]
    fn sphere_plane_matches_the_analytic_answer() {
        let (scene, geometry) = sphere_plane_scene(8_000, 16_000, 9);
        let bbox = scene.cloud.bbox().unwrap();
        for cam in fibonacci_views(&bbox, &ViewSpec { n_views: 6, ..ViewSpec::default() }).unwrap() {
            let r = reference_visibility(
                &scene.mesh,
                &scene.cloud.positions,
                &cam,
                &ReferenceParams::default(),
            )
            .unwrap();
            let analytic: Vec<bool> = scene
                .cloud
                .positions
                .iter()
                .map(|&p| geometry.visible(p, cam.eye))
                .collect();
            let agree = agreement(&r.visible, &analytic);
            assert!(agree >= 0.995, "agreement {agree} for eye {}", cam.eye);
        }
    }

    #[test]
    fn factor_reaches_the_minimum_long_side() {
        let p = ReferenceParams::default();
        assert_eq!(p.factor(1280, 720), 2);
        assert_eq!(p.factor(4096, 100), 1);
        assert_eq!(p.factor(100, 1000), 3);
    }

    #[test]
    fn bad_inputs() {
        let scene = sphere_scene(100);
        let cam = Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 60.0, 64, 64).unwrap();
        let empty = TriMesh::default();
        assert!(matches!(
            reference_visibility(&empty, &scene.cloud.positions, &cam, &ReferenceParams::default()),
            Err(Error::EmptyMesh)
        ));
        assert!(matches!(
            reference_visibility(&scene.mesh, &[DVec3::NAN], &cam, &ReferenceParams::default()),
            Err(Error::Cloud(cloud::Error::NonFinite { index: 0 }))
        ));
        let bad = ReferenceParams { tolerance_px: -1.0, ..ReferenceParams::default() };
        assert!(matches!(
            reference_visibility(&scene.mesh, &scene.cloud.positions, &cam, &bad),
            Err(Error::InvalidParameter { .. })
        ));
    }
}
