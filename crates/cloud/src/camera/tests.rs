//! Camera tests: each model against a brute-force projection computed another way (world to
//! camera coordinates by the inverse rotation, then the model's formula written out), rays
//! against projections, the pose constructors against each other.

use std::f64::consts::PI;

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;

use super::*;

fn cam() -> Camera {
    Camera::new(
        DVec3::new(0.0, 0.0, 5.0),
        DVec3::ZERO,
        DVec3::Y,
        90.0,
        200,
        100,
    )
    .unwrap()
}

/// World to camera coordinates (right, down, forward) by the inverse of the rotation.
fn to_camera(c: &Camera, p: DVec3) -> DVec3 {
    c.rotation().inverse() * (p - c.eye)
}

/// The brute-force projection: each model's formula in camera coordinates.
fn brute(c: &Camera, p: DVec3) -> Option<(f64, f64, f64)> {
    let q = to_camera(c, p);
    let (w, h) = (c.width as f64, c.height as f64);
    match *c.model() {
        Model::Pinhole { fx, fy, cx, cy } => {
            (q.z > 0.0).then(|| (cx + fx * q.x / q.z, cy + fy * q.y / q.z, q.z))
        }
        Model::Orthographic {
            view_width,
            view_height,
        } => (q.z > 0.0).then(|| {
            (
                w / 2.0 + q.x / view_width * w,
                h / 2.0 + q.y / view_height * h,
                q.z,
            )
        }),
        Model::Spherical => {
            let r = q.length();
            // Longitude from the optical axis towards the right, latitude from up (−y).
            let lon = q.x.atan2(q.z);
            let colat = (-q.y / r).acos();
            let mut x = (lon + PI) / (2.0 * PI) * w;
            if x >= w {
                x -= w;
            }
            Some((x, colat / PI * h, r))
        }
    }
}

fn models() -> Vec<Model> {
    vec![
        Model::Pinhole {
            fx: 500.0,
            fy: 480.0,
            cx: 321.5,
            cy: 239.0,
        },
        Model::Orthographic {
            view_width: 4.0,
            view_height: 3.0,
        },
        Model::Spherical,
    ]
}

#[test]
fn target_projects_to_the_image_centre() {
    let p = cam().project(DVec3::ZERO).unwrap();
    assert_eq!((p.x, p.y, p.depth), (100.0, 50.0, 5.0));
    for model in models() {
        let c = Camera::look_at(
            DVec3::new(1.0, 2.0, 7.0),
            DVec3::new(1.0, 2.0, 0.0),
            DVec3::Y,
            model,
            640,
            480,
        )
        .unwrap();
        let p = c.project(DVec3::new(1.0, 2.0, 0.0)).unwrap();
        let (ex, ey) = match model {
            Model::Pinhole { cx, cy, .. } => (cx, cy),
            _ => (320.0, 240.0),
        };
        assert!(
            (p.x - ex).abs() < 1e-9 && (p.y - ey).abs() < 1e-9,
            "{model:?} {p:?}"
        );
        assert!((p.depth - 7.0).abs() < 1e-12);
    }
}

#[test]
fn fov_edges_and_axes() {
    let c = cam();
    // With fov_y = 90 degrees the top edge is at 45 degrees: y = depth.
    let top = c.project(DVec3::new(0.0, 5.0, 0.0)).unwrap();
    assert!((top.y - 0.0).abs() < 1e-9, "{top:?}");
    let right = c.project(DVec3::new(1.0, 0.0, 0.0)).unwrap();
    assert!(right.x > 100.0);
    assert!(c.project(DVec3::new(0.0, 0.0, 6.0)).is_none());
    assert!((c.fov_y_deg().unwrap() - 90.0).abs() < 1e-12);
}

#[test]
fn spherical_image_layout() {
    // Looking along +x with +z up: forward is the centre, up the top row, behind the seam.
    let c = Camera::look_at(DVec3::ZERO, DVec3::X, DVec3::Z, Model::Spherical, 360, 180).unwrap();
    let at = |p: DVec3| {
        let q = c.project(p).unwrap();
        (q.x, q.y)
    };
    let close = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9;
    assert!(close(at(DVec3::X), (180.0, 90.0)));
    // Right of forward is −y when up is +z and forward +x.
    assert!(close(at(-DVec3::Y), (270.0, 90.0)));
    assert!(close(at(DVec3::Y), (90.0, 90.0)));
    assert!(close(at(-DVec3::X), (0.0, 90.0)));
    assert!(at(DVec3::Z).1.abs() < 1e-9);
    assert!((at(-DVec3::Z).1 - 180.0).abs() < 1e-9);
    assert!(c.project(DVec3::ZERO).is_none());
    assert!(!c.has_frustum());
    // A full turn of points lands in every column band.
    let mut seen = [false; 8];
    for k in 0..64 {
        let a = k as f64 / 64.0 * 2.0 * PI;
        let q = c.project(DVec3::new(a.cos(), a.sin(), 0.1)).unwrap();
        let (x, _) = q.pixel(360, 180).unwrap();
        seen[(x / 45) as usize] = true;
    }
    assert!(seen.iter().all(|&s| s));
}

#[test]
fn orthographic_rays_are_parallel_and_start_on_the_near_plane() {
    let c = Camera::look_at(
        DVec3::new(0.0, 0.0, 10.0),
        DVec3::ZERO,
        DVec3::Y,
        Model::Orthographic {
            view_width: 4.0,
            view_height: 2.0,
        },
        400,
        200,
    )
    .unwrap();
    let (o1, d1) = c.ray(0.5, 0.5);
    let (o2, d2) = c.ray(399.5, 199.5);
    assert_eq!(d1, d2);
    assert!(
        (o1 - DVec3::new(-1.995, 0.995, 10.0)).length() < 1e-12,
        "{o1}"
    );
    assert!(
        (o2 - DVec3::new(1.995, -0.995, 10.0)).length() < 1e-12,
        "{o2}"
    );
    // Depth does not change the pixel.
    let a = c.project(DVec3::new(0.5, 0.25, 3.0)).unwrap();
    let b = c.project(DVec3::new(0.5, 0.25, -30.0)).unwrap();
    assert_eq!((a.x, a.y), (b.x, b.y));
    assert!((a.x - 250.0).abs() < 1e-9 && (a.y - 75.0).abs() < 1e-9);
    assert_eq!(
        c.ray_origin_for(DVec3::new(0.5, 0.25, 3.0)),
        DVec3::new(0.5, 0.25, 10.0)
    );
    assert!((c.pixel_size_at(1.0) - 0.01).abs() < 1e-15);
    assert_eq!(c.pixel_size_at(1.0), c.pixel_size_at(100.0));
}

#[test]
fn pose_constructors_agree_with_look_at() {
    let look = Camera::look_at(
        DVec3::new(3.0, -2.0, 4.0),
        DVec3::new(0.5, 0.1, -0.2),
        DVec3::Z,
        Model::Pinhole {
            fx: 700.0,
            fy: 700.0,
            cx: 320.0,
            cy: 240.0,
        },
        640,
        480,
    )
    .unwrap();
    let pose =
        Camera::from_camera_to_world(look.camera_to_world(), *look.model(), 640, 480).unwrap();
    // World-to-camera as COLMAP writes it: R = rotationᵀ, t = −R·eye.
    let r = look.rotation().transpose();
    let q = DQuat::from_mat3(&r);
    let t = -(r * look.eye);
    let colmap =
        Camera::from_world_to_camera([q.w, q.x, q.y, q.z], t.to_array(), *look.model(), 640, 480)
            .unwrap();
    for c in [&pose, &colmap] {
        assert!(
            (c.eye - look.eye).length() < 1e-12,
            "{} vs {}",
            c.eye,
            look.eye
        );
        for p in [
            DVec3::ZERO,
            DVec3::new(1.0, 0.3, 0.2),
            DVec3::new(-0.4, 0.9, -1.0),
        ] {
            let (a, b) = (look.project(p).unwrap(), c.project(p).unwrap());
            assert!(
                (a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9,
                "{a:?} {b:?}"
            );
        }
    }
}

#[test]
fn with_resolution_keeps_the_field_of_view() {
    let c = cam();
    let big = c.with_resolution(400, 200).unwrap();
    assert!((big.fov_y_deg().unwrap() - 90.0).abs() < 1e-12);
    let (p, q) = (
        c.project(DVec3::new(0.3, 0.2, 1.0)).unwrap(),
        big.project(DVec3::new(0.3, 0.2, 1.0)).unwrap(),
    );
    assert!((2.0 * p.x - q.x).abs() < 1e-9 && (2.0 * p.y - q.y).abs() < 1e-9);
}

proptest! {
    #[test]
    fn projection_and_ray_are_inverse(
        ex in -10.0f64..10.0, ey in -10.0f64..10.0, ez in 3.0f64..10.0,
        px in -1.0f64..1.0, py in -1.0f64..1.0, pz in -1.0f64..1.0,
        fov in 10.0f64..120.0,
    ) {
        let c = Camera::new(DVec3::new(ex, ey, ez), DVec3::ZERO, DVec3::Y, fov, 640, 480).unwrap();
        let p = DVec3::new(px, py, pz);
        let q = c.project(p).unwrap();
        let (o, d) = c.ray(q.x, q.y);
        let back = o + d * q.depth;
        prop_assert!((back - p).length() < 1e-9 * (1.0 + p.length() + c.eye.length()));
        prop_assert!((q.depth - c.depth(p)).abs() < 1e-12 * q.depth.max(1.0));
    }

    #[test]
    fn every_model_matches_the_brute_force_projection(
        model_k in 0usize..3,
        ex in -10.0f64..10.0, ey in -10.0f64..10.0, ez in -10.0f64..10.0,
        tx in -1.0f64..1.0, ty in -1.0f64..1.0, tz in -1.0f64..1.0,
        px in -3.0f64..3.0, py in -3.0f64..3.0, pz in -3.0f64..3.0,
    ) {
        let eye = DVec3::new(ex, ey, ez);
        let target = DVec3::new(tx, ty, tz);
        prop_assume!((eye - target).length() > 0.5);
        let up = if (target - eye).normalize().z.abs() > 0.99 { DVec3::Y } else { DVec3::Z };
        let c = Camera::look_at(eye, target, up, models()[model_k], 640, 480).unwrap();
        let p = DVec3::new(px, py, pz);
        let ours = c.project(p).map(|q| (q.x, q.y, q.depth));
        let theirs = brute(&c, p);
        match (ours, theirs) {
            (Some(a), Some(b)) => {
                // Near the spherical seam x wraps: compare on the circle.
                let dx = (a.0 - b.0).abs();
                let dx = if model_k == 2 { dx.min(640.0 - dx) } else { dx };
                prop_assert!(dx < 1e-6 && (a.1 - b.1).abs() < 1e-6 && (a.2 - b.2).abs() < 1e-9,
                    "{ours:?} vs {theirs:?}");
                // And the ray through the pixel reaches p at its depth.
                let (o, d) = c.ray(a.0, a.1);
                prop_assert!((o + d * a.2 - p).length() < 1e-6, "ray misses p");
            }
            (None, None) => {}
            _ => prop_assert!(false, "{ours:?} vs {theirs:?}"),
        }
    }

    #[test]
    fn pixel_centres_round_trip(model_k in 0usize..3, x in 0u32..64, y in 0u32..48, d in 0.5f64..20.0) {
        let c = Camera::look_at(DVec3::new(0.0, -6.0, 1.0), DVec3::ZERO, DVec3::Z, models()[model_k], 64, 48).unwrap();
        let (o, dir) = c.ray(x as f64 + 0.5, y as f64 + 0.5);
        let q = c.project(o + dir * d).unwrap();
        prop_assert_eq!(q.pixel(64, 48), Some((x, y)));
        prop_assert!((q.depth - d).abs() < 1e-9 * d);
    }
}

#[test]
fn degenerate_cameras_are_errors() {
    let e = DVec3::new(0.0, 0.0, 5.0);
    for (eye, target, up, fov, w, h) in [
        (e, e, DVec3::Y, 60.0, 10, 10),
        (e, DVec3::ZERO, DVec3::Z, 60.0, 10, 10),
        (e, DVec3::ZERO, DVec3::Y, 0.0, 10, 10),
        (e, DVec3::ZERO, DVec3::Y, -30.0, 10, 10),
        (e, DVec3::ZERO, DVec3::Y, 180.0, 10, 10),
        (e, DVec3::ZERO, DVec3::Y, 60.0, 0, 10),
        (DVec3::NAN, DVec3::ZERO, DVec3::Y, 60.0, 10, 10),
    ] {
        let r = Camera::new(eye, target, up, fov, w, h);
        assert!(matches!(r, Err(Error::DegenerateCamera(_))), "{r:?}");
    }
    let bad_models = [
        Model::Pinhole {
            fx: 0.0,
            fy: 1.0,
            cx: 0.0,
            cy: 0.0,
        },
        Model::Pinhole {
            fx: 1.0,
            fy: 1.0,
            cx: f64::NAN,
            cy: 0.0,
        },
        Model::Orthographic {
            view_width: -1.0,
            view_height: 1.0,
        },
    ];
    for m in bad_models {
        let r = Camera::look_at(e, DVec3::ZERO, DVec3::Y, m, 10, 10);
        assert!(matches!(r, Err(Error::DegenerateCamera(_))), "{r:?}");
    }
    // Not a rotation: a scaled one, a reflection, NaN.
    for m in [
        DMat3::from_diagonal(DVec3::new(1.0, 1.0, 2.0)),
        DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0)),
        DMat3::from_diagonal(DVec3::new(1.0, f64::NAN, 1.0)),
    ] {
        let r = Camera::from_pose(m, DVec3::ZERO, Model::Spherical, 10, 10);
        let err = r.unwrap_err().to_string();
        assert!(err.contains("rotation"), "{err}");
    }
    let r = Camera::from_world_to_camera([2.0, 0.0, 0.0, 0.0], [0.0; 3], Model::Spherical, 10, 10);
    assert!(r.unwrap_err().to_string().contains("unit quaternion"));
}

#[test]
fn unsupported_models_are_named() {
    let c = Camera::look_at(DVec3::X, DVec3::ZERO, DVec3::Z, Model::Spherical, 8, 4).unwrap();
    let err = c.require("qsplat", &["pinhole"]).unwrap_err().to_string();
    assert!(
        err.contains("qsplat") && err.contains("spherical") && err.contains("pinhole"),
        "{err}"
    );
    assert!(c.require("hpr", &["pinhole", "spherical"]).is_ok());
}

#[test]
fn pinhole_ray_tables_give_every_pixel_centres_ray_bit_for_bit() {
    for model in models() {
        let camera = Camera::look_at(
            DVec3::new(0.3, -2.0, 1.1),
            DVec3::new(0.1, 0.2, -0.3),
            DVec3::Z,
            model,
            37,
            23,
        )
        .unwrap();
        let Some((columns, rows)) = camera.pinhole_ray_tables() else {
            assert!(!matches!(model, Model::Pinhole { .. }), "{model:?}");
            continue;
        };
        assert_eq!((columns.len(), rows.len()), (37, 23));
        for y in 0..23_u32 {
            for x in 0..37_u32 {
                let (origin, dir) = camera.ray(f64::from(x) + 0.5, f64::from(y) + 0.5);
                let table = columns[x as usize] + rows[y as usize];
                assert_eq!(origin, camera.eye);
                assert_eq!(
                    table.to_array().map(f64::to_bits),
                    dir.to_array().map(f64::to_bits),
                    "{model:?} pixel ({x}, {y})"
                );
            }
        }
    }
}
