//! The training and validation data of the learned visibility method (`neuralvis`): points
//! sampled on the training meshes (`harness::fetch::TRAINING_MESH_FILES`, never a tuning or an
//! evaluation dataset's), views around each, and per point and view the label of our ground
//! truth (`truth::Reference`: the z-buffer with exact silhouettes), so that what the network
//! learns is exactly what the benchmark scores.
//!
//! ```text
//! cargo run --release -p harness --example neuralvis_data -- --out DIR [--seed S]
//! ```
//!
//! Split: the meshes in [`VALIDATION`] are validation meshes (one clean cloud each, seen from
//! the benchmark's own 16 Fibonacci views at 1.5 box diagonals, 1280 × 720, as the datasets
//! are), the others training meshes. Each training mesh gives [`CLOUDS_PER_MESH`] clouds: an
//! area-weighted sample of a log-uniform size in [4000, 40000] points, degraded by one of
//! `cloud::degrade`'s models or left clean (the draw is seeded), seen from 16 eyes drawn
//! uniformly on the sphere at 1.1 to 3 box diagonals from the centre of the box (1280 × 720,
//! the whole object in view). Labels of a degraded point are its clean source's (the harness
//! scores them so); outliers get label 255 (no label: the harness scores them apart).
//!
//! On the validation clouds it also runs HPR (`hpr::visible`, linear kernel, `--hpr-gamma`,
//! the benchmark's tuned γ by default) and writes its visible flags beside the labels, so the
//! training's validation F1 is compared with HPR's on the same views.
//!
//! Output (`DIR`, replaced only if it is a folder this program wrote): `manifest.json` (seed,
//! revision, machine, the meshes with their SHA-256 and split, one entry per cloud) and per
//! cloud `NAME.points.npy` (f64, n × 3), `NAME.eyes.npy` (f64, v × 3), `NAME.labels.npy` (u8,
//! n × v: 1 visible, 0 hidden, 255 no label) and for validation clouds `NAME.hpr.npy` (u8,
//! n × v).

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Parser;
use cloud::degrade::{Degradation, Unit};
use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{Camera, PointCloud};
use harness::fetch::{TRAINING_MESH_FILES, fetch_training, training_mesh_path};
use harness::output::meta::RunMeta;
use hpr::{HprParams, Kernel, Radius};
use serde_json::json;
use truth::reference::{Reference, ReferenceParams};

/// The validation meshes: organic shapes, CAD parts, a knot and a height field.
const VALIDATION: &[&str] = &[
    "bear",
    "elk",
    "fandisk",
    "hand",
    "knot2",
    "mech-holes-shark",
    "three_peaks",
];

/// Clouds per training mesh.
const CLOUDS_PER_MESH: usize = 6;
/// Views per cloud.
const VIEWS: usize = 16;
/// Points of a validation cloud.
const VALIDATION_POINTS: usize = 20_000;
/// The file that marks a folder as this program's output.
const MARK: &str = "manifest.json";

#[derive(Parser)]
struct Args {
    /// Output folder (created; replaced only when it holds this program's manifest).
    #[arg(long)]
    out: PathBuf,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 66)]
    seed: u64,
    /// Data folder (the training meshes go to its `training-meshes/`).
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// HPR's γ on the validation views (linear kernel): the benchmark's tuned value.
    #[arg(long, default_value_t = 3.5)]
    hpr_gamma: f64,
    /// Only the first N training meshes and N validation meshes (a smoke run).
    #[arg(long)]
    limit: Option<usize>,
    /// Clouds per training mesh.
    #[arg(long, default_value_t = CLOUDS_PER_MESH)]
    clouds: usize,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let clone = harness::paths::working_clone();
    let data_dir = harness::paths::data_dir(args.data_dir.clone(), clone.as_deref())?.path;
    let report = fetch_training(&data_dir)?;
    eprintln!(
        "training meshes: {} present, {} written",
        report.present.len(),
        report.written.len()
    );
    prepare_out(&args.out)?;
    let start = Instant::now();
    let mut clouds = Vec::new();
    let mut meshes = Vec::new();
    let limit = args.limit.unwrap_or(usize::MAX);
    let (mut n_train, mut n_val) = (0, 0);
    for mesh_file in TRAINING_MESH_FILES {
        let name = mesh_file.file.trim_end_matches(".off");
        let validation = VALIDATION.contains(&name);
        let count = if validation { &mut n_val } else { &mut n_train };
        if *count >= limit {
            continue;
        }
        *count += 1;
        let mesh = harness::datasets::read_mesh(&training_mesh_path(&data_dir, mesh_file))?;
        let reference = Reference::new(&mesh)?;
        meshes.push(json!({
            "name": name,
            "sha256": mesh_file.sha256,
            "split": if validation { "validation" } else { "train" },
            "triangles": mesh.triangles.len(),
        }));
        let t = Instant::now();
        if validation {
            let clean = cloud::sample::sample_surface(
                &mesh,
                VALIDATION_POINTS,
                cloud::rng::splitmix64(args.seed ^ hash(name)),
            )?;
            let bbox = clean.bbox().context("empty sample")?;
            let views = fibonacci_views(&bbox, &ViewSpec::default())?;
            let entry = write_cloud(
                &args.out,
                &format!("{name}-val"),
                &clean,
                None,
                &views,
                &reference,
                Some(args.hpr_gamma),
            )?;
            clouds.push(json!({"mesh": name, "split": "validation", "degradation": "clean", "entry": entry}));
        } else {
            for k in 0..args.clouds {
                let mut rng = seeded(args.seed, &format!("neuralvis-{name}-{k}"));
                let n = (4000.0 * 10f64.powf(rng.random::<f64>())).round() as usize;
                let clean = cloud::sample::sample_surface(&mesh, n, rng.random::<u64>())?;
                let bbox = clean.bbox().context("empty sample")?;
                let (steps, label) = degradation(&mut rng, &bbox);
                let degraded = if steps.is_empty() {
                    None
                } else {
                    Some(cloud::degrade::apply(&clean, &steps, rng.random::<u64>())?)
                };
                let views = random_views(&mut rng, &bbox)?;
                let entry = write_cloud(
                    &args.out,
                    &format!("{name}-{k}"),
                    &clean,
                    degraded.as_ref(),
                    &views,
                    &reference,
                    None,
                )?;
                clouds.push(
                    json!({"mesh": name, "split": "train", "degradation": label, "entry": entry}),
                );
            }
        }
        eprintln!(
            "{name}: {} ({:.1} s)",
            if validation { "validation" } else { "train" },
            t.elapsed().as_secs_f64()
        );
    }
    let meta = RunMeta::now(
        "neuralvis-data",
        false,
        &[],
        json!({"seed": args.seed, "hpr_gamma": args.hpr_gamma, "clouds_per_mesh": args.clouds,
               "views": VIEWS, "validation": VALIDATION, "limit": args.limit}),
    );
    let manifest = json!({
        "format": 1,
        "seed": args.seed,
        "meta": meta,
        "seconds": start.elapsed().as_secs_f64(),
        "reference": format!("{:?}", ReferenceParams::default()),
        "meshes": meshes,
        "clouds": clouds,
    });
    fs::write(
        args.out.join(MARK),
        serde_json::to_string_pretty(&manifest)?,
    )?;
    eprintln!(
        "{} clouds in {:.0} s into {}",
        clouds.len(),
        start.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}

/// Creates `out`, or empties it when it is this program's earlier output.
fn prepare_out(out: &Path) -> Result<()> {
    if out.exists() {
        if !out.join(MARK).is_file() {
            bail!(
                "{} exists and is not this program's output (no {MARK}): not replacing it",
                out.display()
            );
        }
        fs::remove_dir_all(out).with_context(|| format!("cannot clear {}", out.display()))?;
    }
    fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))
}

/// A stable 64-bit hash of a name (FNV-1a).
fn hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// One of `cloud::degrade`'s models with seeded parameters, or none (two draws in five).
fn degradation(rng: &mut cloud::rng::Rng, bbox: &cloud::Aabb) -> (Vec<Degradation>, String) {
    let u = |rng: &mut cloud::rng::Rng, lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
    let steps = match rng.random_range(0..10u32) {
        0..=3 => vec![],
        4 | 5 => vec![Degradation::Noise {
            sigma: u(rng, 0.1, 1.0),
            unit: Unit::Spacing,
            along_normal: false,
        }],
        6 => vec![Degradation::Jitter {
            margin: u(rng, 0.001, 0.01),
            unit: Unit::Diagonal,
        }],
        7 => {
            let d = random_direction(rng);
            vec![Degradation::FallOff {
                from: bbox.center() + d * bbox.diagonal(),
                ratio: u(rng, 2.0, 10.0),
            }]
        }
        8 => vec![Degradation::DensityField {
            ratio: u(rng, 2.0, 10.0),
            wavelength: u(rng, 0.2, 1.0),
        }],
        _ => vec![Degradation::Outliers {
            fraction: u(rng, 0.01, 0.05),
            near_surface: None,
            unit: Unit::Diagonal,
        }],
    };
    let label = steps
        .iter()
        .map(Degradation::label)
        .collect::<Vec<_>>()
        .join("+");
    let label = if label.is_empty() {
        "clean".to_owned()
    } else {
        label
    };
    (steps, label)
}

fn random_direction(rng: &mut cloud::rng::Rng) -> DVec3 {
    let z = 2.0 * rng.random::<f64>() - 1.0;
    let phi = std::f64::consts::TAU * rng.random::<f64>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// [`VIEWS`] eyes uniform on the sphere at 1.1 to 3 box diagonals, looking at the box centre,
/// 1280 × 720 with the whole bounding sphere in view.
fn random_views(rng: &mut cloud::rng::Rng, bbox: &cloud::Aabb) -> Result<Vec<Camera>> {
    let (center, diagonal) = (bbox.center(), bbox.diagonal());
    (0..VIEWS)
        .map(|_| {
            let d = random_direction(rng);
            let factor = 1.1 + 1.9 * rng.random::<f64>();
            let distance = factor * diagonal;
            let fov = (2.0 * (0.5 * diagonal / distance).asin()).to_degrees() * 1.05;
            let up = if d.y.abs() > 1f64.to_radians().cos() {
                DVec3::Z
            } else {
                DVec3::Y
            };
            Ok(Camera::new(
                center + distance * d,
                center,
                up,
                fov,
                1280,
                720,
            )?)
        })
        .collect()
}

/// Labels `clean` (or its degraded version) from `views` and writes the cloud's files; returns
/// its manifest entry.
fn write_cloud(
    out: &Path,
    name: &str,
    clean: &PointCloud,
    degraded: Option<&cloud::degrade::Degraded>,
    views: &[Camera],
    reference: &Reference,
    hpr_gamma: Option<f64>,
) -> Result<serde_json::Value> {
    let points = degraded.map_or(&clean.positions, |d| &d.cloud.positions);
    let (n, v) = (points.len(), views.len());
    let mut labels = vec![0u8; n * v];
    let mut hpr_flags = hpr_gamma.map(|_| vec![0u8; n * v]);
    let hull = hull::by_name("own")?;
    let mut n_exact = 0;
    for (j, camera) in views.iter().enumerate() {
        let truth = reference.visibility(&clean.positions, camera, &ReferenceParams::default())?;
        n_exact += truth.n_exact;
        let flags: Vec<u8> = match degraded {
            None => truth.visible.iter().map(|&b| u8::from(b)).collect(),
            Some(d) => d
                .source
                .iter()
                .map(|&s| {
                    if s == cloud::degrade::OUTLIER {
                        255
                    } else {
                        u8::from(truth.visible[s as usize])
                    }
                })
                .collect(),
        };
        for (i, f) in flags.into_iter().enumerate() {
            labels[i * v + j] = f;
        }
        if let (Some(gamma), Some(out)) = (hpr_gamma, hpr_flags.as_mut()) {
            let params = HprParams {
                kernel: Kernel::Linear(Radius::Gamma(gamma)),
                perturb: 0.0,
                seed: 2007,
            };
            let vis = hpr::visible(points, camera.eye, &params, hull.as_ref())?;
            for i in vis.visible {
                out[i as usize * v + j] = 1;
            }
        }
    }
    let flat: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let eyes: Vec<f64> = views
        .iter()
        .flat_map(|c| [c.eye.x, c.eye.y, c.eye.z])
        .collect();
    write_npy(
        &out.join(format!("{name}.points.npy")),
        "<f8",
        &[n, 3],
        &f64_bytes(&flat),
    )?;
    write_npy(
        &out.join(format!("{name}.eyes.npy")),
        "<f8",
        &[v, 3],
        &f64_bytes(&eyes),
    )?;
    write_npy(
        &out.join(format!("{name}.labels.npy")),
        "|u1",
        &[n, v],
        &labels,
    )?;
    if let Some(flags) = &hpr_flags {
        write_npy(&out.join(format!("{name}.hpr.npy")), "|u1", &[n, v], flags)?;
    }
    let visible = labels.iter().filter(|&&l| l == 1).count();
    Ok(json!({
        "name": name,
        "points": n,
        "views": v,
        "visible_fraction": visible as f64 / (n * v) as f64,
        "exact_fraction": n_exact as f64 / (clean.len() * v) as f64,
        "eyes": views.iter().map(|c| [c.eye.x, c.eye.y, c.eye.z]).collect::<Vec<_>>(),
    }))
}

fn f64_bytes(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Writes a NumPy `.npy` file (format 1.0, C order).
fn write_npy(path: &Path, dtype: &str, shape: &[usize], data: &[u8]) -> Result<()> {
    let shape_text = match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header =
        format!("{{'descr': '{dtype}', 'fortran_order': False, 'shape': {shape_text}, }}");
    // Magic (6) + version (2) + length (2) + header + newline, padded to 64 bytes.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + data.len());
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend_from_slice(&u16::try_from(header.len())?.to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes.extend_from_slice(data);
    fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}
