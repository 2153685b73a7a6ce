//! The point-only z-buffer visibility baseline ("visibility splatting").
//!
//! The z-buffer pass of surface splatting (Pfister et al., "Surfels", SIGGRAPH 2000, §5.1;
//! Zwicker et al., "Surface Splatting", SIGGRAPH 2001), used as a visibility test in the point
//! rendering literature that seed 000 §2 surveys ([Sainz and Pajarola 2004], [Dachsbacher et al.
//! 2003]): every point is splatted as an opaque disc of `radius_px` pixels into a depth buffer
//! at the camera's resolution, and a point is visible when its depth is at most
//! (1 + `depth_tolerance`) times the nearest splat depth at its own pixel.
//!
//! Parameters (`--set` keys in the harness):
//! - `radius_px` (default 2): splat radius in pixels; the disc is centred on the centre of the
//!   pixel containing the point and covers the pixel centres within the radius (the pixel
//!   itself always). Too small leaves holes through which hidden points show; too large lets
//!   foreground splats hide visible points near silhouettes.
//! - `depth_tolerance` (default 0.01): relative depth slack, absorbing the depth variation of a
//!   sloped surface across a splat.
//! - `width`, `height` (default: the view's): buffer resolution.
//!
//! Implementation: one parallel pass projects every point and keeps, per pixel, the nearest
//! point (depth and index packed into one `u64`, atomically minimised); a parallel min filter
//! over the disc offsets turns the per-pixel nearest depths into the splatted buffer (a disc
//! centred on a pixel centre covers exactly the centres within the radius, so splatting each
//! point and filtering the nearest-point image give the same buffer); a last parallel pass
//! tests every point against the buffer at its pixel. O(n + pixels · disc), no per-point
//! rasterisation.

use std::sync::atomic::{AtomicU64, Ordering};

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Parameters of the splat baseline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplatParams {
    /// Splat radius in pixels.
    pub radius_px: f64,
    /// Relative depth tolerance.
    pub depth_tolerance: f64,
}

impl Default for SplatParams {
    fn default() -> Self {
        Self {
            radius_px: 2.0,
            depth_tolerance: 0.01,
        }
    }
}

/// The outcome of one splat pass.
#[derive(Debug, Clone)]
pub struct SplatVisibility {
    /// Indices of the visible points, ascending.
    pub visible: Vec<u32>,
    /// Per pixel (row-major, camera resolution): the index of the point whose splat is nearest
    /// there, or `u32::MAX` where no splat reaches.
    pub pixel_point: Vec<u32>,
}

const EMPTY: u64 = u64::MAX;

#[inline]
fn pack(depth: f32, index: u32) -> u64 {
    // Positive finite f32 values order like their bit patterns.
    (u64::from(depth.to_bits()) << 32) | u64::from(index)
}

#[inline]
fn unpack_depth(v: u64) -> f32 {
    f32::from_bits((v >> 32) as u32)
}

/// Runs the splat baseline for `points` seen by `camera`.
pub fn splat_visibility(
    points: &[DVec3],
    camera: &Camera,
    params: &SplatParams,
) -> Result<SplatVisibility> {
    if !(params.radius_px >= 0.0 && params.radius_px <= 64.0) {
        return Err(Error::InvalidParameter {
            name: "radius_px",
            reason: format!("must be in [0, 64], got {}", params.radius_px),
        });
    }
    if !(params.depth_tolerance >= 0.0) {
        return Err(Error::InvalidParameter {
            name: "depth_tolerance",
            reason: format!("must be >= 0, got {}", params.depth_tolerance),
        });
    }
    if points.len() >= u32::MAX as usize {
        return Err(Error::InvalidParameter {
            name: "points",
            reason: "more than 2^32 - 1 points".into(),
        });
    }
    cloud::points::check_finite(points)?;
    let (w, h) = (camera.width as usize, camera.height as usize);

    // Pass 1: project; nearest point per pixel.
    let nearest: Vec<AtomicU64> = (0..w * h).map(|_| AtomicU64::new(EMPTY)).collect();
    let projected: Vec<(u32, f32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            let Some(proj) = camera.project(p) else {
                return (u32::MAX, 0.0);
            };
            let Some((x, y)) = proj.pixel(camera.width, camera.height) else {
                return (u32::MAX, 0.0);
            };
            let pixel = y as usize * w + x as usize;
            let depth = proj.depth as f32;
            nearest[pixel].fetch_min(pack(depth, i as u32), Ordering::Relaxed);
            (pixel as u32, depth)
        })
        .collect();
    let nearest: Vec<u64> = nearest.into_iter().map(AtomicU64::into_inner).collect();

    // Pass 2: min filter over the disc, rows in parallel, only over rows that hold points.
    let r = params.radius_px;
    let ri = r.floor() as isize;
    let offsets: Vec<(isize, isize)> = (-ri..=ri)
        .flat_map(|dy| (-ri..=ri).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| ((dx * dx + dy * dy) as f64) <= r * r)
        .collect();
    let mut splatted = vec![EMPTY; w * h];
    splatted.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let mut best = EMPTY;
            for &(dx, dy) in &offsets {
                let (sx, sy) = (x as isize + dx, y as isize + dy);
                if sx >= 0 && sy >= 0 && (sx as usize) < w && (sy as usize) < h {
                    best = best.min(nearest[sy as usize * w + sx as usize]);
                }
            }
            *out = best;
        }
    });

    // Pass 3: a point is visible when it is within the tolerance of the buffer at its pixel.
    let scale = 1.0 + params.depth_tolerance as f32;
    let visible: Vec<u32> = projected
        .par_iter()
        .enumerate()
        .filter(|&(_, &(pixel, depth))| {
            pixel != u32::MAX && depth <= unpack_depth(splatted[pixel as usize]) * scale
        })
        .map(|(i, _)| i as u32)
        .collect();
    let pixel_point = splatted
        .par_iter()
        .map(|&v| if v == EMPTY { u32::MAX } else { v as u32 })
        .collect();
    Ok(SplatVisibility {
        visible,
        pixel_point,
    })
}

#[cfg(test)]
mod tests {
    use cloud::synth::{sphere_point_visible, sphere_scene};

    use super::*;

    fn cam() -> Camera {
        Camera::new(
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            45.0,
            320,
            240,
        )
        .unwrap()
    }

    #[test]
    fn a_point_behind_another_is_hidden_and_the_front_one_visible() {
        let pts = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 1.0)];
        let v = splat_visibility(&pts, &cam(), &SplatParams::default()).unwrap();
        assert_eq!(v.visible, vec![1]);
    }

    /// Naive reference: splat every point's disc one by one.
    fn brute_force(points: &[DVec3], camera: &Camera, params: &SplatParams) -> Vec<u32> {
        let (w, h) = (camera.width as i64, camera.height as i64);
        let mut buffer = vec![f32::INFINITY; (w * h) as usize];
        let mut pixels = Vec::new();
        for &p in points {
            let proj = camera.project(p).and_then(|q| {
                q.pixel(camera.width, camera.height)
                    .map(|px| (px, q.depth as f32))
            });
            pixels.push(proj);
            let Some(((x, y), depth)) = proj else {
                continue;
            };
            let r = params.radius_px;
            for sy in (y as i64 - 70)..=(y as i64 + 70) {
                for sx in (x as i64 - 70)..=(x as i64 + 70) {
                    let (dx, dy) = ((sx - x as i64) as f64, (sy - y as i64) as f64);
                    if sx >= 0 && sy >= 0 && sx < w && sy < h && dx * dx + dy * dy <= r * r {
                        let k = (sy * w + sx) as usize;
                        buffer[k] = buffer[k].min(depth);
                    }
                }
            }
        }
        pixels
            .iter()
            .enumerate()
            .filter_map(|(i, px)| {
                let ((x, y), depth) = (*px)?;
                let k = (y as i64 * w + x as i64) as usize;
                (depth <= buffer[k] * (1.0 + params.depth_tolerance as f32)).then_some(i as u32)
            })
            .collect()
    }

    #[test]
    fn equals_splatting_each_disc_one_by_one() {
        let scene = sphere_scene(6_000);
        let camera = Camera::new(
            DVec3::new(0.4, 0.2, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            45.0,
            160,
            120,
        )
        .unwrap();
        for (radius_px, depth_tolerance) in [
            (0.0, 0.0),
            (0.5, 0.01),
            (1.5, 0.0),
            (2.0, 0.01),
            (3.3, 0.05),
        ] {
            let params = SplatParams {
                radius_px,
                depth_tolerance,
            };
            let fast = splat_visibility(&scene.cloud.positions, &camera, &params).unwrap();
            assert_eq!(
                fast.visible,
                brute_force(&scene.cloud.positions, &camera, &params),
                "{params:?}"
            );
        }
    }

    #[test]
    fn dense_sphere_gives_the_front_cap_with_suited_parameters() {
        let scene = sphere_scene(40_000);
        let camera = cam();
        let params = SplatParams {
            radius_px: 1.5,
            depth_tolerance: 0.05,
        };
        let v = splat_visibility(&scene.cloud.positions, &camera, &params).unwrap();
        let mut flags = vec![false; scene.cloud.len()];
        for &i in &v.visible {
            flags[i as usize] = true;
        }
        let agree = scene
            .cloud
            .positions
            .iter()
            .zip(&flags)
            .filter(|&(&p, &f)| sphere_point_visible(DVec3::ZERO, p, camera.eye) == f)
            .count() as f64
            / scene.cloud.len() as f64;
        assert!(agree > 0.95, "{agree}");
    }

    #[test]
    fn sorted_and_reproducible() {
        let scene = sphere_scene(5_000);
        let a = splat_visibility(&scene.cloud.positions, &cam(), &SplatParams::default()).unwrap();
        let b = splat_visibility(&scene.cloud.positions, &cam(), &SplatParams::default()).unwrap();
        assert!(a.visible.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(a.visible, b.visible);
        assert_eq!(a.pixel_point, b.pixel_point);
    }

    #[test]
    fn bad_parameters() {
        let pts = [DVec3::ZERO];
        for params in [
            SplatParams {
                radius_px: -1.0,
                ..SplatParams::default()
            },
            SplatParams {
                radius_px: f64::NAN,
                ..SplatParams::default()
            },
            SplatParams {
                depth_tolerance: -0.1,
                ..SplatParams::default()
            },
        ] {
            assert!(matches!(
                splat_visibility(&pts, &cam(), &params),
                Err(Error::InvalidParameter { .. })
            ));
        }
        assert!(matches!(
            splat_visibility(&[DVec3::INFINITY], &cam(), &SplatParams::default()),
            Err(Error::Cloud(cloud::Error::NonFinite { index: 0 }))
        ));
    }
}
