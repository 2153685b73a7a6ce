//! Tests of the derived pixel choice (against a brute force of its rule) and of the score.

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use cloud::synth::sphere_plane_scene;
use cloud::{Camera, Model};

use super::*;

/// The rule written out: every pixel's ray against every visible sphere, the first entered
/// (ties: the lower index).
fn brute(points: &[DVec3], visible: &[u32], camera: &Camera, r: f64) -> Vec<u32> {
    let mut out = Vec::new();
    for y in 0..camera.height {
        for x in 0..camera.width {
            let (o, d) = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
            let mut best = (f64::INFINITY, NONE);
            for &i in visible {
                let c = points[i as usize];
                // |o + t d - c| = r, solved for the smaller t with t_exit > 0.
                let (a, b, k) = (
                    d.length_squared(),
                    d.dot(c - o),
                    (c - o).length_squared() - r * r,
                );
                let disc = b * b - a * k;
                if disc < 0.0 || (b + disc.sqrt()) / a <= 0.0 {
                    continue;
                }
                let t = ((b - disc.sqrt()) / a).max(0.0);
                if t < best.0 || (t == best.0 && i < best.1) {
                    best = (t, i);
                }
            }
            out.push(best.1);
        }
    }
    out
}

/// 400 random points in a box around the origin, a random half of them "visible".
fn cloud(seed: u64) -> (Vec<DVec3>, Vec<u32>) {
    let mut rng = seeded(seed, "pixels-test");
    let points: Vec<DVec3> = (0..400)
        .map(|_| {
            DVec3::new(
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
                rng.random::<f64>() * 2.0 - 1.0,
            )
        })
        .collect();
    let visible = (0..400u32).filter(|_| rng.random::<bool>()).collect();
    (points, visible)
}

#[test]
fn the_derived_choice_is_each_pixels_first_visible_sphere_for_every_camera_model() {
    let eye = DVec3::new(0.3, -0.4, 3.0);
    let cameras = [
        Camera::new(eye, DVec3::ZERO, DVec3::Y, 50.0, 48, 32).unwrap(),
        Camera::look_at(
            eye,
            DVec3::ZERO,
            DVec3::Y,
            Model::Orthographic {
                view_width: 3.0,
                view_height: 2.0,
            },
            48,
            32,
        )
        .unwrap(),
        // Pinhole among the points: spheres beside the eye and across its plane, a wide and
        // an off-centre, non-square one.
        Camera::new(
            DVec3::new(0.1, 0.05, 0.2),
            DVec3::new(1.0, 0.3, 0.2),
            DVec3::Z,
            120.0,
            48,
            32,
        )
        .unwrap(),
        Camera::look_at(
            DVec3::new(-0.2, 0.1, -0.3),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::X,
            Model::Pinhole {
                fx: 20.0,
                fy: 30.0,
                cx: 20.0,
                cy: 14.0,
            },
            48,
            32,
        )
        .unwrap(),
        // Inside the box: points all around, behind the eye too.
        Camera::look_at(
            DVec3::new(0.1, 0.0, 0.2),
            DVec3::new(1.0, 0.0, 0.2),
            DVec3::Z,
            Model::Spherical,
            64,
            32,
        )
        .unwrap(),
    ];
    for (k, camera) in cameras.iter().enumerate() {
        for (seed, r) in [(1, 0.05), (2, 0.12), (3, 0.3)] {
            let (points, visible) = cloud(seed);
            let got = projected(&points, &visible, camera, r).unwrap();
            assert_eq!((got.width, got.height), (camera.width, camera.height));
            let want = brute(&points, &visible, camera, r);
            assert!(
                want.iter().filter(|&&p| p != NONE).count() > 20,
                "camera {k}, seed {seed}: the scene must cover pixels"
            );
            assert_eq!(got.point, want, "camera {k}, seed {seed}, r {r}");
        }
    }
}

#[test]
fn images_drawn_in_shares_merge_to_the_one_drawn_whole_coincident_points_included() {
    let camera = Camera::new(
        DVec3::new(0.3, -0.4, 3.0),
        DVec3::ZERO,
        DVec3::Y,
        50.0,
        48,
        32,
    )
    .unwrap();
    let (mut points, mut visible) = cloud(4);
    // Copies of visible points at the end: equal entries, the lower index shows.
    for k in 0..60 {
        let i = visible[k] as usize;
        points.push(points[i]);
        visible.push((points.len() - 1) as u32);
    }
    visible.reverse();
    let want = brute(&points, &visible, &camera, 0.12);
    for share in [1, 7, 64, 1000] {
        let got = drawn_in_shares(&points, &visible, &camera, 0.12, share).unwrap();
        assert_eq!(got.point, want, "share {share}");
    }
}

#[test]
fn a_full_set_shows_hidden_points_and_the_true_set_does_not() {
    let (scene, geometry) = sphere_plane_scene(3_000, 6_000, 7);
    let points = &scene.cloud.positions;
    let eye = DVec3::new(0.4, -3.0, 3.5);
    let camera = Camera::new(eye, DVec3::new(0.0, 0.0, 0.5), DVec3::Z, 45.0, 160, 120).unwrap();
    let truth: Vec<bool> = points.iter().map(|&p| geometry.visible(p, eye)).collect();
    let all: Vec<u32> = (0..points.len() as u32).collect();
    let true_set = crate::visibility::indices_of(&truth);
    assert!(
        true_set.len() < points.len() * 3 / 4,
        "the ball hides points"
    );
    let r = footprint_radius(points).unwrap();
    // No mesh needed for precision: every pixel counts as the mesh's.
    let mesh = vec![true; 160 * 120];
    let full =
        PixelScore::of(&projected(points, &all, &camera, r).unwrap(), &truth, &mesh).unwrap();
    let exact = PixelScore::of(
        &projected(points, &true_set, &camera, r).unwrap(),
        &truth,
        &mesh,
    )
    .unwrap();
    assert_eq!(exact.precision(), 1.0, "{exact:?}");
    assert!(exact.covered > 1_000, "{exact:?}");
    assert!(full.precision() < 1.0, "{full:?}");
    assert!(full.f1() < exact.f1(), "{full:?} against {exact:?}");
}

#[test]
fn the_score_counts_pixels_and_refuses_mismatched_inputs() {
    // 2 x 2: point 0 (visible) on a mesh pixel, point 1 (hidden) off the mesh, one mesh pixel
    // empty, one pixel neither.
    let choice = PixelChoice {
        width: 2,
        height: 2,
        point: vec![0, 1, NONE, NONE],
    };
    let s = PixelScore::of(&choice, &[true, false], &[true, false, true, false]).unwrap();
    assert_eq!(
        s,
        PixelScore {
            covered: 2,
            true_pixels: 1,
            mesh_pixels: 2,
            mesh_covered: 1,
        }
    );
    assert_eq!((s.precision(), s.coverage()), (0.5, 0.5));
    assert_eq!(s.f1(), 0.5);
    assert_eq!(f1(1.0, 0.25), 0.4);
    assert_eq!(f1(0.0, 0.0), 0.0);
    assert!(PixelScore::of(&choice, &[true], &[true; 4]).is_err());
    assert!(PixelScore::of(&choice, &[true, true], &[true; 3]).is_err());
    assert!(
        projected(
            &[DVec3::ZERO],
            &[1],
            &Camera::new(DVec3::Z, DVec3::ZERO, DVec3::Y, 50.0, 4, 4).unwrap(),
            0.1
        )
        .is_err()
    );
    assert!(
        projected(
            &[DVec3::ZERO],
            &[0],
            &Camera::new(DVec3::Z, DVec3::ZERO, DVec3::Y, 50.0, 4, 4).unwrap(),
            0.0
        )
        .is_err()
    );
}

/// The pixels [`footprint`] has tested for a sphere.
fn footprint_pixels(camera: &Camera, c: DVec3, r: f64) -> usize {
    match footprint(camera, c, r) {
        None => 0,
        Some(Footprint::Rect(x0, x1, y0, y1)) => ((x1 - x0 + 1) * (y1 - y0 + 1)) as usize,
        Some(Footprint::Cone { u, cos2 }) => (0..i64::from(camera.height))
            .filter_map(|y| row_span(camera, u, cos2, y))
            .map(|(x0, x1)| (x1 - x0 + 1) as usize)
            .sum(),
    }
}

#[test]
fn a_sphere_beside_the_eye_costs_its_own_pixels_not_the_whole_image() {
    // An eye among the points: spheres on the eye's plane (depth 0) beside it. Out of the
    // 90-degree view they cost nothing; across the plane inside the view, only the pixels
    // their cone reaches. Before, each cost the whole image (921,600 ray tests at 1280 x 720).
    let eye = DVec3::ZERO;
    let camera = Camera::new(eye, DVec3::new(0.0, 0.0, 1.0), DVec3::Y, 90.0, 1280, 720).unwrap();
    let r = 0.02;
    let whole = 1280 * 720;
    // Beside the eye, 10 radii off, on its plane: the cone points sideways, out of view.
    assert_eq!(footprint_pixels(&camera, DVec3::new(0.2, 0.0, 0.0), r), 0);
    assert_eq!(footprint_pixels(&camera, DVec3::new(0.0, -0.2, 0.01), r), 0);
    // Just behind the plane, by less than r: still out of view.
    assert_eq!(
        footprint_pixels(&camera, DVec3::new(0.2, 0.1, -0.015), r),
        0
    );
    // Across the plane near the frustum's edge: a sliver of the image, and the derived
    // choice is the rule's (every pixel a brute force of its ray against the sphere).
    let c = DVec3::new(0.03, 0.0, 0.01);
    let n = footprint_pixels(&camera, c, r);
    assert!(n > 0 && n < whole / 2, "{n}");
    let small = Camera::new(eye, DVec3::new(0.0, 0.0, 1.0), DVec3::Y, 90.0, 64, 36).unwrap();
    for c in [
        c,
        DVec3::new(-0.025, 0.01, 0.0),
        DVec3::new(0.0, 0.021, -0.005),
    ] {
        let got = projected(&[c], &[0], &small, r).unwrap();
        assert_eq!(got.point, brute(&[c], &[0], &small, r), "{c}");
    }
    // The eye inside a sphere: every ray starts in it, the whole image.
    assert_eq!(
        footprint_pixels(&camera, DVec3::new(0.01, 0.0, 0.0), r),
        whole
    );
}
