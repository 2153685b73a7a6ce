//! The k-d traversal against the brute force, ray for ray: random clouds and rays, rays lying
//! on splitting planes, points sharing coordinates, whole frames; the seed traversal's
//! guarantees; the errors.

use std::sync::Arc;

use cloud::glam::DVec3;
use proptest::prelude::*;

use super::*;
use crate::brute::{cast_brute, cast_brute_disc};
use crate::hit::{entry, hits};
use crate::traverse::{cast_exact, cast_exact_packet, cast_exact_with, cast_seed};

fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn check_ray(
    points: &[DVec3],
    tree: &KdTree,
    o: [f64; 3],
    d: [f64; 3],
    radius: f64,
    scratch: &mut Scratch,
) {
    let ray = Ray::new(o, d);
    let fast = cast_exact(tree, &ray, radius, scratch);
    let slow = cast_brute(points, o, d, radius);
    assert_eq!(fast, slow, "ray {o:?} -> {d:?}, radius {radius}");
    // The seed traversal returns a genuine hit, never a nearer one than the exact answer, and
    // nothing when nothing is hit.
    let seed = cast_seed(tree, &ray, radius, scratch);
    match (seed, slow) {
        (Some(i), Some((t, _))) => {
            let p = points[i as usize].to_array();
            assert!(hits(&o, &d, &p, radius * radius));
            assert!(entry(&o, &d, &p, radius * radius).unwrap() >= t);
        }
        (Some(i), None) => panic!("seed traversal hit {i} where nothing is hit"),
        (None, _) => {}
    }
}

/// Packets of one to four of `rays` give each ray the brute force's answer.
fn check_packets(points: &[DVec3], tree: &KdTree, rays: &[Ray], radius: f64) {
    let mut scratch = Scratch::default();
    let mut at = 0;
    let mut size = 1;
    while at < rays.len() {
        let packet = &rays[at..(at + size).min(rays.len())];
        let got = cast_exact_packet(tree, packet, radius, traverse::Sphere, &mut scratch);
        for (i, ray) in packet.iter().enumerate() {
            assert_eq!(
                got[i],
                cast_brute(points, ray.o, ray.d, radius),
                "ray {:?} -> {:?} in a packet of {}",
                ray.o,
                ray.d,
                packet.len()
            );
        }
        at += size;
        size = size % 4 + 1;
    }
}

#[test]
fn random_clouds_and_rays_equal_brute_force() {
    for seed in 0..10 {
        let mut r = rng(seed);
        let points: Vec<DVec3> = (0..600)
            .map(|_| DVec3::new(r(), r(), r()) * 4.0 - 2.0)
            .collect();
        let tree = KdTree::build(&points);
        let mut scratch = Scratch::default();
        let mut rays = Vec::new();
        for _ in 0..400 {
            let o = [6.0 * r() - 3.0, 6.0 * r() - 3.0, 6.0 * r() - 3.0];
            let d = [2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0];
            check_ray(&points, &tree, o, d, 0.02 + 0.2 * r(), &mut scratch);
            rays.push(Ray::new(o, d));
        }
        // Packets: unrelated origins and directions, then a shared origin (a pinhole's).
        check_packets(&points, &tree, &rays, 0.1);
        let eye = rays[0].o;
        let fan: Vec<Ray> = rays.iter().map(|r| Ray::new(eye, r.d)).collect();
        check_packets(&points, &tree, &fan, 0.05);
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
    let mut scratch = Scratch::default();
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
    for ox in -5..=5 {
        for oy in -5..=5 {
            for oz in [-5, -1, 0, 2, 5] {
                for radius in [0.1, 0.5, 1.0] {
                    let o = [ox as f64, oy as f64, oz as f64];
                    let fan: Vec<Ray> = dirs.iter().map(|&d| Ray::new(o, d)).collect();
                    check_packets(&points, &tree, &fan, radius);
                }
                for d in dirs {
                    for radius in [0.1, 0.5, 1.0] {
                        check_ray(
                            &points,
                            &tree,
                            [ox as f64, oy as f64, oz as f64],
                            d,
                            radius,
                            &mut scratch,
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn whole_frames_equal_brute_force_pixel_for_pixel() {
    let scene = cloud::synth::sphere_plane_scene(600, 900, 4).0;
    let points = &scene.cloud.positions;
    let caster = RayCaster::new(points).unwrap();
    // Odd sizes too: partial tiles and partial 2 × 2 packets at the right and bottom edges.
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
    }
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
    // A single point in front of the camera is seen by the central rays.
    let frame = caster
        .cast(
            &rays,
            &cam,
            &CastParams {
                radius: 0.2,
                traversal: Traversal::Seed,
                primitive: Primitive::Sphere,
            },
        )
        .unwrap();
    assert_eq!(frame.visible, vec![0]);
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

/// Random unit normals, one per point.
fn random_normals(n: usize, r: &mut impl FnMut() -> f64) -> Vec<DVec3> {
    (0..n)
        .map(|_| {
            loop {
                let v = DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0);
                if v.length() > 0.1 {
                    break v.normalize();
                }
            }
        })
        .collect()
}

#[test]
fn discs_equal_the_brute_force_ray_for_ray_in_packets_and_frames() {
    for seed in 0..6 {
        let mut r = rng(100 + seed);
        let points: Vec<DVec3> = (0..500)
            .map(|_| DVec3::new(r(), r(), r()) * 4.0 - 2.0)
            .collect();
        let normals = random_normals(points.len(), &mut r);
        let unit: Vec<[f64; 3]> = normals.iter().map(|v| v.to_array()).collect();
        let tree = KdTree::build(&points);
        let in_order = tree.in_node_order(&unit);
        let disc = traverse::Disc(&in_order);
        let mut scratch = Scratch::default();
        let mut rays = Vec::new();
        for _ in 0..300 {
            let o = [6.0 * r() - 3.0, 6.0 * r() - 3.0, 6.0 * r() - 3.0];
            let d = [2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0];
            let radius = 0.05 + 0.3 * r();
            let ray = Ray::new(o, d);
            assert_eq!(
                cast_exact_with(&tree, &ray, radius, disc, &mut scratch),
                cast_brute_disc(&points, &unit, o, d, radius),
                "ray {o:?} -> {d:?}, radius {radius}"
            );
            rays.push(ray);
        }
        for packet in rays.chunks(traverse::PACKET) {
            let got = cast_exact_packet(&tree, packet, 0.2, disc, &mut scratch);
            for (i, ray) in packet.iter().enumerate() {
                assert_eq!(got[i], cast_brute_disc(&points, &unit, ray.o, ray.d, 0.2));
            }
        }
        // A whole frame through `RayCaster`: every pixel the brute force's disc.
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
        let mut scratch = Scratch::default();
        for ((ox, oy, oz), (dx, dy, dz)) in rays {
            prop_assume!(dx != 0 || dy != 0 || dz != 0);
            check_ray(&points, &tree, [ox as f64, oy as f64, oz as f64], [dx as f64, dy as f64, dz as f64], radius, &mut scratch);
        }
    }
}
