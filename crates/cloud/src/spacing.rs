//! The point spacing of a cloud, for parameter rules (ray-cast radius, HPR's γ): the median distance from a point to its
//! nearest neighbour, over a seeded sample (`kiddo`'s k-d tree for the neighbour queries).

use std::num::NonZero;

use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

use crate::rng::{RngExt, seeded};

use crate::error::{Error, Result};

/// Median nearest-neighbour distance over up to `sample` points drawn with `seed` (all points
/// when the cloud is smaller). Coincident points count as distance 0.
pub fn median_spacing(points: &[DVec3], sample: usize, seed: u64) -> Result<f64> {
    if points.len() < 2 {
        return Err(Error::InvalidParameter {
            name: "points",
            reason: "need at least two points for a spacing".into(),
        });
    }
    kth_neighbour_median(points, 1, sample, seed, "median-spacing")
}

/// The spacing implied by the local density, 1/sqrt(ρ) for ρ points per unit area: the median,
/// over up to `sample` points drawn with `seed`, of r_k · sqrt(π / k), r_k the distance to the
/// k-th nearest neighbour (a disc of radius r_k holds about k points: π r_k² ρ ≈ k). Unlike the
/// nearest-neighbour distance it does not depend on how regular the sampling is: random
/// samples clump, so their nearest neighbours are closer than a mesh's vertices at the same
/// density.
pub fn density_spacing(points: &[DVec3], k: usize, sample: usize, seed: u64) -> Result<f64> {
    if k == 0 || points.len() <= k {
        return Err(Error::InvalidParameter {
            name: "k",
            reason: format!("need 0 < k < {} points, got {k}", points.len()),
        });
    }
    let r_k = kth_neighbour_median(points, k, sample, seed, DENSITY_PURPOSE)?;
    Ok(density_from_kth(r_k, k))
}

/// The random stream [`density_spacing`] draws its sample from.
pub const DENSITY_PURPOSE: &str = "density-spacing";

/// The spacing [`density_spacing`] gives for a median k-th neighbour distance `r_k`.
pub fn density_from_kth(r_k: f64, k: usize) -> f64 {
    r_k * (std::f64::consts::PI / k as f64).sqrt()
}

/// The points (indices, with repetition) the spacing rules measure, for a cloud of `len`
/// points: all when `len <= sample`, else `sample` drawn from the stream (`seed`, `purpose`).
pub fn sample_picks(len: usize, sample: usize, seed: u64, purpose: &str) -> Vec<usize> {
    let mut rng = seeded(seed, purpose);
    if len <= sample {
        (0..len).collect()
    } else {
        (0..sample).map(|_| rng.random_range(0..len)).collect()
    }
}

/// The median of k-th neighbour distances as [`density_spacing`] takes it (sorts `d`).
pub fn median_of(d: &mut [f64]) -> Option<f64> {
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied()
}

/// Median distance to the k-th nearest neighbour (the point itself not counted) over up to
/// `sample` points drawn from the stream (`seed`, `purpose`); callers check `0 < k < len`.
fn kth_neighbour_median(
    points: &[DVec3],
    k: usize,
    sample: usize,
    seed: u64,
    purpose: &str,
) -> Result<f64> {
    let entries: Vec<[f64; 3]> = points.iter().map(|p| p.to_array()).collect();
    let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&entries).map_err(|e| {
        Error::InvalidParameter {
            name: "points",
            reason: format!("cannot build a k-d tree: {e:?}"),
        }
    })?;
    let picks = sample_picks(points.len(), sample, seed, purpose);
    let n = NonZero::new(k + 1).ok_or(Error::InvalidParameter {
        name: "k",
        reason: "overflow".into(),
    })?;
    let mut d: Vec<f64> = picks
        .iter()
        .map(|&i| {
            // The query point itself is the nearest (distance 0); the last is the k-th
            // neighbour. Coincident points count as distance 0.
            let nn = tree
                .query(&entries[i])
                .nearest_n::<SquaredEuclidean<f64>>(n)
                .execute();
            nn.last().map_or(0.0, |x| x.distance.sqrt())
        })
        .collect();
    median_of(&mut d).ok_or(Error::InvalidParameter {
        name: "sample",
        reason: "no point to measure".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_spacing() {
        let pts: Vec<DVec3> = (0..400)
            .map(|i| DVec3::new((i % 20) as f64 * 0.5, (i / 20) as f64 * 0.5, 3.0))
            .collect();
        assert!((median_spacing(&pts, 1000, 1).unwrap() - 0.5).abs() < 1e-12);
        assert!(median_spacing(&pts[..1], 10, 1).is_err());
    }

    #[test]
    fn density_spacing_is_the_same_for_regular_and_random_samples() {
        // 40,000 points on the unit square, on a grid and at random: 1/sqrt(density) = 0.005.
        let grid: Vec<DVec3> = (0..40_000)
            .map(|i| DVec3::new((i % 200) as f64 * 0.005, (i / 200) as f64 * 0.005, 0.0))
            .collect();
        let mut rng = seeded(3, "test");
        let random: Vec<DVec3> = (0..40_000)
            .map(|_| DVec3::new(rng.random::<f64>(), rng.random::<f64>(), 0.0))
            .collect();
        let g = density_spacing(&grid, 8, 5_000, 1).unwrap();
        let r = density_spacing(&random, 8, 5_000, 1).unwrap();
        assert!((g / 0.005 - 1.0).abs() < 0.25, "grid {g}");
        assert!((r / 0.005 - 1.0).abs() < 0.15, "random {r}");
        // The nearest-neighbour spacing differs by far more between the two.
        let (gn, rn) = (
            median_spacing(&grid, 5_000, 1).unwrap(),
            median_spacing(&random, 5_000, 1).unwrap(),
        );
        assert!(gn / rn > 1.5, "{gn} {rn}");
    }
}
