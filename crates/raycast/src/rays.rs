//! The ray list of seed 001: one ray per pixel, built once for an image size and field of view,
//! re-aimed when the camera moves.
//!
//! "By associating a ray with a pixel as a permanent structure, we can have a list of rays that
//! will be used over and over again." Each pixel keeps its direction in camera space, through
//! the pixel centre (x + 0.5, y + 0.5), so every ray lies in the view frustum; re-aiming for a
//! camera is a change of basis to the camera's right, up and forward vectors, done on the fly
//! while casting (nothing is rewritten per frame).

use cloud::Camera;

use crate::error::{Error, Result};

/// One ray per pixel, in camera space.
#[derive(Debug, Clone, PartialEq)]
pub struct RayList {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f64,
    /// Per pixel (row-major): (right, up) components of the direction whose forward component
    /// is 1.
    pub dirs: Vec<[f64; 2]>,
}

impl RayList {
    /// The rays of `camera`'s image (its size and field of view).
    pub fn new(camera: &Camera) -> Self {
        let (w, h) = (camera.width, camera.height);
        let inv_f = 1.0 / camera.focal_px();
        let mut dirs = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h {
            for x in 0..w {
                dirs.push([
                    (x as f64 + 0.5 - 0.5 * w as f64) * inv_f,
                    (0.5 * h as f64 - y as f64 - 0.5) * inv_f,
                ]);
            }
        }
        Self {
            width: w,
            height: h,
            fov_y_deg: camera.fov_y_deg,
            dirs,
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// Checks that `camera` has this list's image size and field of view.
    pub fn check(&self, camera: &Camera) -> Result<()> {
        if camera.width != self.width
            || camera.height != self.height
            || camera.fov_y_deg != self.fov_y_deg
        {
            return Err(Error::CameraMismatch {
                list: (self.width, self.height, self.fov_y_deg),
                camera: (camera.width, camera.height, camera.fov_y_deg),
            });
        }
        Ok(())
    }

    /// The world-space direction of pixel `k` for `camera`.
    #[inline(always)]
    pub fn aim(&self, camera: &Camera, k: usize) -> [f64; 3] {
        let [u, v] = self.dirs[k];
        (camera.forward() + camera.right() * u + camera.true_up() * v).to_array()
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;

    use super::*;

    #[test]
    fn rays_pass_through_their_pixel_centres() {
        let cam = Camera::new(
            DVec3::new(1.0, 2.0, 5.0),
            DVec3::ZERO,
            DVec3::Y,
            50.0,
            64,
            48,
        )
        .unwrap();
        let rays = RayList::new(&cam);
        assert_eq!(rays.len(), 64 * 48);
        for (k, (x, y)) in [
            (0usize, (0, 0)),
            (64 * 47 + 63, (63, 47)),
            (64 * 20 + 31, (31, 20)),
        ] {
            let d = DVec3::from_array(rays.aim(&cam, k));
            let p = cam.project(cam.eye + d * 3.0).unwrap();
            assert!((p.x - (x as f64 + 0.5)).abs() < 1e-9 && (p.y - (y as f64 + 0.5)).abs() < 1e-9);
        }
        assert!(rays.check(&cam.with_resolution(32, 48).unwrap()).is_err());
    }
}
