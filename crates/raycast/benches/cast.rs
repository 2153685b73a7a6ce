//! Criterion benchmarks of the ray caster alone: the build (`RayCaster::new`) and one view's
//! cast (`RayCaster::cast`, pixel hits and visible set), on the clouds the experiments cast:
//! - `dragon-871414`: the visibility experiment's dataset (ChineseDragon-10kv.off sampled with
//!   seed 871414), its first Fibonacci view at 1920 × 1080, radius `auto::auto_radius`
//!   (1.5 density spacings): spheres, and discs with the samples' normals;
//! - `dragon-1e7`: the scale experiment's cell at 10^7 (the same mesh sampled with seed 16),
//!   its first view at 1280 × 720, the same radius rule.
//!
//! The mesh is read from `$POINTSIGHT_DATA/meshes` (default: the workspace's `bench-data`,
//! filled by `pointsight fetch`). Each cloud is made when a benchmark that needs it is first
//! selected, so `cargo bench -p raycast --bench cast -- dragon-871414` never samples 10^7
//! points. Throughput is in rays (cast) or points (build).

use std::hint::black_box;
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Duration;

use cloud::glam::DVec3;
use cloud::{Camera, TriMesh, ViewSpec};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use raycast::{CastParams, Primitive, RayCaster, RayList, Traversal};

/// A cloud as an experiment casts it.
struct Scene {
    points: Vec<DVec3>,
    normals: Vec<DVec3>,
    camera: Camera,
    radius: f64,
}

fn mesh() -> &'static TriMesh {
    static MESH: OnceLock<TriMesh> = OnceLock::new();
    MESH.get_or_init(|| {
        let dir = std::env::var_os("POINTSIGHT_DATA").map_or_else(
            || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")),
            PathBuf::from,
        );
        let path = dir.join("meshes").join("ChineseDragon-10kv.off");
        match cloud::io::read(&path) {
            Ok(loaded) => loaded.mesh(),
            Err(e) => panic!("{e}: run `pointsight fetch` (or set POINTSIGHT_DATA)"),
        }
    })
}

fn scene(n: usize, seed: u64, (width, height): (u32, u32)) -> Scene {
    let mesh = mesh();
    let sample = cloud::sample::sample_surface(mesh, n, seed).expect("sampling the dragon");
    let bbox = mesh.bbox().expect("the dragon has vertices");
    let view = cloud::views::fibonacci_views(&bbox, &ViewSpec::default()).expect("views")[0];
    let normals = sample
        .normals
        .as_ref()
        .expect("a sampled cloud has normals")
        .iter()
        .map(|v| v.as_dvec3())
        .collect();
    Scene {
        radius: raycast::auto::auto_radius(&sample.positions).expect("radius"),
        camera: view.with_resolution(width, height).expect("camera"),
        points: sample.positions,
        normals,
    }
}

fn dragon() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| scene(871_414, 871_414, (1920, 1080)))
}

fn dragon_1e7() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| scene(10_000_000, 16, (1280, 720)))
}

fn casters(s: &'static Scene) -> &'static (RayCaster, RayList) {
    static DRAGON: OnceLock<(RayCaster, RayList)> = OnceLock::new();
    static BIG: OnceLock<(RayCaster, RayList)> = OnceLock::new();
    let cell = if std::ptr::eq(s, dragon()) {
        &DRAGON
    } else {
        &BIG
    };
    cell.get_or_init(|| {
        let caster = RayCaster::new(&s.points)
            .expect("build")
            .with_normals(&s.normals)
            .expect("normals");
        (caster, RayList::new(&s.camera).expect("rays"))
    })
}

fn bench_build(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for (name, get, n) in [
        (
            "dragon-871414",
            dragon as fn() -> &'static Scene,
            871_414u64,
        ),
        ("dragon-1e7", dragon_1e7, 10_000_000),
    ] {
        g.throughput(Throughput::Elements(n));
        g.bench_function(name, |b| {
            let s = get();
            b.iter(|| RayCaster::new(black_box(&s.points)).expect("build"))
        });
    }
    g.finish();
}

fn bench_cast(c: &mut Criterion) {
    let mut g = c.benchmark_group("cast");
    g.sample_size(20).measurement_time(Duration::from_secs(10));
    for (name, get, rays, primitive) in [
        (
            "dragon-871414 1920x1080 sphere",
            dragon as fn() -> &'static Scene,
            1920u64 * 1080,
            Primitive::Sphere,
        ),
        (
            "dragon-871414 1920x1080 disc",
            dragon,
            1920 * 1080,
            Primitive::Disc,
        ),
        (
            "dragon-1e7 1280x720 sphere",
            dragon_1e7,
            1280 * 720,
            Primitive::Sphere,
        ),
    ] {
        g.throughput(Throughput::Elements(rays));
        g.bench_function(name, |b| {
            let s = get();
            let (caster, list) = casters(s);
            let params = CastParams {
                radius: s.radius,
                traversal: Traversal::Exact,
                primitive,
            };
            b.iter(|| {
                caster
                    .cast(list, &s.camera, black_box(&params))
                    .expect("cast")
            })
        });
    }
    g.finish();
}

criterion_group!(cast_benches, bench_build, bench_cast);
criterion_main!(cast_benches);
