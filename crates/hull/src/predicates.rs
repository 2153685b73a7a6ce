//! Exact geometric predicates: Shewchuk's adaptive `orient3d` (the `robust` crate) behind a
//! cheap floating-point filter.
//!
//! Sign convention (Shewchuk's): `orient3d(a, b, c, d) > 0` when d lies *below* the plane of
//! a, b, c, "below" being the side from which a, b, c appear clockwise. A hull facet (a, b, c)
//! stored counter-clockwise as seen from outside therefore has the outside where
//! `orient3d(a, b, c, q) < 0`.
//!
//! The filter: the determinant det[a − d, b − d, c − d] is evaluated in floating point with
//! the a-priori bound of Shewchuk ("Adaptive Precision Floating-Point Arithmetic and Fast
//! Robust Geometric Predicates", DCG 1997, §4.3: errbound A = (7 + 56ε)ε times the permanent);
//! when the result is larger than the bound its sign is certain, otherwise the adaptive exact
//! evaluation decides. The answer is always the sign of the exact determinant of the given
//! f64 inputs.

use robust::Coord3D;

/// A point.
pub type P3 = [f64; 3];

const EPS: f64 = f64::EPSILON * 0.5;
const O3D_ERRBOUND_A: f64 = (7.0 + 56.0 * EPS) * EPS;

#[inline]
fn c(p: &P3) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Sign of the exact orient3d determinant: 1, 0 or −1.
#[inline]
pub fn orient3d_sign(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    let adx = a[0] - d[0];
    let bdx = b[0] - d[0];
    let cdx = c_[0] - d[0];
    let ady = a[1] - d[1];
    let bdy = b[1] - d[1];
    let cdy = c_[1] - d[1];
    let adz = a[2] - d[2];
    let bdz = b[2] - d[2];
    let cdz = c_[2] - d[2];
    let bdxcdy = bdx * cdy;
    let cdxbdy = cdx * bdy;
    let cdxady = cdx * ady;
    let adxcdy = adx * cdy;
    let adxbdy = adx * bdy;
    let bdxady = bdx * ady;
    let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    let permanent = (bdxcdy.abs() + cdxbdy.abs()) * adz.abs()
        + (cdxady.abs() + adxcdy.abs()) * bdz.abs()
        + (adxbdy.abs() + bdxady.abs()) * cdz.abs();
    let bound = O3D_ERRBOUND_A * permanent;
    if det > bound {
        1
    } else if -det > bound {
        -1
    } else {
        exact_sign(a, b, c_, d)
    }
}

#[cold]
fn exact_sign(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    let v = robust::orient3d(c(a), c(b), c(c_), c(d));
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Sign of the exact 2-d orientation of (a, b, c): 1 counter-clockwise, −1 clockwise, 0 collinear.
#[inline]
pub fn orient2d_sign(a: [f64; 2], b: [f64; 2], c_: [f64; 2]) -> i32 {
    let v = robust::orient2d(
        robust::Coord { x: a[0], y: a[1] },
        robust::Coord { x: b[0], y: b[1] },
        robust::Coord { x: c_[0], y: c_[1] },
    );
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Exact collinearity of three points in 3-d (all three coordinate projections collinear).
pub fn collinear(a: &P3, b: &P3, c_: &P3) -> bool {
    let proj = |p: &P3, i: usize, j: usize| [p[i], p[j]];
    [(0, 1), (1, 2), (0, 2)]
        .iter()
        .all(|&(i, j)| orient2d_sign(proj(a, i, j), proj(b, i, j), proj(c_, i, j)) == 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signs_match_the_convention() {
        let (a, b, c_) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        // a, b, c counter-clockwise seen from +z: +z is "above", so a point there is negative.
        assert_eq!(orient3d_sign(&a, &b, &c_, &[0.2, 0.2, 1.0]), -1);
        assert_eq!(orient3d_sign(&a, &b, &c_, &[0.2, 0.2, -1.0]), 1);
        assert_eq!(orient3d_sign(&a, &b, &c_, &[5.0, 7.0, 0.0]), 0);
    }

    #[test]
    fn filter_never_disagrees_with_the_exact_predicate() {
        // Nearly coplanar points far from the origin: the filter must defer to exact arithmetic.
        let base = 6.0e4;
        let mut state = 12345u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let mut p = || [base + next(), base + next() * 1e-3, base + next() * 1e-12];
            let (a, b, c_, d) = (p(), p(), p(), p());
            assert_eq!(orient3d_sign(&a, &b, &c_, &d), exact_sign(&a, &b, &c_, &d));
        }
    }

    #[test]
    fn collinearity() {
        assert!(collinear(
            &[0.0, 0.0, 0.0],
            &[1.0, 1.0, 1.0],
            &[3.0, 3.0, 3.0]
        ));
        assert!(!collinear(
            &[0.0, 0.0, 0.0],
            &[1.0, 1.0, 1.0],
            &[3.0, 3.0, 3.0000001]
        ));
    }
}
