//! The per-pixel score of any visibility method: which point each pixel shows, and how that
//! image compares with the truth.
//!
//! Per-pixel methods return their own choice (`Output::pixels`: `raycast` one ray per pixel,
//! the nearest sphere it hits; `splat` the nearest point whose disc of `radius_px` pixels covers
//! the pixel centre; `screenspace` and `vardensity` the nearest point projecting into the pixel,
//! where the operator keeps the pixel). A method that returns only a visible set (the HPR
//! family, the robust operator, `hpr-approx`, external methods and peers) is given one here,
//! from its visible set alone ([`projected`]), so that every method has both scores.
//!
//! The footprint of the derived choice is the ray cast's (seed 001, `raycast` with
//! `primitive=sphere` and exact traversal) at its automatic radius: every visible point is a
//! sphere of radius R = `raycast::auto::RADIUS_FACTOR` (1.5) density spacings of the whole
//! cloud ([`footprint_radius`], `raycast::auto::auto_radius`), one ray goes through each pixel
//! centre of the view's camera (`Camera::ray`), and the pixel shows the point whose sphere the
//! ray enters first (a ray that starts inside a sphere enters it at 0; ties: the lower index);
//! no hit, no point. It is what that ray cast would show if the cloud held the visible set
//! only. The harness scores it at the view's own resolution, the one `splat`, `screenspace` and
//! `vardensity` run at by default (1280 × 720 on the built-in views, also `raycast`'s default).
//!
//! NOTE (comparability): a footprint that closes the gaps between samples is what rendering a
//! visible set needs, so the derived coverage is comparable with `raycast`'s (same rule, at its
//! setting's radius and resolution) and `splat`'s (a disc of pixels); `screenspace` and
//! `vardensity` show one pixel per point, so their coverage is bounded by the cloud's density
//! (about 0.2 of the mesh's pixels on bunny-69451 at 1280 × 720) and is not comparable.
//!
//! The score ([`PixelScore`]): pixel precision = covered pixels whose point is truly visible /
//! covered pixels; coverage = the mesh's pixels (the mesh rasterised at the same camera) that
//! show a point / the mesh's pixels; the per-pixel F1 that ranks methods is their harmonic
//! mean, as F1 is of precision and recall.

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::visibility::PixelChoice;

/// "No point" in [`PixelChoice::point`].
pub const NONE: u32 = u32::MAX;

/// The sphere radius of the derived choice for a cloud: the ray cast's automatic radius,
/// `raycast::auto::RADIUS_FACTOR` density spacings.
pub fn footprint_radius(points: &[DVec3]) -> Result<f64> {
    Ok(raycast::auto::auto_radius(points)?)
}

/// Where `ray` (origin, direction) enters the sphere at `c` of radius `r`, in units of the
/// direction (0 when it starts inside); `None` when it misses or the sphere lies behind it.
#[inline]
fn entry(origin: DVec3, dir: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let oc = c - origin;
    let a = dir.length_squared();
    let b = dir.dot(oc);
    let disc = b * b - a * (oc.length_squared() - r * r);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    ((b + s) / a > 0.0).then(|| ((b - s) / a).max(0.0))
}

/// The pixel rectangle (x0..=x1, y0..=y1, columns may wrap for a spherical image) that holds
/// every pixel centre whose ray can meet the sphere at `c` of radius `r`; `None` when the
/// sphere is out of view. Conservative: twice the sphere's projected radius, plus a pixel.
fn footprint_box(camera: &Camera, c: DVec3, r: f64) -> Option<(i64, i64, i64, i64)> {
    let (w, h) = (i64::from(camera.width), i64::from(camera.height));
    let whole = Some((0, w - 1, 0, h - 1));
    let Some(p) = camera.project(c) else {
        // Behind the eye or on its plane: only a sphere reaching the eye's side can be hit.
        return if camera.depth(c) > -r { whole } else { None };
    };
    let near = p.depth - r;
    if near <= p.depth * 1e-6 {
        return whole;
    }
    let half = 2.0 * r / camera.pixel_size_at(near) + 1.0;
    let (mut hx, hy) = (half, half);
    if matches!(camera.model(), cloud::Model::Spherical) {
        // A pixel column narrows towards the poles by sin θ.
        let theta = (p.y / camera.height as f64 * std::f64::consts::PI).sin();
        hx = if theta * w as f64 > 2.0 * hx {
            hx / theta.max(1e-9)
        } else {
            w as f64
        };
    }
    let (x0, x1) = ((p.x - hx).floor() as i64, (p.x + hx).ceil() as i64);
    let (y0, y1) = (
        ((p.y - hy).floor() as i64).max(0),
        ((p.y + hy).ceil() as i64).min(h - 1),
    );
    if y0 > y1 {
        return None;
    }
    if matches!(camera.model(), cloud::Model::Spherical) {
        return Some(if x1 - x0 + 1 >= w {
            (0, w - 1, y0, y1)
        } else {
            (x0, x1, y0, y1)
        });
    }
    let (x0, x1) = (x0.max(0), x1.min(w - 1));
    (x0 <= x1).then_some((x0, x1, y0, y1))
}

/// The pixel choice a visible set shows (the module doc's footprint rule): per pixel of
/// `camera`, the point of `visible` (indices into `points`) whose sphere of radius `radius` the
/// pixel's ray enters first. Errors: an index out of range, a radius that is not finite and
/// positive.
pub fn projected(
    points: &[DVec3],
    visible: &[u32],
    camera: &Camera,
    radius: f64,
) -> Result<PixelChoice> {
    if !(radius.is_finite() && radius > 0.0) {
        return Err(Error::Unsupported(format!(
            "pixel footprint radius {radius}: must be finite and positive"
        )));
    }
    if let Some(&i) = visible.iter().find(|&&i| i as usize >= points.len()) {
        return Err(Error::Unsupported(format!(
            "visible index {i} out of range ({} points)",
            points.len()
        )));
    }
    let share = visible
        .len()
        .div_ceil(rayon::current_num_threads().max(1))
        .max(4096);
    drawn_in_shares(points, visible, camera, radius, share)
}

/// [`projected`]'s image drawn from shares of `share` visible points each (in parallel), merged
/// pixel by pixel. Indices are checked by the caller.
fn drawn_in_shares(
    points: &[DVec3],
    visible: &[u32],
    camera: &Camera,
    radius: f64,
    share: usize,
) -> Result<PixelChoice> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let spherical = matches!(camera.model(), cloud::Model::Spherical);
    // One image per share of the points, merged pixel by pixel: the lexicographic minimum of
    // (entry, index) does not depend on the order, so the result is the sequential one's.
    let draw = |share: &[u32]| {
        let mut best = vec![(f64::INFINITY, NONE); w * h];
        for &i in share {
            let c = points[i as usize];
            let Some((x0, x1, y0, y1)) = footprint_box(camera, c, radius) else {
                continue;
            };
            for y in y0..=y1 {
                for xs in x0..=x1 {
                    let x = if spherical {
                        xs.rem_euclid(w as i64)
                    } else {
                        xs
                    };
                    let (o, d) = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
                    if let Some(t) = entry(o, d, c, radius) {
                        let b = &mut best[y as usize * w + x as usize];
                        if (t, i) < *b {
                            *b = (t, i);
                        }
                    }
                }
            }
        }
        best
    };
    let best = visible
        .par_chunks(share.max(1))
        .map(draw)
        .reduce_with(|mut a, b| {
            for (x, y) in a.iter_mut().zip(b) {
                if y < *x {
                    *x = y;
                }
            }
            a
        })
        .unwrap_or_else(|| vec![(f64::INFINITY, NONE); w * h]);
    Ok(PixelChoice {
        width: camera.width,
        height: camera.height,
        point: best.into_iter().map(|(_, i)| i).collect(),
    })
}

/// A pixel choice against the truth: the counts of the module doc's score.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PixelScore {
    /// Pixels that show a point.
    pub covered: usize,
    /// Covered pixels whose point is truly visible.
    pub true_pixels: usize,
    /// Pixels the mesh covers.
    pub mesh_pixels: usize,
    /// Mesh pixels that show a point.
    pub mesh_covered: usize,
}

impl PixelScore {
    /// `choice` against the true visibility per point (`truth`, indexed like the cloud) and the
    /// mesh's pixels (`mesh`, per pixel of the same image). Errors: `mesh` of another size, a
    /// pixel's point outside `truth`.
    pub fn of(choice: &PixelChoice, truth: &[bool], mesh: &[bool]) -> Result<Self> {
        if mesh.len() != choice.point.len() {
            return Err(Error::Unsupported(format!(
                "mesh mask of {} pixels against a {} x {} choice",
                mesh.len(),
                choice.width,
                choice.height
            )));
        }
        let mut s = Self::default();
        for (&p, &m) in choice.point.iter().zip(mesh) {
            s.mesh_pixels += usize::from(m);
            if p == NONE {
                continue;
            }
            s.covered += 1;
            s.mesh_covered += usize::from(m);
            let t = truth.get(p as usize).ok_or_else(|| {
                Error::Unsupported(format!(
                    "pixel shows point {p} of a truth over {} points",
                    truth.len()
                ))
            })?;
            s.true_pixels += usize::from(*t);
        }
        Ok(s)
    }

    /// Covered pixels whose point is truly visible, over covered pixels (0 when none).
    pub fn precision(&self) -> f64 {
        self.true_pixels as f64 / self.covered.max(1) as f64
    }

    /// The mesh's pixels that show a point, over the mesh's pixels (0 when none).
    pub fn coverage(&self) -> f64 {
        self.mesh_covered as f64 / self.mesh_pixels.max(1) as f64
    }

    /// The harmonic mean of [`Self::precision`] and [`Self::coverage`] (0 when both are).
    pub fn f1(&self) -> f64 {
        f1(self.precision(), self.coverage())
    }
}

/// The harmonic mean of pixel precision and coverage (0 when both are 0): the one per-pixel
/// score methods are ranked by.
pub fn f1(precision: f64, coverage: f64) -> f64 {
    if precision + coverage > 0.0 {
        2.0 * precision * coverage / (precision + coverage)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests;
