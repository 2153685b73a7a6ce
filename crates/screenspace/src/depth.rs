//! The depth buffer every screen-space operator starts from (Pintus et al. 2011, §3 "the
//! points are projected into the frame buffer"; Biasutti et al. 2019, §3: each point's
//! projection from the viewpoint): the nearest point per pixel under the camera's own model
//! (`cloud::Camera`: pinhole, orthographic, spherical equirectangular), the pixel and depth of
//! every projected point, and the direction from a point towards the viewer.
//!
//! Depth is the camera's z-buffer depth (`Camera::depth`: along the optical axis for pinhole
//! and orthographic, range for spherical). Ties at equal depth go to the lower point index, so
//! the buffer is a function of the cloud and camera alone. A spherical image wraps around in
//! x (azimuth ±π are neighbours): [`DepthBuffer::wrap_x`].
//!
//! Deviation from both papers: the GPU rasterises points as 1-pixel fragments with a hardware
//! depth test; here one sequential pass over the points does the same on the CPU.

use cloud::glam::DVec3;
use cloud::{Camera, Model};

use crate::error::{Error, Result};

/// The largest image accepted (8192 × 8192); larger sizes are refused before allocating.
pub const MAX_PIXELS: u64 = 1 << 26;

/// "No point" in a per-pixel or per-point index array.
pub const EMPTY: u32 = u32::MAX;

/// Refuses a zero or absurd image size before anything is allocated.
pub fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidParameter {
            name: "resolution",
            reason: format!("{width} x {height}: both sides must be at least 1 pixel"),
        });
    }
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(Error::ImageTooLarge {
            width,
            height,
            max: MAX_PIXELS,
        });
    }
    Ok(())
}

/// Where the viewer is, seen from a point: a centre of projection (pinhole, spherical) or a
/// direction (orthographic: the viewer is at infinity against the optical axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Viewer {
    /// The eye.
    Point(DVec3),
    /// Unit direction towards the viewer.
    Direction(DVec3),
}

impl Viewer {
    /// The viewer of `camera`.
    pub fn of(camera: &Camera) -> Self {
        match camera.model() {
            Model::Orthographic { .. } => Viewer::Direction(-camera.forward()),
            _ => Viewer::Point(camera.eye),
        }
    }

    /// Unit vector from `p` towards the viewer (zero if `p` is the eye).
    #[inline]
    pub fn toward(&self, p: DVec3) -> DVec3 {
        match *self {
            Viewer::Point(eye) => (eye - p).normalize_or_zero(),
            Viewer::Direction(d) => d,
        }
    }
}

/// The nearest point per pixel and the projection of every point.
#[derive(Debug, Clone)]
pub struct DepthBuffer {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// True for spherical images: column 0 and column `width - 1` are neighbours.
    pub wrap_x: bool,
    /// Per pixel (row-major): the nearest point, or [`EMPTY`].
    pub point: Vec<u32>,
    /// Per point: its pixel (row-major index), or [`EMPTY`] when it does not project into the
    /// image.
    pub pixel_of: Vec<u32>,
    /// Per point: its depth, or infinity when it does not project into the image.
    pub depth: Vec<f64>,
    /// Pixels that hold a point.
    pub occupied: usize,
}

impl DepthBuffer {
    /// Projects `points` with `camera` at the camera's resolution. Errors: a non-finite
    /// point, an image over [`MAX_PIXELS`], or no point in view.
    pub fn build(points: &[DVec3], camera: &Camera) -> Result<Self> {
        let (w, h) = (camera.width, camera.height);
        check_size(w, h)?;
        if points.len() >= EMPTY as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                reason: "more than 2^32 - 2 points".into(),
            });
        }
        cloud::points::check_finite(points)?;
        let mut point = vec![EMPTY; w as usize * h as usize];
        let mut pixel_of = vec![EMPTY; points.len()];
        let mut depth = vec![f64::INFINITY; points.len()];
        let mut occupied = 0;
        for (i, &p) in points.iter().enumerate() {
            let Some(pr) = camera.project(p) else {
                continue;
            };
            let Some((x, y)) = pr.pixel(w, h) else {
                continue;
            };
            let px = y as usize * w as usize + x as usize;
            pixel_of[i] = px as u32;
            depth[i] = pr.depth;
            let owner = point[px];
            if owner == EMPTY {
                occupied += 1;
                point[px] = i as u32;
            } else if pr.depth < depth[owner as usize] {
                point[px] = i as u32;
            }
        }
        if occupied == 0 {
            return Err(Error::NothingInView {
                points: points.len(),
                model: camera.model().name(),
            });
        }
        Ok(Self {
            width: w,
            height: h,
            wrap_x: matches!(camera.model(), Model::Spherical),
            point,
            pixel_of,
            depth,
            occupied,
        })
    }

    /// The (x, y) of a row-major pixel index.
    #[inline]
    pub fn xy(&self, pixel: u32) -> (i64, i64) {
        let w = i64::from(self.width);
        (i64::from(pixel) % w, i64::from(pixel) / w)
    }

    /// The offset from pixel (x0, y0) to (x1, y1), the x part taken the short way round a
    /// spherical image.
    #[inline]
    pub fn offset(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> (i64, i64) {
        let mut dx = x1 - x0;
        if self.wrap_x {
            let w = i64::from(self.width);
            if dx > w / 2 {
                dx -= w;
            } else if dx < -(w - 1) / 2 {
                dx += w;
            }
        }
        (dx, y1 - y0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(model: &str) -> Camera {
        let eye = DVec3::new(0.0, 0.0, 5.0);
        let target = DVec3::ZERO;
        let m = match model {
            "pinhole" => Model::pinhole_fov(40.0, 32, 24).expect("fov"),
            "orthographic" => Model::Orthographic {
                view_width: 4.0,
                view_height: 3.0,
            },
            _ => Model::Spherical,
        };
        Camera::look_at(eye, target, DVec3::Y, m, 32, 24).expect("camera")
    }

    #[test]
    fn the_nearest_point_owns_its_pixel_for_every_model() {
        for model in ["pinhole", "orthographic", "spherical"] {
            let pts = [
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(0.0, 0.0, 0.5),
            ];
            let b = DepthBuffer::build(&pts, &camera(model)).expect(model);
            assert_eq!(b.occupied, 1, "{model}");
            let px = b.pixel_of[0];
            assert_eq!(b.pixel_of[1], px);
            assert_eq!(b.point[px as usize], 1, "{model}");
            assert!((b.depth[1] - 4.0).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_sizes_and_empty_views_are_errors() {
        assert!(matches!(
            check_size(0, 10),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(matches!(
            check_size(1 << 20, 1 << 20),
            Err(Error::ImageTooLarge { .. })
        ));
        let behind = [DVec3::new(0.0, 0.0, 9.0), DVec3::new(1.0, 0.0, 7.0)];
        let e = DepthBuffer::build(&behind, &camera("pinhole")).expect_err("behind");
        assert!(matches!(e, Error::NothingInView { points: 2, .. }), "{e}");
        let e = DepthBuffer::build(&[], &camera("orthographic")).expect_err("empty");
        assert!(matches!(e, Error::NothingInView { points: 0, .. }), "{e}");
        let nan = [DVec3::new(f64::NAN, 0.0, 0.0)];
        assert!(matches!(
            DepthBuffer::build(&nan, &camera("spherical")),
            Err(Error::Cloud(_))
        ));
    }

    #[test]
    fn spherical_offsets_wrap_the_short_way() {
        let pts = [DVec3::ZERO];
        let b = DepthBuffer::build(&pts, &camera("spherical")).expect("b");
        assert!(b.wrap_x);
        assert_eq!(b.offset(0, 3, 31, 3), (-1, 0));
        assert_eq!(b.offset(31, 3, 0, 4), (1, 1));
        assert_eq!(b.offset(2, 0, 5, 0), (3, 0));
    }
}
