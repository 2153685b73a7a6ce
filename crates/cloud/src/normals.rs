//! Normal estimation from the k nearest neighbours by covariance analysis.
//!
//! Seed 002 §2.1.1 (Carvalho 2009, after Hoppe et al. 1992): for a point x with neighbours
//! N = {x_1..x_k}, C = Σ_j (x_j − x̄)(x_j − x̄)ᵀ (eq. 2.1) with x̄ the neighbours' mean; the
//! eigenvector of the smallest eigenvalue of C estimates the normal direction. Neighbours come
//! from `kiddo`'s immutable k-d tree (the point itself is one of its k neighbours); the 3×3
//! symmetric eigenproblem is solved by cyclic Jacobi rotations, which are exact enough at this
//! size and never fail to converge.
//!
//! Orientation: covariance analysis gives a direction, not a sign. [`Orientation`] names the
//! documented rules; the default, [`Orientation::AwayFromCentroid`], flips each normal so that
//! n·(p − centroid) ≥ 0, right for star-shaped objects and wrong inside deep concavities.
//! Where a reference is known (a sampled mesh's face normals), [`Orientation::Reference`]
//! follows it. Hoppe's minimum-spanning-tree propagation is not implemented.

use std::num::NonZero;

use glam::{DMat3, DVec3, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::points::check_finite;

/// How estimated normals get their sign.
#[derive(Debug, Clone, Copy)]
pub enum Orientation<'a> {
    /// n·(p − centroid of the cloud) ≥ 0.
    AwayFromCentroid,
    /// n·(viewpoint − p) ≥ 0: the normal faces a sensor or camera.
    TowardsViewpoint(DVec3),
    /// n·reference ≥ 0, one reference direction per point.
    Reference(&'a [Vec3]),
}

/// Estimates one unit normal per point from its `k` nearest neighbours (k ≥ 3, k ≤ n).
pub fn estimate_normals(
    positions: &[DVec3],
    k: usize,
    orientation: Orientation<'_>,
) -> Result<Vec<Vec3>> {
    if positions.is_empty() {
        return Err(Error::EmptyCloud);
    }
    check_finite(positions)?;
    if k < 3 || k > positions.len() {
        return Err(Error::InvalidParameter {
            name: "k",
            reason: format!(
                "need 3 <= k <= {} (the number of points), got {k}",
                positions.len()
            ),
        });
    }
    if let Orientation::Reference(r) = orientation
        && r.len() != positions.len()
    {
        return Err(Error::AttributeLength {
            name: "reference normals",
            expected: positions.len(),
            found: r.len(),
        });
    }
    let entries: Vec<[f64; 3]> = positions.iter().map(|p| p.to_array()).collect();
    let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&entries).map_err(|e| {
        Error::InvalidParameter {
            name: "positions",
            reason: format!("cannot build a k-d tree: {e:?}"),
        }
    })?;
    let k_nz = NonZero::new(k).ok_or(Error::InvalidParameter {
        name: "k",
        reason: "k must be positive".into(),
    })?;
    let centroid = centroid(positions);
    let normals = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let neighbours = canonical_knn(&tree, *p, k_nz, |item| item);
            let n = covariance_normal(neighbours.iter().map(|nb| positions[nb.1 as usize]));
            let reference = match orientation {
                Orientation::AwayFromCentroid => *p - centroid,
                Orientation::TowardsViewpoint(v) => v - *p,
                Orientation::Reference(r) => r[i].as_dvec3(),
            };
            orient(n, reference)
        })
        .collect();
    Ok(normals)
}

/// The cloud's centroid as [`Orientation::AwayFromCentroid`] uses it: the positions summed in
/// order, divided by their count.
pub fn centroid(positions: &[DVec3]) -> DVec3 {
    positions.iter().copied().sum::<DVec3>() / positions.len() as f64
}

/// `n` flipped so that `n · reference ≥ 0`.
pub fn orient(n: DVec3, reference: DVec3) -> Vec3 {
    if n.dot(reference) < 0.0 {
        (-n).as_vec3()
    } else {
        n.as_vec3()
    }
}

/// The unit normal of the neighbours `points` (in order: the sums follow it): the eigenvector
/// of the smallest eigenvalue of their covariance (eq. 2.1), unoriented.
pub fn covariance_normal(points: impl Iterator<Item = DVec3> + Clone) -> DVec3 {
    let (sum, count) = points
        .clone()
        .fold((DVec3::ZERO, 0usize), |(s, c), p| (s + p, c + 1));
    let mean = sum / count.max(1) as f64;
    let mut cov = DMat3::ZERO;
    for p in points {
        let d = p - mean;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    smallest_eigenvector(cov)
}

/// The `k` nearest neighbours of `p` in `tree` (the point itself included when it is in the
/// tree) as (squared distance, item), in a canonical order that does not depend on how the
/// tree was built: by distance, equal distances by `global(item)` (the point's index in the
/// whole cloud), and when several points tie at the k-th distance, those of smallest global
/// index. So the same neighbourhood, summed in the same order, comes out of any tree holding
/// the point's true neighbours (an out-of-core build's chunk and its halo).
pub fn canonical_knn(
    tree: &ImmutableKdTree<f64, 3>,
    p: DVec3,
    k: NonZero<usize>,
    global: impl Fn(u64) -> u64,
) -> Vec<(f64, u64)> {
    let q = p.to_array();
    let size = tree.size();
    let mut want = k.get().saturating_add(1).min(size.max(1));
    loop {
        let got = tree
            .query(&q)
            .nearest_n::<SquaredEuclidean<f64>>(NonZero::new(want).unwrap_or(k))
            .execute();
        let kth = got.get(k.get() - 1).map(|nb| nb.distance);
        // Complete when every point at the k-th distance is in the answer: the answer holds
        // every point of the tree, or its last is farther than the k-th.
        let complete = got.len() < want
            || want >= size
            || kth.is_none_or(|d| got.last().is_some_and(|l| l.distance > d));
        if complete {
            let mut nb: Vec<(f64, u64)> = got
                .iter()
                .filter(|nb| kth.is_none_or(|d| nb.distance <= d))
                .map(|nb| (nb.distance, u64::from(nb.item)))
                .collect();
            nb.sort_by(|a, b| a.0.total_cmp(&b.0).then(global(a.1).cmp(&global(b.1))));
            nb.truncate(k.get());
            return nb;
        }
        want = want.saturating_mul(2).min(size);
    }
}

/// Unit eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix (cyclic Jacobi).
pub fn smallest_eigenvector(m: DMat3) -> DVec3 {
    let mut a = m.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * diag.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A' = Jᵀ A J with the rotation J in the (p, q) plane.
            for k in 0..3 {
                let akp = a[k][p];
                let akq = a[k][q];
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let apk = a[p][k];
                let aqk = a[q][k];
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let vkp = row[p];
                let vkq = row[q];
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    let smallest = (0..3)
        .min_by(|&i, &j| a[i][i].total_cmp(&a[j][j]))
        .unwrap_or(0);
    DVec3::new(v[0][smallest], v[1][smallest], v[2][smallest]).normalize_or(DVec3::Z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{RngExt, seeded};

    #[test]
    fn jacobi_finds_the_smallest_axis() {
        // Eigenvalues 5, 3, 1 along rotated axes.
        let rot = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let m = rot * DMat3::from_diagonal(DVec3::new(5.0, 3.0, 1.0)) * rot.transpose();
        let n = smallest_eigenvector(m);
        let expected = rot * DVec3::Z;
        assert!(n.dot(expected).abs() > 1.0 - 1e-12, "{n} vs {expected}");
    }

    #[test]
    fn plane_normals_are_the_plane_normal_oriented() {
        let mut rng = seeded(3, "test");
        let pts: Vec<DVec3> = (0..500)
            .map(|_| DVec3::new(rng.random::<f64>(), rng.random::<f64>(), 2.0))
            .collect();
        let normals = estimate_normals(
            &pts,
            10,
            Orientation::TowardsViewpoint(DVec3::new(0.5, 0.5, -5.0)),
        )
        .unwrap();
        assert!(
            normals.iter().all(|n| (n.z + 1.0).abs() < 1e-5),
            "{:?}",
            normals[0]
        );
    }

    #[test]
    fn sphere_normals_point_outwards() {
        let pts: Vec<DVec3> = crate::synth::fibonacci_sphere(2000);
        let normals = estimate_normals(&pts, 12, Orientation::AwayFromCentroid).unwrap();
        for (p, n) in pts.iter().zip(&normals) {
            assert!(n.as_dvec3().dot(*p) > 0.99, "{p} {n}");
        }
    }

    #[test]
    fn bad_inputs() {
        assert!(matches!(
            estimate_normals(&[], 8, Orientation::AwayFromCentroid),
            Err(Error::EmptyCloud)
        ));
        assert!(matches!(
            estimate_normals(&[DVec3::ZERO; 4], 8, Orientation::AwayFromCentroid),
            Err(Error::InvalidParameter { name: "k", .. })
        ));
        assert!(matches!(
            estimate_normals(&[DVec3::NAN; 4], 3, Orientation::AwayFromCentroid),
            Err(Error::NonFinite { index: 0 })
        ));
    }
}
