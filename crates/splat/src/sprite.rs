//! The point-sprite rule (`rule = sprite`): z-buffer selection as a GPU point renderer does it,
//! the rule of VTK's `vtkSelectVisiblePoints` (and of OpenGL point picking in general).
//!
//! Every point is drawn as a square sprite of `size = 2 × radius_px` pixels (an integer)
//! centred on its exact projection, covering the pixels whose centres lie in the square (the
//! OpenGL specification's point rasterisation, §14.4 of the 4.6 core profile: the pixels
//! (i, j) with i + ½ in [x − size/2, x + size/2), likewise j), at the point's own depth, into a
//! buffer of nearest depths. A point is selected when, moved toward the eye along the view axis
//! by one world tolerance for the whole view, `depth_tolerance × ‖eye − centroid‖` (the cloud's
//! mean), it lies strictly nearer than the buffer at the pixel the moved point projects to.
//!
//! Against the disc rule of [`crate::visibility`] (a disc centred on the point's pixel, a
//! relative tolerance at that pixel) this is another selection, not a variant: the square
//! covers more at the same radius and its position follows the sub-pixel projection, and one
//! world tolerance is loose near the eye and tight far away. It is here so that a GPU
//! z-buffer tool (VTK's) meets our CPU z-buffer on its own rule.
//!
//! Implementation: a point's sprite covers columns [a, a + size) with a = ⌈x − size/2 − ½⌉
//! (rows likewise), so the nearest point per *anchor* (a, b), followed by a one-sided
//! separable minimum over `size` anchors, is the drawn buffer; the anchors of points near the
//! top and left edges lie up to `size` pixels outside the image, and the buffer of anchors is
//! that much larger. Points whose projection falls outside the image are not drawn (clipped
//! whole, as OpenGL clips a point by its vertex). Projection in f32 as the disc rule's. Pinhole
//! and orthographic cameras only (a spherical image has no view axis to shift along).

use cloud::Camera;
use cloud::glam::Vec3A;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::splatter::{
    EMPTY, SplatParams, SplatScratch, SplatVisibility, Splatter, nearest_per_cell,
};

/// The sprite's side in pixels for `radius_px`, which must make it a whole number of at least 1.
pub fn sprite_size(radius_px: f64) -> Result<usize> {
    let size = 2.0 * radius_px;
    if !((1.0..=128.0).contains(&size) && (size - size.round()).abs() < 1e-9) {
        return Err(Error::InvalidParameter {
            name: "radius_px",
            reason: format!(
                "rule=sprite draws squares of 2 x radius_px whole pixels (1 to 128): radius_px \
                 {radius_px} gives {size}"
            ),
        });
    }
    Ok(size.round() as usize)
}

/// The first column (or row) a sprite of `size` centred at `x` covers.
#[inline]
fn anchor(x: f32, size: usize) -> i64 {
    (x - size as f32 * 0.5 - 0.5).ceil() as i64
}

/// The point-sprite selection of `splatter`'s points from `camera` (see the module's
/// documentation); `pixels` asks for the per-pixel output. Parameters already checked.
pub(crate) fn visibility(
    splatter: &Splatter,
    camera: &Camera,
    params: &SplatParams,
    scratch: &mut SplatScratch,
    pixels: bool,
) -> Result<SplatVisibility> {
    let size = sprite_size(params.radius_px)?;
    if matches!(camera.model(), cloud::Model::Spherical) {
        // Depth there is the distance to the eye, which a shift along the view axis does not
        // lessen for points beside or behind it (and sprites would not wrap at the seam).
        return Err(Error::InvalidParameter {
            name: "rule",
            reason: "rule=sprite takes pinhole and orthographic cameras (a GPU point renderer's \
                     rule), not spherical ones: use rule=disc"
                .into(),
        });
    }
    let (w, h) = (camera.width as usize, camera.height as usize);
    let (aw, ah) = (w + size, h + size);
    let threads = rayon::current_num_threads().max(1);
    cloud::memory::ensure(
        cloud::memory::image_bytes(aw as u32, ah as u32, 8 * threads as u64 + 8 + 8, 1)
            + 12 * splatter.len() as u128,
        &format!("the sprite buffers of a {w}x{h} image"),
    )?;
    let project = splatter.projector_f32(camera);
    let pos = splatter.positions();
    let tolerance = (params.depth_tolerance * (splatter.centroid() - camera.eye).length()) as f32;
    let shift = Vec3A::from(camera.forward().as_vec3()) * tolerance;

    // The nearest point per anchor.
    nearest_per_cell(pos, aw * ah, &mut scratch.private, |_, &p| {
        project(p).map(|(x, y, z)| {
            let ax = (anchor(x, size) + size as i64) as usize;
            let ay = (anchor(y, size) + size as i64) as usize;
            (ay * aw + ax, z)
        })
    });
    let nearest = &scratch.private[0];

    // Pixel (X, Y) shows the nearest of the anchors [X − size + 1, X] × [Y − size + 1, Y]
    // (anchor index = anchor + size): rows first, then columns.
    let rows = &mut scratch.splatted;
    rows.clear();
    rows.resize(ah * w, EMPTY);
    rows.par_chunks_mut(w)
        .zip(nearest.par_chunks(aw))
        .for_each(|(out, src)| {
            for (x, o) in out.iter_mut().enumerate() {
                *o = src[x + 1..=x + size].iter().copied().min().unwrap_or(EMPTY);
            }
        });
    let rows = &scratch.splatted;
    let mut buffer = vec![EMPTY; w * h];
    buffer.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        for sy in y + 1..=y + size {
            for (o, &v) in out.iter_mut().zip(&rows[sy * w..(sy + 1) * w]) {
                *o = (*o).min(v);
            }
        }
    });

    // Each point, moved toward the eye by the tolerance, against the buffer where it lands.
    let flags: Vec<bool> = pos
        .par_iter()
        .map(|&p| {
            project(p - shift).is_some_and(|(x, y, z)| {
                let v = buffer[y as usize * w + x as usize];
                v == EMPTY || z < f32::from_bits((v >> 32) as u32)
            })
        })
        .collect();
    let perm = splatter.permutation();
    let mut visible: Vec<u32> = flags
        .iter()
        .zip(perm)
        .filter_map(|(&f, &i)| f.then_some(i))
        .collect();
    visible.par_sort_unstable();
    let pixel_point = if pixels {
        buffer
            .iter()
            .map(|&v| {
                if v == EMPTY {
                    u32::MAX
                } else {
                    perm[v as u32 as usize]
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    Ok(SplatVisibility {
        visible,
        pixel_point,
    })
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::synth::sphere_scene;

    use super::*;
    use crate::splatter::Rule;
    use crate::visibility::splat_visibility;

    /// Naive reference: each sprite drawn pixel by pixel, each point tested (same f32
    /// projection as the fast path).
    fn brute_force(points: &[DVec3], camera: &Camera, params: &SplatParams) -> Vec<u32> {
        let s = Splatter::new(points).unwrap();
        let project = s.projector_f32(camera);
        let size = sprite_size(params.radius_px).unwrap() as i64;
        let (w, h) = (camera.width as i64, camera.height as i64);
        let mut buffer = vec![f32::INFINITY; (w * h) as usize];
        for &p in s.positions() {
            let Some((x, y, z)) = project(p) else {
                continue;
            };
            // Pixels i with i + 1/2 in [x - size/2, x + size/2).
            for py in 0..h {
                let c = py as f32 + 0.5;
                if !(c >= y - size as f32 / 2.0 && c < y + size as f32 / 2.0) {
                    continue;
                }
                for px in 0..w {
                    let c = px as f32 + 0.5;
                    if c >= x - size as f32 / 2.0 && c < x + size as f32 / 2.0 {
                        let k = (py * w + px) as usize;
                        buffer[k] = buffer[k].min(z);
                    }
                }
            }
        }
        let tol = (params.depth_tolerance * (s.centroid() - camera.eye).length()) as f32;
        let shift = Vec3A::from(camera.forward().as_vec3()) * tol;
        let mut out: Vec<u32> = s
            .positions()
            .iter()
            .zip(s.permutation())
            .filter(|&(&p, _)| {
                project(p - shift)
                    .is_some_and(|(x, y, z)| z < buffer[(y as i64 * w + x as i64) as usize])
            })
            .map(|(_, &i)| i)
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn equals_drawing_each_sprite_one_by_one() {
        let scene = sphere_scene(3_000);
        for (eye, width, height) in [
            (DVec3::new(0.4, 0.2, 3.0), 96, 72),
            (DVec3::new(-2.0, 1.0, 1.5), 80, 60),
        ] {
            let camera = Camera::new(eye, DVec3::ZERO, DVec3::Y, 45.0, width, height).unwrap();
            for (radius_px, depth_tolerance) in [
                (0.5, 0.001),
                (1.0, 0.01),
                (1.5, 0.03),
                (2.0, 0.01),
                (4.0, 0.1),
            ] {
                let params = SplatParams {
                    radius_px,
                    depth_tolerance,
                    rule: Rule::Sprite,
                };
                let fast = splat_visibility(&scene.cloud.positions, &camera, &params).unwrap();
                let slow = brute_force(&scene.cloud.positions, &camera, &params);
                assert_eq!(fast.visible, slow, "{params:?} from {eye}");
                assert!(!slow.is_empty());
            }
        }
    }

    #[test]
    fn a_sprite_covers_size_pixels_a_side_and_hides_what_is_behind() {
        // One point in front of a wall of points: the pixels its sprite covers show it.
        let mut pts = vec![DVec3::new(0.0, 0.0, 1.0)];
        for i in -20..=20 {
            for j in -20..=20 {
                pts.push(DVec3::new(f64::from(i) * 0.01, f64::from(j) * 0.01, 0.0));
            }
        }
        let camera = Camera::new(
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            30.0,
            64,
            64,
        )
        .unwrap();
        for size in [1, 2, 3, 4] {
            let params = SplatParams {
                radius_px: f64::from(size) / 2.0,
                depth_tolerance: 0.001,
                rule: Rule::Sprite,
            };
            let v = splat_visibility(&pts, &camera, &params).unwrap();
            let shown = v.pixel_point.iter().filter(|&&p| p == 0).count();
            assert_eq!(shown, (size * size) as usize, "size {size}");
            assert!(v.visible.contains(&0));
            // The wall's points under the sprite are hidden, the rest of the wall is not.
            assert!(
                v.visible.len() > 1 && v.visible.len() < pts.len(),
                "{}",
                v.visible.len()
            );
        }
        // Strictly nearer: without a tolerance a point does not pass its own depth.
        let params = SplatParams {
            radius_px: 1.0,
            depth_tolerance: 0.0,
            rule: Rule::Sprite,
        };
        assert!(
            splat_visibility(&pts, &camera, &params)
                .unwrap()
                .visible
                .is_empty()
        );
        let spherical = Camera::look_at(
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            cloud::Model::Spherical,
            64,
            32,
        )
        .unwrap();
        let params = SplatParams {
            radius_px: 1.0,
            depth_tolerance: 0.01,
            rule: Rule::Sprite,
        };
        assert!(matches!(
            splat_visibility(&pts, &spherical, &params),
            Err(Error::InvalidParameter { name: "rule", .. })
        ));
        for radius_px in [0.0, 0.3, 1.25, 65.0] {
            let params = SplatParams {
                radius_px,
                depth_tolerance: 0.0,
                rule: Rule::Sprite,
            };
            assert!(matches!(
                splat_visibility(&pts, &camera, &params),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
}
