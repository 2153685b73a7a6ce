//! The exact traversal against the brute force, ray for ray: random, clustered, planar and
//! coincident clouds, spheres and discs, rays lying on splitting planes, single rays and
//! packets of every size, whole frames; degenerate and extreme rays; the seed traversal's
//! guarantees; the errors.

use std::sync::Arc;

use cloud::glam::DVec3;
use proptest::prelude::*;

use super::*;
use crate::brute::{cast_brute, cast_brute_disc};
use crate::hit::{entry, hits};
use crate::packet::{MAX_RAYS, Packet, Stack};
use crate::traverse::cast_seed;

fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The exact traversal's answers for `rays`, cast in packets of 1, 2, …, 64 rays in turn
/// (and one ray at a time), each checked against the brute force (spheres, or discs of
/// `normals`).
fn check_packets(
    what: &str,
    points: &[DVec3],
    normals: Option<&[[f64; 3]]>,
    rays: &[([f64; 3], [f64; 3])],
    radius: f64,
) {
    let bvh = Bvh::build(points);
    let by_slot = normals.map(|n| bvh.in_slot_order(n, [f64::NAN; 3]));
    let mut packet = Packet::default();
    let mut stack = Stack::default();
    let brute = |o: [f64; 3], d: [f64; 3]| match normals {
        Some(n) => cast_brute_disc(points, n, o, d, radius),
        None => cast_brute(points, o, d, radius),
    };
    for sizes in [&[1usize][..], &[2, 3, 5, 7, 11, 16, 31, 64]] {
        let mut at = 0;
        let mut k = 0;
        while at < rays.len() {
            let size = sizes[k % sizes.len()].min(MAX_RAYS);
            k += 1;
            let chunk = &rays[at..(at + size).min(rays.len())];
            packet.clear();
            for &(o, d) in chunk {
                packet.push(o, d);
            }
            match &by_slot {
                Some(n) => packet::cast(&bvh, &mut packet, radius, packet::Disc(n), &mut stack),
                None => packet::cast(&bvh, &mut packet, radius, packet::Sphere, &mut stack),
            }
            for (i, &(o, d)) in chunk.iter().enumerate() {
                assert_eq!(
                    packet.hit(i),
                    brute(o, d),
                    "{what}: ray {o:?} -> {d:?}, radius {radius}, ray {i} of a packet of {}",
                    chunk.len()
                );
            }
            at += chunk.len();
        }
    }
}

/// The seed traversal returns a genuine hit, never a nearer one than the exact answer, and
/// nothing when nothing is hit.
fn check_seed(points: &[DVec3], tree: &KdTree, o: [f64; 3], d: [f64; 3], radius: f64) {
    let mut scratch = Scratch::default();
    let seed = cast_seed(tree, &Ray::new(o, d), radius, &mut scratch);
    match (seed, cast_brute(points, o, d, radius)) {
        (Some(i), Some((t, _))) => {
            let p = points[i as usize].to_array();
            assert!(hits(&o, &d, &p, radius * radius));
            assert!(entry(&o, &d, &p, radius * radius).unwrap() >= t);
        }
        (Some(i), None) => panic!("seed traversal hit {i} where nothing is hit"),
        (None, _) => {}
    }
}

/// Rays from around the cloud's box towards it: `n` with their own origins, then `n` from
/// one eye (a pinhole's fan).
fn rays_around(
    r: &mut impl FnMut() -> f64,
    lo: DVec3,
    hi: DVec3,
    n: usize,
) -> Vec<([f64; 3], [f64; 3])> {
    let size = (hi - lo).max_element().max(1e-3);
    let centre = (lo + hi) * 0.5;
    let around = |r: &mut dyn FnMut() -> f64| {
        centre + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 3.0 * size
    };
    let inside = |r: &mut dyn FnMut() -> f64| lo + (hi - lo) * DVec3::new(r(), r(), r());
    let mut out = Vec::new();
    for _ in 0..n {
        let o = around(r);
        let d = inside(r) - o;
        out.push((o.to_array(), d.to_array()));
    }
    let eye = around(r);
    for _ in 0..n {
        out.push((eye.to_array(), (inside(r) - eye).to_array()));
    }
    out
}

fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        })
}

/// Random unit normals, one per point.
fn random_normals(n: usize, r: &mut impl FnMut() -> f64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| {
            loop {
                let v = DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0);
                if v.length() > 0.1 {
                    break v.normalize().to_array();
                }
            }
        })
        .collect()
}

/// The clouds of the tests: uniform in a box, clustered, planar (in an axis plane and
/// tilted), coincident, on a sphere; far from the origin too.
fn clouds(seed: u64, n: usize) -> Vec<(&'static str, Vec<DVec3>)> {
    let mut r = rng(seed);
    let uniform: Vec<DVec3> = (0..n)
        .map(|_| DVec3::new(r(), r(), r()) * 4.0 - 2.0)
        .collect();
    let centres: Vec<DVec3> = (0..5).map(|_| DVec3::new(r(), r(), r()) * 4.0).collect();
    let clustered = (0..n)
        .map(|i| centres[i % 5] + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 0.05)
        .collect();
    let planar = (0..n)
        .map(|_| DVec3::new(r() * 3.0, r() * 2.0, 0.5))
        .collect();
    let tilted = (0..n)
        .map(|_| {
            let (u, v) = (r() * 3.0, r() * 2.0);
            DVec3::new(u, v, 0.3 * u - 0.7 * v)
        })
        .collect();
    let coincident = (0..n)
        .map(|i| [DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 3.5)][i % 2])
        .collect();
    let sphere = cloud::synth::fibonacci_sphere(n);
    let far = uniform
        .iter()
        .map(|p| *p * 0.01 + DVec3::new(4.0e5, -6.0e6, 1.0e3))
        .collect();
    vec![
        ("uniform", uniform),
        ("clustered", clustered),
        ("planar", planar),
        ("tilted plane", tilted),
        ("coincident", coincident),
        ("sphere", sphere),
        ("far from the origin", far),
    ]
}

#[test]
fn every_kind_of_cloud_equals_brute_force_spheres_and_discs() {
    for seed in 0..3 {
        for (name, points) in clouds(seed, 700) {
            let mut r = rng(100 + seed);
            let (lo, hi) = bounds(&points);
            let rays = rays_around(&mut r, lo, hi, 150);
            let size = (hi - lo).max_element().max(1e-3);
            for radius in [size * 0.004, size * 0.03, size * 0.2] {
                check_packets(name, &points, None, &rays, radius);
            }
            let normals = random_normals(points.len(), &mut r);
            check_packets(name, &points, Some(&normals), &rays, size * 0.03);
        }
    }
}

#[test]
fn rays_on_splitting_planes_and_points_with_equal_coordinates() {
    // An integer grid: every splitting value is an integer shared by many points; rays start
    // at integer coordinates and run along axes and diagonals, lying in splitting planes.
    let mut points = Vec::new();
    for x in -3..=3 {
        for y in -3..=3 {
            for z in -3..=3 {
                if (x + y + z) % 2 == 0 {
                    points.push(DVec3::new(x as f64, y as f64, z as f64));
                }
            }
        }
    }
    let tree = KdTree::build(&points);
    let dirs = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 1.0, 0.0],
        [0.0, -1.0, 1.0],
        [1.0, 0.0, -1.0],
        [1.0, 1.0, 1.0],
    ];
    for radius in [0.1, 0.5, 1.0] {
        let mut rays = Vec::new();
        for ox in -5..=5 {
            for oy in -5..=5 {
                for oz in [-5, -1, 0, 2, 5] {
                    let o = [ox as f64, oy as f64, oz as f64];
                    for d in dirs {
                        rays.push((o, d));
                        check_seed(&points, &tree, o, d, radius);
                    }
                }
            }
        }
        check_packets("grid", &points, None, &rays, radius);
    }
}

#[test]
fn degenerate_and_extreme_rays_equal_brute_force() {
    let points = clouds(7, 300).swap_remove(0).1;
    let mut rays = vec![
        // No direction: nothing is hit.
        ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        // Origin inside spheres, direction tiny, huge, subnormal.
        (points[3].to_array(), [1e-200, 0.0, 3e-201]),
        (points[5].to_array(), [1e200, -2e199, 0.0]),
        (points[8].to_array(), [5e-310, 0.0, 0.0]),
        ([-9.0, 0.1, 0.2], [1e-12, 0.0, 0.0]),
        ([-9.0, 0.1, 0.2], [3e15, 1e14, -2e13]),
        // Non-finite: the brute force's answer whatever it is.
        ([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, -9.0], [f64::INFINITY, 0.0, 1.0]),
        // Far away.
        ([1e7, 2e7, -3e7], [-1e7, -2e7, 3e7]),
    ];
    // A packet of everything, then mixed with ordinary rays.
    let mut r = rng(9);
    rays.extend(rays_around(
        &mut r,
        DVec3::splat(-2.0),
        DVec3::splat(2.0),
        20,
    ));
    check_packets("extreme rays", &points, None, &rays, 0.15);
}

#[test]
fn whole_frames_equal_brute_force_pixel_for_pixel() {
    let scene = cloud::synth::sphere_plane_scene(600, 900, 4).0;
    let points = &scene.cloud.positions;
    let caster = RayCaster::new(points).unwrap();
    // Odd sizes too: partial tiles at the right and bottom edges.
    for (eye, (width, height)) in [
        (DVec3::new(0.3, -0.4, 5.0), (40, 30)),
        (DVec3::new(4.0, 1.0, 0.6), (40, 30)),
        (DVec3::new(0.3, -0.4, 5.0), (37, 29)),
    ] {
        let cam = Camera::new(
            eye,
            DVec3::new(0.0, 0.0, 0.5),
            DVec3::Z.cross(DVec3::X).normalize() + DVec3::Z * 0.1,
            45.0,
            width,
            height,
        )
        .unwrap();
        let rays = RayList::new(&cam).unwrap();
        let params = CastParams {
            radius: 0.08,
            traversal: Traversal::Exact,
            primitive: Primitive::Sphere,
        };
        let frame = caster.cast(&rays, &cam, &params).unwrap();
        for k in 0..rays.len() {
            let expected = {
                let (o, d) = rays.aim(&cam, k);
                cast_brute(points, o, d, 0.08)
            }
            .map_or(NONE, |h| h.1);
            assert_eq!(frame.pixel_point[k], expected, "pixel {k}");
        }
        assert_eq!(frame.visible, visible_set(&frame.pixel_point, points.len()));
        assert_eq!(frame.rays, u64::from(width * height));
        // The seed traversal: genuine hits, never nearer than the exact ones.
        let seed = caster
            .cast(
                &rays,
                &cam,
                &CastParams {
                    traversal: Traversal::Seed,
                    ..params
                },
            )
            .unwrap();
        for k in 0..rays.len() {
            let (o, d) = rays.aim(&cam, k);
            check_seed(points, caster.tree(), o, d, 0.08);
            if seed.pixel_point[k] != NONE {
                assert_ne!(frame.pixel_point[k], NONE, "pixel {k}");
            }
        }
    }
}

/// Frames where the cloud covers a few tiles (pinhole and orthographic cameras far away, so
/// that most tiles lie outside its box's window), fills the image, or surrounds the eye (no
/// window), and a spherical camera: every pixel the brute force's.
#[test]
fn frames_of_every_camera_model_and_distance_equal_brute_force() {
    let mut r = rng(77);
    let points: Vec<DVec3> = (0..2_000)
        .map(|_| DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * DVec3::new(2.0, 1.0, 0.5))
        .collect();
    let caster = RayCaster::new(&points).unwrap();
    let models = [
        Model::pinhole_fov(50.0, 61, 45).unwrap(),
        Model::Orthographic {
            view_width: 6.0,
            view_height: 4.5,
        },
        Model::Spherical,
    ];
    for (model, radius) in models.into_iter().flat_map(|m| [(m, 0.03), (m, 0.25)]) {
        for eye in [
            DVec3::new(0.3, 0.2, 12.0),
            DVec3::new(-2.5, 1.0, 1.5),
            DVec3::new(0.05, 0.0, 0.01),
        ] {
            let cam =
                Camera::look_at(eye, DVec3::new(0.1, 0.0, 0.0), DVec3::Y, model, 61, 45).unwrap();
            let rays = RayList::new(&cam).unwrap();
            let params = CastParams {
                radius,
                traversal: Traversal::Exact,
                primitive: Primitive::Sphere,
            };
            let frame = caster.cast(&rays, &cam, &params).unwrap();
            let mut hit = 0;
            for k in 0..rays.len() {
                let (o, d) = rays.aim(&cam, k);
                let expected = cast_brute(&points, o, d, radius).map_or(NONE, |h| h.1);
                assert_eq!(
                    frame.pixel_point[k], expected,
                    "{model:?} from {eye}, radius {radius}, pixel {k}"
                );
                hit += usize::from(expected != NONE);
            }
            // (A spherical image from afar may miss a cloud of a few degrees.)
            assert!(
                hit > 0 || (model == Model::Spherical && eye.z > 10.0),
                "{model:?} from {eye} sees the cloud"
            );
        }
    }
}

#[test]
fn visible_set_is_the_sorted_distinct_points() {
    let pixels = [5, NONE, 64, 5, 0, 127, NONE, 63, 200];
    assert_eq!(visible_set(&pixels, 201), vec![0, 5, 63, 64, 127, 200]);
    assert_eq!(visible_set(&[NONE; 4], 3), Vec::<u32>::new());
}

#[test]
fn errors() {
    assert_eq!(RayCaster::new(&[]).unwrap_err(), Error::EmptyCloud);
    assert_eq!(
        RayCaster::new(&[DVec3::ZERO, DVec3::NAN]).unwrap_err(),
        Error::NonFinite(1)
    );
    let caster = RayCaster::new(&[DVec3::ZERO]).unwrap();
    let cam = Camera::new(DVec3::Z * 3.0, DVec3::ZERO, DVec3::Y, 40.0, 8, 8).unwrap();
    let rays = RayList::new(&cam).unwrap();
    for radius in [0.0, -1.0, f64::NAN] {
        let params = CastParams {
            radius,
            traversal: Traversal::Exact,
            primitive: Primitive::Sphere,
        };
        assert!(matches!(
            caster.cast(&rays, &cam, &params),
            Err(Error::InvalidParameter { name: "radius", .. })
        ));
    }
    let other = cam.with_resolution(16, 8).unwrap();
    let params = CastParams {
        radius: 0.1,
        traversal: Traversal::Exact,
        primitive: Primitive::Sphere,
    };
    assert!(matches!(
        caster.cast(&rays, &other, &params),
        Err(Error::CameraMismatch { .. })
    ));
    // A single point in front of the camera is seen by the central rays, both traversals.
    for traversal in [Traversal::Seed, Traversal::Exact] {
        let frame = caster
            .cast(
                &rays,
                &cam,
                &CastParams {
                    radius: 0.2,
                    traversal,
                    primitive: Primitive::Sphere,
                },
            )
            .unwrap();
        assert_eq!(frame.visible, vec![0]);
    }
}

#[test]
fn concurrent_update_gives_the_direct_result() {
    let points = cloud::synth::fibonacci_sphere(3_000);
    let caster = Arc::new(RayCaster::new(&points).unwrap());
    let cam = Camera::new(
        DVec3::new(0.0, 1.0, 4.0),
        DVec3::ZERO,
        DVec3::Y,
        40.0,
        64,
        48,
    )
    .unwrap();
    let rays = Arc::new(RayList::new(&cam).unwrap());
    let params = CastParams {
        radius: 0.05,
        traversal: Traversal::Exact,
        primitive: Primitive::Sphere,
    };
    let mut worker = concurrent::spawn(Arc::clone(&caster), Arc::clone(&rays), params);
    let s = worker.request(cam);
    worker.wait_for(s).unwrap();
    let direct = caster.cast(&rays, &cam, &params).unwrap();
    assert_eq!(worker.front().unwrap().result.as_ref().unwrap(), &direct);
}

#[test]
fn disc_frames_equal_the_brute_force_pixel_for_pixel() {
    for seed in 0..4 {
        let mut r = rng(100 + seed);
        let points: Vec<DVec3> = (0..500)
            .map(|_| DVec3::new(r(), r(), r()) * 4.0 - 2.0)
            .collect();
        let unit = random_normals(points.len(), &mut r);
        let normals: Vec<DVec3> = unit.iter().map(|v| DVec3::from_array(*v)).collect();
        let caster = RayCaster::new(&points)
            .unwrap()
            .with_normals(&normals)
            .unwrap();
        let cam = Camera::new(
            DVec3::new(0.4, 0.3, 6.0),
            DVec3::ZERO,
            DVec3::Y,
            40.0,
            37,
            29,
        )
        .unwrap();
        let list = RayList::new(&cam).unwrap();
        let params = CastParams {
            radius: 0.15,
            traversal: Traversal::Exact,
            primitive: Primitive::Disc,
        };
        let frame = caster.cast(&list, &cam, &params).unwrap();
        for k in 0..list.len() {
            let (o, d) = list.aim(&cam, k);
            let expected = cast_brute_disc(&points, &unit, o, d, 0.15).map_or(NONE, |h| h.1);
            assert_eq!(frame.pixel_point[k], expected, "pixel {k}");
        }
        // Discs are thinner than spheres: they are hit by fewer rays, never by more.
        let spheres = CastParams {
            primitive: Primitive::Sphere,
            ..params
        };
        let sphere_frame = caster.cast(&list, &cam, &spheres).unwrap();
        let hit = |f: &Frame| f.pixel_point.iter().filter(|&&p| p != NONE).count();
        assert!(hit(&frame) <= hit(&sphere_frame));
    }
}

#[test]
fn disc_errors() {
    let points = [DVec3::ZERO, DVec3::X];
    let caster = RayCaster::new(&points).unwrap();
    let cam = Camera::new(DVec3::Z * 3.0, DVec3::ZERO, DVec3::Y, 40.0, 8, 8).unwrap();
    let rays = RayList::new(&cam).unwrap();
    let disc = CastParams {
        radius: 0.2,
        traversal: Traversal::Exact,
        primitive: Primitive::Disc,
    };
    // No normals given; the seed traversal; wrong count; a zero or NaN normal.
    let err = caster.cast(&rays, &cam, &disc).unwrap_err().to_string();
    assert!(err.contains("normals"), "{err}");
    let with = caster.clone().with_normals(&[DVec3::Z, DVec3::Z]).unwrap();
    let seed = CastParams {
        traversal: Traversal::Seed,
        ..disc
    };
    let err = with.cast(&rays, &cam, &seed).unwrap_err().to_string();
    assert!(err.contains("exact traversal"), "{err}");
    assert!(with.cast(&rays, &cam, &disc).unwrap().visible.contains(&0));
    for bad in [
        vec![DVec3::Z],
        vec![DVec3::Z, DVec3::ZERO],
        vec![DVec3::NAN, DVec3::Z],
    ] {
        assert!(matches!(
            caster.clone().with_normals(&bad),
            Err(Error::InvalidParameter {
                name: "normals",
                ..
            })
        ));
    }
}

/// A cloud of one of the kinds the proptests draw: `kind` 0 uniform, 1 clustered, 2 planar,
/// 3 coincident (a few positions repeated), 4 on a sphere; scaled by `scale` and moved by
/// `shift`.
fn drawn_cloud(kind: u8, n: usize, seed: u64, scale: f64, shift: [f64; 3]) -> Vec<DVec3> {
    let mut r = rng(seed);
    let base: Vec<DVec3> = match kind {
        0 => (0..n)
            .map(|_| DVec3::new(r(), r(), r()) * 2.0 - 1.0)
            .collect(),
        1 => {
            let c: Vec<DVec3> = (0..3)
                .map(|_| DVec3::new(r(), r(), r()) * 2.0 - 1.0)
                .collect();
            (0..n)
                .map(|i| c[i % 3] + DVec3::new(r(), r(), r()) * 0.02)
                .collect()
        }
        2 => (0..n)
            .map(|_| {
                let (u, v) = (r() * 2.0 - 1.0, r() * 2.0 - 1.0);
                DVec3::new(u, v, 0.25 * u)
            })
            .collect(),
        3 => {
            let c: Vec<DVec3> = (0..4)
                .map(|_| (DVec3::new(r(), r(), r()) * 4.0).floor() * 0.5 - 1.0)
                .collect();
            (0..n).map(|i| c[i % 4]).collect()
        }
        _ => cloud::synth::fibonacci_sphere(n),
    };
    base.iter()
        .map(|p| *p * scale + DVec3::from_array(shift))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn small_clouds_equal_brute_force(
        pts in proptest::collection::vec((-3i32..=3, -3i32..=3, -3i32..=3), 1..60),
        rays in proptest::collection::vec(((-5i32..=5, -5i32..=5, -5i32..=5), (-2i32..=2, -2i32..=2, -2i32..=2)), 1..40),
        radius in 0.05f64..1.5,
    ) {
        // Coarse integer coordinates: many duplicates, shared coordinates and in-plane rays.
        let points: Vec<DVec3> = pts.iter().map(|&(x, y, z)| DVec3::new(x as f64, y as f64, z as f64) * 0.5).collect();
        let tree = KdTree::build(&points);
        let rays: Vec<([f64; 3], [f64; 3])> = rays
            .iter()
            .map(|&((ox, oy, oz), (dx, dy, dz))| ([ox as f64, oy as f64, oz as f64], [dx as f64, dy as f64, dz as f64]))
            .collect();
        for &(o, d) in &rays {
            check_seed(&points, &tree, o, d, radius);
        }
        check_packets("integer cloud", &points, None, &rays, radius);
    }

    /// Clouds of every kind at the hierarchy's sizes (tens to hundreds of leaves), spheres and
    /// discs, rays from one eye and from everywhere, in packets.
    #[test]
    fn drawn_clouds_equal_brute_force(
        kind in 0u8..5,
        n in 1usize..1500,
        seed in 0u64..1000,
        scale in prop_oneof![Just(1.0), 1e-3f64..1e3],
        shift in proptest::array::uniform3(prop_oneof![Just(0.0), -1e4f64..1e4]),
        radius_frac in prop_oneof![1e-4f64..1e-2, 1e-2f64..0.3],
        discs in any::<bool>(),
    ) {
        let points = drawn_cloud(kind, n, seed, scale, shift);
        let (lo, hi) = bounds(&points);
        let mut r = rng(seed + 1);
        let rays = rays_around(&mut r, lo, hi, 40);
        let radius = radius_frac * scale;
        if discs {
            let normals = random_normals(points.len(), &mut r);
            check_packets("drawn discs", &points, Some(&normals), &rays, radius);
        } else {
            check_packets("drawn spheres", &points, None, &rays, radius);
        }
    }

    /// Whole frames of the caster (tiles, the cloud's window, normals in slot order) on drawn
    /// clouds of every kind, from a pinhole or orthographic camera near or far: every pixel
    /// the brute force's, spheres and discs.
    #[test]
    fn drawn_cloud_frames_equal_brute_force(
        kind in 0u8..5,
        n in 1usize..3000,
        seed in 0u64..1000,
        scale in prop_oneof![Just(1.0), 1e-2f64..1e2],
        shift in proptest::array::uniform3(prop_oneof![Just(0.0), -1e3f64..1e3]),
        radius_frac in 1e-3f64..0.1,
        distance in 1.5f64..20.0,
        orthographic in any::<bool>(),
        discs in any::<bool>(),
    ) {
        let points = drawn_cloud(kind, n, seed, scale, shift);
        let (lo, hi) = bounds(&points);
        let centre = (lo + hi) * 0.5;
        let size = (hi - lo).max_element().max(1e-3 * scale);
        let mut r = rng(seed + 7);
        let towards = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize_or(DVec3::Z);
        let eye = centre + towards * distance * size;
        let model = if orthographic {
            Model::Orthographic { view_width: 2.0 * size, view_height: 1.5 * size }
        } else {
            Model::pinhole_fov(40.0, 29, 22).unwrap()
        };
        let up = if towards.cross(DVec3::Z).length() > 0.1 { DVec3::Z } else { DVec3::X };
        let cam = Camera::look_at(eye, centre, up, model, 29, 22).unwrap();
        let list = RayList::new(&cam).unwrap();
        let radius = radius_frac * size;
        let unit = random_normals(points.len(), &mut r);
        let caster = RayCaster::new(&points).unwrap().with_normals(&unit.iter().map(|v| DVec3::from_array(*v)).collect::<Vec<_>>()).unwrap();
        let params = CastParams {
            radius,
            traversal: Traversal::Exact,
            primitive: if discs { Primitive::Disc } else { Primitive::Sphere },
        };
        let frame = caster.cast(&list, &cam, &params).unwrap();
        for k in 0..list.len() {
            let (o, d) = list.aim(&cam, k);
            let expected = if discs {
                cast_brute_disc(&points, &unit, o, d, radius)
            } else {
                cast_brute(&points, o, d, radius)
            }
            .map_or(NONE, |h| h.1);
            prop_assert_eq!(frame.pixel_point[k], expected, "pixel {}", k);
        }
        prop_assert_eq!(&frame.visible, &visible_set(&frame.pixel_point, points.len()));
    }
}
