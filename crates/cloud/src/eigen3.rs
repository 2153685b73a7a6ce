//! The eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix, and the covariance
//! normal of a set of neighbours (seed 002 eq. 2.1) it gives [`crate::normals`].
//!
//! Method: the closed form that PCL's normal estimation uses (`pcl::eigen33`, after Smith,
//! "Eigenvalues of a symmetric 3 × 3 matrix", Comm. ACM 4(4), 1961): the matrix is scaled by
//! its largest coefficient, the three roots of its characteristic polynomial
//! λ³ − c₂λ² + c₁λ − c₀ = 0 come from the trigonometric solution of the cubic, and the
//! eigenvector of the smallest root λ₀ is the longest of the three cross products of the rows
//! of A − λ₀I (each is orthogonal to the rows, so it spans their null space). The result is
//! accurate when λ₀ is separated from λ₁ relative to the largest eigenvalue, the case of a
//! surface's neighbourhood; when it is not (a line, an isotropic blob, all points equal), the
//! longest cross product is tiny against the matrix, and [`jacobi_smallest`] (cyclic Jacobi
//! rotations, exact to rounding and always convergent) answers instead. Either way the answer
//! is a pure function of the matrix, so every caller (in memory or chunk by chunk) gets the
//! same bits. The closed form takes about a fifth of Jacobi's time; the tests compare the two.

use glam::{DMat3, DVec3};

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

/// Below this squared length (relative to the scaled matrix) the cross products do not
/// determine the null space: the eigenvalues are (nearly) repeated.
const DEGENERATE: f64 = 1e-12;

/// Unit eigenvector of the smallest eigenvalue of the symmetric matrix `m` (its sign is not
/// specified). Closed form, Jacobi where the smallest eigenvalue is (nearly) repeated.
pub fn smallest_eigenvector(m: DMat3) -> DVec3 {
    let a = m.to_cols_array_2d();
    let scale = a.iter().flatten().fold(0.0f64, |s, &x| s.max(x.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return jacobi_smallest(m);
    }
    let inv = 1.0 / scale;
    let (m00, m01, m02) = (a[0][0] * inv, a[1][0] * inv, a[2][0] * inv);
    let (m11, m12, m22) = (a[1][1] * inv, a[2][1] * inv, a[2][2] * inv);
    let lambda = smallest_root(m00, m01, m02, m11, m12, m22);
    let r0 = DVec3::new(m00 - lambda, m01, m02);
    let r1 = DVec3::new(m01, m11 - lambda, m12);
    let r2 = DVec3::new(m02, m12, m22 - lambda);
    let candidates = [r0.cross(r1), r0.cross(r2), r1.cross(r2)];
    let mut best = candidates[0];
    let mut best_len = best.length_squared();
    for c in &candidates[1..] {
        let l = c.length_squared();
        if l > best_len {
            best = *c;
            best_len = l;
        }
    }
    if !(best_len > DEGENERATE) {
        return jacobi_smallest(m);
    }
    best / best_len.sqrt()
}

/// The smallest root of the characteristic polynomial of the symmetric matrix given by its
/// upper triangle (scaled so its largest coefficient is 1).
fn smallest_root(m00: f64, m01: f64, m02: f64, m11: f64, m12: f64, m22: f64) -> f64 {
    let c0 = m00 * m11 * m22 + 2.0 * m01 * m02 * m12
        - m00 * m12 * m12
        - m11 * m02 * m02
        - m22 * m01 * m01;
    let c1 = m00 * m11 - m01 * m01 + m00 * m22 - m02 * m02 + m11 * m22 - m12 * m12;
    let c2 = m00 + m11 + m22;
    let c2_3 = c2 / 3.0;
    let alpha_3 = ((3.0 * c1 - c2 * c2) / 9.0).min(0.0);
    let half_b = 0.5 * (c0 + c2_3 * (2.0 * c2_3 * c2_3 - c1));
    let q = (half_b * half_b + alpha_3 * alpha_3 * alpha_3).min(0.0);
    let rho = (-alpha_3).sqrt();
    let theta = (-q).sqrt().atan2(half_b) / 3.0;
    let (sin, cos) = theta.sin_cos();
    let sqrt3 = 3.0f64.sqrt();
    // The three roots are c2/3 + 2ρ cos θ ≥ c2/3 − ρ(cos θ − √3 sin θ) ≥ c2/3 − ρ(cos θ + √3
    // sin θ) for θ in [0, π/3]: the last is the smallest.
    c2_3 - rho * (cos + sqrt3 * sin)
}

/// Unit eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix by cyclic Jacobi
/// rotations (to rounding; at most 50 sweeps, in practice 4 to 6).
pub fn jacobi_smallest(m: DMat3) -> DVec3 {
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

    fn random_rotation(rng: &mut impl RngExt) -> DMat3 {
        let axis = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize_or(DVec3::X);
        DMat3::from_axis_angle(axis, rng.random_range(0.0..std::f64::consts::TAU))
    }

    /// Known eigenvectors, from flat (a surface's neighbourhood: λ₀ ≪ λ₁) to nearly repeated
    /// smallest eigenvalues and across scales: the closed form (or its fallback) finds the
    /// smallest axis to within the accuracy its gap allows, and so does Jacobi.
    #[test]
    fn the_closed_form_finds_the_smallest_axis_as_jacobi_does() {
        let mut rng = seeded(7, "eigen3 test");
        for case in 0..20_000 {
            let rot = random_rotation(&mut rng);
            let big = 10f64.powf(rng.random_range(-8.0..8.0));
            let l2 = big * rng.random_range(1.0..5.0);
            let l1 = big * rng.random_range(0.05..1.0);
            // Gap from a plane (l0 = 0) to nearly repeated (l0 close to l1).
            let l0 = match case % 4 {
                0 => 0.0,
                1 => l1 * 1e-9,
                2 => l1 * rng.random_range(0.0..0.5),
                _ => l1 * rng.random_range(0.5..0.999),
            };
            let m = rot * DMat3::from_diagonal(DVec3::new(l2, l1, l0)) * rot.transpose();
            let expected = rot * DVec3::Z;
            // Rounding of the input matrix (|m| ε) moves the eigenvector by about |m| ε / gap.
            let tolerance = 1e-12 * l2 / (l1 - l0);
            for (name, n) in [
                ("closed form", smallest_eigenvector(m)),
                ("jacobi", jacobi_smallest(m)),
            ] {
                assert!((n.length() - 1.0).abs() < 1e-12, "{name}: {n} not unit");
                // The sine of the angle between them.
                let off = n.cross(expected).length();
                assert!(
                    off < tolerance.max(1e-12),
                    "case {case} {name}: {n} vs {expected} (eigenvalues {l2}, {l1}, {l0})"
                );
            }
        }
    }

    #[test]
    fn degenerate_matrices_give_a_unit_vector() {
        for m in [
            DMat3::ZERO,
            DMat3::IDENTITY,
            DMat3::from_diagonal(DVec3::new(1.0, 0.0, 0.0)),
            DMat3::from_diagonal(DVec3::new(2.0, 2.0, 1.0)),
            DMat3::from_cols_array(&[1e-300; 9]),
        ] {
            let n = smallest_eigenvector(m);
            assert!((n.length() - 1.0).abs() < 1e-12, "{m}: {n}");
        }
        // A line along x: any unit vector orthogonal to x is right.
        let n = smallest_eigenvector(DMat3::from_diagonal(DVec3::new(3.0, 0.0, 0.0)));
        assert!(n.x.abs() < 1e-12, "{n}");
        // A repeated smallest eigenvalue: the answer lies in its plane (orthogonal to z).
        let n = smallest_eigenvector(DMat3::from_diagonal(DVec3::new(1.0, 1.0, 5.0)));
        assert!(n.z.abs() < 1e-9, "{n}");
    }
}
