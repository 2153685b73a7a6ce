//! The caster's side of a timing against point-cloud-utils' `RaySurfelIntersector` on the
//! same rays, driven by `scripts/raycast-vs-pcu.py` (which alternates the two in one run).
//!
//! `peer_cast DIR N SEED WIDTH HEIGHT` samples ChineseDragon-10kv.off (from
//! `$POINTSIGHT_DATA/meshes`, default the workspace's `bench-data`) with `N` points and seed
//! `SEED`, takes its first Fibonacci view at `WIDTH` × `HEIGHT` and the radius of
//! `auto::auto_radius` (1.5 density spacings), builds the caster, and writes to `DIR` what the
//! peer needs, as little-endian `f32`: `points.f32`, `normals.f32`, `origins.f32` and
//! `dirs.f32` (one ray per pixel, row-major, unit directions), `radius.txt`. It prints
//! `ready RAYS BUILD_WALL BUILD_CPU` and then answers each line of standard input:
//! `sphere` or `disc` casts the view once and prints `WALL CPU VISIBLE` (seconds, the
//! process's CPU seconds over all its threads, points seen); the first cast of each primitive
//! also writes its per-pixel hits, `u32`, `NONE` for none, to `DIR/pixels-PRIMITIVE.u32`;
//! `build` builds the caster again and prints `WALL CPU`. Linux only (CPU time from
//! `/proc/self/task/*/schedstat`).

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use cloud::ViewSpec;
use cloud::glam::DVec3;
use raycast::{CastParams, Primitive, RayCaster, RayList, Traversal};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// CPU seconds of this process: the sum over its threads' run times.
fn cpu_seconds() -> Res<f64> {
    let mut ns = 0u64;
    for task in std::fs::read_dir("/proc/self/task")? {
        let text = std::fs::read_to_string(task?.path().join("schedstat"))?;
        ns += text
            .split(' ')
            .next()
            .ok_or("empty schedstat")?
            .parse::<u64>()?;
    }
    Ok(ns as f64 * 1e-9)
}

fn write_f32(path: &Path, values: impl Iterator<Item = f64>) -> Res<()> {
    let bytes: Vec<u8> = values.flat_map(|v| (v as f32).to_le_bytes()).collect();
    std::fs::write(path, bytes)?;
    Ok(())
}

fn arg<T: std::str::FromStr>(args: &[String], k: usize, what: &str) -> Res<T> {
    args.get(k).and_then(|a| a.parse().ok()).ok_or_else(|| {
        format!("argument {k}: {what}; usage: peer_cast DIR N SEED WIDTH HEIGHT").into()
    })
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(arg::<String>(&args, 1, "output folder")?);
    let n: usize = arg(&args, 2, "points")?;
    let seed: u64 = arg(&args, 3, "sampling seed")?;
    let (width, height): (u32, u32) = (arg(&args, 4, "width")?, arg(&args, 5, "height")?);
    let data = std::env::var_os("POINTSIGHT_DATA").map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")),
        PathBuf::from,
    );
    let mesh = cloud::io::read(&data.join("meshes").join("ChineseDragon-10kv.off"))?.mesh();
    let sample = cloud::sample::sample_surface(&mesh, n, seed)?;
    let normals: Vec<DVec3> = sample
        .normals
        .as_ref()
        .ok_or("a sampled cloud has normals")?
        .iter()
        .map(|v| v.as_dvec3())
        .collect();
    let radius = raycast::auto::auto_radius(&sample.positions)?;
    let bbox = mesh.bbox().ok_or("the mesh has no vertices")?;
    let camera = cloud::views::fibonacci_views(&bbox, &ViewSpec::default())?[0]
        .with_resolution(width, height)?;
    let rays = RayList::new(&camera)?;

    std::fs::create_dir_all(&dir)?;
    let flat = |v: &[DVec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f64>>();
    write_f32(&dir.join("points.f32"), flat(&sample.positions).into_iter())?;
    write_f32(&dir.join("normals.f32"), flat(&normals).into_iter())?;
    let (mut origins, mut dirs) = (Vec::new(), Vec::new());
    for k in 0..rays.len() {
        let (o, d) = rays.aim(&camera, k);
        let d = DVec3::from_array(d).normalize();
        origins.extend(o);
        dirs.extend(d.to_array());
    }
    write_f32(&dir.join("origins.f32"), origins.into_iter())?;
    write_f32(&dir.join("dirs.f32"), dirs.into_iter())?;
    std::fs::write(dir.join("radius.txt"), format!("{radius:e}\n"))?;

    let build = || -> Res<(RayCaster, f64, f64)> {
        let (t, c) = (Instant::now(), cpu_seconds()?);
        let caster = RayCaster::new(&sample.positions)?.with_normals(&normals)?;
        Ok((caster, t.elapsed().as_secs_f64(), cpu_seconds()? - c))
    };
    let (mut caster, wall, cpu) = build()?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "ready {} {wall:.6} {cpu:.6}", rays.len())?;
    out.flush()?;
    let mut dumped = [false; 2];
    for line in std::io::stdin().lock().lines() {
        let line = line?;
        let primitive = match line.trim() {
            "sphere" => Primitive::Sphere,
            "disc" => Primitive::Disc,
            "build" => {
                drop(caster);
                let (c, wall, cpu) = build()?;
                caster = c;
                writeln!(out, "{wall:.6} {cpu:.6}")?;
                out.flush()?;
                continue;
            }
            other => return Err(format!("unknown command {other:?}").into()),
        };
        let params = CastParams {
            radius,
            traversal: Traversal::Exact,
            primitive,
        };
        let (t, c) = (Instant::now(), cpu_seconds()?);
        let frame = caster.cast(&rays, &camera, &params)?;
        let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_seconds()? - c);
        let k = usize::from(primitive == Primitive::Disc);
        if !dumped[k] {
            dumped[k] = true;
            let name = ["pixels-sphere.u32", "pixels-disc.u32"][k];
            let bytes: Vec<u8> = frame
                .pixel_point
                .iter()
                .flat_map(|p| p.to_le_bytes())
                .collect();
            std::fs::write(dir.join(name), bytes)?;
        }
        writeln!(out, "{wall:.6} {cpu:.6} {}", frame.visible.len())?;
        out.flush()?;
    }
    Ok(())
}
