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
//! Implementation ([`Splatter`]): prepared once per cloud, the points are stored in f32
//! relative to their centroid (pixel positions differ from an f64 projection by under 1e-3
//! pixel on the datasets here) and in Morton order, so that consecutive points land on nearby
//! pixels. Per view: a parallel pass projects every point; each thread keeps the nearest point
//! per pixel of its share in a private buffer (depth and index packed in a `u64`; no atomics),
//! and the buffers are merged; a separable min filter over the disc turns nearest depths into
//! the splatted buffer (a disc centred on a pixel centre covers exactly the centres within the
//! radius, so filtering the nearest-point image equals splatting every point); a last parallel
//! pass tests every point against the buffer at its pixel. All of it on the pixel rectangle the
//! points cover, with buffers reused from view to view ([`SplatScratch`]).
//!
//! Every camera model of `cloud::camera` is supported: the projection is the model's (pinhole,
//! orthographic, equirectangular) and the disc is in pixels. NOTE: on a spherical image the
//! min filter does not wrap around the left and right edges (splats at the seam are cut), and
//! a disc of pixels covers a wider angle near the poles.

use std::sync::atomic::{AtomicU64, Ordering};

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::splatter::{
    EMPTY, OFF, Rule, SplatParams, SplatScratch, SplatVisibility, Splatter, nearest_per_cell,
    unpack_depth,
};

impl Splatter {
    /// Runs the baseline for `camera`; `pixels` asks for the per-pixel output.
    pub fn visibility(
        &self,
        camera: &Camera,
        params: &SplatParams,
        scratch: &mut SplatScratch,
        pixels: bool,
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
        let (w, h) = (camera.width as usize, camera.height as usize);
        if w >= OFF as usize || h >= OFF as usize {
            return Err(Error::InvalidParameter {
                name: "width/height",
                reason: format!("at most {} pixels a side, got {w}x{h}", OFF - 1),
            });
        }
        if params.rule == Rule::Sprite {
            return crate::sprite::visibility(self, camera, params, scratch, pixels);
        }
        cloud::memory::ensure(
            self.memory_estimate(camera),
            &format!("the splat buffers of a {w}x{h} image"),
        )?;

        // Pass 1: project, and find the pixel rectangle the points cover on the way.
        let project = self.projector(camera);
        const CHUNK: usize = 16_384;
        scratch.projected.resize(self.pos.len(), (OFF, OFF, 0.0));
        let (x0, y0, x1, y1) = self
            .pos
            .par_chunks(CHUNK)
            .zip(scratch.projected.par_chunks_mut(CHUNK))
            .map(|(src, dst)| {
                let mut b = (usize::MAX, usize::MAX, 0, 0);
                for (&p, out) in src.iter().zip(dst.iter_mut()) {
                    *out = match project(p) {
                        Some((x, y, z)) => {
                            let (xu, yu) = (x as usize, y as usize);
                            b = (b.0.min(xu), b.1.min(yu), b.2.max(xu), b.3.max(yu));
                            (x, y, z)
                        }
                        None => (OFF, OFF, 0.0),
                    };
                }
                b
            })
            .reduce(
                || (usize::MAX, usize::MAX, 0, 0),
                |a, b| (a.0.min(b.0), a.1.min(b.1), a.2.max(b.2), a.3.max(b.3)),
            );
        let projected = &scratch.projected;
        let ri = params.radius_px.floor() as usize;
        if x0 > x1 {
            let pixel_point = if pixels {
                vec![u32::MAX; w * h]
            } else {
                Vec::new()
            };
            return Ok(SplatVisibility {
                visible: Vec::new(),
                pixel_point,
            });
        }
        let (rx0, ry0) = (x0.saturating_sub(ri), y0.saturating_sub(ri));
        let (rx1, ry1) = ((x1 + ri).min(w - 1), (y1 + ri).min(h - 1));
        let (rw, rh) = (rx1 - rx0 + 1, ry1 - ry0 + 1);
        let local = |x: u16, y: u16| (y as usize - ry0) * rw + (x as usize - rx0);

        // The nearest point per pixel.
        nearest_per_cell(projected, rw * rh, &mut scratch.private, |_, &(x, y, z)| {
            (x != OFF).then(|| (local(x, y), z))
        });
        let nearest = &scratch.private[0];

        // Pass 2: the disc filter, separably: for each row offset dy the disc spans a
        // horizontal window of half-width hw(dy) = floor(sqrt(r² − dy²)); horizontal minima
        // for each distinct half-width, then the minimum over dy.
        let r = params.radius_px;
        let half_widths: Vec<usize> = (0..=ri)
            .map(|dy| (r * r - (dy * dy) as f64).max(0.0).sqrt().floor() as usize)
            .collect();
        let mut distinct = half_widths.clone();
        distinct.sort_unstable();
        distinct.dedup();
        // Half-width 0 is the nearest buffer itself; the others are materialised.
        let wide: Vec<usize> = distinct.iter().copied().filter(|&hw| hw > 0).collect();
        scratch.horizontal.resize_with(wide.len(), Vec::new);
        for (hw, out) in wide.iter().zip(scratch.horizontal.iter_mut()) {
            out.clear();
            out.resize(rw * rh, EMPTY);
            out.par_chunks_mut(rw)
                .zip(nearest.par_chunks(rw))
                .for_each(|(o, row)| {
                    for x in 0..rw {
                        let (a, b) = (x.saturating_sub(*hw), (x + hw).min(rw - 1));
                        o[x] = row[a..=b].iter().copied().min().unwrap_or(EMPTY);
                    }
                });
        }
        let horizontal = &scratch.horizontal;
        let source = |dy: usize| -> &[u64] {
            match wide.iter().position(|&d| d == half_widths[dy]) {
                Some(k) => &horizontal[k],
                None => nearest,
            }
        };
        scratch.splatted.clear();
        scratch.splatted.resize(rw * rh, EMPTY);
        scratch.depth.clear();
        scratch.depth.resize(rw * rh, f32::INFINITY);
        scratch
            .splatted
            .par_chunks_mut(rw)
            .zip(scratch.depth.par_chunks_mut(rw))
            .enumerate()
            .for_each(|(y, (out, d))| {
                for dy in -(ri as isize)..=(ri as isize) {
                    let sy = y as isize + dy;
                    if sy < 0 || sy >= rh as isize {
                        continue;
                    }
                    let src = &source(dy.unsigned_abs())[sy as usize * rw..(sy as usize + 1) * rw];
                    for (o, &v) in out.iter_mut().zip(src) {
                        *o = (*o).min(v);
                    }
                }
                for (dv, &v) in d.iter_mut().zip(out.iter()) {
                    *dv = if v == EMPTY {
                        f32::INFINITY
                    } else {
                        unpack_depth(v)
                    };
                }
            });

        // Pass 3: a point is visible when it is within the tolerance of the buffer at its
        // pixel; flags go to a bitset over input indices, read back in ascending order.
        let scale = 1.0 + params.depth_tolerance as f32;
        let depth = &scratch.depth;
        let bits: Vec<AtomicU64> = (0..self.perm.len().div_ceil(64))
            .map(|_| AtomicU64::new(0))
            .collect();
        projected
            .par_iter()
            .zip(self.perm.par_iter())
            .for_each(|(&(x, y, z), &i)| {
                if x != OFF && z <= depth[local(x, y)] * scale {
                    bits[i as usize / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
                }
            });
        let visible: Vec<u32> = bits
            .iter()
            .enumerate()
            .flat_map(|(word, b)| {
                let mut v = b.load(Ordering::Relaxed);
                std::iter::from_fn(move || {
                    (v != 0).then(|| {
                        let bit = v.trailing_zeros();
                        v &= v - 1;
                        (word * 64) as u32 + bit
                    })
                })
            })
            .collect();
        let pixel_point = if pixels {
            let mut pixel_point = vec![u32::MAX; w * h];
            for (y, row) in scratch.splatted.chunks(rw).enumerate() {
                let start = (ry0 + y) * w + rx0;
                for (o, &v) in pixel_point[start..start + rw].iter_mut().zip(row) {
                    *o = if v == EMPTY {
                        u32::MAX
                    } else {
                        self.perm[v as u32 as usize]
                    };
                }
            }
            pixel_point
        } else {
            Vec::new()
        };
        Ok(SplatVisibility {
            visible,
            pixel_point,
        })
    }
}

/// Runs the splat baseline for `points` seen by `camera` (prepares, then one view, with the
/// per-pixel output).
pub fn splat_visibility(
    points: &[DVec3],
    camera: &Camera,
    params: &SplatParams,
) -> Result<SplatVisibility> {
    Splatter::new(points)?.visibility(camera, params, &mut SplatScratch::default(), true)
}

#[cfg(test)]
mod tests {
    use cloud::synth::{sphere_point_visible, sphere_scene};

    use super::*;
    use cloud::Model;

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
        let centre = 120 * 320 + 160;
        assert_eq!(v.pixel_point[centre], 1);
    }

    /// Naive reference: splat every point's disc one by one (same projection).
    fn brute_force(points: &[DVec3], camera: &Camera, params: &SplatParams) -> Vec<u32> {
        let s = Splatter::new(points).unwrap();
        let project = s.projector(camera);
        let (w, h) = (camera.width as i64, camera.height as i64);
        let mut buffer = vec![f32::INFINITY; (w * h) as usize];
        let mut pixels = vec![None; points.len()];
        for (k, &p) in s.pos.iter().enumerate() {
            let proj = project(p);
            pixels[s.perm[k] as usize] = proj;
            let Some((x, y, depth)) = proj else { continue };
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
                let (x, y, depth) = (*px)?;
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
                ..SplatParams::default()
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
    fn the_f32_projection_matches_the_camera_to_a_thousandth_of_a_pixel() {
        // Coordinates far from the origin, like the dragon's.
        let center = DVec3::new(0.0, 30.0, -980.0);
        let pts: Vec<DVec3> = cloud::synth::fibonacci_sphere(2_000)
            .iter()
            .map(|p| *p * 50.0 + center)
            .collect();
        let s = Splatter::new(&pts).unwrap();
        for model in [
            Model::pinhole_fov(40.0, 1920, 1080).unwrap(),
            Model::Pinhole {
                fx: 1500.0,
                fy: 1400.0,
                cx: 900.0,
                cy: 560.0,
            },
            Model::Orthographic {
                view_width: 150.0,
                view_height: 90.0,
            },
            Model::Spherical,
        ] {
            let camera = Camera::look_at(
                DVec3::new(40.0, 60.0, -800.0),
                center,
                DVec3::Y,
                model,
                1920,
                1080,
            )
            .unwrap();
            let project = s.projector(&camera);
            let mut compared = 0;
            for (k, &p) in s.pos.iter().enumerate() {
                let exact = camera.project(pts[s.perm[k] as usize]).unwrap();
                let Some((x, y, z)) = project(p) else {
                    continue;
                };
                // The pixel agrees unless the exact position is within 1e-3 of a pixel edge.
                let near_edge = |a: f64| (a - a.round()).abs() < 1e-3;
                assert!(
                    x as f64 == exact.x.floor() || near_edge(exact.x),
                    "{model:?}: {x} vs {}",
                    exact.x
                );
                assert!(
                    y as f64 == exact.y.floor() || near_edge(exact.y),
                    "{model:?}: {y} vs {}",
                    exact.y
                );
                assert!((z as f64 - exact.depth).abs() < 1e-4 * exact.depth);
                compared += 1;
            }
            assert!(compared > 500, "{model:?}: {compared}");
        }
    }

    #[test]
    fn dense_sphere_gives_the_front_cap_with_suited_parameters() {
        let scene = sphere_scene(40_000);
        let camera = cam();
        let params = SplatParams {
            radius_px: 1.5,
            depth_tolerance: 0.05,
            ..SplatParams::default()
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
    fn reusing_scratch_gives_the_same_answers() {
        let scene = sphere_scene(5_000);
        let s = Splatter::new(&scene.cloud.positions).unwrap();
        let mut scratch = SplatScratch::default();
        let params = SplatParams::default();
        let other = Camera::new(
            DVec3::new(2.0, 1.0, 1.0),
            DVec3::ZERO,
            DVec3::Y,
            50.0,
            200,
            100,
        )
        .unwrap();
        let a = s.visibility(&cam(), &params, &mut scratch, true).unwrap();
        let _ = s.visibility(&other, &params, &mut scratch, false).unwrap();
        let b = s.visibility(&cam(), &params, &mut scratch, true).unwrap();
        assert_eq!(a.visible, b.visible);
        assert_eq!(a.pixel_point, b.pixel_point);
        assert!(a.visible.windows(2).all(|w| w[0] < w[1]));
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
