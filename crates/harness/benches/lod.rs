//! Criterion benchmarks of the level-of-detail methods on dragon-871414 when fetched (else a
//! synthetic stand-in of the same size): the QSplat and SPT builds and their per-view
//! selections, and the SRN selection.
//!
//! Targets (2 cores): QSplat build ≥ 4 M points/s with normals and colours, same file bytes
//! (`qsplat-build`, throughput in points); the SPT cut and the SRN selection at ≥ 50 % of the
//! read bandwidth that `benches/bandwidth.rs` measures (`spt-cut` in entries and in bytes of
//! 16-byte entries scanned; `srn-select` in points, 8 bytes each). Compare builds as ratios in
//! one run: run both binaries in turn, A B A B.

use std::hint::black_box;
use std::path::PathBuf;

use cloud::{Camera, PointCloud};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

fn dragon() -> (String, PointCloud, Vec<Camera>) {
    let ds = harness::datasets::Datasets::default()
        .load("dragon-871414", &data_dir())
        .or_else(|e| {
            eprintln!("dragon-871414 unavailable ({e:#}); using torus samples of the same size");
            let scene = cloud::synth::torus_scene(871_414, 1).expect("torus");
            let bbox = scene.mesh.bbox().expect("bbox");
            let views = cloud::views::fibonacci_views(&bbox, &cloud::views::ViewSpec::default())
                .expect("views");
            anyhow::Ok(harness::datasets::Dataset {
                name: "torus-871414".into(),
                description: "torus samples standing in for the dragon".into(),
                cloud: scene.cloud,
                mesh: Some(scene.mesh),
                views,
                files: Vec::new(),
                origin: cloud::glam::DVec3::ZERO,
                scale: (1.0, 1.0),
                surface_tolerance: None,
                truth_positions: None,
                outliers: None,
                mesh_fit: None,
                allow_off_surface: false,
            })
        });
    let ds = ds.expect("dataset");
    (
        format!("{} ({} points)", ds.name(), ds.cloud.len()),
        ds.cloud,
        ds.views,
    )
}

fn benches(c: &mut Criterion) {
    let (name, cloud, views) = dragon();
    let spacing = cloud::spacing::density_spacing(&cloud.positions, 8, 20_000, 1).expect("spacing");

    let mut g = c.benchmark_group("qsplat-build");
    g.sample_size(10);
    g.throughput(Throughput::Elements(cloud.len() as u64));
    g.bench_function(&name, |b| {
        b.iter(|| qsplat::build_tree(black_box(&cloud), spacing).expect("build"))
    });
    g.finish();

    let tree = qsplat::build_tree(&cloud, spacing).expect("build");
    let mut g = c.benchmark_group("qsplat-traverse");
    g.sample_size(20);
    for px in [1.0, 4.0] {
        let params = qsplat::TraverseParams {
            threshold_px: px,
            ..Default::default()
        };
        g.bench_function(format!("{name} view 0 1280x720 {px} px"), |b| {
            b.iter(|| qsplat::traverse(&tree, &views[0], black_box(&params)))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("spt-build");
    g.sample_size(10);
    g.throughput(Throughput::Elements(cloud.len() as u64));
    g.bench_function(&name, |b| {
        b.iter(|| spt::build(black_box(&cloud), 2.0 * spacing).expect("build"))
    });
    g.finish();

    let tree = spt::build(&cloud, 2.0 * spacing).expect("build");
    let mut g = c.benchmark_group("spt-cut");
    g.sample_size(50);
    let mut out = Vec::new();
    for px in [1.0, 4.0] {
        let eye = views[0].eye;
        let eps = spt::epsilon_for_pixels(&views[0], px);
        let stats = tree.cut_into(eye, eps, &mut out).expect("cut");
        g.throughput(Throughput::Elements(stats.entries as u64));
        g.bench_function(
            format!(
                "{name} view 0 {px} px ({} of {} entries scanned)",
                stats.entries,
                tree.len()
            ),
            |b| b.iter(|| tree.cut_into(eye, black_box(eps), &mut out).expect("cut")),
        );
        // The same cut in bytes of list entries scanned (16 each), to set against the read
        // bandwidth of `benches/bandwidth.rs`.
        let entry = size_of::<spt::list::Entry>() as u64;
        g.throughput(Throughput::Bytes(stats.entries as u64 * entry));
        g.bench_function(format!("{name} view 0 {px} px, bytes of entries"), |b| {
            b.iter(|| tree.cut_into(eye, black_box(eps), &mut out).expect("cut"))
        });
    }
    g.finish();

    // SRN: marble texture through the spherical parameterisation, as the lod experiment does.
    let texture = srn::texture::marble(512, 2006);
    let map = srn::masking_map(&texture, &srn::MaskingParams::default()).expect("masking");
    c.bench_function("srn-masking-map 512x512", |b| {
        b.iter(|| srn::masking_map(black_box(&texture), &srn::MaskingParams::default()))
    });
    let center = cloud::Aabb::from_points(&cloud.positions)
        .expect("bbox")
        .center();
    let uvs = srn::param::spherical_uvs(&cloud.positions, center);
    let srn = srn::Srn::new(&uvs, &map, 2006).expect("srn");
    let mut g = c.benchmark_group("srn-select");
    g.sample_size(50);
    g.throughput(Throughput::Elements(cloud.len() as u64));
    let mut kept = Vec::new();
    for scale in [1.0f32, 4.0] {
        let params = srn::SrnParams {
            scale,
            ..Default::default()
        };
        g.bench_function(format!("{name} scale {scale}"), |b| {
            b.iter(|| {
                srn.select_into(black_box(&params), &mut kept)
                    .expect("select")
            })
        });
    }
    g.finish();
}

criterion_group!(lod_benches, benches);
criterion_main!(lod_benches);
