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
    entry_from(dir, oc, oc.length_squared() - r * r)
}

/// [`entry`] from the sphere's terms relative to the ray's origin: `oc` (centre − origin)
/// and `k` (|oc|² − r²), which a caller testing many rays from one origin computes once.
#[inline]
fn entry_from(dir: DVec3, oc: DVec3, k: f64) -> Option<f64> {
    let a = dir.length_squared();
    let b = dir.dot(oc);
    let disc = b * b - a * k;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    ((b + s) / a > 0.0).then(|| ((b - s) / a).max(0.0))
}

/// The pixels whose rays can meet a sphere: a rectangle (x0..=x1, y0..=y1, columns may wrap
/// for a spherical image), or, for a pinhole sphere that reaches the eye's plane (beside the
/// eye, or behind it), its exact rows ([`row_span`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Footprint {
    /// Every pixel centre whose ray can meet the sphere lies in this rectangle.
    Rect(i64, i64, i64, i64),
    /// A pinhole sphere across the eye's plane, the eye outside it: the rays within the cone
    /// of half-angle α around the unit direction `u` to its centre (`cos2` = cos² α), found
    /// row by row.
    Cone {
        /// The unit direction from the eye to the sphere's centre.
        u: DVec3,
        /// cos² of the cone's half-angle (r / distance = sin α).
        cos2: f64,
    },
}

/// Where the sphere at `c` of radius `r` can show in `camera`'s image; `None` when it is out of
/// view. Conservative: a rectangle of twice the sphere's projected radius plus a pixel around
/// its projection, or, for a pinhole sphere across the eye's plane, the exact span of each
/// row with a pixel's margin ([`row_span`]); the whole image only when the eye is inside the
/// sphere (then every ray starts in it).
fn footprint(camera: &Camera, c: DVec3, r: f64) -> Option<Footprint> {
    let (w, h) = (i64::from(camera.width), i64::from(camera.height));
    let whole = Some(Footprint::Rect(0, w - 1, 0, h - 1));
    let to_centre = c - camera.eye;
    let distance = to_centre.length();
    if distance <= r {
        return whole;
    }
    match camera.model() {
        cloud::Model::Orthographic {
            view_width,
            view_height,
        } => {
            // Parallel rays from the plane through the eye: the sphere's disc around its
            // projection, wherever its depth (rays start on that plane; one behind it by less
            // than r is entered at 0).
            if camera.depth(c) <= -r {
                return None;
            }
            let (sx, sy) = (
                f64::from(camera.width) / view_width,
                f64::from(camera.height) / view_height,
            );
            let (px, py) = (
                0.5 * w as f64 + to_centre.dot(camera.right()) * sx,
                0.5 * h as f64 + to_centre.dot(camera.down()) * sy,
            );
            let (hx, hy) = (r * sx + 1.0, r * sy + 1.0);
            rect(px, py, hx, hy, w, h)
        }
        cloud::Model::Pinhole { .. } => {
            if camera.depth(c) <= -r {
                return None;
            }
            let Some(p) = camera.project(c).filter(|p| p.depth - r > p.depth * 1e-6) else {
                let sin = r / distance;
                return Some(Footprint::Cone {
                    u: to_centre / distance,
                    cos2: (1.0 - sin * sin).max(0.0),
                });
            };
            let half = 2.0 * r / camera.pixel_size_at(p.depth - r) + 1.0;
            rect(p.x, p.y, half, half, w, h)
        }
        cloud::Model::Spherical => {
            let p = camera.project(c)?;
            let near = p.depth - r;
            if near <= p.depth * 1e-6 {
                return whole;
            }
            let half = 2.0 * r / camera.pixel_size_at(near) + 1.0;
            // A pixel column narrows towards the poles by sin θ.
            let theta = (p.y / camera.height as f64 * std::f64::consts::PI).sin();
            let hx = if theta * w as f64 > 2.0 * half {
                half / theta.max(1e-9)
            } else {
                w as f64
            };
            let (x0, x1) = ((p.x - hx).floor() as i64, (p.x + hx).ceil() as i64);
            let (y0, y1) = (
                ((p.y - half).floor() as i64).max(0),
                ((p.y + half).ceil() as i64).min(h - 1),
            );
            if y0 > y1 {
                return None;
            }
            Some(if x1 - x0 + 1 >= w {
                Footprint::Rect(0, w - 1, y0, y1)
            } else {
                Footprint::Rect(x0, x1, y0, y1)
            })
        }
    }
}

/// The rectangle of half-sizes `hx`, `hy` pixels around (`x`, `y`), clipped to a `w` × `h`
/// image; `None` when it misses it.
fn rect(x: f64, y: f64, hx: f64, hy: f64, w: i64, h: i64) -> Option<Footprint> {
    let (x0, x1) = (
        ((x - hx).floor() as i64).max(0),
        ((x + hx).ceil() as i64).min(w - 1),
    );
    let (y0, y1) = (
        ((y - hy).floor() as i64).max(0),
        ((y + hy).ceil() as i64).min(h - 1),
    );
    (x0 <= x1 && y0 <= y1).then_some(Footprint::Rect(x0, x1, y0, y1))
}

/// The pixels of row `y` of a pinhole `camera` whose rays lie within the cone around the unit
/// direction `u` whose half-angle has cosine² `cos2` (a sphere seen from outside), as columns
/// `x0..=x1` with a pixel's margin, clipped to the image; `None` when the row misses it.
///
/// The row's rays are d(a) = f + b·down + a·right (a, b: the pixel centre's offsets over the
/// focal lengths), |d|² = 1 + b² + a², d·u = P + a·Q; d is in the cone when d·u > 0 and
/// (P + aQ)² ≥ cos²α (1 + b² + a²), a quadratic in a.
fn row_span(camera: &Camera, u: DVec3, cos2: f64, y: i64) -> Option<(i64, i64)> {
    let cloud::Model::Pinhole { fx, fy, cx, cy } = *camera.model() else {
        return None;
    };
    let w = i64::from(camera.width);
    let b = (y as f64 + 0.5 - cy) / fy;
    let p = u.dot(camera.forward()) + b * u.dot(camera.down());
    let q = u.dot(camera.right());
    let (qa, qb, qc) = (q * q - cos2, 2.0 * p * q, p * p - cos2 * (1.0 + b * b));
    // The interval of a (possibly unbounded) in the cone's forward nappe.
    let (lo, hi) = if qa.abs() <= 1e-12 {
        // Q² = cos²α (the cone touches the right axis): the forward half-line P + aQ > 0,
        // a superset; each pixel's own test decides.
        match q.partial_cmp(&0.0) {
            Some(std::cmp::Ordering::Greater) => (-p / q, f64::INFINITY),
            Some(std::cmp::Ordering::Less) => (f64::NEG_INFINITY, -p / q),
            _ => return None,
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if qa < 0.0 {
            // Between the roots, when that stretch is on the forward nappe.
            if disc < 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let (r1, r2) = ((-qb + s) / (2.0 * qa), (-qb - s) / (2.0 * qa));
            let (a1, a2) = (r1.min(r2), r1.max(r2));
            if p + 0.5 * (a1 + a2) * q <= 0.0 {
                return None;
            }
            (a1, a2)
        } else {
            // Outside the roots (everywhere when there are none): the forward side alone.
            let (a1, a2) = if disc < 0.0 {
                (f64::NAN, f64::NAN)
            } else {
                let s = disc.sqrt();
                let (r1, r2) = ((-qb + s) / (2.0 * qa), (-qb - s) / (2.0 * qa));
                (r1.min(r2), r1.max(r2))
            };
            match (q > 0.0, disc < 0.0) {
                (true, false) => (a2, f64::INFINITY),
                (false, false) => (f64::NEG_INFINITY, a1),
                (true, true) => (-p / q, f64::INFINITY),
                (false, true) => (f64::NEG_INFINITY, -p / q),
            }
        }
    };
    let x0 = (cx + fx * lo - 0.5).floor() - 1.0;
    let x1 = (cx + fx * hi - 0.5).ceil() + 1.0;
    let (x0, x1) = (x0.max(0.0), x1.min((w - 1) as f64));
    (x0 <= x1).then_some((x0 as i64, x1 as i64))
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
    // A pinhole ray is a column's term plus a row's, the same bits as `camera.ray`'s.
    let tables = camera.pinhole_ray_tables();
    // One image per share of the points, merged pixel by pixel: the lexicographic minimum of
    // (entry, index) does not depend on the order, so the result is the sequential one's.
    let draw = |share: &[u32]| {
        let mut best = vec![(f64::INFINITY, NONE); w * h];
        for &i in share {
            let c = points[i as usize];
            let footprint = footprint(camera, c, radius);
            if let (Some((columns, rows)), Some(Footprint::Rect(x0, x1, y0, y1))) =
                (&tables, footprint)
            {
                // `entry` from the eye, the sphere's terms hoisted out of the pixel loop.
                let oc = c - camera.eye;
                let k = oc.length_squared() - radius * radius;
                for y in y0..=y1 {
                    let (row, line) = (rows[y as usize], y as usize * w);
                    for x in x0..=x1 {
                        if let Some(t) = entry_from(columns[x as usize] + row, oc, k) {
                            let best = &mut best[line + x as usize];
                            // `(t, i) < *best`, written out (the tuple's partial_cmp is slow).
                            if t < best.0 || (t == best.0 && i < best.1) {
                                *best = (t, i);
                            }
                        }
                    }
                }
                continue;
            }
            let mut test = |x: i64, y: i64| {
                let (o, d) = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
                if let Some(t) = entry(o, d, c, radius) {
                    let b = &mut best[y as usize * w + x as usize];
                    if (t, i) < *b {
                        *b = (t, i);
                    }
                }
            };
            match footprint {
                None => {}
                Some(Footprint::Rect(x0, x1, y0, y1)) => {
                    for y in y0..=y1 {
                        for xs in x0..=x1 {
                            test(
                                if spherical {
                                    xs.rem_euclid(w as i64)
                                } else {
                                    xs
                                },
                                y,
                            );
                        }
                    }
                }
                Some(Footprint::Cone { u, cos2 }) => {
                    for y in 0..h as i64 {
                        if let Some((x0, x1)) = row_span(camera, u, cos2, y) {
                            for x in x0..=x1 {
                                test(x, y);
                            }
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
