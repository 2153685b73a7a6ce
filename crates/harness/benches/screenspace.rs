//! Criterion benchmark of the screen-space operators (issue 24: `screenspace`, Pintus et al.
//! 2011; `vardensity`, Biasutti et al. 2019) against the splat baseline (`splat`), all through
//! the registry at their sweep defaults, on a synthetic ball-before-a-square cloud of 200,000
//! points seen by a 1280 × 720 pinhole camera. Run it twice in a row (A B A B) and compare
//! the ratios, not the absolute times.

use std::hint::black_box;

use cloud::Camera;
use cloud::glam::DVec3;
use criterion::{Criterion, criterion_group, criterion_main};
use registry::Input;

fn benches(c: &mut Criterion) {
    let scene = cloud::synth::sphere_plane_scene(70_000, 130_000, 9).0;
    let camera = Camera::new(
        DVec3::new(1.5, -2.5, 4.0),
        DVec3::new(0.0, 0.0, 0.5),
        DVec3::Z,
        50.0,
        1280,
        720,
    )
    .expect("camera");
    let input = Input {
        cloud: &scene.cloud,
        mesh: None,
    };
    let sweeps = registry::Sweeps::builtin();
    let mut g = c.benchmark_group("screenspace-vs-splat");
    g.sample_size(20);
    for name in ["splat", "screenspace", "vardensity"] {
        let method = registry::method(name).expect("registered");
        let setting = sweeps.methods[name].default_setting().expect("a default");
        let params = setting.params();
        let prepared = registry::prepare(method, input, &params).expect("prepare");
        g.bench_function(format!("{name} sphere-plane-200000 1280x720"), |b| {
            b.iter(|| prepared.visible(black_box(&camera)).expect("visible"))
        });
    }
    g.finish();
}

criterion_group!(group, benches);
criterion_main!(group);
