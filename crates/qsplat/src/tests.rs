//! Enclosure (property test), file round trip, corrupt files, traversal behaviour.

use cloud::glam::{DVec3, Vec3};
use cloud::{Camera, PointCloud};
use proptest::prelude::*;

use super::*;
use crate::tree::Word;

fn sphere_cloud(n: usize, colored: bool) -> PointCloud {
    let positions = cloud::synth::fibonacci_sphere(n)
        .into_iter()
        .map(|p| p * 3.0 + DVec3::new(10.0, -5.0, 2.0))
        .collect::<Vec<_>>();
    let normals = cloud::synth::fibonacci_sphere(n)
        .into_iter()
        .map(|p| p.as_vec3())
        .collect();
    let colors = colored.then(|| {
        (0..n)
            .map(|i| [(i % 256) as u8, (i * 7 % 256) as u8, 128])
            .collect()
    });
    PointCloud {
        positions,
        normals: Some(normals),
        colors,
        ..PointCloud::default()
    }
}

/// Every decoded sphere encloses the leaf sphere (point ± leaf radius) of every point below
/// it, and the traversal decodes exactly the encoder's spheres.
fn check_enclosure(cloud: &PointCloud, leaf_radius: f64) {
    let normals = cloud.normals.as_deref().unwrap();
    let h = build::build(&build::Input {
        positions: &cloud.positions,
        normals,
        colors: None,
        leaf_radius,
    });
    let (tree, decoded) = QTree::encode_with_spheres(&h, false);
    let mut parent = vec![usize::MAX; h.nodes.len()];
    for (id, n) in h.nodes.iter().enumerate() {
        for &c in n.children() {
            parent[c as usize] = id;
        }
    }
    for (id, n) in h.nodes.iter().enumerate() {
        let Some(p) = n.point else { continue };
        let p = cloud.positions[p as usize];
        let mut a = id;
        loop {
            let (c, r) = decoded[a];
            assert!(
                (c - p).length() + leaf_radius <= r,
                "node {a} does not enclose point {p}"
            );
            if a == h.root() {
                break;
            }
            a = parent[a];
        }
    }
    // The traversal (no culling, every leaf) decodes the same leaf spheres.
    let cam = Camera::new(
        DVec3::new(0.0, 0.0, 100.0),
        DVec3::ZERO,
        DVec3::Y,
        60.0,
        10,
        10,
    )
    .unwrap();
    let leaves = traverse(
        &tree,
        &cam,
        &TraverseParams {
            threshold_px: 0.0,
            frustum_cull: false,
            backface_cull: false,
        },
    );
    assert_eq!(leaves.len() as u64, tree.n_points);
    let key = |c: DVec3, r: f64| (c.x.to_bits(), c.y.to_bits(), c.z.to_bits(), r.to_bits());
    let mut from_traversal: Vec<_> = leaves.iter().map(|s| key(s.center, s.radius)).collect();
    let mut from_encoder: Vec<_> = h
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.point.is_some())
        .map(|(id, _)| key(decoded[id].0, decoded[id].1))
        .collect();
    from_traversal.sort_unstable();
    from_encoder.sort_unstable();
    assert_eq!(from_traversal, from_encoder);
}

#[test]
fn decoded_spheres_enclose_their_subtrees() {
    check_enclosure(&sphere_cloud(600, false), 0.05);
}

#[test]
fn bytes_per_point_is_about_six_without_colour() {
    let cloud = sphere_cloud(20_000, false);
    let tree = build_tree(&cloud, 0.02).unwrap();
    let per_point = file::to_bytes(&tree).len() as f64 / 20_000.0;
    assert!((4.5..7.5).contains(&per_point), "{per_point}");
    let colored = build_tree(&sphere_cloud(20_000, true), 0.02).unwrap();
    let per_point = file::to_bytes(&colored).len() as f64 / 20_000.0;
    assert!((7.0..11.0).contains(&per_point), "{per_point}");
}

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The file bytes of a seeded 150,000-point torus (parallel build and encode paths, colours
/// from positions) are those the first, serial-BFS encoder wrote: speed-ups must not change a
/// byte. (The hash depends on libm's acos, atan and sin, as the bytes do.)
#[test]
fn file_bytes_are_unchanged_by_speed_ups() {
    let mut cloud = cloud::synth::torus_scene(150_000, 7).unwrap().cloud;
    let colors = cloud
        .positions
        .iter()
        .map(|p| {
            let c = (p.abs() * 97.0).fract() * 255.0;
            [c.x as u8, c.y as u8, c.z as u8]
        })
        .collect();
    cloud.colors = Some(colors);
    let plain = PointCloud {
        colors: None,
        ..cloud.clone()
    };
    let colored = file::to_bytes(&build_tree(&cloud, 0.004).unwrap());
    let uncolored = file::to_bytes(&build_tree(&plain, 0.004).unwrap());
    // The bytes before the checksums are version 1's (but for the version field), and the
    // checksums add 8 bytes a page (4 without colours) and 4 for the file: 16 pages.
    let v1 = |b: &[u8], trailer: usize| {
        let mut b = b[..b.len() - trailer].to_vec();
        b[8] = 1;
        fnv1a(&b)
    };
    assert_eq!(
        (
            colored.len(),
            v1(&colored, 16 * 8 + 4),
            uncolored.len(),
            v1(&uncolored, 16 * 4 + 4)
        ),
        (
            1_528_540 + 16 * 8 + 4,
            8_479_932_785_771_492_576,
            1_019_048 + 16 * 4 + 4,
            10_145_279_929_842_933_578
        )
    );
    assert_eq!(
        (fnv1a(&colored), fnv1a(&uncolored)),
        (8_961_253_971_960_256_285, 13_945_642_448_823_988_293)
    );
}

#[test]
fn file_round_trip() {
    for colored in [false, true] {
        let cloud = sphere_cloud(3_000, colored);
        let tree = build_tree(&cloud, 0.03).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.qsp");
        file::write(&tree, &path).unwrap();
        assert_eq!(file::read(&path).unwrap(), tree);
    }
}

#[test]
fn truncated_and_corrupt_files_are_errors() {
    let tree = build_tree(&sphere_cloud(500, true), 0.05).unwrap();
    let bytes = file::to_bytes(&tree);
    // Every truncation.
    for len in [0, 7, 8, 20, 60, 70, bytes.len() / 2, bytes.len() - 1] {
        assert!(
            matches!(
                file::from_bytes(&bytes[..len], "t"),
                Err(Error::Corrupt { .. })
            ),
            "length {len}"
        );
    }
    // Bad magic, version, flags.
    for (at, v) in [(0usize, b'X'), (8, 9), (12, 7)] {
        let mut b = bytes.clone();
        b[at] = v;
        assert!(matches!(
            file::from_bytes(&b, "t"),
            Err(Error::Corrupt { .. })
        ));
    }
    // A huge word count is refused before any allocation.
    let mut b = bytes.clone();
    b[24..32].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        file::from_bytes(&b, "t"),
        Err(Error::Corrupt { offset: 24, .. })
    ));
    // Flipping tree bits or codes in any word is caught by the structural walk (or decodes to
    // another valid tree, never a panic).
    for k in 0..tree.words.len() {
        for bit in [0, 1, 2, 19, 31] {
            let mut b = bytes.clone();
            let at = 68 + 4 * k;
            let w = u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) ^ (1 << bit);
            b[at..at + 4].copy_from_slice(&w.to_le_bytes());
            assert!(matches!(
                file::from_bytes(&b, "t"),
                Err(Error::Checksum { offset: 68, .. })
            ));
            file::reseal(&mut b);
            let _ = file::from_bytes(&b, "t");
        }
    }
    let mut b = bytes.clone();
    let bad = Word {
        sphere: 8_000,
        normal: 0,
        cone: 0,
        children: 0,
        grandchildren: false,
    }
    .pack();
    let first_node = 68 + 4 * usize::from(Word::unpack(tree.root_word).unwrap().grandchildren);
    b[first_node..first_node + 4].copy_from_slice(&bad.to_le_bytes());
    file::reseal(&mut b);
    assert!(
        matches!(file::from_bytes(&b, "t"), Err(Error::Corrupt { reason, .. }) if reason.contains("sphere index"))
    );
}

#[test]
fn traversal_thresholds_cull_and_coarsen() {
    let cloud = sphere_cloud(5_000, false);
    let tree = build_tree(&cloud, 0.02).unwrap();
    let cam = Camera::new(
        DVec3::new(10.0, -5.0, 20.0),
        DVec3::new(10.0, -5.0, 2.0),
        DVec3::Y,
        40.0,
        320,
        240,
    )
    .unwrap();
    // Fewer, larger splats as the threshold grows (the cut moves up the tree a level at a
    // time: a level-6 node projects to about 3.4 pixels here, its parent to about 9).
    let counts: Vec<usize> = [0.5, 2.0, 8.0, 32.0]
        .iter()
        .map(|&t| {
            traverse(
                &tree,
                &cam,
                &TraverseParams {
                    threshold_px: t,
                    ..TraverseParams::default()
                },
            )
            .len()
        })
        .collect();
    assert!(counts.windows(2).all(|w| w[1] <= w[0]), "{counts:?}");
    assert!(counts[3] * 5 < counts[0], "{counts:?}");
    let coarse = traverse(
        &tree,
        &cam,
        &TraverseParams {
            threshold_px: 8.0,
            ..TraverseParams::default()
        },
    );
    // Coarse splats respect the threshold unless they are leaves (no children to go to).
    for s in &coarse {
        assert!(
            s.radius * 2.0 * cam.focal_px() / cam.depth(s.center) <= 8.0 + 1e-9
                || s.radius <= 0.02 * 1.3
        );
    }
    // At leaf level, back-face culling keeps about the front cap (42% of a sphere of radius 3
    // seen from 18 away), plus the leaves within the quantised cone (sin 1/16) of the rim.
    let leaves = traverse(
        &tree,
        &cam,
        &TraverseParams {
            threshold_px: 0.0,
            ..TraverseParams::default()
        },
    );
    let all = traverse(
        &tree,
        &cam,
        &TraverseParams {
            threshold_px: 0.0,
            frustum_cull: false,
            backface_cull: false,
        },
    );
    assert_eq!(all.len(), 5_000);
    let share = leaves.len() as f64 / 5_000.0;
    assert!((0.42..0.5).contains(&share), "{share}");
    // No kept leaf faces away from the eye beyond its cone.
    for s in &leaves {
        let v = s.center - cam.eye;
        assert!(s.normal.dot(v) <= v.length() / 16.0 + s.radius);
    }
    // A camera looking away sees nothing.
    let away = Camera::new(
        DVec3::new(10.0, -5.0, 20.0),
        DVec3::new(10.0, -5.0, 40.0),
        DVec3::Y,
        40.0,
        320,
        240,
    )
    .unwrap();
    assert!(traverse(&tree, &away, &TraverseParams::default()).is_empty());
}

#[test]
fn inputs_are_checked() {
    let mut cloud = sphere_cloud(10, false);
    assert!(matches!(
        build_tree(&cloud, 0.0),
        Err(Error::InvalidParameter { .. })
    ));
    cloud.normals = None;
    assert!(matches!(
        build_tree(&cloud, 0.1),
        Err(Error::MissingNormals)
    ));
    assert!(matches!(
        build_tree(&PointCloud::default(), 0.1),
        Err(Error::EmptyCloud)
    ));
    let single = PointCloud {
        positions: vec![DVec3::ONE],
        normals: Some(vec![Vec3::Z]),
        ..PointCloud::default()
    };
    let t = build_tree(&single, 0.1).unwrap();
    assert_eq!(t.words.len(), 0);
    assert_eq!(file::from_bytes(&file::to_bytes(&t), "t").unwrap(), t);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn random_clouds_enclose(seed in 0u64..1000, n in 2usize..300, r in 0.001f64..0.5) {
        let mut s = seed | 1;
        let mut next = || { s ^= s << 13; s ^= s >> 7; s ^= s << 17; (s >> 11) as f64 / (1u64 << 53) as f64 };
        let positions: Vec<DVec3> = (0..n).map(|_| DVec3::new(next(), next() * 0.3, next() * 5.0) * 10.0 - 2.0).collect();
        let normals: Vec<Vec3> = (0..n).map(|_| Vec3::new(next() as f32 - 0.5, next() as f32 - 0.5, 0.3).normalize()).collect();
        let cloud = PointCloud { positions, normals: Some(normals), ..PointCloud::default() };
        check_enclosure(&cloud, r);
    }
}
