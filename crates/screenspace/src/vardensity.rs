//! Biasutti, Bugeau, Aujol, Brédif, "Visibility Estimation in Point Clouds with Variable
//! Density", VISAPP 2019 (HAL hal-01812061): each point's visibility from its screen-space
//! neighbourhood, with no assumption on the cloud's density, made for mobile-mapping LiDAR.
//!
//! **Source.** Of the paper only the first page (title, abstract, the opening of §1) could be
//! read from the stored copies (scitepress.org, 123dok.net). The abstract fixes the design:
//! fully automatic, no density assumption, "the visibility of each point is estimated by
//! considering its screen-space neighborhood from the given viewpoint". The score below is
//! our reconstruction of §3 (a depth-relative exponential score over a screen-space k-nearest
//! neighbourhood); its equation could not be checked against the text and must be before any
//! number from it is quoted as the paper's. The brief's fallback (Biasutti's account of
//! Pintus et al.) was not reachable either.
//!
//! **The rule.** All points are projected into the depth buffer of the camera's own model
//! ([`crate::depth`]; spherical equirectangular images, the mobile-LiDAR case, wrap in
//! azimuth). For the point P of an occupied pixel, its neighbourhood N(P) is the k occupied
//! pixels nearest to P's pixel in the image (Euclidean distance between pixel centres, ties
//! to the lower pixel index, searched out to `max_radius` pixels): the neighbourhood grows
//! where the projected cloud is sparse and shrinks where it is dense, which is what replaces
//! a density assumption. With d the depth of P and d_min, d_max the least and greatest depth
//! over N(P) (P excluded),
//!
//!   v(P) = 1                                   if d ≤ d_min,
//!   v(P) = exp(−((d − d_min) / (d_max − d_min))²)  otherwise (0 when d_max = d_min < d),
//!
//! and the pixel is kept when v(P) ≥ `threshold`. A point with no neighbour in reach scores 1
//! (nothing in front of it). A point on the surface its neighbours sample lies within
//! [d_min, d_max] up to the sampling, v ≥ e^-1 ≈ 0.37; a point seen through a gap of a nearer
//! surface lies many spreads behind it, v ≈ 0.
//!
//! **Deviations** (besides the reconstruction above): CPU (rayon over rows); the depth is the
//! camera's z-buffer depth (range for spherical images, distance along the axis for pinhole
//! and orthographic); the neighbour search is capped at `max_radius` pixels (Chebyshev) so
//! that an isolated point costs O(max_radius²) and not the whole image.

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

use crate::depth::{DepthBuffer, EMPTY};
use crate::error::{Error, Result};
use crate::select::{Verdict, check_tolerance, select};

/// The operator's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VardensityParams {
    /// Neighbours k in the screen-space neighbourhood (1..=256).
    pub k: u32,
    /// Farthest ring searched, pixels (Chebyshev; 1..=1024).
    pub max_radius: u32,
    /// Minimum score v, in [0, 1].
    pub threshold: f64,
    /// Relative depth tolerance of [`crate::select`] (0: one point per pixel).
    pub depth_tolerance: f64,
}

impl Default for VardensityParams {
    fn default() -> Self {
        Self {
            k: 8,
            max_radius: 32,
            threshold: 0.5,
            depth_tolerance: 0.0,
        }
    }
}

impl VardensityParams {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason: String| Err(Error::InvalidParameter { name, reason });
        if !(1..=256).contains(&self.k) {
            return bad("k", format!("{}: must be in 1..=256", self.k));
        }
        if !(1..=1024).contains(&self.max_radius) {
            return bad(
                "max_radius",
                format!("{}: must be in 1..=1024 pixels", self.max_radius),
            );
        }
        if !(0.0..=1.0).contains(&self.threshold) {
            return bad(
                "threshold",
                format!("{}: must be a number in [0, 1]", self.threshold),
            );
        }
        check_tolerance(self.depth_tolerance)
    }
}

/// The score v from P's depth and its neighbours' depths.
#[inline]
pub fn score(d: f64, neighbour_depths: impl Iterator<Item = f64>) -> f64 {
    let (mut lo, mut hi, mut any) = (f64::INFINITY, f64::NEG_INFINITY, false);
    for q in neighbour_depths {
        lo = lo.min(q);
        hi = hi.max(q);
        any = true;
    }
    if !any || d <= lo {
        return 1.0;
    }
    let spread = hi - lo;
    if !(spread > 0.0) {
        return 0.0;
    }
    let r = (d - lo) / spread;
    (-r * r).exp()
}

/// The column offsets a pixel may have from another: all on a flat image, the short way
/// round ([−(w−1)/2, w/2], as [`DepthBuffer::offset`]) on a wrapped one.
fn dx_range(buffer: &DepthBuffer) -> (i64, i64) {
    let w = i64::from(buffer.width);
    if buffer.wrap_x {
        (-((w - 1) / 2), w / 2)
    } else {
        (-w, w)
    }
}

/// The k occupied pixels nearest to pixel (x, y) other than itself, within Chebyshev radius
/// `max_r`: (distance², pixel), nearest first, ties to the lower pixel index; by ring search.
fn nearest(buffer: &DepthBuffer, x: i64, y: i64, k: usize, max_r: i64, out: &mut Vec<(i64, u32)>) {
    out.clear();
    let (w, h) = (i64::from(buffer.width), i64::from(buffer.height));
    let (dx_lo, dx_hi) = dx_range(buffer);
    let visit = |dx: i64, dy: i64, out: &mut Vec<(i64, u32)>| {
        let ny = y + dy;
        if ny < 0 || ny >= h {
            return;
        }
        let mut nx = x + dx;
        if buffer.wrap_x {
            nx = nx.rem_euclid(w);
        } else if nx < 0 || nx >= w {
            return;
        }
        let px = (ny * w + nx) as u32;
        if buffer.point[px as usize] != EMPTY {
            out.push((dx * dx + dy * dy, px));
        }
    };
    for r in 1..=max_r.min(w.max(h)) {
        for dy in -r..=r {
            if dy.abs() == r {
                for dx in (-r).max(dx_lo)..=r.min(dx_hi) {
                    visit(dx, dy, out);
                }
            } else {
                if -r >= dx_lo {
                    visit(-r, dy, out);
                }
                if r <= dx_hi {
                    visit(r, dy, out);
                }
            }
        }
        if out.len() >= k {
            out.sort_unstable();
            // Every pixel of a later ring is at distance >= r + 1.
            if out[k - 1].0 < (r + 1) * (r + 1) {
                break;
            }
        }
    }
    out.sort_unstable();
    out.truncate(k);
}

/// v per pixel of `buffer` (`NaN` for empty pixels).
pub fn pixel_scores(buffer: &DepthBuffer, params: &VardensityParams) -> Vec<f64> {
    let w = buffer.width as usize;
    let mut out = vec![f64::NAN; buffer.point.len()];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut near = Vec::new();
        for (x, o) in row.iter_mut().enumerate() {
            let i = buffer.point[y * w + x];
            if i == EMPTY {
                continue;
            }
            nearest(
                buffer,
                x as i64,
                y as i64,
                params.k as usize,
                i64::from(params.max_radius),
                &mut near,
            );
            let d = buffer.depth[i as usize];
            *o = score(
                d,
                near.iter()
                    .map(|&(_, px)| buffer.depth[buffer.point[px as usize] as usize]),
            );
        }
    });
    out
}

/// The points of `points` the operator keeps from `camera` (at the camera's resolution).
pub fn visible(points: &[DVec3], camera: &Camera, params: &VardensityParams) -> Result<Verdict> {
    params.validate()?;
    let buffer = DepthBuffer::build(points, camera)?;
    let v = pixel_scores(&buffer, params);
    let t = params.threshold;
    Ok(select(&buffer, &v, |s| s >= t, params.depth_tolerance))
}

#[cfg(test)]
mod tests;
