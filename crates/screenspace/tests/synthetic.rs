//! Both operators on `cloud::synth`'s ball in front of a square, whose visibility is known
//! analytically (`SpherePlane::visible`), for every camera model: F1 against the analytic
//! truth must beat a stated bound. Also: degenerate clouds and views are errors, a lone point
//! is visible, and the verdict does not change when the scene and camera are scaled together.

use cloud::glam::DVec3;
use cloud::synth::{SpherePlane, sphere_plane_scene};
use cloud::{Camera, Model};
use proptest::prelude::*;
use screenspace::{Error, PintusParams, VardensityParams, Verdict, pintus, vardensity};

fn camera(model: &str, eye: DVec3, w: u32, h: u32) -> Camera {
    let m = match model {
        "pinhole" => Model::pinhole_fov(50.0, w, h).expect("fov"),
        "orthographic" => Model::Orthographic {
            view_width: 5.0,
            view_height: 5.0 * f64::from(h) / f64::from(w),
        },
        _ => Model::Spherical,
    };
    Camera::look_at(eye, DVec3::new(0.0, 0.0, 0.5), DVec3::Z, m, w, h).expect("camera")
}

/// F1 of `v` against the analytic visibility from `camera`.
fn f1(points: &[DVec3], geometry: &SpherePlane, camera: &Camera, v: &Verdict) -> f64 {
    let mut flag = vec![false; points.len()];
    for &i in &v.visible {
        flag[i as usize] = true;
    }
    let (mut tp, mut fp, mut fn_) = (0usize, 0usize, 0usize);
    for (i, &p) in points.iter().enumerate() {
        // Orthographic: the viewer is far along −forward.
        let eye = match camera.model() {
            Model::Orthographic { .. } => p - camera.forward() * 1e6,
            _ => camera.eye,
        };
        let in_view = camera
            .project(p)
            .and_then(|pr| pr.pixel(camera.width, camera.height))
            .is_some();
        let truth = in_view && geometry.visible(p, eye);
        match (flag[i], truth) {
            (true, true) => tp += 1,
            (true, false) => fp += 1,
            (false, true) => fn_ += 1,
            _ => {}
        }
    }
    2.0 * tp as f64 / (2 * tp + fp + fn_) as f64
}

/// The scene: 6,000 points on the ball, 12,000 on the square.
fn scene() -> (Vec<DVec3>, SpherePlane) {
    let (s, g) = sphere_plane_scene(6_000, 12_000, 3);
    (s.cloud.positions, g)
}

/// (model, eye, width, height, F1 bound of screenspace, F1 bound of vardensity): an oblique
/// view for the frustum models, a scanner beside the ball for the spherical image (the
/// mobile-LiDAR case). Measured when written: pinhole 0.985 / 0.939, orthographic 0.988 /
/// 0.967, spherical 0.977 / 0.826.
fn views() -> Vec<(&'static str, DVec3, u32, u32, f64, f64)> {
    vec![
        ("pinhole", DVec3::new(1.5, -2.5, 4.0), 200, 150, 0.95, 0.90),
        (
            "orthographic",
            DVec3::new(1.5, -2.5, 4.0),
            200,
            150,
            0.95,
            0.90,
        ),
        (
            "spherical",
            DVec3::new(1.2, -1.4, 1.6),
            720,
            360,
            0.95,
            0.80,
        ),
    ]
}

#[test]
fn both_operators_beat_their_f1_bounds_on_the_ball_before_the_square() {
    let (points, g) = scene();
    for (model, eye, w, h, bound_p, bound_b) in views() {
        let cam = camera(model, eye, w, h);
        let p = pintus::visible(
            &points,
            &cam,
            &PintusParams {
                depth_tolerance: 0.02,
                ..PintusParams::default()
            },
        )
        .expect("pintus");
        let b = vardensity::visible(
            &points,
            &cam,
            &VardensityParams {
                depth_tolerance: 0.02,
                ..VardensityParams::default()
            },
        )
        .expect("vardensity");
        let (fp, fb) = (f1(&points, &g, &cam, &p), f1(&points, &g, &cam, &b));
        eprintln!("{model}: F1 pintus {fp:.3}, vardensity {fb:.3}");
        assert!(fp > bound_p, "{model}: pintus F1 {fp} <= {bound_p}");
        assert!(fb > bound_b, "{model}: vardensity F1 {fb} <= {bound_b}");
    }
}

#[test]
fn degenerate_clouds_and_views_are_errors() {
    let cam = camera("pinhole", DVec3::new(0.0, -3.0, 3.0), 64, 48);
    let behind: Vec<DVec3> = (0..10)
        .map(|i| DVec3::new(0.0, -6.0 - f64::from(i), 6.0))
        .collect();
    for pts in [Vec::new(), behind] {
        let e = pintus::visible(&pts, &cam, &PintusParams::default()).expect_err("pintus");
        assert!(matches!(e, Error::NothingInView { .. }), "{e}");
        let e = vardensity::visible(&pts, &cam, &VardensityParams::default()).expect_err("b");
        assert!(matches!(e, Error::NothingInView { .. }), "{e}");
    }
    let nan = vec![DVec3::new(0.0, f64::NAN, 0.0)];
    assert!(matches!(
        pintus::visible(&nan, &cam, &PintusParams::default()),
        Err(Error::Cloud(_))
    ));
    let huge = cam.with_resolution(100_000, 100_000).expect("camera");
    let e =
        vardensity::visible(&[DVec3::ZERO], &huge, &VardensityParams::default()).expect_err("huge");
    assert!(matches!(e, Error::ImageTooLarge { .. }), "{e}");
}

const MODELS: [&str; 3] = ["pinhole", "orthographic", "spherical"];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A point alone in front of the camera is visible to both operators, in every model.
    #[test]
    fn a_lone_point_is_visible(
        m in 0usize..3,
        x in -0.8f64..0.8, y in -0.8f64..0.8, z in -0.5f64..1.5,
    ) {
        let cam = camera(MODELS[m], DVec3::new(0.5, -3.0, 3.0), 48, 32);
        let p = [DVec3::new(x, y, z)];
        let in_view = cam.project(p[0]).and_then(|pr| pr.pixel(48, 32)).is_some();
        prop_assume!(in_view);
        let a = pintus::visible(&p, &cam, &PintusParams::default()).expect("pintus");
        prop_assert_eq!(a.visible, vec![0]);
        let b = vardensity::visible(&p, &cam, &VardensityParams::default()).expect("vardensity");
        prop_assert_eq!(b.visible, vec![0]);
    }

    /// Scaling the scene and the camera by a power of two (exact in floating point) changes
    /// no verdict: both rules are scale-free.
    #[test]
    fn the_verdict_is_invariant_under_a_uniform_scale(m in 0usize..3, e in -6i32..6) {
        let (s, _) = sphere_plane_scene(600, 1_200, 5);
        let pts = s.cloud.positions;
        let cam = camera(MODELS[m], DVec3::new(1.5, -2.5, 4.0), 64, 48);
        let f = 2f64.powi(e);
        let scaled: Vec<DVec3> = pts.iter().map(|p| *p * f).collect();
        let cam2 = cam.scaled(f);
        let p = PintusParams::default();
        prop_assert_eq!(
            pintus::visible(&pts, &cam, &p).expect("a").visible,
            pintus::visible(&scaled, &cam2, &p).expect("b").visible
        );
        let b = VardensityParams::default();
        prop_assert_eq!(
            vardensity::visible(&pts, &cam, &b).expect("a").visible,
            vardensity::visible(&scaled, &cam2, &b).expect("b").visible
        );
    }
}
