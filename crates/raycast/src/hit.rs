//! The point hit test of seed 001 ("Testing a Point"): a ray against a sphere of radius R
//! around the point (the circular prism seen from the other side).
//!
//! With ray origin O and direction D (t ≥ 0), point C and E = O − C, the seed sets
//! d = D·D, f = E·D, e = E·E, r = R², and derives from the quadratic (D·D)t² + 2E·D t + E·E −
//! R² = 0 with t ≥ 0 the Boolean form
//!
//!   ((f ≥ 0) ∧ (d(e − r) < 0)) ∨ ((f < 0) ∧ (f² ≥ d(e − r)))
//!
//! (S4 of the casting summary): three dot products and three comparisons. [`hits`] is exactly
//! that. [`entry`] adds, for a hit, the parameter at which the ray enters the sphere (0 when the
//! origin is inside), the key by which the exact traversal and the brute force order hits.

/// The seed's hit test.
#[inline(always)]
pub fn hits(o: &[f64; 3], dir: &[f64; 3], c: &[f64; 3], r2: f64) -> bool {
    let ex = o[0] - c[0];
    let ey = o[1] - c[1];
    let ez = o[2] - c[2];
    let d = dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2];
    let f = ex * dir[0] + ey * dir[1] + ez * dir[2];
    let e = ex * ex + ey * ey + ez * ez;
    let der = d * (e - r2);
    (f >= 0.0 && der < 0.0) || (f < 0.0 && f * f >= der)
}

/// For a hit, the ray parameter where it enters the sphere (0 if O is inside); `None` for a
/// miss. `hits` and `entry(..).is_some()` always agree.
#[inline(always)]
pub fn entry(o: &[f64; 3], dir: &[f64; 3], c: &[f64; 3], r2: f64) -> Option<f64> {
    let ex = o[0] - c[0];
    let ey = o[1] - c[1];
    let ez = o[2] - c[2];
    let d = dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2];
    let f = ex * dir[0] + ey * dir[1] + ez * dir[2];
    let e = ex * ex + ey * ey + ez * ez;
    let der = d * (e - r2);
    if der < 0.0 {
        // Origin inside the sphere: the seed's first case, or its second with a negative
        // right-hand side.
        Some(0.0)
    } else if f < 0.0 && f * f >= der {
        Some(((-f - (f * f - der).sqrt()) / d).max(0.0))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_boolean_form() {
        let o = [0.0, 0.0, 0.0];
        let dir = [0.0, 0.0, 2.0];
        // In front, within the radius; just outside; behind.
        assert!(hits(&o, &dir, &[0.05, 0.0, 3.0], 0.01));
        assert!(!hits(&o, &dir, &[0.11, 0.0, 3.0], 0.01));
        assert!(!hits(&o, &dir, &[0.0, 0.0, -3.0], 0.01));
        // Origin inside the sphere: a hit whatever the direction.
        assert!(hits(&o, &dir, &[0.0, 0.05, -0.01], 0.01));
        assert_eq!(entry(&o, &dir, &[0.0, 0.05, -0.01], 0.01), Some(0.0));
        // Entry parameter: the sphere of radius 0.1 at z = 3 is entered at z = 2.9, t = 1.45.
        let t = entry(&o, &dir, &[0.0, 0.0, 3.0], 0.01).unwrap();
        assert!((t - 1.45).abs() < 1e-12, "{t}");
    }

    proptest::proptest! {
        #[test]
        fn hits_and_entry_agree(
            c in proptest::array::uniform3(-5.0f64..5.0),
            dir in proptest::array::uniform3(-1.0f64..1.0),
            r in 0.0f64..2.0,
        ) {
            let o = [0.1, -0.2, 0.3];
            proptest::prop_assume!(dir.iter().any(|v| v.abs() > 1e-3));
            proptest::prop_assert_eq!(hits(&o, &dir, &c, r * r), entry(&o, &dir, &c, r * r).is_some());
        }
    }
}
