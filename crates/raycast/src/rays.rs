//! The ray list of seed 001: one ray per pixel, built once for an image size and camera model,
//! re-aimed when the camera moves.
//!
//! "By associating a ray with a pixel as a permanent structure, we can have a list of rays that
//! will be used over and over again." Each pixel keeps its ray in camera axes (right, down,
//! forward), through the pixel centre (x + 0.5, y + 0.5); re-aiming for a camera is a change of
//! basis to the camera's axes, done on the fly while casting (nothing is rewritten per frame).
//! The seed casts from a pinhole; the list also holds the rays of the other camera models
//! (`cloud::camera`): parallel rays from the near plane (orthographic) and the unit directions
//! of an equirectangular image (spherical).

use cloud::glam::DVec3;
use cloud::{Camera, Model};

use crate::error::{Error, Result};

/// Per-pixel rays in camera axes.
#[derive(Debug, Clone, PartialEq)]
enum Layout {
    /// Pinhole: (right, down) components of the direction whose forward component is 1.
    Central(Vec<[f64; 2]>),
    /// Orthographic: (right, down) offsets of the origin from the eye; direction forward.
    Parallel(Vec<[f64; 2]>),
    /// Spherical: unit directions (right, down, forward).
    Sphere(Vec<[f64; 3]>),
}

/// One ray per pixel, in camera axes.
#[derive(Debug, Clone, PartialEq)]
pub struct RayList {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    model: Model,
    layout: Layout,
}

/// An upper bound of the bytes a view of `camera` over `n_points` points allocates: the ray
/// list (up to 24 bytes a pixel, spherical), the per-pixel hit (4 bytes a pixel), and the
/// visible set (a flag and an index per point). The per-dataset k-d tree is not included
/// (it is built once, before). `tests/memory_estimates.rs` checks it against the measured peak.
pub fn memory_estimate(camera: &Camera, n_points: usize) -> u128 {
    cloud::memory::image_bytes(camera.width, camera.height, 28, 1)
        + 5 * n_points as u128
        + (1 << 16)
}

impl RayList {
    /// The rays of `camera`'s image (its size and model); refused before allocating when the
    /// list and a frame's per-pixel hits (up to 28 bytes a pixel) would not fit in memory.
    pub fn new(camera: &Camera) -> Result<Self> {
        let (w, h) = (camera.width, camera.height);
        cloud::memory::ensure(
            memory_estimate(camera, 0),
            &format!("the ray list and per-pixel hits of a {w}x{h} image"),
        )
        .map_err(|e| Error::OutOfMemory(e.to_string()))?;
        let n = w as usize * h as usize;
        let (right, down, forward) = (camera.right(), camera.down(), camera.forward());
        let pixels = (0..h).flat_map(|y| (0..w).map(move |x| (x as f64 + 0.5, y as f64 + 0.5)));
        let layout = match camera.model() {
            Model::Pinhole { .. } => {
                let mut v = Vec::with_capacity(n);
                v.extend(pixels.map(|(x, y)| {
                    let (_, d) = camera.ray(x, y);
                    [d.dot(right), d.dot(down)]
                }));
                Layout::Central(v)
            }
            Model::Orthographic { .. } => {
                let mut v = Vec::with_capacity(n);
                v.extend(pixels.map(|(x, y)| {
                    let (o, _) = camera.ray(x, y);
                    [(o - camera.eye).dot(right), (o - camera.eye).dot(down)]
                }));
                Layout::Parallel(v)
            }
            Model::Spherical => {
                let mut v = Vec::with_capacity(n);
                v.extend(pixels.map(|(x, y)| {
                    let (_, d) = camera.ray(x, y);
                    [d.dot(right), d.dot(down), d.dot(forward)]
                }));
                Layout::Sphere(v)
            }
        };
        Ok(Self {
            width: w,
            height: h,
            model: *camera.model(),
            layout,
        })
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Checks that `camera` has this list's image size and model.
    pub fn check(&self, camera: &Camera) -> Result<()> {
        if camera.width != self.width
            || camera.height != self.height
            || *camera.model() != self.model
        {
            return Err(Error::CameraMismatch {
                list: format!("{}x{} {:?}", self.width, self.height, self.model),
                camera: format!("{}x{} {:?}", camera.width, camera.height, camera.model()),
            });
        }
        Ok(())
    }

    /// The world-space ray (origin, direction) of pixel `k` for `camera`.
    #[inline(always)]
    pub fn aim(&self, camera: &Camera, k: usize) -> ([f64; 3], [f64; 3]) {
        let (r, d, f) = (camera.right(), camera.down(), camera.forward());
        let (o, dir): (DVec3, DVec3) = match &self.layout {
            Layout::Central(v) => {
                let [u, w] = v[k];
                (camera.eye, f + r * u + d * w)
            }
            Layout::Parallel(v) => {
                let [u, w] = v[k];
                (camera.eye + r * u + d * w, f)
            }
            Layout::Sphere(v) => {
                let [a, b, c] = v[k];
                (camera.eye, r * a + d * b + f * c)
            }
        };
        (o.to_array(), dir.to_array())
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;

    use super::*;

    #[test]
    fn rays_pass_through_their_pixel_centres() {
        for model in [
            Model::pinhole_fov(50.0, 64, 48).unwrap(),
            Model::Orthographic {
                view_width: 2.0,
                view_height: 1.5,
            },
            Model::Spherical,
        ] {
            let cam = Camera::look_at(
                DVec3::new(1.0, 2.0, 5.0),
                DVec3::ZERO,
                DVec3::Y,
                model,
                64,
                48,
            )
            .unwrap();
            let rays = RayList::new(&cam).unwrap();
            assert_eq!(rays.len(), 64 * 48);
            for (k, (x, y)) in [
                (0usize, (0, 0)),
                (64 * 47 + 63, (63, 47)),
                (64 * 20 + 31, (31, 20)),
            ] {
                let (o, d) = rays.aim(&cam, k);
                let p = cam
                    .project(DVec3::from_array(o) + DVec3::from_array(d) * 3.0)
                    .unwrap();
                assert!(
                    (p.x - (x as f64 + 0.5)).abs() < 1e-9 && (p.y - (y as f64 + 0.5)).abs() < 1e-9,
                    "{model:?} {p:?}"
                );
            }
            assert!(rays.check(&cam.with_resolution(32, 48).unwrap()).is_err());
        }
    }
}
