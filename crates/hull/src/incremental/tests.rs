//! `own` against the exact checks: brute force on small sets, certificates on larger ones,
//! degenerate families (cospherical, coplanar, collinear, duplicates), and Qhull agreement on
//! HPR-like shells.

use proptest::prelude::*;

use super::*;
use crate::ConvexHull;
use crate::check::{extreme_points_brute_force, verify};

fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `own` equals the brute-force oracle and passes the certificate check.
fn check_small(points: &[P3]) {
    let h = hull(points).unwrap();
    verify(points, &h.facets, &h.vertices).unwrap();
    assert_eq!(
        Some(h.vertices),
        extreme_points_brute_force(points),
        "{points:?}"
    );
}

/// `own` passes the certificate check.
fn check_large(points: &[P3]) -> OwnHull {
    let h = hull(points).unwrap();
    verify(points, &h.facets, &h.vertices).unwrap();
    h
}

#[test]
fn random_points_in_a_cube() {
    for seed in 0..20 {
        let mut r = rng(seed);
        let pts: Vec<P3> = (0..40).map(|_| [r(), r(), r()]).collect();
        check_small(&pts);
    }
}

#[test]
fn integer_lattice_is_full_of_coplanar_and_collinear_points() {
    let mut pts = Vec::new();
    for x in 0..3 {
        for y in 0..3 {
            for z in 0..3 {
                pts.push([x as f64, y as f64, z as f64]);
            }
        }
    }
    check_small(&pts);
    let h = hull(&pts).unwrap();
    assert_eq!(h.vertices.len(), 8);
}

#[test]
fn cube_surface_grid_keeps_only_the_corners() {
    let mut pts = Vec::new();
    let n = 6;
    for x in 0..=n {
        for y in 0..=n {
            for z in 0..=n {
                if [x, y, z].iter().any(|&c| c == 0 || c == n) {
                    pts.push([x as f64, y as f64, z as f64]);
                }
            }
        }
    }
    let h = check_large(&pts);
    assert_eq!(h.vertices.len(), 8);
}

#[test]
fn exactly_cospherical_integer_points_are_all_vertices() {
    // All integer points with x² + y² + z² = 325 (many, exactly on the sphere).
    let mut pts = Vec::new();
    for x in -18i32..=18 {
        for y in -18i32..=18 {
            for z in -18i32..=18 {
                if x * x + y * y + z * z == 325 {
                    pts.push([x as f64, y as f64, z as f64]);
                }
            }
        }
    }
    assert!(pts.len() > 100, "{}", pts.len());
    let h = check_large(&pts);
    assert_eq!(h.vertices.len(), pts.len());
}

#[test]
fn duplicates_report_the_lowest_index() {
    let mut r = rng(7);
    let mut pts: Vec<P3> = (0..30).map(|_| [r(), r(), r()]).collect();
    for i in 0..30 {
        pts.push(pts[i]);
    }
    pts.insert(0, pts[5]);
    check_small(&pts);
}

#[test]
fn vertices_only_hull_and_its_distinct_flag() {
    let mut r = rng(11);
    let mut pts: Vec<P3> = (0..3_000).map(|_| [r(), r(), r()]).collect();
    let full = hull(&pts).unwrap();
    let only = hull_vertices(&pts).unwrap();
    assert_eq!(only.vertices, full.vertices);
    assert!(only.facets.is_empty() && !full.facets.is_empty());
    assert!(full.distinct && only.distinct);
    // One copy of an interior point, then of a vertex: either makes the set not distinct.
    let interior = (0..pts.len())
        .find(|i| full.vertices.binary_search(&(*i as u32)).is_err())
        .unwrap();
    pts.push(pts[interior]);
    assert!(!hull_vertices(&pts).unwrap().distinct);
    pts.pop();
    pts.push(pts[full.vertices[3] as usize]);
    let h = hull_vertices(&pts).unwrap();
    assert!(!h.distinct);
    assert_eq!(h.vertices, full.vertices, "the copy is not reported");
    assert_eq!(
        Incremental.vertices_distinct(&pts).unwrap(),
        (h.vertices, false)
    );
}

#[test]
fn degenerate_inputs_are_errors() {
    let plane: Vec<P3> = (0..20)
        .map(|i| [i as f64, (i * i % 7) as f64, 0.0])
        .collect();
    assert!(matches!(hull(&plane), Err(HullError::Degenerate(m)) if m.contains("coplanar")));
    let line: Vec<P3> = (0..20)
        .map(|i| [i as f64, 2.0 * i as f64, -(i as f64)])
        .collect();
    assert!(matches!(hull(&line), Err(HullError::Degenerate(m)) if m.contains("collinear")));
    let same = vec![[1.5, 2.0, 3.0]; 10];
    assert!(matches!(hull(&same), Err(HullError::Degenerate(m)) if m.contains("coincide")));
    // A slanted plane far from the axes, still exactly coplanar (integer coordinates).
    let slanted: Vec<P3> = (0..50)
        .map(|i| {
            let (a, b) = ((i % 7) as f64, (i / 7) as f64);
            [1e6 + a, 2e6 + b, 3e6 + 2.0 * a - 5.0 * b]
        })
        .collect();
    assert!(matches!(hull(&slanted), Err(HullError::Degenerate(_))));
}

/// Points of a bumpy closed surface, flipped about an eye as HPR does.
fn hpr_shell(n: usize, gamma: f64, seed: u64) -> Vec<P3> {
    let mut r = rng(seed);
    let eye = [0.2, -0.1, 4.0];
    let mut pts: Vec<P3> = (0..n)
        .map(|_| {
            let z: f64 = 2.0 * r() - 1.0;
            let t: f64 = std::f64::consts::TAU * r();
            let s = (1.0 - z * z).sqrt();
            let bump = 1.0 + 0.15 * (5.0 * t).sin() * (3.0 * z).cos();
            [
                bump * s * t.cos() - eye[0],
                bump * s * t.sin() - eye[1],
                bump * z - eye[2],
            ]
        })
        .collect();
    let max = pts.iter().map(|p| norm2(p).sqrt()).fold(0.0, f64::max);
    let radius = max * 10f64.powf(gamma);
    for p in &mut pts {
        let len = norm2(p).sqrt();
        let k = 2.0 * (radius - len) / len;
        *p = [p[0] + k * p[0], p[1] + k * p[1], p[2] + k * p[2]];
    }
    pts.push([0.0, 0.0, 0.0]);
    pts
}

#[test]
fn hpr_shells_pass_the_certificate_and_agree_with_qhull_where_it_is_sure() {
    for (gamma, seed) in [(1.0, 1), (2.0, 2), (3.0, 3), (4.0, 4)] {
        let pts = hpr_shell(1_500, gamma, seed);
        let h = check_large(&pts);
        assert!(
            h.vertices.contains(&(pts.len() as u32 - 1)),
            "the eye is a vertex"
        );
        let q = ConvexHull::vertices(
            &crate::qhull_impl::Qhull::new(crate::qhull_impl::QhullOption::Qt),
            &pts,
        )
        .unwrap();
        let common = h
            .vertices
            .iter()
            .filter(|v| q.binary_search(v).is_ok())
            .count();
        // Qhull merges nearly coplanar facets: its set may miss a few exact vertices, but the
        // two agree on nearly all of them.
        let jaccard = common as f64 / (h.vertices.len() + q.len() - common) as f64;
        assert!(jaccard > 0.98, "gamma {gamma}: jaccard {jaccard}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn small_random_sets_equal_brute_force(pts in proptest::collection::vec(
        (-4i32..=4, -4i32..=4, -4i32..=4), 5..24)) {
        // Integer coordinates on a small grid: full of coplanar, collinear and duplicate points.
        let pts: Vec<P3> = pts.iter().map(|&(x, y, z)| [x as f64, y as f64, z as f64]).collect();
        match extreme_points_brute_force(&pts) {
            None => prop_assert!(matches!(hull(&pts), Err(HullError::Degenerate(_)))),
            Some(expected) => {
                let h = hull(&pts).unwrap();
                prop_assert!(verify(&pts, &h.facets, &h.vertices).is_ok());
                prop_assert_eq!(h.vertices, expected);
            }
        }
    }

    #[test]
    fn nearly_cospherical_sets_pass_the_certificate(seed in 0u64..1000, n in 20usize..200) {
        let mut r = rng(seed);
        let pts: Vec<P3> = (0..n).map(|_| {
            let v = [2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0];
            let l = norm2(&v).sqrt().max(1e-9);
            [1e3 + v[0] / l, -2e3 + v[1] / l, 5e2 + v[2] / l]
        }).collect();
        let h = hull(&pts).unwrap();
        prop_assert!(verify(&pts, &h.facets, &h.vertices).is_ok());
    }
}

/// 2,000 random points in [0, 1e200]³ and in [0, 1e-200]³ (where unscaled predicates overflow
/// and underflow, refusing them as "all points are collinear" or "all points coincide"):
/// exact power-of-two copies of a unit cloud give its hull.
#[test]
fn extreme_magnitudes_give_the_same_hull_as_the_unit_cloud() {
    let mut r = rng(2000);
    let unit: Vec<P3> = (0..2000).map(|_| [r(), r(), r()]).collect();
    let expected = hull(&unit).unwrap().vertices;
    for k in [664, -664, 1000, -1000] {
        let f = 2f64.powi(k / 2) * 2f64.powi(k - k / 2);
        let scaled: Vec<P3> = unit.iter().map(|p| p.map(|c| c * f)).collect();
        assert!(scaled.iter().flatten().all(|c| c.is_finite()));
        assert_eq!(hull(&scaled).unwrap().vertices, expected, "2^{k}");
    }
    // Coordinates spanning more than a double can rescale are refused, not misreported.
    let mut wide = unit.clone();
    wide[0] = [1e300, 0.5, 0.5];
    wide[1] = [1e-300, 0.5, 0.5];
    let err = hull(&wide).unwrap_err().to_string();
    assert!(err.contains("magnitudes"), "{err}");
}
