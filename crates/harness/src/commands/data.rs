//! The data commands: `fetch` (the real meshes), `paths` (where the folders are), `datasets`
//! (the list, with what is ready),
//! `export` (a dataset as a PLY or LAS file), `inspect` (what a file holds) and `views` (a
//! dataset's cameras as the views CSV or JSON lines).

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use cloud::glam::DVec3;

use crate::cli::ViewsFormat;
use crate::{datasets, output, paths};

/// `pointsight fetch`.
pub fn fetch(data_dir: &Path) -> Result<()> {
    let report = crate::fetch::fetch(data_dir)?;
    for f in &report.present {
        println!("{f}: present, checksum ok");
    }
    for f in &report.written {
        println!("{f}: fetched, checksum ok");
    }
    println!("data folder: {}", data_dir.display());
    Ok(())
}

/// `pointsight paths`: each folder and page script with the step of the rule that chose it.
pub fn paths(data: &paths::Place, methods: &[paths::Place], clone: Option<&Path>) {
    println!("data={} ({})", data.path.display(), data.why());
    if methods.is_empty() {
        println!("methods=- (--no-installed-methods)");
    }
    for folder in methods {
        let readable = if folder.warning().is_some() {
            ", cannot be read"
        } else {
            ""
        };
        println!(
            "methods={} ({}{readable})",
            folder.path.display(),
            folder.why()
        );
    }
    for quick in [false, true] {
        println!(
            "{}={}",
            if quick { "reports_quick" } else { "reports" },
            paths::reports_dir(quick, clone).display()
        );
    }
    println!(
        "clone={}",
        clone.map_or("-".into(), |c| c.display().to_string())
    );
    // The docs' example files: the clone's, else the copy installed beside the binary.
    let examples = clone
        .map(|c| c.join("examples"))
        .or_else(|| paths::installed_share().map(|s| s.join("examples")))
        .filter(|e| e.is_dir());
    println!(
        "examples={}",
        examples.map_or("-".into(), |e| e.display().to_string())
    );
    for (file, var) in [
        ("viewer.js", crate::view::page::BUNDLE_VAR),
        ("results.js", "POINTSIGHT_RESULTS_JS"),
    ] {
        let candidates = paths::script_candidates(file, var);
        match paths::find_script(&candidates) {
            Some(p) => println!("{file}={}", p.display()),
            None => println!(
                "{file}=- (not found; looked for {})",
                candidates
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// `pointsight datasets`.
pub fn list_datasets(run: &crate::run::Run, data_dir: &Path) -> Result<()> {
    for d in datasets::REGISTRY {
        let ready = match d.mesh_file() {
            None => "generated",
            Some(m) if crate::fetch::mesh_path(data_dir, &m).exists() => "ready",
            Some(_) => "needs-fetch",
        };
        println!(
            "{:<20} {:>8}  {:<11}  {:<10}  {}",
            d.name,
            d.n_points,
            ready,
            d.role.word(),
            d.description
        );
    }
    if let Some(m) = run.datasets.manifest() {
        for (name, e) in &m.datasets {
            let ready = [&e.cloud, &e.mesh, &e.lod_file]
                .into_iter()
                .flatten()
                .all(|p| m.resolve(p).exists());
            println!(
                "{name:<20} {:>8}  {:<11}  {:<10}  {}",
                e.sample.map_or("-".to_owned(), |s| s.n.to_string()),
                if ready { "ready" } else { "missing-file" },
                datasets::Role::Own.word(),
                if e.description.is_empty() {
                    format!("from {}", m.path.display())
                } else {
                    e.description.clone()
                }
            );
        }
    }
    Ok(())
}

/// `pointsight export`, with the dataset's normals when `normals` (as extra bytes in LAS and
/// LAZ). A manifest's plain sample of a mesh written as LAS or LAZ is streamed
/// ([`export_sample`]: memory for the mesh and a batch, whatever the sample's size; the
/// dataset's views, which `export` does not use, are not read then); any other dataset is
/// loaded whole first.
pub fn export(
    run: &crate::run::Run,
    dataset: &str,
    out: &Path,
    normals: bool,
    data_dir: &Path,
) -> Result<()> {
    let is_las = cloud::io::Format::of_path(out) == Some(cloud::io::Format::Las);
    if is_las && let Some((mesh, n, seed)) = run.datasets.plain_sample(dataset)? {
        let scale = export_sample(&mesh, n, seed, normals, out)
            .with_context(|| format!("exporting dataset {dataset}"))?;
        println!(
            "dataset={dataset} points={n} file={} scale={scale:e}",
            out.display()
        );
        return Ok(());
    }
    let ds = run.datasets.load(dataset, data_dir)?;
    // In world coordinates (the recentring and rescaling undone: exact).
    let positions = ds.world_positions();
    let n = positions.len();
    // Directions: the recentring and the power-of-two rescaling leave them as they are.
    let normals =
        if normals {
            Some(ds.cloud.normals.clone().with_context(|| {
                format!("--normals: dataset {dataset} has no normals to export")
            })?)
        } else {
            None
        };
    if is_las {
        let with_attributes = cloud::PointCloud {
            positions,
            normals,
            colors: ds.cloud.colors,
            intensity: ds.cloud.intensity,
            classification: ds.cloud.classification,
            ..Default::default()
        };
        // Whole or not at all (cloud::io::atomic).
        let scale = cloud::io::las::write_las(out, &with_attributes)?;
        println!(
            "dataset={dataset} points={n} file={} scale={scale:e}",
            out.display()
        );
    } else {
        let positions_only = cloud::PointCloud {
            positions,
            normals,
            ..Default::default()
        };
        cloud::io::ply_write::write_ply(out, &positions_only)?;
        println!("dataset={dataset} points={n} file={}", out.display());
    }
    Ok(())
}

/// Points drawn and written at a time by [`export_sample`].
const EXPORT_BATCH: usize = 1 << 16;

/// Writes the `n` samples of `mesh` drawn with `seed` as LAS or LAZ (by `out`'s extension)
/// without holding them; for a dataset that `datasets::plain_sample` gives, the file its whole
/// export writes, byte for byte. The sampler runs twice: first for the samples' bounding box,
/// which fixes the file's grid as `cloud::io::las::write_las` fixes it from a whole cloud, then
/// to write them. Each coordinate goes through `+ 0.0` as the whole dataset's does (its
/// recentring undone), which turns `-0.0` into `0.0` and keeps every other value. With
/// `normals`, each point's triangle's normal as extra bytes (computed from the mesh file's own
/// coordinates, so within a few units in the last place of the whole dataset's). Returns the
/// grid's scale.
fn export_sample(
    mesh: &cloud::TriMesh,
    n: usize,
    seed: u64,
    normals: bool,
    out: &Path,
) -> Result<f64> {
    let bar = crate::progress::bar((n as u64).saturating_mul(2), "export: box, then points");
    let mut sampler = cloud::sample::SurfaceSampler::new(mesh, seed)?;
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut batch = Vec::with_capacity(EXPORT_BATCH);
    let mut left = n;
    while left > 0 {
        let k = left.min(EXPORT_BATCH);
        batch.clear();
        sampler.positions_into(k, &mut batch);
        for p in &batch {
            let p = *p + DVec3::ZERO;
            lo = lo.min(p);
            hi = hi.max(p);
        }
        left -= k;
        bar.inc(k as u64);
    }
    let mut sampler = cloud::sample::SurfaceSampler::new(mesh, seed)?;
    let mut left = n;
    let (scale, written) = cloud::io::las::write_las_streamed(out, lo, hi, normals, |batch| {
        let k = left.min(EXPORT_BATCH);
        for _ in 0..k {
            let sample = sampler.draw();
            batch
                .positions
                .push(cloud::sample::sample_position(mesh, &sample) + DVec3::ZERO);
            if normals {
                batch
                    .normals
                    .push(mesh.face_normal(sample.triangle as usize).as_vec3());
            }
        }
        left -= k;
        bar.inc(k as u64);
        left > 0
    })?;
    bar.finish_and_clear();
    debug_assert_eq!(written, n as u64);
    Ok(scale)
}

/// `pointsight inspect`.
pub fn inspect(
    file: &Path,
    format: Option<String>,
    classes: Option<Vec<u8>>,
    scan: Option<usize>,
    columns: Option<cloud::io::xyz::Columns>,
) -> Result<()> {
    let options = cloud::io::ReadOptions {
        format: super::parse_format(format)?,
        classes,
        scan,
        columns,
    };
    let start = std::time::Instant::now();
    let loaded = cloud::io::read_with(file, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    let c = &loaded.cloud;
    let mut attributes = Vec::new();
    for (name, present) in [
        ("normals", c.normals.is_some()),
        ("colors", c.colors.is_some()),
        ("uvs", c.uvs.is_some()),
        ("intensity", c.intensity.is_some()),
        ("classification", c.classification.is_some()),
        ("scan", c.scan.is_some()),
    ] {
        if present {
            attributes.push(name);
        }
    }
    if let Some(b) = c.bbox() {
        println!(
            "bbox_min={},{},{} bbox_max={},{},{}",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
    }
    for (k, s) in loaded.scanners.iter().enumerate() {
        println!(
            "scanner={k} position={},{},{}",
            s.position.x, s.position.y, s.position.z
        );
    }
    // Which normals the file gives (their fields), if any.
    println!(
        "normals={}",
        loaded
            .normal_fields
            .as_deref()
            .unwrap_or("- (none: estimated where needed)")
    );
    // Coincident points (real scans have them; normals and spacings take them in bounded work).
    let (distinct, duplicates, most) = cloud::knn::coincidence(&c.positions);
    println!("distinct_positions={distinct} duplicates={duplicates} most_copies={most}");
    println!(
        "file={} points={} faces={} attributes={} read_seconds={seconds:.6} \
         points_per_second={:.0}",
        file.display(),
        c.len(),
        loaded.triangles.len(),
        if attributes.is_empty() {
            "-".to_owned()
        } else {
            attributes.join(",")
        },
        c.len() as f64 / seconds.max(1e-12)
    );
    Ok(())
}

/// `pointsight views`: a dataset's views as CSV or JSON lines, to a file or standard output.
pub fn views(
    run: &crate::run::Run,
    dataset: &str,
    out: Option<&Path>,
    format: ViewsFormat,
    data_dir: &Path,
) -> Result<()> {
    let ds = run.datasets.load(dataset, data_dir)?;
    let text = match format {
        ViewsFormat::Csv => views_csv(&ds.views)?,
        ViewsFormat::Jsonl => cloud::io::views::write_views(&ds.views),
    };
    match out {
        Some(path) => output::write_atomic(path, text.as_bytes())?,
        None => std::io::stdout().write_all(text.as_bytes())?,
    }
    Ok(())
}

/// The views CSV of the output contract (look-at pinhole views; other models need the JSON
/// lines format).
pub fn views_csv(views: &[cloud::Camera]) -> Result<String> {
    if let Some(c) = views.iter().find(|c| c.fov_y_deg().is_none()) {
        bail!(
            "the views CSV holds pinhole views only; this dataset has {} views: use --format jsonl",
            c.model().name()
        );
    }
    let mut s = String::from(
        "view,eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,fov_y_deg,width,height\n",
    );
    for (k, c) in views.iter().enumerate() {
        s.push_str(&format!(
            "{k},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            c.eye.x,
            c.eye.y,
            c.eye.z,
            c.target.x,
            c.target.y,
            c.target.z,
            c.up.x,
            c.up.y,
            c.up.z,
            c.fov_y_deg().unwrap_or_default(),
            c.width,
            c.height
        ));
    }
    Ok(s)
}
