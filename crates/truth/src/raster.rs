//! Depth-buffer rasterisation of a triangle mesh, tile-parallel.
//!
//! Each pixel keeps the depth (distance along the view axis) of the nearest triangle covering
//! its centre and that triangle's index. Conventions are the camera's (`cloud::camera`): pixel
//! (i, j) has its centre at (i + 0.5, j + 0.5). Coverage is the inclusive edge-function test at
//! pixel centres; both faces of every triangle are drawn (no back-face culling: the meshes are
//! not assumed closed or consistently oriented). Depth is interpolated perspective-correctly
//! for pinhole cameras (1/z is affine in screen space) and linearly for orthographic ones (z
//! is affine there). Triangles are clipped against a near plane at `near = 1e-6 · depth range`
//! in front of the eye (Sutherland–Hodgman), so any camera works, including one inside the
//! object. Spherical cameras are refused: triangles are not straight in an equirectangular
//! image (the reference tests each point's ray exactly there).
//!
//! Parallelism: triangles are binned into 64 × 64 tiles, tiles are rasterised independently
//! with rayon.

use cloud::glam::{DVec2, DVec3};
use cloud::{Camera, Model, TriMesh};
use rayon::prelude::*;

use crate::error::Result;

/// "No triangle" in [`DepthBuffer::triangle`].
pub const NO_TRIANGLE: u32 = u32::MAX;

const TILE: usize = 64;

/// A depth buffer with the index of the nearest triangle per pixel.
#[derive(Debug, Clone)]
pub struct DepthBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Depth per pixel, row-major; `f64::INFINITY` where no triangle covers the centre.
    pub depth: Vec<f64>,
    /// Nearest triangle per pixel, row-major; [`NO_TRIANGLE`] where none.
    pub triangle: Vec<u32>,
}

impl DepthBuffer {
    /// Index of pixel (x, y) in the row-major arrays.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Number of pixels covered by some triangle.
    pub fn covered(&self) -> usize {
        self.triangle.iter().filter(|&&t| t != NO_TRIANGLE).count()
    }
}

/// A triangle in screen space: pixel coordinates and, at the corners, the quantity that is
/// affine in screen space (1/depth for pinhole, depth for orthographic).
#[derive(Debug, Clone, Copy)]
struct ScreenTri {
    p: [DVec2; 3],
    inv_z: [f64; 3],
    id: u32,
}

/// An upper bound of the bytes [`rasterize`] allocates: the buffer (8 B depth + 4 B triangle
/// per pixel) and the tiles' copies of it, and per triangle its screen form and its tile bins.
/// `tests/memory_estimates.rs` checks it against the measured peak.
pub fn memory_estimate(mesh: &TriMesh, camera: &Camera) -> u128 {
    cloud::memory::image_bytes(camera.width, camera.height, 12, 2)
        + 128 * mesh.triangles.len() as u128
        + (1 << 16)
}

/// Rasterises `mesh` as seen by `camera` (pinhole or orthographic) at the camera's resolution.
pub fn rasterize(mesh: &TriMesh, camera: &Camera) -> Result<DepthBuffer> {
    camera.require("the mesh rasteriser", &["pinhole", "orthographic"])?;
    let perspective = matches!(camera.model(), Model::Pinhole { .. });
    cloud::memory::ensure(
        memory_estimate(mesh, camera),
        &format!(
            "the mesh depth buffer of {}x{} pixels",
            camera.width, camera.height
        ),
    )?;
    let (width, height) = (camera.width as usize, camera.height as usize);
    let tris = screen_triangles(mesh, camera);

    // Bin triangles into tiles by their screen bounding box.
    let tiles_x = width.div_ceil(TILE);
    let tiles_y = height.div_ceil(TILE);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); tiles_x * tiles_y];
    for (k, t) in tris.iter().enumerate() {
        let Some((x0, y0, x1, y1)) = pixel_bounds(t, width, height) else {
            continue;
        };
        for ty in y0 / TILE..=y1 / TILE {
            for tx in x0 / TILE..=x1 / TILE {
                bins[ty * tiles_x + tx].push(k as u32);
            }
        }
    }

    let tiles: Vec<(usize, Vec<f64>, Vec<u32>)> = bins
        .par_iter()
        .enumerate()
        .map(|(tile, list)| {
            let (tx, ty) = (tile % tiles_x, tile / tiles_x);
            let (ox, oy) = (tx * TILE, ty * TILE);
            let (tw, th) = (TILE.min(width - ox), TILE.min(height - oy));
            let mut depth = vec![f64::INFINITY; tw * th];
            let mut ids = vec![NO_TRIANGLE; tw * th];
            for &k in list {
                draw(
                    &tris[k as usize],
                    perspective,
                    ox,
                    oy,
                    tw,
                    th,
                    &mut depth,
                    &mut ids,
                );
            }
            (tile, depth, ids)
        })
        .collect();

    let mut buffer = DepthBuffer {
        width: camera.width,
        height: camera.height,
        depth: vec![f64::INFINITY; width * height],
        triangle: vec![NO_TRIANGLE; width * height],
    };
    for (tile, depth, ids) in tiles {
        let (ox, oy) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let tw = TILE.min(width - ox);
        for (row, (d, t)) in depth.chunks(tw).zip(ids.chunks(tw)).enumerate() {
            let start = (oy + row) * width + ox;
            buffer.depth[start..start + tw].copy_from_slice(d);
            buffer.triangle[start..start + tw].copy_from_slice(t);
        }
    }
    Ok(buffer)
}

/// Projects (and near-clips) every triangle.
fn screen_triangles(mesh: &TriMesh, camera: &Camera) -> Vec<ScreenTri> {
    let depths: Vec<f64> = mesh.vertices.iter().map(|&v| camera.depth(v)).collect();
    let far = depths.iter().copied().fold(0.0f64, f64::max);
    let near = (1e-6 * far).max(f64::MIN_POSITIVE);
    let (right, down) = (camera.right(), camera.down());
    let (w, h) = (camera.width as f64, camera.height as f64);
    let to_screen = |v: DVec3, z: f64| -> (DVec2, f64) {
        let rel = v - camera.eye;
        match *camera.model() {
            Model::Pinhole { fx, fy, cx, cy } => (
                DVec2::new(cx + fx * rel.dot(right) / z, cy + fy * rel.dot(down) / z),
                1.0 / z,
            ),
            Model::Orthographic {
                view_width,
                view_height,
            } => (
                DVec2::new(
                    0.5 * w + rel.dot(right) * w / view_width,
                    0.5 * h + rel.dot(down) * h / view_height,
                ),
                z,
            ),
            // Refused by `rasterize`.
            Model::Spherical => (DVec2::NAN, f64::NAN),
        }
    };
    let mut out = Vec::with_capacity(mesh.triangles.len());
    for (id, tri) in mesh.triangles.iter().enumerate() {
        let corners = tri.map(|v| (mesh.vertices[v as usize], depths[v as usize]));
        if corners.iter().all(|&(_, z)| z > near) {
            let s = corners.map(|(v, z)| to_screen(v, z));
            out.push(ScreenTri {
                p: s.map(|(p, _)| p),
                inv_z: s.map(|(_, iz)| iz),
                id: id as u32,
            });
            continue;
        }
        // Sutherland–Hodgman against depth = near.
        let mut poly: Vec<(DVec3, f64)> = Vec::with_capacity(4);
        for i in 0..3 {
            let (a, za) = corners[i];
            let (b, zb) = corners[(i + 1) % 3];
            if za > near {
                poly.push((a, za));
            }
            if (za > near) != (zb > near) {
                let t = (near - za) / (zb - za);
                poly.push((a + t * (b - a), near));
            }
        }
        for i in 1..poly.len().saturating_sub(1) {
            let s = [poly[0], poly[i], poly[i + 1]].map(|(v, z)| to_screen(v, z));
            out.push(ScreenTri {
                p: s.map(|(p, _)| p),
                inv_z: s.map(|(_, iz)| iz),
                id: id as u32,
            });
        }
    }
    out
}

/// Inclusive pixel range whose centres the triangle's bounding box may cover.
fn pixel_bounds(
    t: &ScreenTri,
    width: usize,
    height: usize,
) -> Option<(usize, usize, usize, usize)> {
    let min = t.p[0].min(t.p[1]).min(t.p[2]);
    let max = t.p[0].max(t.p[1]).max(t.p[2]);
    // Centres at i + 0.5: the first centre >= min.x is ceil(min.x - 0.5).
    let x0 = (min.x - 0.5).ceil().max(0.0);
    let y0 = (min.y - 0.5).ceil().max(0.0);
    let x1 = (max.x - 0.5).floor().min(width as f64 - 1.0);
    let y1 = (max.y - 0.5).floor().min(height as f64 - 1.0);
    if !(x0 <= x1 && y0 <= y1) {
        return None;
    }
    Some((x0 as usize, y0 as usize, x1 as usize, y1 as usize))
}

#[inline]
fn edge(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

/// Draws one triangle into a tile's buffers.
#[allow(clippy::too_many_arguments)]
fn draw(
    t: &ScreenTri,
    perspective: bool,
    ox: usize,
    oy: usize,
    tw: usize,
    th: usize,
    depth: &mut [f64],
    ids: &mut [u32],
) {
    let area = edge(t.p[0], t.p[1], t.p[2]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    // Orient counter-clockwise in the edge-function sense so inside means all >= 0.
    let (p, iz) = if area > 0.0 {
        (t.p, t.inv_z)
    } else {
        (
            [t.p[0], t.p[2], t.p[1]],
            [t.inv_z[0], t.inv_z[2], t.inv_z[1]],
        )
    };
    let inv_area = 1.0 / area.abs();
    let Some((x0, y0, x1, y1)) = pixel_bounds(t, ox + tw, oy + th) else {
        return;
    };
    let (x0, y0) = (x0.max(ox), y0.max(oy));
    if x0 > x1 || y0 > y1 {
        return;
    }
    for y in y0..=y1 {
        for x in x0..=x1 {
            let c = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let w0 = edge(p[1], p[2], c);
            let w1 = edge(p[2], p[0], c);
            let w2 = edge(p[0], p[1], c);
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let affine = (w0 * iz[0] + w1 * iz[1] + w2 * iz[2]) * inv_area;
            let z = if perspective { 1.0 / affine } else { affine };
            let k = (y - oy) * tw + (x - ox);
            if z < depth[k] {
                depth[k] = z;
                ids[k] = t.id;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(w: u32, h: u32) -> Camera {
        Camera::new(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, DVec3::Y, 60.0, w, h).unwrap()
    }

    fn quad(z: f64, half: f64) -> TriMesh {
        TriMesh::new(
            vec![
                DVec3::new(-half, -half, z),
                DVec3::new(half, -half, z),
                DVec3::new(half, half, z),
                DVec3::new(-half, half, z),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn a_facing_quad_has_exact_depth_and_no_gaps() {
        let cam = camera(130, 70);
        let buf = rasterize(&quad(0.0, 0.5), &cam).unwrap();
        let mut covered = 0;
        for y in 0..cam.height {
            for x in 0..cam.width {
                let k = buf.index(x, y);
                let (_, dir) = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
                let hit = cam.eye + dir * 4.0;
                let inside = hit.x.abs() <= 0.5 && hit.y.abs() <= 0.5;
                // Pixels whose centre ray hits the quad are covered, the others are not
                // (up to the inclusive edges).
                if inside && hit.x.abs() < 0.499 && hit.y.abs() < 0.499 {
                    assert!((buf.depth[k] - 4.0).abs() < 1e-12, "{x},{y}");
                    covered += 1;
                } else if !inside {
                    assert_eq!(buf.triangle[k], NO_TRIANGLE, "{x},{y}");
                }
            }
        }
        assert!(covered > 100);
    }

    #[test]
    fn nearer_surface_wins_and_tiles_agree_with_one_tile() {
        let mut mesh = quad(0.0, 0.8);
        let near = quad(1.0, 0.3);
        let base = mesh.vertices.len() as u32;
        mesh.vertices.extend(near.vertices);
        mesh.triangles
            .extend(near.triangles.iter().map(|t| t.map(|v| v + base)));
        let cam = camera(300, 200);
        let buf = rasterize(&mesh, &cam).unwrap();
        let centre = buf.index(150, 100);
        assert!((buf.depth[centre] - 3.0).abs() < 1e-12);
        assert!(buf.triangle[centre] >= 2);
        let corner = cam.project(DVec3::new(0.7, 0.7, 0.0)).unwrap();
        let k = buf.index(corner.x as u32, corner.y as u32);
        assert!((buf.depth[k] - 4.0).abs() < 1e-12);
    }

    #[test]
    fn perspective_correct_depth_on_a_slanted_triangle() {
        let mesh = TriMesh::new(
            vec![
                DVec3::new(-1.0, -1.0, -2.0),
                DVec3::new(1.0, -1.0, -2.0),
                DVec3::new(0.0, 1.0, 1.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let cam = camera(200, 200);
        let buf = rasterize(&mesh, &cam).unwrap();
        let n = mesh.face_normal(0);
        let a = mesh.vertices[0];
        let mut checked = 0;
        for y in 0..200 {
            for x in 0..200 {
                let k = buf.index(x, y);
                if buf.triangle[k] == NO_TRIANGLE {
                    continue;
                }
                let (_, d) = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
                let t = n.dot(a - cam.eye) / n.dot(d);
                assert!(
                    (buf.depth[k] - t).abs() < 1e-9 * t,
                    "{} vs {t}",
                    buf.depth[k]
                );
                checked += 1;
            }
        }
        assert!(checked > 1000);
    }

    #[test]
    fn a_triangle_through_the_eye_plane_is_clipped_not_lost() {
        // The quad extends behind the camera: only its front part is drawn.
        let mesh = TriMesh::new(
            vec![
                DVec3::new(-1.0, -0.5, 10.0),
                DVec3::new(1.0, -0.5, 10.0),
                DVec3::new(1.0, -0.5, -10.0),
                DVec3::new(-1.0, -0.5, -10.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let cam = camera(100, 100);
        let buf = rasterize(&mesh, &cam).unwrap();
        assert!(buf.covered() > 1000);
        assert!(buf.depth.iter().all(|&d| d > 0.0));
    }
}
