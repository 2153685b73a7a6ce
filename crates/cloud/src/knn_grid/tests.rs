//! `knn_grid`'s tests: every answer against a brute force (copies, ties, outliers), the
//! candidates' bound with copies, and the sampled cell sizing.

use super::*;
use crate::rng::{RngExt, seeded};
use proptest::prelude::*;

/// The canonical k nearest by brute force: every point sorted by (distance, global).
fn brute(positions: &[DVec3], global: &[u64], p: DVec3, k: usize) -> Vec<(f64, u64)> {
    let mut all: Vec<(f64, u64, u64)> = positions
        .iter()
        .enumerate()
        .map(|(i, q)| (dist2(&p.to_array(), &q.to_array()), global[i], i as u64))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    all.truncate(k);
    all.into_iter().map(|(d, _, i)| (d, i)).collect()
}

/// Checks every point's answer; returns the queries the k-d tree answered.
fn check_all(pts: &[DVec3], global: &[u64], k: usize) -> u64 {
    let grid = GridKnn::new(pts, |i| global[i as usize], k).unwrap();
    let kk = NonZero::new(k).unwrap();
    let got = grid
        .for_each_point(kk, |_| true, |_, nb| nb.to_vec())
        .unwrap();
    let knn = Knn::new(pts, |i| global[i as usize]).unwrap();
    for (i, p) in pts.iter().enumerate() {
        let want = brute(pts, global, *p, k);
        assert_eq!(got[i], want, "point {i} at {p}, k {k}");
        assert_eq!(knn.canonical_knn(*p, kk), want, "kiddo, point {i}");
        assert_eq!(
            grid.canonical_knn(*p, kk).unwrap(),
            want,
            "one query, point {i}"
        );
    }
    grid.fell_back()
}

#[test]
fn every_point_as_brute_force_with_copies_and_sparse_outliers() {
    let mut rng = seeded(5, "knn-grid-test");
    let mut pts: Vec<DVec3> = (0..600)
        .map(|_| DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.05))
        .collect();
    // Copies of a point, a cluster at one new position, ±0.0, far outliers (the k-d
    // tree's queries) and a dense clump.
    let a = pts[17];
    pts.extend(std::iter::repeat_n(a, 40));
    pts.extend(std::iter::repeat_n(DVec3::new(0.3, 0.3, 0.01), 25));
    pts.extend(std::iter::repeat_n(DVec3::new(-0.0, 0.5, 0.0), 3));
    pts.extend(std::iter::repeat_n(DVec3::new(0.0, 0.5, -0.0), 3));
    pts.extend([DVec3::new(40.0, 0.0, 0.0), DVec3::new(-30.0, 5.0, 1.0)]);
    pts.extend((0..100).map(|i| {
        DVec3::new(
            0.7 + 1e-4 * f64::from(i % 10),
            0.2,
            1e-4 * f64::from(i / 10),
        )
    }));
    let global: Vec<u64> = (0..pts.len() as u64)
        .map(|i| (i * 7919) % 100_003)
        .collect();
    let mut fell_back = 0;
    for k in [1, 3, 8, 16, 50] {
        fell_back += check_all(&pts, &global, k);
    }
    // The outliers' queries went to the k-d tree.
    assert!(fell_back >= 2, "{fell_back}");
}

#[test]
fn ties_on_a_lattice_are_by_global_index() {
    // An integer lattice: every query has many neighbours at equal distances.
    let pts: Vec<DVec3> = (0..512)
        .map(|i| DVec3::new(f64::from(i % 8), f64::from((i / 8) % 8), f64::from(i / 64)))
        .collect();
    let global: Vec<u64> = (0..512).rev().collect();
    for k in [7, 16, 27] {
        check_all(&pts, &global, k);
    }
}

#[test]
fn copies_cost_a_small_constant_times_a_clean_cloud() {
    // As crate::knn's test: 10^5 identical points beside a clean cloud, and a clean cloud
    // with 20,000 copies of one of its points.
    let mut rng = seeded(3, "knn-test");
    let clean: Vec<DVec3> = (0..20_000)
        .map(|_| DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.1))
        .collect();
    let per_point = |pts: &[DVec3]| {
        let g = GridKnn::new(pts, |i| i, 16).unwrap();
        g.for_each_point(NonZero::new(16).unwrap(), |_| true, |_, nb| nb.len())
            .unwrap();
        g.examined() as f64 / pts.len() as f64
    };
    let base = per_point(&clean);
    let mut many = clean.clone();
    many.extend(std::iter::repeat_n(DVec3::new(2.0, 2.0, 2.0), 100_000));
    let mut beside = clean.clone();
    beside.extend(std::iter::repeat_n(clean[1234], 20_000));
    for (name, pts) in [("10^5 identical", many), ("20,000 copies", beside)] {
        let e = per_point(&pts);
        eprintln!("{name}: {e:.1} candidates a point (clean cloud: {base:.1})");
        assert!(
            e <= 3.0 * base,
            "{name}: {e} candidates a point, clean {base}"
        );
    }
    assert!(base <= 400.0, "clean: {base}");
}

#[test]
fn a_large_sets_cells_are_sized_from_a_sample_of_its_cells() {
    // A wavy sheet of 120,000 points: the median occupancy over one cell in sixteen is
    // that over every cell within a quarter, and the answers are the k-d tree's.
    let mut rng = seeded(11, "knn-sample");
    let pts: Vec<DVec3> = (0..120_000)
        .map(|_| {
            let (x, y) = (rng.random::<f64>(), rng.random::<f64>());
            DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos())
        })
        .collect();
    assert!(pts.len() >= SAMPLE_CELLS_FROM);
    let (lo, hi) = (DVec3::new(0.0, 0.0, -0.1), DVec3::new(1.0, 1.0, 0.1));
    for cell in [0.005, 0.01, 0.02] {
        let keys: Vec<u64> = pts
            .iter()
            .map(|p| cell_key(GridKnn::cell_of_raw(*p, lo, 1.0 / cell, hi, cell)))
            .collect();
        let sampled = median_run(&keys);
        let mut all = keys.clone();
        all.sort_unstable();
        let whole = median(&mut runs_of(&all));
        assert!(
            (0.75..=1.34).contains(&(sampled / whole)),
            "cell {cell}: sampled median {sampled}, every cell's {whole}"
        );
    }
    let grid = GridKnn::new(&pts, |i| i, 16).unwrap();
    let knn = Knn::new(&pts, |i| i).unwrap();
    let k = NonZero::new(16).unwrap();
    for i in (0..pts.len()).step_by(97) {
        assert_eq!(
            grid.canonical_knn(pts[i], k).unwrap(),
            knn.canonical_knn(pts[i], k),
            "point {i}"
        );
    }
}

#[test]
fn nearest_to_any_position_as_brute_force_with_one_scratch() {
    // Queries at, between and far outside the points, in an order that reuses a block
    // for neighbouring queries and leaves it for distant ones; copies and a lattice's
    // ties included; one scratch throughout.
    let mut rng = seeded(8, "knn-grid-nearest-test");
    let mut pts: Vec<DVec3> = (0..800)
        .map(|_| DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.1))
        .collect();
    pts.extend(std::iter::repeat_n(pts[3], 12));
    pts.extend((0..125).map(|i| {
        DVec3::new(
            2.0 + f64::from(i % 5),
            f64::from((i / 5) % 5),
            f64::from(i / 25),
        ) * 0.25
    }));
    let global: Vec<u64> = (0..pts.len() as u64).map(|i| (i * 613) % 2003).collect();
    let grid = GridKnn::new(&pts, |i| global[i as usize], 6).unwrap();
    let mut queries: Vec<DVec3> = pts.iter().step_by(3).copied().collect();
    queries.extend((0..600).map(|_| {
        DVec3::new(
            rng.random_range(-0.5..3.5),
            rng.random_range(-0.5..1.5),
            rng.random_range(-0.3..1.3),
        )
    }));
    queries.extend([DVec3::new(50.0, 1.0, 0.0), DVec3::new(0.5, -20.0, 7.0)]);
    let mut scratch = Queries::default();
    for k in [1, 4, 6, 17] {
        let kk = NonZero::new(k).unwrap();
        for (i, q) in queries.iter().enumerate() {
            let got = grid.nearest(*q, kk, &mut scratch).unwrap().to_vec();
            assert_eq!(got, brute(&pts, &global, *q, k), "k {k}, query {i} at {q}");
        }
    }
    assert!(scratch.examined() > 0);
}

#[test]
fn an_owned_grid_answers_as_a_borrowed_one() {
    let pts: Vec<DVec3> = (0..300)
        .map(|i| DVec3::new(f64::from(i % 17), f64::from(i % 13), f64::from(i % 7)) * 0.1)
        .collect();
    let kk = NonZero::new(9).unwrap();
    let borrowed = GridKnn::new(&pts, |i| i, 9).unwrap();
    let owned = GridKnn::new_owned(pts.clone(), |i| i, 9).unwrap();
    let a = borrowed
        .for_each_point(kk, |_| true, |_, nb| nb.to_vec())
        .unwrap();
    let b = owned
        .for_each_point(kk, |_| true, |_, nb| nb.to_vec())
        .unwrap();
    assert_eq!(a, b);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn equals_brute_force(
        pts in prop::collection::vec((0u8..12, 0u8..12, 0u8..3), 1..160),
        dup in prop::collection::vec(0usize..160, 0..40),
        k in 1usize..24,
        scale in prop::sample::select(vec![1e-3, 0.37, 1.0, 1e4]),
    ) {
        // Coordinates on a coarse lattice (many ties and copies), scaled.
        let mut p: Vec<DVec3> = pts
            .iter()
            .map(|&(x, y, z)| DVec3::new(f64::from(x), f64::from(y), f64::from(z)) * scale)
            .collect();
        let extra: Vec<DVec3> = dup.iter().map(|&d| p[d % p.len()]).collect();
        p.extend(extra);
        let global: Vec<u64> = (0..p.len() as u64).map(|i| (i * 31) % 1009).collect();
        check_all(&p, &global, k.min(p.len()));
    }
}
