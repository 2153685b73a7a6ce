//! Criterion benchmarks of HPR (issue: hull/HPR): the flip, each hull implementation, and HPR
//! end to end, on the real datasets when `pointsight fetch` has run (POINTSIGHT_DATA or
//! bench-data/), else on a synthetic stand-in of the same size.
//!
//! The ratio that matters is measured in one run: `own` against `qhull` (Qt) on the
//! dragon-871414 flipped set at γ = 4 (group `hull-dragon-gamma4`).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

use cloud::glam::DVec3;
use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use hpr::{HprParams, Kernel, Radius};

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

/// The dataset's points and view-0 eye, or a synthetic sphere of `n` points seen from outside.
fn cloud(name: &str, n: usize) -> (String, Vec<DVec3>, DVec3) {
    match harness::datasets::Datasets::default().load(name, &data_dir()) {
        Ok(ds) => (name.to_owned(), ds.cloud.positions.clone(), ds.views[0].eye),
        Err(e) => {
            eprintln!("{name} unavailable ({e:#}); using a synthetic sphere of {n} points");
            let pts = cloud::synth::fibonacci_sphere(n);
            (format!("sphere-{n}"), pts, DVec3::new(0.3, 0.2, 3.0))
        }
    }
}

fn flipped(points: &[DVec3], eye: DVec3, gamma: f64) -> Vec<[f64; 3]> {
    hpr::transform::transform(points, eye, Kernel::Linear(Radius::Gamma(gamma)))
        .expect("flip")
        .points
}

fn benches(c: &mut Criterion) {
    let (name, dragon, eye) = cloud("dragon-871414", 871_414);
    let mut g = c.benchmark_group("flip");
    g.sample_size(20);
    g.bench_function(format!("{name} gamma4"), |b| {
        b.iter(|| flipped(black_box(&dragon), eye, 4.0))
    });
    g.finish();

    // The 10x target: own vs Qhull (Qt) on the same flipped set, in one run.
    let set = flipped(&dragon, eye, 4.0);
    let mut g = c.benchmark_group("hull-dragon-gamma4");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(40))
        .warm_up_time(Duration::from_secs(5));
    for h in ["own", "qhull"] {
        let imp = hull::by_name(h).expect("hull");
        g.bench_function(format!("{name} {h}"), |b| {
            b.iter(|| imp.vertices(black_box(&set)).expect("hull"))
        });
    }
    g.finish();

    // Every implementation on a bunny-sized set.
    let (bname, bunny, beye) = cloud("bunny-69451", 69_451);
    let bset = flipped(&bunny, beye, 3.0);
    let mut g = c.benchmark_group("hull-bunny-gamma3");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for h in hull::NAMES.iter().chain(&["qhull-qj"]) {
        let imp = hull::by_name(h).expect("hull");
        g.bench_function(format!("{bname} {h}"), |b| {
            b.iter(|| imp.vertices(black_box(&bset)).expect("hull"))
        });
    }
    g.finish();

    // End to end: flip + exact hull + mapping.
    let mut g = c.benchmark_group("hpr-end-to-end");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    let own = hull::by_name("own").expect("own");
    for gamma in [2.0, 3.0, 4.0] {
        let params = HprParams {
            kernel: Kernel::Linear(Radius::Gamma(gamma)),
            ..HprParams::default()
        };
        g.bench_function(format!("{name} gamma{gamma}"), |b| {
            b.iter_batched(
                || (),
                |_| hpr::visible(black_box(&dragon), eye, &params, own.as_ref()).expect("hpr"),
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

criterion_group!(hpr_benches, benches);
criterion_main!(hpr_benches);
