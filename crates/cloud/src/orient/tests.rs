//! Orientation against known outward normals: a torus (its inner half is concave, where the
//! centroid rule fails), the guide's subset path, and the real dragon (with
//! `POINTSIGHT_REAL_DATA`).

use glam::DVec3;

use super::*;
use crate::normals::{Orientation, estimate_normals};
use crate::rng::{RngExt, seeded};

/// The torus of `synth::torus_scene` (ring 1, tube 0.35): points and their outward normals.
fn torus(n: usize, seed: u64) -> (Vec<DVec3>, Vec<DVec3>) {
    let scene = crate::synth::torus_scene(n, seed).unwrap();
    let pts = scene.cloud.positions;
    let outward = pts
        .iter()
        .map(|p| {
            let c = DVec3::new(p.x, p.y, 0.0).normalize() * 1.0;
            (*p - c).normalize()
        })
        .collect();
    (pts, outward)
}

fn agreement(normals: &[Vec3], truth: &[DVec3]) -> f64 {
    let ok = normals
        .iter()
        .zip(truth)
        .filter(|(n, t)| n.as_dvec3().dot(**t) > 0.0)
        .count();
    ok as f64 / truth.len() as f64
}

/// `raw` (at `pts`) with the guide's signs.
fn signed(g: &Guide, pts: &[DVec3], raw: &[DVec3]) -> Vec<Vec3> {
    pts.iter().zip(raw).map(|(p, n)| g.orient(*p, *n)).collect()
}

/// Unoriented normals (as the covariance gives them) of `pts` from `k` neighbours.
fn unoriented(pts: &[DVec3], k: usize) -> Vec<DVec3> {
    estimate_normals(pts, k, Orientation::TowardsViewpoint(DVec3::ZERO))
        .unwrap()
        .into_iter()
        .map(|n| n.as_dvec3())
        .collect()
}

#[test]
fn the_tree_orients_a_torus_where_the_centroid_rule_fails() {
    let (pts, outward) = torus(20_000, 3);
    let raw = unoriented(&pts, 16);
    let g = Guide::new(select_guide(&pts, GUIDE_MAX), 16).unwrap();
    assert_eq!(g.len(), pts.len());
    let mst: Vec<Vec3> = signed(&g, &pts, &raw);
    let away = estimate_normals(&pts, 16, Orientation::AwayFromCentroid).unwrap();
    let (a_mst, a_away) = (agreement(&mst, &outward), agreement(&away, &outward));
    eprintln!("torus 20000: tree {a_mst:.5}, away from the centroid {a_away:.5}");
    assert!(a_mst >= 0.99, "tree: {a_mst}");
    assert!(
        a_away < 0.9,
        "the centroid rule should fail inside the ring: {a_away}"
    );
}

#[test]
fn a_guide_much_smaller_than_the_cloud_orients_it_as_well() {
    let (pts, outward) = torus(60_000, 5);
    let raw = unoriented(&pts, 16);
    let guide = select_guide(&pts, 3_000);
    assert!(
        (1_500..=3_300).contains(&guide.len()),
        "guide of {}",
        guide.len()
    );
    let g = Guide::new(guide, 16).unwrap();
    let oriented: Vec<Vec3> = signed(&g, &pts, &raw);
    let a = agreement(&oriented, &outward);
    eprintln!("torus 60000 from a guide of {}: {a:.5}", g.len());
    assert!(a >= 0.99, "guided: {a}");
}

#[test]
fn the_guide_is_a_set_of_positions_whatever_their_order() {
    let (mut pts, _) = torus(30_000, 7);
    let mut sampler = GuideSampler::new(1_000);
    for p in &pts {
        sampler.push(*p);
    }
    let key = |v: &mut Vec<DVec3>| {
        v.sort_by(by_position);
        v.clone()
    };
    let streamed = key(&mut sampler.finish());
    let whole = key(&mut select_guide(&pts, 1_000));
    assert_eq!(streamed, whole);
    let mut rng = seeded(9, "shuffle");
    for i in (1..pts.len()).rev() {
        pts.swap(i, rng.random_range(0..=i));
    }
    assert_eq!(key(&mut select_guide(&pts, 1_000)), whole);
    // Every point of a small cloud is its own guide.
    assert_eq!(select_guide(&pts[..500], 1_000).len(), 500);
    assert_eq!(guide_shift(1_000, 1_000), 0);
    assert_eq!(guide_shift(1_001, 1_000), 1);
}

/// With the whole cloud as its guide, the rule is the tree's on the whole cloud.
#[test]
fn a_whole_guide_gives_the_plain_tree() {
    let (pts, _) = torus(5_000, 11);
    let raw = unoriented(&pts, 12);
    let g = Guide::new(select_guide(&pts, guide_max()), 12).unwrap();
    assert_eq!(g.len(), pts.len());
    let guided: Vec<Vec3> = signed(&g, &pts, &raw);
    let knn = crate::knn::Knn::new(&pts, |i| i).unwrap();
    let k = NonZero::new(12).unwrap();
    let neighbours: Vec<Vec<u32>> = pts
        .iter()
        .map(|p| {
            knn.canonical_knn(*p, k)
                .iter()
                .skip(1)
                .map(|x| x.1 as u32)
                .collect()
        })
        .collect();
    let mut plain = raw.clone();
    mst_orient(&pts, &mut plain, &neighbours);
    let plain: Vec<Vec3> = plain.iter().map(|n| n.as_vec3()).collect();
    assert_eq!(guided, plain);
    // The same through `estimate_normals`.
    assert_eq!(
        estimate_normals(&pts, 12, Orientation::Propagated).unwrap(),
        plain
    );
}

#[test]
fn planes_copies_and_separate_parts_are_oriented_without_panics() {
    // A plane: every normal +z (the root's, propagated).
    let plane: Vec<DVec3> = (0..400)
        .map(|i| DVec3::new((i % 20) as f64, (i / 20) as f64, 0.0))
        .collect();
    let n = estimate_normals(&plane, 8, Orientation::Propagated).unwrap();
    assert!(n.iter().all(|n| n.z > 0.99), "{:?}", &n[..4]);
    // Two spheres far apart, each with copies of its points: both outward, twice the same.
    let mut pts = Vec::new();
    for c in [DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)] {
        for p in crate::synth::fibonacci_sphere(2_000) {
            pts.push(c + p);
            pts.push(c + p);
        }
    }
    let a = estimate_normals(&pts, 16, Orientation::Propagated).unwrap();
    let b = estimate_normals(&pts, 16, Orientation::Propagated).unwrap();
    assert_eq!(a, b);
    let outward: Vec<DVec3> = pts
        .iter()
        .map(|p| {
            if p.x > 50.0 {
                *p - DVec3::new(100.0, 0.0, 0.0)
            } else {
                *p
            }
        })
        .collect();
    assert_eq!(agreement(&a, &outward), 1.0);
    // A guide of one position orients by +z.
    let g = Guide::new(vec![DVec3::ONE; 5], 8).unwrap();
    assert!(g.is_empty());
    assert_eq!(g.orient(DVec3::ZERO, -DVec3::Z), Vec3::Z);
}

/// The real dragon (fetched): ≥ 99 % of 200,000 samples agree with the mesh's outward face
/// normals, from the whole guide and from a guide of a tenth of them.
#[test]
fn the_dragon_is_oriented_as_its_mesh() {
    if std::env::var_os("POINTSIGHT_REAL_DATA").is_none() {
        eprintln!("skipped: set POINTSIGHT_REAL_DATA=1 (with `just fetch`) to run");
        return;
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../bench-data/meshes/ChineseDragon-10kv.off");
    let loaded = crate::io::off::read_off(&path).unwrap();
    let mesh = crate::mesh::TriMesh::new(loaded.cloud.positions, loaded.triangles).unwrap();
    let cloud = crate::sample::sample_surface(&mesh, 200_000, 16).unwrap();
    let truth: Vec<DVec3> = cloud
        .normals
        .unwrap()
        .iter()
        .map(|n| n.as_dvec3())
        .collect();
    let pts = cloud.positions;
    let away = estimate_normals(&pts, 16, Orientation::AwayFromCentroid).unwrap();
    let raw = unoriented(&pts, 16);
    let w = Guide::new(select_guide(&pts, pts.len()), 16).unwrap();
    assert_eq!(w.len(), pts.len());
    let whole: Vec<Vec3> = signed(&w, &pts, &raw);
    let g = Guide::new(select_guide(&pts, 20_000), 16).unwrap();
    let guided: Vec<Vec3> = signed(&g, &pts, &raw);
    let (a, b, c) = (
        agreement(&whole, &truth),
        agreement(&guided, &truth),
        agreement(&away, &truth),
    );
    eprintln!(
        "dragon 200000: tree {a:.5}, guide of {} {b:.5}, centroid {c:.5}",
        g.len()
    );
    assert!(a >= 0.99 && b >= 0.99, "tree {a}, guided {b}");
}

/// The rule of the module doc by brute force: the `CANDIDATES` nearest distinct guide
/// positions by (squared distance, position order), the one whose plane passes closest.
fn brute_reference(g: &Guide, p: DVec3) -> DVec3 {
    g.closest_plane(
        p,
        g.brute_nearest(p, CANDIDATES.min(g.distinct.len()))
            .into_iter(),
    )
}

#[test]
fn the_reference_is_the_rule_by_brute_force_ties_and_far_points_included() {
    // A torus (guide of every 4th point, about) queried at its own points, at points off
    // it and far outside the guide's box, in an order that reuses and abandons the grid's
    // blocks; and an integer lattice, where many guide points tie in distance.
    let (pts, _) = torus(12_000, 9);
    let g = Guide::new(select_guide(&pts, 3_000), 16).unwrap();
    let mut rng = seeded(4, "guide-reference-test");
    let mut queries: Vec<DVec3> = pts.iter().step_by(7).copied().collect();
    queries.extend((0..2_000).map(|_| {
        DVec3::new(
            rng.random_range(-1.6..1.6),
            rng.random_range(-1.6..1.6),
            rng.random_range(-0.5..0.5),
        )
    }));
    queries.extend([DVec3::new(40.0, -3.0, 2.0), DVec3::new(-9.0, 0.0, -30.0)]);
    for (i, q) in queries.iter().enumerate() {
        assert_eq!(g.reference(*q), brute_reference(&g, *q), "query {i} at {q}");
    }
    let lattice: Vec<DVec3> = (0..1_000)
        .map(|i| {
            DVec3::new(
                f64::from(i % 10),
                f64::from((i / 10) % 10),
                f64::from(i / 100),
            )
        })
        .collect();
    let g = Guide::new(lattice.clone(), 8).unwrap();
    for q in lattice
        .iter()
        .map(|p| *p + DVec3::splat(0.5))
        .chain(lattice.iter().copied())
    {
        assert_eq!(g.reference(q), brute_reference(&g, q), "lattice query {q}");
    }
}

#[test]
fn two_guides_on_one_thread_keep_their_own_answers() {
    // A thread's query buffers belong to one guide: alternating between two guides whose
    // grids have (nearly) the same cells, at the same query points, must not answer one
    // guide's query from the other's candidates.
    let (a, _) = torus(6_000, 1);
    let b: Vec<DVec3> = a
        .iter()
        .enumerate()
        .map(|(i, p)| *p + 1e-4 * DVec3::new((i as f64).sin(), (i as f64).cos(), 0.0))
        .collect();
    let (ga, gb) = (
        Guide::new(a.clone(), 12).unwrap(),
        Guide::new(b.clone(), 12).unwrap(),
    );
    for p in a.iter().step_by(5) {
        assert_eq!(ga.reference(*p), brute_reference(&ga, *p));
        assert_eq!(gb.reference(*p), brute_reference(&gb, *p));
    }
}

#[test]
fn the_streamed_guide_equals_the_whole_ones_at_every_count_and_bound() {
    // The sampler recomputes its shift only past `max · 2^shift`: every prefix of the stream,
    // at bounds that make it change often, gives the set of the whole prefix.
    let (pts, _) = torus(2_100, 3);
    for max in [1, 2, 3, 7, 64, 5_000] {
        let mut sampler = GuideSampler::new(max);
        for (n, p) in pts.iter().enumerate() {
            sampler.push(*p);
            if n % 97 == 0 || n + 1 == pts.len() || (n + 1).is_power_of_two() {
                let mut streamed = sampler.clone().finish();
                let mut whole = select_guide(&pts[..=n], max);
                streamed.sort_by(by_position);
                whole.sort_by(by_position);
                assert_eq!(streamed, whole, "max {max}, {} points", n + 1);
            }
        }
    }
}
