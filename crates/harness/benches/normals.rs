//! Criterion benchmark of the normals kernel that dominates the out-of-core LOD builds'
//! preparation (`lod-build`'s `normals` stage, `docs/lod-out-of-core.md`; its share of a build
//! is in the stage seconds of `reports/scale`'s out-of-core cells):
//! [`cloud::normals::estimate_normals`] at k = 16 (the grid's exact k-nearest-neighbour
//! queries, [`cloud::knn_grid`], and the covariance normal of each), on 2·10^6 samples of the
//! synthetic torus (always available, so runs on any machine compare), oriented away from the
//! centroid so that the queries, not the orientation's propagation, are what is timed.
//!
//! Compare a change as a ratio in one session: `cargo bench -p harness --bench normals --
//! --save-baseline before` on the old code, then `-- --baseline before` on the new.

use std::hint::black_box;

use cloud::normals::{Orientation, estimate_normals};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn benches(c: &mut Criterion) {
    let n = 2_000_000;
    let scene = cloud::synth::torus_scene(n, 1).expect("torus");
    let positions = scene.cloud.positions;
    let mut g = c.benchmark_group("normals");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function(format!("torus {n} points, k = 16"), |b| {
        b.iter(|| {
            estimate_normals(black_box(&positions), 16, Orientation::AwayFromCentroid)
                .expect("normals")
        })
    });
    g.finish();
}

criterion_group!(normals, benches);
criterion_main!(normals);
