//! The dual-space construction: the cloud flipped about the viewpoint, its exact convex hull,
//! and the depth of the hull's surface along every point's ray.
//!
//! **Construction** (Mehra et al. 2010, §1 and abstract: "visibility is computed based on a
//! construction involving convex hull in a dual space, an idea inspired by the work of Katz et
//! al."; the transform itself is Katz, Tal and Basri 2007 §3.1). With the viewpoint C moved to
//! the origin, every point p goes along its own ray to p̂ = p · (2R/‖p‖ − 1), so that its
//! distance ρ = ‖p‖ becomes ρ̂ = 2R − ρ (spherical flipping, R > max ρ). The hull is that of
//! the flipped points and the origin, computed exactly by [`hull::own`] (facets wanted, so the
//! vertex-only path of HPR is not enough). Katz's visible set is the hull's vertices other than
//! the origin.
//!
//! **Surface depth.** The hull is convex and has the origin as a vertex (the eye is outside
//! the cloud's hull, see below), so every ray from the origin into it leaves it through exactly
//! one facet not incident to the origin; those facets tile, by central projection from the
//! origin, the cone of directions of the cloud. For a point q̂ of the flipped cloud,
//! ρ̂_hull(q̂) = sup{t : t · q̂/‖q̂‖ ∈ hull} is found by walking that tiling (the orient3d test
//! of [`hull::predicates`] against the plane through the origin and each edge, as `own` locates
//! points), starting from the facet of the previous point in an order along the directions
//! (a Morton curve over the octahedral map of the unit sphere), so walks are short; a walk
//! that does not settle within its step budget falls back to the minimum over all far facets,
//! which is also the brute-force definition the tests check it against. Since flipping maps
//! ρ to 2R − ρ along the same ray, the *gap* ρ̂_hull − ρ̂ is a length in the original space:
//! how far behind the front surface that the hull reconstructs (mapped back) the point lies.
//!
//! **Degenerate input.** Empty, fewer than three points, non-finite coordinates, the eye on a
//! point, R ≤ max ρ: typed errors before the hull. All points coincident, or all points and the
//! eye coplanar: the hull's `Degenerate` error, reworded. The eye inside the cloud's convex
//! hull: the origin is then not a vertex of the dual hull (all directions are occupied, there
//! is no supporting plane through the eye), and the robust operator's depths have no front to
//! be measured from: an error ([`RobustError::EyeInsideCloud`]), where plain HPR would answer.
//!
//! Cost: the flip O(n), the hull expected O(n log n), the depths O(n) walks of a few steps
//! each plus a sort of the directions, in parallel (rayon).

use cloud::glam::DVec3;
use hull::P3;
use hull::predicates::orient3d_sign;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::{Result, RobustError};

const NONE: u32 = u32::MAX;
const ORIGIN: P3 = [0.0, 0.0, 0.0];

/// The flipped cloud and its hull.
#[derive(Debug, Clone)]
pub struct Dual {
    /// Flipped points, eye-centred, in input order; the origin (the eye) appended last.
    pub flipped: Vec<P3>,
    /// The flipping radius.
    pub radius: f64,
    /// The largest distance of a point from the eye.
    pub max_distance: f64,
    /// Indices of the hull's vertices other than the eye, ascending.
    pub vertices: Vec<u32>,
    /// The hull's facets (counter-clockwise seen from outside), all of them.
    pub facets: Vec<[u32; 3]>,
    /// Per facet, the facet across edge `v[e] → v[e + 1]`.
    adjacency: Vec<[u32; 3]>,
    /// Per facet: not incident to the eye.
    far: Vec<bool>,
}

impl Dual {
    /// Flips `points` about `eye` with radius `radius` and builds the hull.
    pub fn build(points: &[DVec3], eye: DVec3, radius: f64) -> Result<Self> {
        if points.is_empty() {
            return Err(RobustError::EmptyCloud);
        }
        if points.len() < 3 {
            return Err(RobustError::TooFewPoints(points.len()));
        }
        if points.len() >= (u32::MAX - 1) as usize {
            return Err(RobustError::InvalidParameter {
                name: "points",
                reason: "more than 2^32 - 2 points".into(),
            });
        }
        if !eye.is_finite() {
            return Err(RobustError::NonFinite(None));
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(RobustError::NonFinite(Some(i)));
        }
        let distances: Vec<f64> = points.par_iter().map(|p| (*p - eye).length()).collect();
        if let Some(i) = distances.iter().position(|&d| d == 0.0) {
            return Err(RobustError::EyeOnPoint(i));
        }
        let max_distance = distances.iter().copied().fold(0.0, f64::max);
        if !(radius > max_distance) || !radius.is_finite() {
            return Err(RobustError::RadiusTooSmall {
                radius,
                max_distance,
            });
        }
        let mut flipped: Vec<P3> = points
            .par_iter()
            .zip(&distances)
            // The same arithmetic as `hpr::transform` (v · ((2R − d)/d)), so that τ = 0 gives HPR's
            // vertex set bit for bit.
            .map(|(p, &d)| ((*p - eye) * ((2.0 * radius - d) / d)).to_array())
            .collect();
        flipped.push(ORIGIN);
        let eye_index = points.len() as u32;
        let hull = hull::incremental::hull(&flipped).map_err(|e| match e {
            hull::HullError::Degenerate(m) => RobustError::Degenerate(format!(
                "the flipped cloud and the eye do not span 3-d space (all points coincident, \
                 or all points and the eye coplanar): {m}"
            )),
            other => RobustError::Hull(other),
        })?;
        if hull.vertices.binary_search(&eye_index).is_err() {
            return Err(RobustError::EyeInsideCloud);
        }
        let vertices: Vec<u32> = hull
            .vertices
            .iter()
            .copied()
            .filter(|&v| v != eye_index)
            .collect();
        let facets = hull.facets;
        let mut edges: FxHashMap<(u32, u32), u32> = FxHashMap::default();
        for (f, t) in facets.iter().enumerate() {
            for e in 0..3 {
                edges.insert((t[e], t[(e + 1) % 3]), f as u32);
            }
        }
        let adjacency = facets
            .iter()
            .map(|t| {
                let mut a = [NONE; 3];
                for e in 0..3 {
                    a[e] = edges.get(&(t[(e + 1) % 3], t[e])).copied().unwrap_or(NONE);
                }
                a
            })
            .collect();
        let far = facets.iter().map(|t| !t.contains(&eye_index)).collect();
        Ok(Self {
            flipped,
            radius,
            max_distance,
            vertices,
            facets,
            adjacency,
            far,
        })
    }

    /// Number of points (the eye not counted).
    pub fn len(&self) -> usize {
        self.flipped.len() - 1
    }

    /// Never true: [`Dual::build`] refuses empty clouds.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn p(&self, i: u32) -> &P3 {
        &self.flipped[i as usize]
    }

    /// The distance from the origin at which the ray towards `q` leaves the hull through far
    /// facet `f`, if it does (`None`: the ray does not meet the facet's plane ahead).
    fn exit_through(&self, f: usize, q: &P3) -> Option<f64> {
        let t = self.facets[f];
        let a = DVec3::from_array(*self.p(t[0]));
        let b = DVec3::from_array(*self.p(t[1]));
        let c = DVec3::from_array(*self.p(t[2]));
        let normal = (b - a).cross(c - a);
        let u = DVec3::from_array(*q).normalize();
        let along = normal.dot(u);
        (along > 0.0).then(|| normal.dot(a) / along)
    }

    /// ρ̂_hull along the ray of `q` by brute force: the nearest far-facet plane ahead (the
    /// hull is the intersection of its facets' half-spaces; the eye's facets contain the
    /// origin and bound no ray that enters the hull). O(facets).
    pub fn surface_brute_force(&self, q: &P3) -> f64 {
        (0..self.facets.len())
            .filter(|&f| self.far[f])
            .filter_map(|f| self.exit_through(f, q))
            .fold(f64::INFINITY, f64::min)
    }

    /// ρ̂_hull along the ray of `q` and the far facet it leaves through, walking from far facet
    /// `start`; `None` when the walk does not settle (the caller falls back to brute force).
    fn surface_walk(&self, q: &P3, start: u32, seed: &mut u64) -> Option<(f64, u32)> {
        let budget = 64 + 16 * (self.facets.len() as f64).sqrt() as usize;
        let mut f = start;
        for _ in 0..budget {
            if f == NONE || !self.far[f as usize] {
                return None;
            }
            let t = self.facets[f as usize];
            // Stochastic edge order (Devillers, Pion and Teillaud 2002): no cycles.
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            let first = (*seed % 3) as usize;
            let mut next = None;
            for k in 0..3 {
                let e = (first + k) % 3;
                let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
                let side_c = orient3d_sign(&ORIGIN, self.p(a), self.p(b), self.p(c));
                if side_c == 0 {
                    return None;
                }
                let side_q = orient3d_sign(&ORIGIN, self.p(a), self.p(b), q);
                if side_q == -side_c {
                    next = Some(self.adjacency[f as usize][e]);
                    break;
                }
            }
            match next {
                Some(g) => f = g,
                None => return self.exit_through(f as usize, q).map(|r| (r, f)),
            }
        }
        None
    }

    /// The gap ρ̂_hull − ρ̂ of every point (0 for hull vertices), in input order.
    pub fn gaps(&self) -> Vec<f64> {
        let n = self.len();
        let mut gaps = vec![0.0; n];
        let Some(first_far) = self.far.iter().position(|&x| x) else {
            return gaps;
        };
        let mut is_vertex = vec![false; n];
        for &v in &self.vertices {
            is_vertex[v as usize] = true;
        }
        let mut order: Vec<(u32, u32)> = (0..n as u32)
            .filter(|&i| !is_vertex[i as usize])
            .map(|i| (direction_key(self.p(i)), i))
            .collect();
        order.par_sort_unstable();
        let results: Vec<(u32, f64)> = order
            .par_chunks(2048)
            .enumerate()
            .flat_map_iter(|(chunk_idx, chunk)| {
                let mut seed = 0x9e37_79b9_7f4a_7c15u64 ^ (chunk_idx as u64 + 1);
                let mut start = first_far as u32;
                chunk
                    .iter()
                    .map(|&(_, i)| {
                        let q = self.p(i);
                        let surface = match self.surface_walk(q, start, &mut seed) {
                            Some((r, f)) => {
                                start = f;
                                r
                            }
                            None => self.surface_brute_force(q),
                        };
                        let rho = DVec3::from_array(*q).length();
                        (i, surface - rho)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        for (i, g) in results {
            gaps[i as usize] = g;
        }
        gaps
    }
}

/// A Morton key of the direction of `q` over the octahedral map of the unit sphere.
fn direction_key(q: &P3) -> u32 {
    let v = DVec3::from_array(*q);
    let l1 = v.x.abs() + v.y.abs() + v.z.abs();
    let (mut x, mut y) = (v.x / l1, v.y / l1);
    if v.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * ox.signum();
        y = (1.0 - ox.abs()) * oy.signum();
    }
    let quant = |c: f64| (((c + 1.0) * 0.5).clamp(0.0, 1.0) * 65535.0) as u32;
    interleave(quant(x)) | (interleave(quant(y)) << 1)
}

fn interleave(mut x: u32) -> u32 {
    x &= 0xffff;
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    x = (x | (x << 1)) & 0x5555_5555;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::rng::{RngExt, seeded};

    fn random_cloud(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = seeded(seed, "dual-test");
        (0..n)
            .map(|_| {
                DVec3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                )
            })
            .collect()
    }

    #[test]
    fn the_dual_hull_is_exact_against_a_certificate_and_brute_force() {
        // Certificate (O(n · facets) = O(n²)) on 2,000 points, brute-force extreme points
        // (O(n⁴)) on 60.
        let eye = DVec3::new(0.2, -0.1, 2.5);
        for (n, brute) in [(2_000, false), (60, true)] {
            let pts = random_cloud(n, n as u64);
            let dual = Dual::build(&pts, eye, 30.0).unwrap();
            let mut all = dual.vertices.clone();
            all.push(n as u32);
            hull::check::verify(&dual.flipped, &dual.facets, &all).unwrap();
            if brute {
                let oracle = hull::check::extreme_points_brute_force(&dual.flipped).unwrap();
                assert_eq!(oracle, all);
            }
        }
    }

    #[test]
    fn walked_depths_equal_the_brute_force_minimum() {
        let pts = random_cloud(3_000, 7);
        let dual = Dual::build(&pts, DVec3::new(0.0, 0.0, 1.8), 12.0).unwrap();
        let gaps = dual.gaps();
        let mut checked = 0;
        for (i, &g) in gaps.iter().enumerate() {
            let q = dual.flipped[i];
            let brute = dual.surface_brute_force(&q) - DVec3::from_array(q).length();
            if dual.vertices.binary_search(&(i as u32)).is_ok() {
                assert_eq!(g, 0.0);
                assert!(brute.abs() < 1e-9, "vertex {i}: {brute}");
            } else {
                assert!(
                    (g - brute).abs() < 1e-9,
                    "point {i}: walk {g}, brute {brute}"
                );
                assert!(g >= -1e-9, "point {i} above the hull: {g}");
                checked += 1;
            }
        }
        assert!(checked > 1_000, "{checked}");
    }

    #[test]
    fn a_gap_is_a_length_behind_the_front() {
        // A point straight behind another, 0.3 further from the eye: its gap is 0.3 when the
        // front point is a vertex whose facets are all about as far as it along that ray.
        let mut pts = crate::tests::grid(21, 0.05, 1.0);
        pts.push(DVec3::new(0.0, 0.0, 1.3));
        let dual = Dual::build(&pts, DVec3::ZERO, 100.0).unwrap();
        let gaps = dual.gaps();
        let last = *gaps.last().unwrap();
        assert!((last - 0.3).abs() < 1e-3, "{last}");
    }
}
