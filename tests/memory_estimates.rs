//! The memory guard's estimates against the measured peaks: for each method that sizes an
//! allocation by the user's resolution (the ray cast, the splat baseline, the mesh rasteriser
//! behind the reference), one view at several resolutions and camera models is run under a
//! counting allocator (`peak_alloc`), and the estimate the guard checks must not be lower than
//! the peak of bytes the call allocated. One test, so the process-wide count is the call's own.

use cloud::camera::{Camera, Model};
use cloud::glam::DVec3;
use peak_alloc::PeakAlloc;

#[global_allocator]
static ALLOCATOR: PeakAlloc = PeakAlloc;

/// Peak bytes allocated by `f` beyond what was live before it.
fn peak_of<T>(f: impl FnOnce() -> T) -> usize {
    let before = ALLOCATOR.current_usage();
    ALLOCATOR.reset_peak_usage();
    let value = f();
    let peak = ALLOCATOR.peak_usage().saturating_sub(before);
    drop(value);
    peak
}

fn cameras() -> Vec<Camera> {
    let eye = DVec3::new(0.3, 0.2, 3.0);
    let mut out = Vec::new();
    for (w, h) in [(64, 48), (640, 480), (1920, 1080)] {
        let f = f64::from(h);
        for model in [
            Model::Pinhole {
                fx: f,
                fy: f,
                cx: f64::from(w) / 2.0,
                cy: f / 2.0,
            },
            Model::Orthographic {
                view_width: 2.5,
                view_height: 2.5 * f / f64::from(w),
            },
            Model::Spherical,
        ] {
            out.push(Camera::look_at(eye, DVec3::ZERO, DVec3::Y, model, w, h).expect("a camera"));
        }
    }
    out
}

fn model_name(c: &Camera) -> &'static str {
    match c.model() {
        Model::Pinhole { .. } => "pinhole",
        Model::Orthographic { .. } => "orthographic",
        Model::Spherical => "spherical",
    }
}

#[test]
fn every_estimate_is_at_least_the_measured_peak() {
    let scene = cloud::synth::sphere_scene(20_000);
    let points = &scene.cloud.positions;
    let caster = raycast::RayCaster::new(points).expect("the k-d tree");
    let splatter = splat::Splatter::new(points).expect("the splatter");
    let mut report = Vec::new();
    for camera in cameras() {
        let name = format!("{} {}x{}", model_name(&camera), camera.width, camera.height);

        let estimate = raycast::memory_estimate(&camera, points.len());
        let peak = peak_of(|| {
            let rays = raycast::RayList::new(&camera).expect("rays");
            let params = raycast::CastParams {
                radius: 0.02,
                traversal: raycast::Traversal::Exact,
                primitive: raycast::Primitive::Sphere,
            };
            caster.cast(&rays, &camera, &params).expect("a frame")
        });
        report.push(format!("raycast {name}: estimate {estimate} peak {peak}"));
        assert!(
            estimate >= peak as u128,
            "raycast {name}: {estimate} < {peak}"
        );

        if !matches!(camera.model(), Model::Spherical) {
            let estimate = splatter.memory_estimate(&camera);
            let peak = peak_of(|| {
                splatter
                    .visibility(
                        &camera,
                        &splat::SplatParams::default(),
                        &mut splat::SplatScratch::default(),
                        true,
                    )
                    .expect("a splat view")
            });
            report.push(format!("splat {name}: estimate {estimate} peak {peak}"));
            assert!(
                estimate >= peak as u128,
                "splat {name}: {estimate} < {peak}"
            );

            let estimate = truth::raster::memory_estimate(&scene.mesh, &camera);
            let peak =
                peak_of(|| truth::raster::rasterize(&scene.mesh, &camera).expect("a depth buffer"));
            report.push(format!("raster {name}: estimate {estimate} peak {peak}"));
            assert!(
                estimate >= peak as u128,
                "raster {name}: {estimate} < {peak}"
            );
        }
    }
    eprintln!("{}", report.join("\n"));
}
