//! The point spacing of a cloud, for parameter rules (ray-cast radius, HPR's γ): the median distance from a point to its
//! nearest neighbour, over a seeded sample ([`crate::knn`] for the neighbour queries, so that
//! coincident points cost no more than others).
//!
//! Coincident points count as distance 0. A spacing of 0 (every point at one position, or at
//! least half the sample with k copies at their very position) is refused
//! ([`Error::NoSurface`]) rather than handed to a rule that divides by it.

use std::num::NonZero;

use glam::DVec3;

use crate::rng::{RngExt, seeded};

use crate::error::{Error, Result};
use crate::knn::Knn;

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

/// Fails unless `median`, the median distance to the `k`-th neighbour over `sampled` points,
/// is positive (module doc).
pub fn check_median(median: f64, k: usize, sampled: usize) -> Result<()> {
    if median > 0.0 {
        return Ok(());
    }
    Err(Error::NoSurface {
        reason: format!(
            "the median distance to the {} over {sampled} sampled points is 0: at least half \
             of them have {k} or more copies at their very position (remove the duplicates)",
            if k == 1 {
                "nearest neighbour".to_owned()
            } else {
                format!("{k}-th neighbour")
            }
        ),
    })
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
    crate::points::check_finite(points)?;
    let first = points[0];
    if points.iter().all(|&p| p == first) {
        return Err(crate::normals::no_surface(points.len() as u64, first));
    }
    let knn = Knn::new(points, |i| i)?;
    let picks = sample_picks(points.len(), sample, seed, purpose);
    let n = NonZero::new(k + 1).ok_or(Error::InvalidParameter {
        name: "k",
        reason: "overflow".into(),
    })?;
    // The query point itself is the nearest (distance 0); the (k+1)-th is the k-th neighbour.
    // Coincident points count as distance 0.
    let mut d: Vec<f64> = picks
        .iter()
        .map(|&i| knn.kth_distance2(points[i], n).sqrt())
        .collect();
    let median = median_of(&mut d).ok_or(Error::InvalidParameter {
        name: "sample",
        reason: "no point to measure".into(),
    })?;
    check_median(median, k, picks.len())?;
    Ok(median)
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
    fn a_spacing_of_zero_is_refused_with_the_reason() {
        let same = vec![DVec3::ONE; 50];
        let err = density_spacing(&same, 8, 100, 1).unwrap_err().to_string();
        assert!(err.contains("all 50 points coincide"), "{err}");
        // Two thirds of the points in clusters of 10 copies: the median 8-th neighbour is 0.
        let mut pts: Vec<DVec3> = (0..300)
            .map(|i| DVec3::new(f64::from(i % 20), f64::from(i / 20), 0.0))
            .collect();
        for c in 0..60 {
            pts.extend(std::iter::repeat_n(
                DVec3::new(f64::from(c), 100.0, 0.0),
                10,
            ));
        }
        let err = density_spacing(&pts, 8, 10_000, 1).unwrap_err().to_string();
        assert!(
            err.contains("8 or more copies at their very position"),
            "{err}"
        );
        // A third: the clean points decide.
        pts.truncate(300 + 15 * 10);
        assert!(density_spacing(&pts, 8, 10_000, 1).unwrap() > 0.0);
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
