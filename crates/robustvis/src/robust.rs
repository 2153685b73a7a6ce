//! The robust operator: every point within a depth band τ of the dual hull's surface.
//!
//! **Definition.** With the dual construction of [`crate::dual`] (flipping radius R about the
//! eye C, hull H of the flipped points and the origin), point i is visible when
//!
//!   gap_i = ρ̂_H(u_i) − ρ̂_i ≤ τ,   ρ̂_H(u) = sup{t ≥ 0 : t·u ∈ H},
//!
//! u_i the direction of p_i from C and ρ̂_i = 2R − ‖p_i − C‖ its flipped distance. Because
//! flipping keeps rays and reverses distances, gap_i is how far p_i lies behind the front
//! surface the hull reconstructs, measured along its ray in the original space. τ = 0 is Katz's
//! operator exactly (the hull's vertices, with every copy of a visible point; non-extreme
//! points exactly on a facet are not added, as HPR does not add them); τ > 0 keeps the points
//! that noise pushed behind the front by at most τ (see [`crate::bounds`] for how τ and R are
//! chosen from the noise and concavity bounds).
//!
//! **Relation to the paper.** Mehra et al. 2010 build their robust operator from the dual hull
//! and the two bounds (abstract; §1); the operator's exact form in the paper could not be
//! read (see the crate documentation). This depth-band form is ours: it is the smallest change
//! to Katz's operator that makes the noise bound a bound on something other than R. Its cost
//! is HPR's hull (facets kept) plus one short walk per point.

use cloud::glam::DVec3;
use rustc_hash::FxHashSet;

use crate::dual::Dual;
use crate::{Result, RobustError};

/// The outcome of one call.
#[derive(Debug, Clone, PartialEq)]
pub struct Visibility {
    /// Indices of the visible points, ascending.
    pub visible: Vec<u32>,
    /// Per point (input order): gap_i, 0 for the hull's vertices.
    pub gaps: Vec<f64>,
    /// The flipping radius used.
    pub radius: f64,
    /// The largest distance of a point from the eye.
    pub max_distance: f64,
    /// Number of hull vertices other than the eye (Katz's visible set before copies).
    pub hull_vertices: usize,
}

/// The robust operator with radius `radius` and band `tolerance` (τ ≥ 0, a length).
pub fn visible(points: &[DVec3], eye: DVec3, radius: f64, tolerance: f64) -> Result<Visibility> {
    if !(tolerance >= 0.0) || !tolerance.is_finite() {
        return Err(RobustError::InvalidParameter {
            name: "tolerance",
            reason: format!("the depth band must be a finite length >= 0, got {tolerance}"),
        });
    }
    let dual = Dual::build(points, eye, radius)?;
    let gaps = dual.gaps();
    let mut flags = vec![false; points.len()];
    for &v in &dual.vertices {
        flags[v as usize] = true;
    }
    // Copies of a vertex flip onto it: visible, as in HPR.
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let at_vertices: FxHashSet<[u64; 3]> = dual
        .vertices
        .iter()
        .map(|&v| key(points[v as usize]))
        .collect();
    for (i, p) in points.iter().enumerate() {
        if !flags[i]
            && ((tolerance > 0.0 && gaps[i] <= tolerance) || at_vertices.contains(&key(*p)))
        {
            flags[i] = true;
        }
    }
    let visible = flags
        .iter()
        .enumerate()
        .filter(|(_, f)| **f)
        .map(|(i, _)| i as u32)
        .collect();
    Ok(Visibility {
        visible,
        gaps,
        radius: dual.radius,
        max_distance: dual.max_distance,
        hull_vertices: dual.vertices.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::rng::{RngExt, seeded};
    use proptest::prelude::*;

    /// The definition evaluated by brute force: the supporting planes of the flipped points and
    /// the origin by enumeration of triples (O(n⁴)), ρ̂_H(u) the nearest plane ahead.
    fn brute_force(points: &[DVec3], eye: DVec3, radius: f64, tolerance: f64) -> Vec<(u32, f64)> {
        let mut q: Vec<DVec3> = points
            .iter()
            .map(|p| {
                let v = *p - eye;
                v * ((2.0 * radius - v.length()) / v.length())
            })
            .collect();
        q.push(DVec3::ZERO);
        let n = q.len();
        let mut planes: Vec<(DVec3, f64)> = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                for k in j + 1..n {
                    let normal = (q[j] - q[i]).cross(q[k] - q[i]);
                    if normal.length() < 1e-12 {
                        continue;
                    }
                    let normal = normal.normalize();
                    let c = normal.dot(q[i]);
                    let side: Vec<f64> = q.iter().map(|p| normal.dot(*p) - c).collect();
                    let scale = 1e-9 * radius;
                    if side.iter().all(|&s| s <= scale) {
                        planes.push((normal, c));
                    } else if side.iter().all(|&s| s >= -scale) {
                        planes.push((-normal, -c));
                    }
                }
            }
        }
        let mut out = Vec::new();
        for i in 0..points.len() {
            let u = q[i].normalize();
            let surface = planes
                .iter()
                .filter(|(nrm, c)| nrm.dot(u) > 1e-12 && *c > 1e-9 * radius)
                .map(|(nrm, c)| c / nrm.dot(u))
                .fold(f64::INFINITY, f64::min);
            let gap = surface - q[i].length();
            if gap <= tolerance.max(1e-9 * radius) {
                out.push((i as u32, gap));
            }
        }
        out
    }

    fn small_cloud(n: usize, seed: u64) -> Vec<DVec3> {
        // A noisy bumpy sheet in front of a second sheet: both visible and hidden points.
        let mut rng = seeded(seed, "robust-brute");
        (0..n)
            .map(|i| {
                let (x, y) = (rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                let z = if i % 3 == 0 { 0.6 } else { 0.0 } + 0.05 * rng.random::<f64>();
                DVec3::new(x, y, z)
            })
            .collect()
    }

    #[test]
    fn the_operator_equals_its_definition_by_brute_force() {
        let eye = DVec3::new(0.1, 0.05, 2.0);
        for seed in 0..6 {
            let pts = small_cloud(45, seed);
            for (radius, tolerance) in [(4.0, 0.02), (20.0, 0.05), (8.0, 0.3)] {
                let fast = visible(&pts, eye, radius, tolerance).unwrap();
                let brute = brute_force(&pts, eye, radius, tolerance);
                // Agree except where the gap is within rounding of τ.
                for i in 0..pts.len() as u32 {
                    let in_fast = fast.visible.binary_search(&i).is_ok();
                    let in_brute = brute.iter().any(|(j, _)| *j == i);
                    if in_fast != in_brute {
                        let g = fast.gaps[i as usize];
                        assert!(
                            (g - tolerance).abs() < 1e-7,
                            "seed {seed} R {radius} τ {tolerance} point {i}: fast {in_fast} gap {g}"
                        );
                    }
                }
                assert!(fast.visible.len() < pts.len(), "something is hidden");
            }
        }
    }

    #[test]
    fn zero_band_is_katz_hpr() {
        let pts = small_cloud(3_000, 11);
        let eye = DVec3::new(0.1, 0.05, 2.0);
        for gamma in [1.0, 2.0, 3.0] {
            let m = pts.iter().map(|p| (*p - eye).length()).fold(0.0, f64::max);
            let r = m * 10f64.powf(gamma);
            let ours = visible(&pts, eye, r, 0.0).unwrap();
            let params = hpr::HprParams {
                kernel: hpr::Kernel::Linear(hpr::Radius::Absolute(r)),
                ..hpr::HprParams::default()
            };
            let own = hull::by_name("own").unwrap();
            let theirs = hpr::visible(&pts, eye, &params, own.as_ref()).unwrap();
            assert_eq!(ours.visible, theirs.visible, "γ {gamma}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Gaps are never negative (no point is above the hull), a wider band keeps a superset,
        /// and moving the cloud and the eye together changes nothing.
        #[test]
        fn bands_nest_and_gaps_are_non_negative(
            seed in 0u64..1000,
            t1 in 0.0f64..0.2,
            extra in 0.0f64..0.2,
            shift in prop::array::uniform3(-5.0f64..5.0),
        ) {
            let pts = small_cloud(400, seed);
            let eye = DVec3::new(0.2, -0.1, 1.5);
            let narrow = visible(&pts, eye, 15.0, t1).unwrap();
            let wide = visible(&pts, eye, 15.0, t1 + extra).unwrap();
            prop_assert!(narrow.gaps.iter().all(|&g| g >= -1e-9));
            prop_assert!(narrow.visible.iter().all(|i| wide.visible.binary_search(i).is_ok()));
            let d = DVec3::from_array(shift);
            let moved: Vec<DVec3> = pts.iter().map(|p| *p + d).collect();
            let m = visible(&moved, eye + d, 15.0, t1).unwrap();
            // Translation moves coordinates by rounding: compare away from the band's edge.
            for i in 0..pts.len() {
                let g = narrow.gaps[i];
                if (g - t1).abs() > 1e-6 && g.abs() > 1e-6 {
                    prop_assert_eq!(
                        narrow.visible.binary_search(&(i as u32)).is_ok(),
                        m.visible.binary_search(&(i as u32)).is_ok()
                    );
                }
            }
        }
    }
}
