//! The visibility-confidence score of Katz and Tal, "On the Visibility of Point Clouds",
//! ICCV 2015 (abstract; the paper's application section): instead of HPR's yes/no answer at one
//! kernel parameter, a per-point score of how confidently a point is visible.
//!
//! Why it exists: by the parameter condition ([`crate::properties`], property 3) every
//! visible point of a densely sampled surface reaches the hull as γ approaches its limit γ*,
//! front-facing points already far from it, points at silhouettes and in concavities only near
//! it, and hidden points (whose images leak through the chords of a too-flat transformed
//! surface, seed 000 §6) last of all. How early on the way to γ* a point is on the hull is
//! therefore a confidence.
//!
//! Definition used here: for a family of kernels ([`Family`]) and a grid γ₁, …, γ_m of valid
//! parameters (evenly spaced in γ for the linear kernel, whose γ is already a decade of R;
//! geometrically in |γ| for the others), the score of point p is
//!
//!   s(p) = |{ j : p̂(γ_j) is a vertex of conv(P̂(γ_j) ∪ {C}) }| / m  ∈ {0, 1/m, …, 1},
//!
//! the fraction of the grid at which HPR marks p visible. The visible set at threshold t is
//! { p : s(p) ≥ t } ([`threshold`]); with visible sets nested along the grid (the usual case,
//! not a theorem) threshold j/m is exactly HPR at the (m − j + 1)-th parameter from γ*.
//!
//! Deviations and gaps: we had the paper's abstract and first page, not the section that
//! defines the score; the definition above is ours, built from the three properties. If the
//! paper defines the score as the critical parameter itself (the γ at which p reaches the
//! hull), ours is its discretisation on the grid, and the two order points alike wherever the
//! visible sets are nested. The score is computed with m exact hulls (cost m × HPR; the
//! parameters run one after another, each hull in parallel inside).
//!
//! The tests compare the score with a direct evaluation of the definition: the kernel written
//! out again and the hull vertices found by `hull::check`'s O(n⁴) brute force.

use cloud::glam::DVec3;
use hull::ConvexHull;

use crate::properties::Family;
use crate::{HprError, HprParams};

/// The largest grid (the score is stored per point as a count).
pub const MAX_STEPS: usize = 1024;

/// The parameter grid of the score.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The kernel family.
    pub family: Family,
    /// The parameters, from the one farthest from the limit to the nearest.
    pub gammas: Vec<f64>,
}

impl Grid {
    /// `steps` parameters from `from` to `to` (both valid for `family`, `to` the nearer to the
    /// limit of property 3): evenly spaced for the linear kernel, geometrically otherwise.
    pub fn new(family: Family, from: f64, to: f64, steps: usize) -> Result<Self, HprError> {
        let bad = |name: &'static str, reason: String| HprError::InvalidParameter { name, reason };
        if steps == 0 || steps > MAX_STEPS {
            return Err(bad(
                "steps",
                format!("must be in 1..={MAX_STEPS}, got {steps}"),
            ));
        }
        for (name, g) in [("from", from), ("to", to)] {
            if !family.valid(g) {
                return Err(bad(
                    name,
                    format!(
                        "{g} is not a valid parameter of the {} kernel",
                        family.name()
                    ),
                ));
            }
        }
        let toward = if family.limit_is_up() {
            to >= from
        } else {
            to <= from
        };
        if !toward {
            return Err(bad(
                "to",
                format!(
                    "must be nearer the limit of the {} kernel than from ({from}), got {to}",
                    family.name()
                ),
            ));
        }
        let gammas = if steps == 1 {
            vec![to]
        } else {
            let t = |j: usize| j as f64 / (steps - 1) as f64;
            match family {
                Family::Linear => (0..steps).map(|j| from + (to - from) * t(j)).collect(),
                // Same sign throughout: geometric spacing of |γ|.
                _ => (0..steps)
                    .map(|j| from * (to / from).powf(t(j)))
                    .map(|g| if family.valid(g) { g } else { to })
                    .collect(),
            }
        };
        Ok(Self { family, gammas })
    }
}

/// The score of every point.
#[derive(Debug, Clone, PartialEq)]
pub struct Confidence {
    /// Per point, indexed like the cloud: the fraction of the grid at which it is visible.
    pub score: Vec<f32>,
    /// Per grid parameter, the number of visible points.
    pub visible_counts: Vec<usize>,
}

/// The confidence score of every point of `points` seen from `eye`.
pub fn confidence(
    points: &[DVec3],
    eye: DVec3,
    grid: &Grid,
    hull: &dyn ConvexHull,
) -> Result<Confidence, HprError> {
    if grid.gammas.is_empty() || grid.gammas.len() > MAX_STEPS {
        return Err(HprError::InvalidParameter {
            name: "steps",
            reason: format!("must be in 1..={MAX_STEPS}, got {}", grid.gammas.len()),
        });
    }
    let mut counts = vec![0u16; points.len()];
    let mut visible_counts = Vec::with_capacity(grid.gammas.len());
    for &gamma in &grid.gammas {
        let params = HprParams {
            kernel: grid.family.kernel(gamma),
            perturb: 0.0,
            seed: 0,
        };
        let v = crate::visible(points, eye, &params, hull)?;
        for &i in &v.visible {
            counts[i as usize] += 1;
        }
        visible_counts.push(v.visible.len());
    }
    let m = grid.gammas.len() as f32;
    Ok(Confidence {
        score: counts.into_iter().map(|c| f32::from(c) / m).collect(),
        visible_counts,
    })
}

/// The points whose score is at least `t` (0 < t ≤ 1), ascending.
pub fn threshold(score: &[f32], t: f64) -> Result<Vec<u32>, HprError> {
    if !(t > 0.0 && t <= 1.0) {
        return Err(HprError::InvalidParameter {
            name: "threshold",
            reason: format!("must be in (0, 1], got {t}"),
        });
    }
    // A score j/m meets t when j/m ≥ t; compare in f64 with a little slack for the f32
    // rounding of j/m (the scores are multiples of 1/m, m ≤ 1024).
    Ok(score
        .iter()
        .enumerate()
        .filter(|&(_, &s)| f64::from(s) >= t - 1e-6)
        .map(|(i, _)| i as u32)
        .collect())
}

#[cfg(test)]
mod tests {
    use cloud::rng::{RngExt, seeded};
    use hull::check::extreme_points_brute_force;
    use proptest::prelude::*;

    use super::*;

    fn own() -> Box<dyn ConvexHull> {
        hull::by_name("own").unwrap()
    }

    /// The definition evaluated directly: each kernel written out, the transformed points and
    /// the eye, hull vertices by brute force, visible = vertices other than the eye.
    fn brute_force(points: &[DVec3], eye: DVec3, grid: &Grid) -> Vec<f32> {
        let m = points
            .iter()
            .map(|p| (*p - eye).length())
            .fold(0.0, f64::max);
        let mut counts = vec![0u32; points.len()];
        for &g in &grid.gammas {
            let mut t: Vec<[f64; 3]> = points
                .iter()
                .map(|&p| {
                    let v = p - eye;
                    let d = v.length();
                    let f = match grid.family {
                        Family::Linear => 2.0 * m * 10f64.powf(g) - d,
                        Family::Exponential => d.powf(g),
                        Family::Log => (m * 10f64.powf(g) / d).ln(),
                        Family::ExpDecay => (-g * d / m).exp(),
                    };
                    (v / d * f).to_array()
                })
                .collect();
            t.push([0.0; 3]);
            let vertices = extreme_points_brute_force(&t).expect("the test clouds span 3-d");
            for v in vertices {
                if (v as usize) < points.len() {
                    counts[v as usize] += 1;
                }
            }
        }
        let steps = grid.gammas.len() as f32;
        counts.into_iter().map(|c| c as f32 / steps).collect()
    }

    /// A bumpy closed surface (radius 1 + a·sin(3θ)·cos(2φ)) sampled at `n` seeded points:
    /// concave parts, so the score takes many values.
    fn bumpy(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = seeded(seed, "confidence-test");
        (0..n)
            .map(|_| {
                let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
                let phi = std::f64::consts::TAU * rng.random::<f64>();
                let r = (1.0 - z * z).sqrt();
                let theta = z.acos();
                let radius = 1.0 + 0.3 * (3.0 * theta).sin() * (2.0 * phi).cos();
                DVec3::new(r * phi.cos(), r * phi.sin(), z) * radius
            })
            .collect()
    }

    #[test]
    fn the_score_is_the_definition_evaluated_by_brute_force() {
        let eye = DVec3::new(0.4, -0.3, 3.0);
        let grids = [
            Grid::new(Family::Linear, 0.2, 2.5, 6).unwrap(),
            Grid::new(Family::Exponential, -0.5, -0.01, 5).unwrap(),
            Grid::new(Family::Log, 0.1, 3.0, 4).unwrap(),
            Grid::new(Family::ExpDecay, 4.0, 0.05, 4).unwrap(),
        ];
        for (k, grid) in grids.iter().enumerate() {
            let points = bumpy(70, k as u64);
            let fast = confidence(&points, eye, grid, own().as_ref()).unwrap();
            let brute = brute_force(&points, eye, grid);
            assert_eq!(fast.score, brute, "{:?}", grid.family);
            let distinct: std::collections::BTreeSet<u32> =
                fast.score.iter().map(|s| s.to_bits()).collect();
            assert!(distinct.len() >= 3, "{:?}: {distinct:?}", grid.family);
        }
    }

    #[test]
    fn thresholds_select_the_hpr_answer_where_sets_nest() {
        // Score 1 = visible at every parameter; with one step the score is HPR itself.
        let points = bumpy(2_000, 9);
        let eye = DVec3::new(0.0, 0.5, 4.0);
        let grid = Grid::new(Family::Linear, 3.0, 3.0, 1).unwrap();
        let c = confidence(&points, eye, &grid, own().as_ref()).unwrap();
        let hpr = crate::visible(&points, eye, &HprParams::default(), own().as_ref()).unwrap();
        assert_eq!(threshold(&c.score, 1.0).unwrap(), hpr.visible);
        assert_eq!(c.visible_counts, vec![hpr.visible.len()]);
        // More of the grid required, fewer points.
        let grid = Grid::new(Family::Linear, 1.0, 5.0, 9).unwrap();
        let c = confidence(&points, eye, &grid, own().as_ref()).unwrap();
        let sizes: Vec<usize> = (1..=9)
            .map(|j| threshold(&c.score, j as f64 / 9.0).unwrap().len())
            .collect();
        assert!(sizes.windows(2).all(|w| w[0] >= w[1]), "{sizes:?}");
        assert!(sizes[0] > sizes[8], "{sizes:?}");
    }

    #[test]
    fn bad_parameters_and_degenerate_clouds_are_errors() {
        let err = |r: Result<Grid, HprError>, which: &str| match r {
            Err(HprError::InvalidParameter { name, .. }) => assert_eq!(name, which),
            other => panic!("{which}: {other:?}"),
        };
        err(Grid::new(Family::Linear, 1.0, 3.0, 0), "steps");
        err(Grid::new(Family::Linear, 1.0, 3.0, MAX_STEPS + 1), "steps");
        err(Grid::new(Family::Linear, f64::NAN, 3.0, 4), "from");
        err(Grid::new(Family::Linear, -1.0, 3.0, 4), "from");
        err(Grid::new(Family::Exponential, -0.1, 0.1, 4), "to");
        err(Grid::new(Family::Linear, 3.0, 1.0, 4), "to");
        err(Grid::new(Family::ExpDecay, 0.1, 1.0, 4), "to");
        for t in [f64::NAN, 0.0, -0.5, 1.5, f64::INFINITY] {
            assert!(
                matches!(
                    threshold(&[0.5], t),
                    Err(HprError::InvalidParameter {
                        name: "threshold",
                        ..
                    })
                ),
                "{t}"
            );
        }
        let grid = Grid::new(Family::Linear, 1.0, 3.0, 3).unwrap();
        let h = own();
        let eye = DVec3::new(0.0, 0.0, 5.0);
        assert_eq!(
            confidence(&[], eye, &grid, h.as_ref()),
            Err(HprError::EmptyCloud)
        );
        let same = vec![DVec3::ONE; 10];
        assert!(matches!(
            confidence(&same, eye, &grid, h.as_ref()),
            Err(HprError::Hull(_))
        ));
        // Coplanar with the eye: the flipped points and the eye are coplanar too.
        let flat: Vec<DVec3> = (0..20)
            .map(|i| DVec3::new(i as f64 * 0.1 - 1.0, (i % 5) as f64 * 0.2, 0.0))
            .collect();
        assert!(matches!(
            confidence(&flat, DVec3::new(0.3, 0.3, 0.0), &grid, h.as_ref()),
            Err(HprError::Hull(hull::HullError::Degenerate(_)))
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Scores are multiples of 1/m in [0, 1], and a point nearest the eye along its own
        /// ray, in front of every other point (the nearest point of the cloud), scores 1:
        /// its image is the farthest from C, hence a vertex at every parameter.
        #[test]
        fn scores_are_fractions_and_the_nearest_point_is_sure(seed in 0u64..1_000, steps in 1usize..6) {
            let points = bumpy(120, seed);
            let eye = DVec3::new(0.2, 0.1, 3.5);
            let grid = Grid::new(Family::Linear, 0.5, 3.0, steps).unwrap();
            let c = confidence(&points, eye, &grid, own().as_ref()).unwrap();
            for &s in &c.score {
                prop_assert!((0.0..=1.0).contains(&s));
                let j = s * steps as f32;
                prop_assert!((j - j.round()).abs() < 1e-4);
            }
            let nearest = (0..points.len())
                .min_by(|&a, &b| (points[a] - eye).length().total_cmp(&(points[b] - eye).length()))
                .unwrap();
            prop_assert_eq!(c.score[nearest], 1.0);
        }
    }
}
