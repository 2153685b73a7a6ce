//! Normal estimation from the k nearest neighbours by covariance analysis.
//!
//! Seed 002 §2.1.1 (Carvalho 2009, after Hoppe et al. 1992): for a point x with neighbours
//! N = {x_1..x_k}, C = Σ_j (x_j − x̄)(x_j − x̄)ᵀ (eq. 2.1) with x̄ the neighbours' mean; the
//! eigenvector of the smallest eigenvalue of C estimates the normal direction. Neighbours come
//! from [`crate::knn_grid`] (a uniform grid, all points at once; the point itself is one of its k
//! neighbours; the canonical order of [`crate::knn`], ties by index, coincident points in
//! bounded work); the 3×3
//! symmetric eigenproblem is solved by cyclic Jacobi rotations, which are exact enough at this
//! size and never fail to converge.
//!
//! Orientation: covariance analysis gives a direction, not a sign. [`Orientation`] names the
//! documented rules: [`Orientation::Propagated`], Hoppe et al. 1992's minimum-spanning-tree
//! propagation over a guide chosen by position ([`crate::orient`]), what the level-of-detail
//! builds use, right in concave parts too; [`Orientation::AwayFromCentroid`] flips each normal
//! so that n·(p − centroid) ≥ 0, right for star-shaped objects and wrong inside deep
//! concavities; [`Orientation::TowardsViewpoint`] faces a sensor. Where a reference is known
//! (a sampled mesh's face normals), [`Orientation::Reference`] follows it.

use std::num::NonZero;

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::knn_grid::GridKnn;
use crate::points::check_finite;

/// How estimated normals get their sign.
#[derive(Debug, Clone, Copy)]
pub enum Orientation<'a> {
    /// Hoppe's minimum spanning tree over the guide of [`crate::orient`] (at most
    /// [`crate::orient::GUIDE_MAX`] points; the whole cloud when it is no larger).
    Propagated,
    /// n·(p − centroid of the cloud) ≥ 0.
    AwayFromCentroid,
    /// n·(viewpoint − p) ≥ 0: the normal faces a sensor or camera.
    TowardsViewpoint(DVec3),
    /// n·reference ≥ 0, one reference direction per point.
    Reference(&'a [Vec3]),
}

/// Estimates one unit normal per point from its `k` nearest neighbours (k ≥ 3, k ≤ n), taken
/// in [`crate::knn`]'s canonical order (coincident points in bounded work). A cloud of fewer
/// than 3 points, or whose points all coincide, has no surface and is refused.
pub fn estimate_normals(
    positions: &[DVec3],
    k: usize,
    orientation: Orientation<'_>,
) -> Result<Vec<Vec3>> {
    if positions.is_empty() {
        return Err(Error::EmptyCloud);
    }
    check_finite(positions)?;
    check_surface(positions)?;
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
    let grid = GridKnn::new(positions, |i| i, k)?;
    let k_nz = NonZero::new(k).ok_or(Error::InvalidParameter {
        name: "k",
        reason: "k must be positive".into(),
    })?;
    let centroid = centroid(positions);
    if let Orientation::Propagated = orientation {
        let raw = grid.for_each_point(
            k_nz,
            |_| true,
            |_, neighbours| covariance_normal(neighbours.iter().map(|nb| positions[nb.1 as usize])),
        )?;
        drop(grid);
        let guide = crate::orient::Guide::new(
            crate::orient::select_guide(positions, crate::orient::guide_max()),
            k,
        )?;
        return Ok(positions
            .par_iter()
            .zip(&raw)
            .map(|(p, n)| guide.orient(*p, *n))
            .collect());
    }
    grid.for_each_point(
        k_nz,
        |_| true,
        |i, neighbours| {
            let p = positions[i];
            let n = covariance_normal(neighbours.iter().map(|nb| positions[nb.1 as usize]));
            let reference = match orientation {
                Orientation::Propagated => DVec3::Z,
                Orientation::AwayFromCentroid => p - centroid,
                Orientation::TowardsViewpoint(v) => v - p,
                Orientation::Reference(r) => r[i].as_dvec3(),
            };
            orient(n, reference)
        },
    )
}

/// Fails unless `positions` can have a surface: at least 3 points, not all at one position
/// ([`Error::NoSurface`]).
pub fn check_surface(positions: &[DVec3]) -> Result<()> {
    let first = positions.first().copied().unwrap_or_default();
    if positions.len() < 3 || positions.iter().all(|&p| p == first) {
        return Err(no_surface(positions.len() as u64, first));
    }
    Ok(())
}

/// The error of a cloud of `n` points without a surface: fewer than 3, or (3 or more) all at
/// `at`.
pub fn no_surface(n: u64, at: DVec3) -> Error {
    Error::NoSurface {
        reason: if n < 3 {
            format!(
                "{n} point{}: a surface needs at least 3",
                if n == 1 { "" } else { "s" }
            )
        } else {
            format!("all {n} points coincide at ({}, {}, {})", at.x, at.y, at.z)
        },
    }
}

/// How far from 1 the length of a normal a file gives may be: a given normal is used as it
/// is, so one that is not a unit vector (NaN, zero, or not normalised) is refused.
pub const GIVEN_LENGTH_TOLERANCE: f32 = 1e-3;

/// Whether `n` may be used as a given normal: finite, of length 1 within
/// [`GIVEN_LENGTH_TOLERANCE`].
pub fn is_given_normal(n: Vec3) -> bool {
    n.is_finite() && (n.length() - 1.0).abs() <= GIVEN_LENGTH_TOLERANCE
}

/// The first of `normals` that [`is_given_normal`] refuses, with its index.
pub fn first_bad_normal(normals: &[Vec3]) -> Option<(usize, Vec3)> {
    normals
        .iter()
        .position(|&n| !is_given_normal(n))
        .map(|i| (i, normals[i]))
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

pub use crate::eigen3::covariance_normal;

/// Unit eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix
/// ([`crate::eigen3`]: closed form, Jacobi where the eigenvalue is repeated).
pub fn smallest_eigenvector(m: DMat3) -> DVec3 {
    crate::eigen3::smallest_eigenvector(m)
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
        let square = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE];
        assert!(matches!(
            estimate_normals(&square, 8, Orientation::AwayFromCentroid),
            Err(Error::InvalidParameter { name: "k", .. })
        ));
        let err = estimate_normals(&[DVec3::ONE; 4], 3, Orientation::AwayFromCentroid)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "the point cloud has no surface: all 4 points coincide at (1, 1, 1)"
        );
        let err = estimate_normals(&[DVec3::ONE], 1, Orientation::AwayFromCentroid)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "the point cloud has no surface: 1 point: a surface needs at least 3"
        );
        assert!(matches!(
            estimate_normals(&[DVec3::NAN; 4], 3, Orientation::AwayFromCentroid),
            Err(Error::NonFinite { index: 0 })
        ));
    }
}
