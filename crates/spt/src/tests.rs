//! Sequential cut = recursive traversal (property test), cut validity, errors.

use cloud::PointCloud;
use cloud::glam::{DVec3, Vec3};
use cloud::rng::{RngExt, seeded};
use proptest::prelude::*;

use super::*;

/// A bumpy sphere with noisy normals, so that errors vary over the tree.
fn bumpy(n: usize, seed: u64) -> PointCloud {
    let mut rng = seeded(seed, "spt-test-normals");
    let dirs = cloud::synth::fibonacci_sphere(n);
    let positions: Vec<DVec3> = dirs
        .iter()
        .map(|d| *d * (1.0 + 0.05 * (7.0 * d.x).sin() * (5.0 * d.y).cos()) + 2.0)
        .collect();
    let normals = dirs
        .iter()
        .map(|d| {
            (d.as_vec3()
                + 0.2
                    * Vec3::new(
                        rng.random::<f32>() - 0.5,
                        rng.random::<f32>() - 0.5,
                        rng.random::<f32>() - 0.5,
                    ))
            .normalize()
        })
        .collect();
    PointCloud {
        positions,
        normals: Some(normals),
        ..PointCloud::default()
    }
}

fn nodes_of(spt: &Spt, entries: &[u32]) -> Vec<u32> {
    let mut v: Vec<u32> = entries.iter().map(|&e| spt.node_of(e)).collect();
    v.sort_unstable();
    v
}

/// Every leaf has exactly one drawn node on its path to the root.
fn assert_is_cut(spt: &Spt, drawn: &[u32]) {
    let h = spt.hierarchy();
    let mut is_drawn = vec![false; h.nodes.len()];
    for &d in drawn {
        assert!(!is_drawn[d as usize], "node {d} drawn twice");
        is_drawn[d as usize] = true;
    }
    // Count drawn nodes on each root-to-leaf path.
    let mut stack = vec![(h.root(), 0u32)];
    while let Some((i, above)) = stack.pop() {
        let here = above + u32::from(is_drawn[i]);
        if h.nodes[i].children.is_empty() {
            assert_eq!(here, 1, "leaf {i} covered {here} times");
        }
        for &k in &h.nodes[i].children {
            stack.push((k as usize, here));
        }
    }
}

#[test]
fn sequential_cut_equals_recursive_on_views() {
    let cloud = bumpy(8_000, 1);
    let spt = build(&cloud, 0.04).unwrap();
    let center = DVec3::splat(2.0);
    for (k, dir) in cloud::synth::fibonacci_sphere(12).into_iter().enumerate() {
        for dist in [1.05, 1.5, 3.0, 10.0] {
            let eye = center + dir * dist;
            for eps in [0.0, 1e-4, 1e-3, 3e-3, 1e-2, 0.1, 10.0] {
                let (seq, stats) = spt.cut(eye, eps).unwrap();
                let mut rec = spt.cut_recursive(eye, eps).unwrap();
                rec.sort_unstable();
                assert_eq!(nodes_of(&spt, &seq), rec, "view {k} dist {dist} eps {eps}");
                assert_eq!(stats.selected, seq.len());
                assert!(stats.entries <= spt.len() && stats.tested <= stats.entries);
                assert_is_cut(&spt, &rec);
            }
        }
    }
}

#[test]
fn parallel_scan_of_long_prefixes_equals_recursive() {
    // Long enough prefixes that the scan splits into several parallel chunks.
    let cloud = bumpy(60_000, 2);
    let spt = build(&cloud, 0.01).unwrap();
    let center = DVec3::splat(2.0);
    for dir in cloud::synth::fibonacci_sphere(3) {
        for eps in [0.0, 1e-3, 3e-3] {
            let eye = center + dir * 1.5;
            let (seq, stats) = spt.cut(eye, eps).unwrap();
            if eps == 0.0 {
                assert!(stats.groups > 16_384, "{stats:?}");
            }
            let mut rec = spt.cut_recursive(eye, eps).unwrap();
            rec.sort_unstable();
            assert_eq!(nodes_of(&spt, &seq), rec, "eps {eps}");
            assert!(seq.windows(2).all(|w| w[0] < w[1]));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn sequential_cut_equals_recursive(seed in 0u64..1_000, n in 2usize..3_000, x in -6.0f64..6.0, y in -6.0f64..6.0, z in -6.0f64..6.0, log_eps in -6.0f64..0.0, diameter in 0.001f64..0.3) {
        let cloud = bumpy(n, seed);
        let spt = build(&cloud, diameter).unwrap();
        let eye = DVec3::new(x, y, z);
        let eps = 10f64.powf(log_eps);
        let (seq, _) = spt.cut(eye, eps).unwrap();
        let mut rec = spt.cut_recursive(eye, eps).unwrap();
        rec.sort_unstable();
        prop_assert_eq!(nodes_of(&spt, &seq), rec);
    }
}

#[test]
fn thresholds_order_the_cuts() {
    let cloud = bumpy(5_000, 2);
    let spt = build(&cloud, 0.04).unwrap();
    let eye = DVec3::new(2.0, 2.0, 8.0);
    assert_eq!(
        spt.cut(eye, 0.0).unwrap().0.len(),
        5_000,
        "ε = 0 draws every leaf"
    );
    assert_eq!(
        spt.cut(eye, 1e9).unwrap().0.len(),
        1,
        "a huge ε draws the root"
    );
    let mut last = usize::MAX;
    for eps in [1e-4, 1e-3, 1e-2, 1e-1] {
        let (cut, stats) = spt.cut(eye, eps).unwrap();
        assert!(cut.len() <= last, "coarser with larger ε");
        last = cut.len();
        assert!(stats.entries >= stats.tested);
    }
    // Far away, most of the list lies beyond the prefix.
    let (_, far) = spt.cut(DVec3::new(2.0, 2.0, 1_000.0), 1e-3).unwrap();
    assert!(far.entries * 10 < spt.len(), "{far:?}");
}

#[test]
fn an_eye_inside_the_object_refines_around_it() {
    let cloud = bumpy(4_000, 3);
    let spt = build(&cloud, 0.04).unwrap();
    let (inside, _) = spt.cut(DVec3::splat(2.0), 1e-2).unwrap();
    let (outside, _) = spt.cut(DVec3::new(2.0, 2.0, 12.0), 1e-2).unwrap();
    assert!(inside.len() > outside.len());
    assert_is_cut(&spt, &nodes_of(&spt, &inside));
}

#[test]
fn flat_regions_are_drawn_with_larger_splats() {
    // A plane and a sphere of the same size and sampling: at the same ε the plane needs fewer,
    // larger splats (seed §5.3.3: "large flat areas have small errors").
    let n = 4_096;
    let side = 64;
    let plane: Vec<DVec3> = (0..n)
        .map(|i| {
            DVec3::new(
                (i % side) as f64 / 32.0 - 1.0,
                (i / side) as f64 / 32.0 - 1.0,
                0.0,
            )
        })
        .collect();
    let plane = PointCloud {
        normals: Some(vec![Vec3::Z; n]),
        positions: plane,
        ..PointCloud::default()
    };
    let ball = bumpy(n, 4);
    let eye = DVec3::new(0.0, 0.0, 6.0);
    let a = build(&plane, 0.04).unwrap();
    let b = build(&ball, 0.04).unwrap();
    let flat = a.cut(eye, 1e-2).unwrap().0.len();
    let round = b.cut(eye + DVec3::splat(2.0), 1e-2).unwrap().0.len();
    assert!(flat * 4 < round, "plane {flat} vs sphere {round}");
    assert!(
        a.hierarchy().nodes.iter().all(|n| n.e_p == 0.0),
        "flat children, no perpendicular error"
    );
}

#[test]
fn bad_inputs_are_errors() {
    let empty = PointCloud::default();
    assert!(matches!(build(&empty, 0.1), Err(Error::EmptyCloud)));
    let mut no_normals = bumpy(10, 0);
    no_normals.normals = None;
    assert!(matches!(
        build(&no_normals, 0.1),
        Err(Error::MissingNormals)
    ));
    let mut nan = bumpy(10, 0);
    nan.positions[3].y = f64::NAN;
    assert!(matches!(build(&nan, 0.1), Err(Error::Cloud(_))));
    let ok = bumpy(10, 0);
    assert!(matches!(
        build(&ok, 0.0),
        Err(Error::InvalidParameter { .. })
    ));
    let spt = build(&ok, 0.1).unwrap();
    assert!(spt.cut(DVec3::new(f64::NAN, 0.0, 0.0), 1e-3).is_err());
    assert!(spt.cut(DVec3::ZERO, -1.0).is_err());
    assert!(spt.cut_recursive(DVec3::ZERO, f64::INFINITY).is_err());
    // One point: the root is a leaf and always drawn.
    let one = PointCloud {
        positions: vec![DVec3::ONE],
        normals: Some(vec![Vec3::Z]),
        ..PointCloud::default()
    };
    let spt = build(&one, 0.1).unwrap();
    assert_eq!(spt.cut(DVec3::ZERO, 0.0).unwrap().0, vec![0]);
    // Coincident points are split by list position; with one normal they have no error and the
    // root stands for them all, with different normals they are refined.
    let same = PointCloud {
        positions: vec![DVec3::ONE; 5],
        normals: Some(vec![Vec3::Z; 5]),
        ..PointCloud::default()
    };
    let spt = build(&same, 0.1).unwrap();
    assert_eq!(spt.cut(DVec3::ZERO, 0.0).unwrap().0.len(), 1);
    let normals = (0..5)
        .map(|i| Vec3::new(0.1 * i as f32, 0.0, 1.0).normalize())
        .collect();
    let tilted = PointCloud {
        positions: vec![DVec3::ONE; 5],
        normals: Some(normals),
        ..PointCloud::default()
    };
    let spt = build(&tilted, 0.1).unwrap();
    assert_eq!(spt.cut(DVec3::ZERO, 0.0).unwrap().0.len(), 5);
}
