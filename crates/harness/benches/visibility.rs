//! Criterion benchmarks of the visibility methods other than HPR: the k-d build and a
//! full-frame ray cast (issue: ray cast), and the splat baseline, on dragon-871414 when fetched
//! (else a synthetic stand-in of the same size).
//!
//! Targets: at 1920 × 1080 on dragon-871414, 20 million rays per second on 2 cores in f64
//! with the same hits ray for ray (`raycast-frame`, throughput in elements = rays; the exact
//! traversal casts 2 × 2 pixel packets, the seed traversal one ray at a time); the splat
//! baseline under 10 ms a view.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

use cloud::Camera;
use cloud::glam::DVec3;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use raycast::{CastParams, RayCaster, RayList, Traversal};

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

fn dragon() -> (String, Vec<DVec3>, Camera) {
    match harness::datasets::Datasets::default().load("dragon-871414", &data_dir()) {
        Ok(ds) => (
            "dragon-871414".into(),
            ds.cloud.positions.clone(),
            ds.views[0],
        ),
        Err(e) => {
            eprintln!("dragon-871414 unavailable ({e:#}); using a synthetic sphere-plane scene");
            let ds = harness::datasets::Datasets::default()
                .load("sphere-plane-24000", &data_dir())
                .expect("synthetic");
            let pts = cloud::synth::sphere_plane_scene(300_000, 571_414, 1)
                .0
                .cloud
                .positions;
            ("sphere-plane-871414".into(), pts, ds.views[0])
        }
    }
}

fn benches(c: &mut Criterion) {
    let (name, points, view) = dragon();
    let mut g = c.benchmark_group("kd-build");
    g.sample_size(10);
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function(&name, |b| {
        b.iter(|| RayCaster::new(black_box(&points)).expect("build"))
    });
    g.finish();

    let caster = RayCaster::new(&points).expect("build");
    let radius = raycast::auto::auto_radius(&points).expect("radius");
    let cam = view.with_resolution(1920, 1080).expect("camera");
    let rays = RayList::new(&cam).expect("a ray list");
    let mut g = c.benchmark_group("raycast-frame");
    g.sample_size(10).measurement_time(Duration::from_secs(15));
    g.throughput(Throughput::Elements(rays.len() as u64));
    for traversal in [Traversal::Exact, Traversal::Seed] {
        let params = CastParams {
            radius,
            traversal,
            primitive: raycast::Primitive::Sphere,
        };
        g.bench_function(format!("{name} 1920x1080 {traversal:?}"), |b| {
            b.iter(|| caster.cast(&rays, &cam, black_box(&params)).expect("cast"))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("splat");
    g.sample_size(50);
    let params = splat::SplatParams::default();
    let splatter = splat::Splatter::new(&points).expect("prepare");
    let mut scratch = splat::SplatScratch::default();
    g.bench_function(format!("{name} 1280x720 visible set"), |b| {
        b.iter(|| {
            splatter
                .visibility(&view, black_box(&params), &mut scratch, false)
                .expect("splat")
        })
    });
    g.bench_function(format!("{name} 1280x720 with per-pixel output"), |b| {
        b.iter(|| {
            splatter
                .visibility(&view, black_box(&params), &mut scratch, true)
                .expect("splat")
        })
    });
    g.bench_function(format!("{name} prepare"), |b| {
        b.iter(|| splat::Splatter::new(black_box(&points)).expect("prepare"))
    });
    g.finish();
}

criterion_group!(visibility_benches, benches);
criterion_main!(visibility_benches);
