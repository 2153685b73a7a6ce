//! The reference visibility every method is scored against: a depth buffer of the mesh.
//!
//! The mesh is rasterised ([`crate::raster`]) at the view's resolution times a factor s, the
//! smallest integer that makes the long side at least [`ReferenceParams::min_long_side`]
//! (2048 by default: s = 2 for the 1280 × 720 views). A point p is visible when
//!
//!   depth(p) ≤ surface_depth(p) + tolerance_px · pixel_size(depth(p)),
//!
//! where pixel_size(z) = z / focal_px is one reference pixel's footprint at depth z and
//! surface_depth(p) is the depth at which p's own ray (from the eye through p) first meets one
//! of the triangles the buffer shows in the 3 × 3 pixels around p's pixel. Testing p's exact ray
//! against the triangles the buffer found, rather than comparing with the depth at the pixel
//! centre as Mehra et al. (2010) do, removes the slope error of steep triangles, so the
//! tolerance only absorbs rounding and creases: half a pixel by default. Before p is called
//! visible its ray is also tried against the triangles around those triangles' corners, which
//! catches occluders too thin to cover a pixel centre.
//!
//! Silhouettes are where a z-buffer is unreliable: near an edge-on surface the occluder of a
//! point can be a stack of slivers thinner than a pixel. A point is *ambiguous* when one of its
//! nine pixels shows no triangle or one of its candidate triangles is within
//! [`ReferenceParams::grazing_cos`] of edge-on (|n̂·d̂| < 0.2, about 12°); ambiguous points are
//! resolved by the exact segment test ([`crate::exact`]) with the same tolerance. The share of
//! points resolved that way is reported ([`ReferenceView::n_exact`]).
//!
//! Camera models (`cloud::camera`): pinhole and orthographic cameras rasterise as above (an
//! orthographic point's ray starts at its foot on the near plane, parallel to the axis);
//! spherical cameras have no z-buffer (an equirectangular image bends triangles): every point
//! gets the exact segment test from the eye with the same tolerance (`buffer` is then empty).
//! Points that project
//! outside the image or behind the eye are not visible.
//!
//! Validation: `tests/reference_bunny.rs` compares the pure z-buffer decision (no exact
//! fallback) and the full reference with the exact test on bunny-69451, every view; the unit
//! tests compare with the analytic answers of the synthetic sphere and sphere-plane scenes.

use cloud::glam::DVec3;
use cloud::{Camera, TriMesh};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::exact::ExactVisibility;
use crate::raster::{DepthBuffer, NO_TRIANGLE, rasterize};

/// Parameters of the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceParams {
    /// The long side of the depth buffer is at least this many pixels.
    pub min_long_side: u32,
    /// Depth tolerance in reference pixels at the point's depth.
    pub tolerance_px: f64,
    /// A candidate triangle with |cos(normal, ray)| below this makes a point ambiguous.
    pub grazing_cos: f64,
    /// Resolve ambiguous points with the exact segment test (true) or keep the z-buffer
    /// decision (false, for measuring the z-buffer alone).
    pub exact_fallback: bool,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            min_long_side: 2048,
            tolerance_px: 0.5,
            grazing_cos: 0.2,
            exact_fallback: true,
        }
    }
}

impl ReferenceParams {
    /// The supersampling factor for a view of `width` × `height`.
    pub fn factor(&self, width: u32, height: u32) -> u32 {
        self.min_long_side.div_ceil(width.max(height)).max(1)
    }
}

/// The reference visibility of one view.
#[derive(Debug, Clone)]
pub struct ReferenceView {
    /// One flag per point.
    pub visible: Vec<bool>,
    /// The supersampled depth buffer (empty for spherical cameras).
    pub buffer: DepthBuffer,
    /// The camera the buffer was rendered with (the view at the supersampled resolution).
    pub camera: Camera,
    /// How many points were ambiguous and resolved by the exact test.
    pub n_exact: usize,
}

/// A mesh prepared for reference queries: vertex rings and the exact test's BVH, built once
/// and reused for every view.
#[derive(Debug)]
pub struct Reference {
    mesh: TriMesh,
    rings: VertexRings,
    exact: ExactVisibility,
}

impl Reference {
    /// Prepares `mesh`.
    pub fn new(mesh: &TriMesh) -> Result<Self> {
        let exact = ExactVisibility::new(mesh)?;
        Ok(Self {
            mesh: mesh.clone(),
            rings: VertexRings::new(mesh),
            exact,
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The exact test over the same mesh.
    pub fn exact(&self) -> &ExactVisibility {
        &self.exact
    }

    /// The reference visibility of `points` (which should lie on the mesh) from `camera`.
    pub fn visibility(
        &self,
        points: &[DVec3],
        camera: &Camera,
        params: &ReferenceParams,
    ) -> Result<ReferenceView> {
        if !(params.tolerance_px >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "tolerance_px",
                reason: format!("must be >= 0, got {}", params.tolerance_px),
            });
        }
        cloud::points::check_finite(points)?;
        let s = params.factor(camera.width, camera.height);
        let big = camera.with_resolution(camera.width * s, camera.height * s)?;
        let (buffer, decisions) = if camera.has_frustum() {
            let buffer = rasterize(&self.mesh, &big)?;
            let decisions: Vec<Decision> = points
                .par_iter()
                .map(|&p| self.decide(&buffer, &big, p, params))
                .collect();
            (buffer, decisions)
        } else {
            // NOTE: no z-buffer for the equirectangular image (triangles are curved there):
            // every point gets the exact segment test, with the same tolerance.
            let decisions = points
                .par_iter()
                .map(|&p| {
                    let depth = big.depth(p);
                    if !(depth > 0.0) {
                        return Decision::ZBuffer(false);
                    }
                    let slack = params.tolerance_px * big.pixel_size_at(depth);
                    let margin = (slack / depth).max(crate::exact::SEGMENT_MARGIN);
                    Decision::Exact(self.exact.is_visible_with_margin(big.eye, p, margin))
                })
                .collect();
            let empty = DepthBuffer {
                width: 0,
                height: 0,
                depth: Vec::new(),
                triangle: Vec::new(),
            };
            (empty, decisions)
        };
        let n_exact = decisions
            .iter()
            .filter(|d| **d == Decision::Exact(true) || **d == Decision::Exact(false))
            .count();
        Ok(ReferenceView {
            visible: decisions
                .iter()
                .map(|d| matches!(d, Decision::ZBuffer(true) | Decision::Exact(true)))
                .collect(),
            buffer,
            camera: big,
            n_exact,
        })
    }

    fn decide(
        &self,
        buffer: &DepthBuffer,
        cam: &Camera,
        p: DVec3,
        params: &ReferenceParams,
    ) -> Decision {
        let Some(proj) = cam.project(p) else {
            return Decision::ZBuffer(false);
        };
        let Some((x, y)) = proj.pixel(buffer.width, buffer.height) else {
            return Decision::ZBuffer(false);
        };
        let origin = cam.ray_origin_for(p);
        let dir = p - origin;
        let dir_len = dir.length();
        // The triangles the buffer shows around p's pixel are the candidates for the first
        // surface along p's own ray.
        let mut candidates = [NO_TRIANGLE; 9];
        let mut n_candidates = 0;
        let mut ambiguous = false;
        for yy in y.saturating_sub(1)..=(y + 1).min(buffer.height - 1) {
            for xx in x.saturating_sub(1)..=(x + 1).min(buffer.width - 1) {
                let t = buffer.triangle[buffer.index(xx, yy)];
                if t == NO_TRIANGLE {
                    ambiguous = true;
                } else if !candidates[..n_candidates].contains(&t) {
                    candidates[n_candidates] = t;
                    n_candidates += 1;
                    let [a, b, c] = self.mesh.corners(t as usize);
                    let n = (b - a).cross(c - a);
                    if n.dot(dir).abs() < params.grazing_cos * n.length() * dir_len {
                        ambiguous = true;
                    }
                }
            }
        }
        let slack = params.tolerance_px * cam.pixel_size_at(proj.depth);
        if ambiguous && params.exact_fallback {
            let margin = (slack / proj.depth).max(crate::exact::SEGMENT_MARGIN);
            return Decision::Exact(self.exact.is_visible_with_margin(origin, p, margin));
        }
        let first_hit = |triangles: &mut dyn Iterator<Item = u32>| {
            triangles
                .filter_map(|t| segment_parameter(origin, dir, self.mesh.corners(t as usize)))
                .fold(f64::INFINITY, f64::min)
        };
        // `surface` is in units of the eye-to-p segment; compare in depth units.
        let hidden_by = |surface: f64| proj.depth > surface * proj.depth + slack;
        if hidden_by(first_hit(&mut candidates[..n_candidates].iter().copied())) {
            return Decision::ZBuffer(false);
        }
        let rings = &self.rings;
        Decision::ZBuffer(!hidden_by(first_hit(
            &mut candidates[..n_candidates].iter().flat_map(|&t| {
                self.mesh.triangles[t as usize]
                    .into_iter()
                    .flat_map(|v| rings.around(v).iter().copied())
            }),
        )))
    }
}

/// How a point's visibility was decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Decision {
    ZBuffer(bool),
    Exact(bool),
}

/// One-shot convenience: prepares `mesh` and computes one view.
pub fn reference_visibility(
    mesh: &TriMesh,
    points: &[DVec3],
    camera: &Camera,
    params: &ReferenceParams,
) -> Result<ReferenceView> {
    Reference::new(mesh)?.visibility(points, camera, params)
}

/// The triangles around each vertex (compressed rows).
#[derive(Debug)]
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

    /// Checks the reference against an analytic answer: total agreement at least `min_total`,
    /// and no disagreement at all on points the `ambiguous` predicate does not exempt. The
    /// meshes are inscribed approximations (an icosphere of 81,920 triangles lies up to
    /// 1.2e-4 inside the unit sphere), so rays grazing the true sphere within about 1e-2 rad
    /// may legitimately disagree, and the z-buffer itself is approximate within a pixel or two of
    /// a silhouette, where the rays are grazing.
    fn check_against_analytic(
        scene: &cloud::synth::Scene,
        analytic: impl Fn(DVec3, DVec3) -> bool,
        ambiguous: impl Fn(DVec3, DVec3) -> bool,
        min_total: f64,
    ) {
        let bbox = scene.cloud.bbox().unwrap();
        let spec = ViewSpec {
            n_views: 6,
            ..ViewSpec::default()
        };
        for cam in fibonacci_views(&bbox, &spec).unwrap() {
            let r = reference_visibility(
                &scene.mesh,
                &scene.cloud.positions,
                &cam,
                &ReferenceParams::default(),
            )
            .unwrap();
            let mut agree = 0;
            for (&p, &v) in scene.cloud.positions.iter().zip(&r.visible) {
                let expected = analytic(p, cam.eye);
                if v == expected {
                    agree += 1;
                } else {
                    assert!(ambiguous(p, cam.eye), "{p} from {}: reference {v}", cam.eye);
                }
            }
            let total = agree as f64 / r.visible.len() as f64;
            assert!(total >= min_total, "agreement {total} from {}", cam.eye);
        }
    }

    /// |cos| of the angle between the sphere normal at p and the direction to the eye.
    fn grazing(center: DVec3, p: DVec3, eye: DVec3) -> f64 {
        (p - center).normalize().dot((eye - p).normalize()).abs()
    }

    #[test]
    fn sphere_matches_the_analytic_answer() {
        let scene = sphere_scene(20_000);
        check_against_analytic(
            &scene,
            |p, eye| sphere_point_visible(DVec3::ZERO, p, eye),
            |p, eye| grazing(DVec3::ZERO, p, eye) < 0.1,
            0.995,
        );
    }

    #[test]
    fn sphere_plane_matches_the_analytic_answer() {
        let (scene, g) = sphere_plane_scene(8_000, 16_000, 9);
        check_against_analytic(
            &scene,
            |p, eye| g.visible(p, eye),
            |p, eye| {
                let on_sphere = ((p - g.center).length() - g.radius).abs() < 1e-9;
                // Distance from the ball's centre to the eye-to-p segment.
                let d = p - eye;
                let t = ((g.center - eye).dot(d) / d.length_squared()).clamp(0.0, 1.0);
                let miss = (eye + t * d - g.center).length() / g.radius - 1.0;
                (on_sphere && grazing(g.center, p, eye) < 0.1) || (!on_sphere && miss.abs() < 0.02)
            },
            0.995,
        );
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
        let cam = Camera::new(
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            60.0,
            64,
            64,
        )
        .unwrap();
        let empty = TriMesh::default();
        assert!(matches!(
            reference_visibility(
                &empty,
                &scene.cloud.positions,
                &cam,
                &ReferenceParams::default()
            ),
            Err(Error::EmptyMesh)
        ));
        assert!(matches!(
            reference_visibility(
                &scene.mesh,
                &[DVec3::NAN],
                &cam,
                &ReferenceParams::default()
            ),
            Err(Error::Cloud(cloud::Error::NonFinite { index: 0 }))
        ));
        let bad = ReferenceParams {
            tolerance_px: -1.0,
            ..ReferenceParams::default()
        };
        assert!(matches!(
            reference_visibility(&scene.mesh, &scene.cloud.positions, &cam, &bad),
            Err(Error::InvalidParameter { .. })
        ));
    }
}
