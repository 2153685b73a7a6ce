//! Pintus, Gobbetti, Agus, "Real-time Rendering of Massive Unstructured Raw Point Clouds
//! using Screen-space Operators", VAST 2011: per-frame visibility of a raw cloud (no normals,
//! no preprocessing) from the depth buffer alone.
//!
//! **Source.** The full text was not available to us: the stored copies reached are the
//! abstract and the bibliographic pages (CRS4, Eurographics digital library). What is
//! implemented is the operator as the abstract, REFERENCES.md and the public implementations
//! that follow the paper describe it (CesiumGS's point-occlusion pass, read for the rule and not
//! copied): a point projected into the depth buffer is visible when the solid angle of the
//! cone of directions towards the viewer that its screen-space neighbours leave open is large
//! enough; the neighbourhood is a fixed window per level of a multi-level pyramid (§4 of the
//! paper by the abstract's account: "computes point cloud visibility" as the first of its
//! screen-space operators, followed by filling and shading, which are rendering steps and not
//! implemented here). Section and equation numbers of the paper could therefore not be
//! checked; the coordinator should compare this rule with §4 of the paper before quoting it.
//!
//! **The rule**, for a pixel holding point P with unit direction w towards the viewer:
//! the image plane around P's pixel is cut into S equal angular sectors (by the direction of
//! the pixel offset, atan2(dy, dx), sector 0 centred on +x); on every pyramid level l < L,
//! each neighbour Q ≠ P in the (2h+1)² window around P's level-l pixel with
//! cos θ = w·(Q−P)/|Q−P| > 0 (Q is in front of the plane through P normal to w; Q behind it
//! cannot occlude) narrows the open cone of its sector s to θ_s = min θ. The open cone of sector s has the solid angle (2π/S)(1 − cos
//! θ_s), so the fraction of the hemisphere towards the viewer left open is
//!
//!   Ω(P) = (1/S) Σ_s (1 − cos θ_s),    θ_s = π/2 where nothing occludes,
//!
//! and the pixel is kept when Ω ≥ `threshold`. A point in an empty neighbourhood or on a
//! surface facing the viewer scores 1; a point seen through a gap of a nearer surface, with
//! occluders on every side, scores near 0; a point on a surface seen at grazing incidence
//! scores about 1/2 (the surface itself closes half the hemisphere), so useful thresholds lie
//! below 1/2.
//!
//! **Deviations.** CPU (rayon over rows) instead of fragment shaders; f64 throughout; the
//! open solid angle is the exact sum of the sectors' cone solid angles (1 − cos θ_s), where
//! the public shader sums the angles θ_s themselves; sectors take the level-0 pixel offset of
//! Q from P (not the coarse-level offset), so the same neighbour falls in the same sector on
//! every level; orthographic cameras use the constant direction −forward towards the viewer;
//! spherical (equirectangular) images wrap in azimuth and use the range as depth; no hole
//! filling, no shading, no temporal reuse. Points that lose their pixel to a nearer point are
//! not shown, hence not visible (see [`crate::select`] for the optional depth tolerance).

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

use crate::depth::{DepthBuffer, EMPTY, Viewer};
use crate::error::{Error, Result};
use crate::pyramid::Pyramid;
use crate::select::{Verdict, check_tolerance, select};

/// The operator's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PintusParams {
    /// Angular sectors S around each pixel (1..=64).
    pub sectors: u32,
    /// Half width h of the window, pixels of each level (1..=32).
    pub half_width: u32,
    /// Pyramid levels L (1..=16; level 0 is the depth buffer).
    pub levels: u32,
    /// Minimum open fraction Ω of the hemisphere, in [0, 1].
    pub threshold: f64,
    /// Relative depth tolerance of [`crate::select`] (0: the paper's rule).
    pub depth_tolerance: f64,
}

impl Default for PintusParams {
    fn default() -> Self {
        Self {
            sectors: 8,
            half_width: 2,
            levels: 3,
            threshold: 0.25,
            depth_tolerance: 0.0,
        }
    }
}

impl PintusParams {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason: String| Err(Error::InvalidParameter { name, reason });
        if !(1..=64).contains(&self.sectors) {
            return bad("sectors", format!("{}: must be in 1..=64", self.sectors));
        }
        if !(1..=32).contains(&self.half_width) {
            return bad(
                "half_width",
                format!("{}: must be in 1..=32 pixels", self.half_width),
            );
        }
        if !(1..=16).contains(&self.levels) {
            return bad("levels", format!("{}: must be in 1..=16", self.levels));
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

/// The sector (0..S) of the pixel offset (dx, dy) ≠ (0, 0): sector 0 is centred on +x and
/// the sectors follow atan2(dy, dx), so the eight compass neighbours of S = 8 fall in eight
/// different sectors, none on a boundary.
#[inline]
pub fn sector(dx: i64, dy: i64, sectors: u32) -> usize {
    let s = f64::from(sectors);
    let turn = (dy as f64).atan2(dx as f64) / std::f64::consts::TAU + 0.5 / s;
    ((turn.rem_euclid(1.0) * s) as usize).min(sectors as usize - 1)
}

/// Ω per pixel of `buffer` (`NaN` for empty pixels).
pub fn open_fraction(
    points: &[DVec3],
    buffer: &DepthBuffer,
    pyramid: &Pyramid,
    viewer: Viewer,
    params: &PintusParams,
) -> Vec<f64> {
    let w = buffer.width as usize;
    let mut out = vec![f64::NAN; buffer.point.len()];
    let h = i64::from(params.half_width);
    let s_count = params.sectors as usize;
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let mut best = vec![0.0f64; s_count];
        for (x, o) in row.iter_mut().enumerate() {
            let i = buffer.point[y * w + x];
            if i == EMPTY {
                continue;
            }
            let p = points[i as usize];
            let toward = viewer.toward(p);
            best.iter_mut().for_each(|b| *b = 0.0);
            for (l, level) in pyramid.levels.iter().enumerate() {
                let (lw, lh) = (i64::from(level.width), i64::from(level.height));
                let (lx, ly) = ((x >> l) as i64, (y >> l) as i64);
                for ny in (ly - h).max(0)..=(ly + h).min(lh - 1) {
                    for dx in -h..=h {
                        let mut nx = lx + dx;
                        if buffer.wrap_x {
                            nx = nx.rem_euclid(lw);
                        } else if nx < 0 || nx >= lw {
                            continue;
                        }
                        let j = level.point[(ny * lw + nx) as usize];
                        if j == EMPTY || j == i {
                            continue;
                        }
                        let v = points[j as usize] - p;
                        let len = v.length();
                        if !(len > 0.0) {
                            continue;
                        }
                        let c = toward.dot(v) / len;
                        if c <= 0.0 {
                            continue;
                        }
                        let (qx, qy) = buffer.xy(buffer.pixel_of[j as usize]);
                        let (ox, oy) = buffer.offset(x as i64, y as i64, qx, qy);
                        if ox == 0 && oy == 0 {
                            continue;
                        }
                        let s = sector(ox, oy, params.sectors);
                        if c > best[s] {
                            best[s] = c;
                        }
                    }
                }
            }
            *o = 1.0 - best.iter().sum::<f64>() / s_count as f64;
        }
    });
    out
}

/// The points of `points` the operator keeps from `camera` (at the camera's resolution).
pub fn visible(points: &[DVec3], camera: &Camera, params: &PintusParams) -> Result<Verdict> {
    params.validate()?;
    let buffer = DepthBuffer::build(points, camera)?;
    let pyramid = Pyramid::build(&buffer, params.levels);
    let omega = open_fraction(points, &buffer, &pyramid, Viewer::of(camera), params);
    let t = params.threshold;
    Ok(select(&buffer, &omega, |s| s >= t, params.depth_tolerance))
}

#[cfg(test)]
mod tests;
