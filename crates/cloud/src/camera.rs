//! A pinhole camera: eye, target, up, vertical field of view, image size in pixels.
//!
//! Conventions, used by every method and by the ground truth:
//! - view space: `forward` = normalised (target − eye), `right` = forward × up, `up` the
//!   re-orthogonalised up vector; depth is the distance along `forward` (not along the ray);
//! - pixel space: x to the right in [0, width), y downwards in [0, height); pixel (i, j) covers
//!   [i, i+1) × [j, j+1) and its centre is (i + 0.5, j + 0.5);
//! - the focal length in pixels is f = (height / 2) / tan(fov_y / 2), square pixels.

use glam::DVec3;

use crate::error::{Error, Result};

/// A point projected into the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Continuous pixel x (0 at the left edge).
    pub x: f64,
    /// Continuous pixel y (0 at the top edge).
    pub y: f64,
    /// Depth along the view axis (positive in front of the eye).
    pub depth: f64,
}

impl Projection {
    /// The pixel containing the projection, if it lies inside a `width` × `height` image.
    #[inline]
    pub fn pixel(&self, width: u32, height: u32) -> Option<(u32, u32)> {
        if self.x >= 0.0 && self.y >= 0.0 && self.x < width as f64 && self.y < height as f64 {
            Some((self.x as u32, self.y as u32))
        } else {
            None
        }
    }
}

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Centre of projection.
    pub eye: DVec3,
    /// The point looked at.
    pub target: DVec3,
    /// The requested up vector (not necessarily orthogonal to the view direction).
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    forward: DVec3,
    right: DVec3,
    true_up: DVec3,
    focal_px: f64,
}

impl Camera {
    /// Builds a camera; fails when eye = target, up is parallel to the view direction, the
    /// field of view is outside (0, 180) degrees, the image is empty or a value is not finite.
    pub fn new(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        fov_y_deg: f64,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(Error::DegenerateCamera(
                "non-finite eye, target or up".into(),
            ));
        }
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(Error::DegenerateCamera(format!(
                "vertical field of view {fov_y_deg} is not in (0, 180) degrees"
            )));
        }
        if width == 0 || height == 0 {
            return Err(Error::DegenerateCamera(format!(
                "image size {width}x{height}"
            )));
        }
        let forward = (target - eye).normalize_or_zero();
        if forward == DVec3::ZERO {
            return Err(Error::DegenerateCamera("eye and target coincide".into()));
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == DVec3::ZERO || forward.cross(up).length() < 1e-9 * up.length() {
            return Err(Error::DegenerateCamera(
                "the up vector is parallel to the view direction".into(),
            ));
        }
        let true_up = right.cross(forward);
        let focal_px = 0.5 * height as f64 / (0.5 * fov_y_deg.to_radians()).tan();
        Ok(Self {
            eye,
            target,
            up,
            fov_y_deg,
            width,
            height,
            forward,
            right,
            true_up,
            focal_px,
        })
    }

    /// The same view at another image size (same vertical field of view).
    pub fn with_resolution(&self, width: u32, height: u32) -> Result<Self> {
        Self::new(
            self.eye,
            self.target,
            self.up,
            self.fov_y_deg,
            width,
            height,
        )
    }

    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// Unit right vector of the image.
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// Unit up vector of the image (orthogonal to forward and right).
    pub fn true_up(&self) -> DVec3 {
        self.true_up
    }

    /// Focal length in pixels.
    pub fn focal_px(&self) -> f64 {
        self.focal_px
    }

    /// Depth of `p` along the view axis.
    #[inline]
    pub fn depth(&self, p: DVec3) -> f64 {
        (p - self.eye).dot(self.forward)
    }

    /// Projects `p`; `None` when it is not in front of the eye (depth ≤ 0). The result may lie
    /// outside the image; use [`Projection::pixel`] to clip.
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<Projection> {
        let v = p - self.eye;
        let depth = v.dot(self.forward);
        if depth <= 0.0 {
            return None;
        }
        let inv = self.focal_px / depth;
        Some(Projection {
            x: 0.5 * self.width as f64 + v.dot(self.right) * inv,
            y: 0.5 * self.height as f64 - v.dot(self.true_up) * inv,
            depth,
        })
    }

    /// Direction (not normalised; its forward component is 1) of the ray through the
    /// continuous pixel position (x, y).
    #[inline]
    pub fn ray_direction(&self, x: f64, y: f64) -> DVec3 {
        let inv = 1.0 / self.focal_px;
        self.forward
            + self.right * ((x - 0.5 * self.width as f64) * inv)
            + self.true_up * ((0.5 * self.height as f64 - y) * inv)
    }

    /// Size in world units of one pixel at depth `depth`.
    #[inline]
    pub fn pixel_size_at(&self, depth: f64) -> f64 {
        depth / self.focal_px
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::ZERO,
            DVec3::Y,
            90.0,
            200,
            100,
        )
        .unwrap()
    }

    #[test]
    fn target_projects_to_the_image_centre() {
        let p = cam().project(DVec3::ZERO).unwrap();
        assert_eq!((p.x, p.y, p.depth), (100.0, 50.0, 5.0));
    }

    #[test]
    fn fov_edges_and_axes() {
        let c = cam();
        // With fov_y = 90 degrees the top edge is at 45 degrees: y = depth.
        let top = c.project(DVec3::new(0.0, 5.0, 0.0)).unwrap();
        assert!((top.y - 0.0).abs() < 1e-9, "{top:?}");
        let right = c.project(DVec3::new(1.0, 0.0, 0.0)).unwrap();
        assert!(right.x > 100.0);
        assert!(c.project(DVec3::new(0.0, 0.0, 6.0)).is_none());
    }

    #[test]
    fn ray_through_a_projection_hits_the_point() {
        let c = cam();
        let p = DVec3::new(0.3, -0.7, 1.1);
        let q = c.project(p).unwrap();
        let d = c.ray_direction(q.x, q.y);
        let hit = c.eye + d * q.depth;
        assert!((hit - p).length() < 1e-12, "{hit} vs {p}");
    }

    proptest::proptest! {
        #[test]
        fn projection_and_ray_are_inverse(
            ex in -10.0f64..10.0, ey in -10.0f64..10.0, ez in 3.0f64..10.0,
            px in -1.0f64..1.0, py in -1.0f64..1.0, pz in -1.0f64..1.0,
            fov in 10.0f64..120.0,
        ) {
            let c = Camera::new(DVec3::new(ex, ey, ez), DVec3::ZERO, DVec3::Y, fov, 640, 480).unwrap();
            let p = DVec3::new(px, py, pz);
            let q = c.project(p).unwrap();
            let back = c.eye + c.ray_direction(q.x, q.y) * q.depth;
            proptest::prop_assert!((back - p).length() < 1e-9 * (1.0 + p.length() + c.eye.length()));
            proptest::prop_assert!((q.depth - c.depth(p)).abs() < 1e-12 * q.depth.max(1.0));
        }
    }

    #[test]
    fn degenerate_cameras_are_errors() {
        let e = DVec3::new(0.0, 0.0, 5.0);
        for (eye, target, up, fov, w, h) in [
            (e, e, DVec3::Y, 60.0, 10, 10),
            (e, DVec3::ZERO, DVec3::Z, 60.0, 10, 10),
            (e, DVec3::ZERO, DVec3::Y, 0.0, 10, 10),
            (e, DVec3::ZERO, DVec3::Y, 180.0, 10, 10),
            (e, DVec3::ZERO, DVec3::Y, 60.0, 0, 10),
            (DVec3::NAN, DVec3::ZERO, DVec3::Y, 60.0, 10, 10),
        ] {
            let r = Camera::new(eye, target, up, fov, w, h);
            assert!(matches!(r, Err(Error::DegenerateCamera(_))), "{r:?}");
        }
    }
}
