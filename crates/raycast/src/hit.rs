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
//!
//! Beyond the seed, [`disc_entry`]: the point as an oriented disc of radius R (a surfel, the
//! primitive of point-cloud-utils' `RaySurfelIntersector` and of splatting), hit where the ray
//! crosses the disc's plane within R of the point. The disc lies inside the sphere, so its
//! parameter is never below the sphere's entry: the exact traversal's bounds (enlarged by R)
//! stay sound for it.

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

/// The ray parameter where it crosses the disc of radius √`r2` around `c` with unit normal
/// `nrm` (either side), `None` when it misses it, runs parallel to its plane (edge-on) or
/// crosses it behind the origin.
#[inline(always)]
pub fn disc_entry(
    o: &[f64; 3],
    dir: &[f64; 3],
    c: &[f64; 3],
    nrm: &[f64; 3],
    r2: f64,
) -> Option<f64> {
    let denom = nrm[0] * dir[0] + nrm[1] * dir[1] + nrm[2] * dir[2];
    if denom == 0.0 {
        return None;
    }
    let t = (nrm[0] * (c[0] - o[0]) + nrm[1] * (c[1] - o[1]) + nrm[2] * (c[2] - o[2])) / denom;
    if !(t >= 0.0) {
        return None;
    }
    let x = [
        o[0] + t * dir[0] - c[0],
        o[1] + t * dir[1] - c[1],
        o[2] + t * dir[2] - c[2],
    ];
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= r2).then_some(t)
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

    #[test]
    fn disc_hits_face_on_and_misses_edge_on_and_outside() {
        let o = [0.0, 0.0, 0.0];
        let dir = [0.0, 0.0, 2.0];
        let z = [0.0, 0.0, 1.0];
        // Face on: crossed at z = 3, t = 1.5, whichever way the normal points.
        assert_eq!(disc_entry(&o, &dir, &[0.05, 0.0, 3.0], &z, 0.01), Some(1.5));
        assert_eq!(
            disc_entry(&o, &dir, &[0.05, 0.0, 3.0], &[0.0, 0.0, -1.0], 0.01),
            Some(1.5)
        );
        // Beyond the radius, behind the origin, edge on.
        assert_eq!(disc_entry(&o, &dir, &[0.11, 0.0, 3.0], &z, 0.01), None);
        assert_eq!(disc_entry(&o, &dir, &[0.0, 0.0, -3.0], &z, 0.01), None);
        assert_eq!(
            disc_entry(&o, &dir, &[0.05, 0.0, 3.0], &[1.0, 0.0, 0.0], 0.01),
            None
        );
        // Tilted by 60° about y: the ray passing 0.09 from the centre crosses the plane
        // 0.09 / cos 60° = 0.18 from it, beyond the radius 0.1: a miss, where the sphere is hit.
        let tilt = [60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos()];
        assert_eq!(disc_entry(&o, &dir, &[0.09, 0.0, 3.0], &tilt, 0.01), None);
        assert!(hits(&o, &dir, &[0.09, 0.0, 3.0], 0.01));
    }

    proptest::proptest! {
        /// A disc hit is a sphere hit, never before the sphere's entry.
        #[test]
        fn a_disc_hit_is_inside_the_sphere(
            c in proptest::array::uniform3(-5.0f64..5.0),
            dir in proptest::array::uniform3(-1.0f64..1.0),
            nrm in proptest::array::uniform3(-1.0f64..1.0),
            r in 0.01f64..2.0,
        ) {
            let o = [0.1, -0.2, 0.3];
            proptest::prop_assume!(dir.iter().any(|v| v.abs() > 1e-3));
            let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
            proptest::prop_assume!(len > 1e-3);
            let nrm = nrm.map(|v| v / len);
            if let Some(t) = disc_entry(&o, &dir, &c, &nrm, r * r) {
                let s = entry(&o, &dir, &c, r * r * (1.0 + 1e-9));
                proptest::prop_assert!(s.is_some_and(|s| s <= t + 1e-9 * (1.0 + t)), "{s:?} {t}");
            }
        }

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
