//! The pointsight harness: the thin layer between the method crates and a researcher.
//!
//! - [`datasets`]: the datasets (built-in table, user files, manifests); [`fetch`]: the real
//!   meshes;
//! - [`methods`]: the method registry (one adapter per method), `--set` parameters;
//! - [`score`]: precision, recall, F1, Jaccard against a ground truth;
//! - [`lod_build`]: LOD files built within a memory limit, out of core (`lod-build`);
//! - [`experiments`]: the experiment registry and its frame (measure to CSV, render from CSV);
//! - [`output`]: atomic files, CSV, run metadata, plots, the report page;
//! - [`visible`]: one method on one view or many; [`view`]: the interactive 3D page of
//!   every method's visible set; [`cli`] and [`run`]: the `pointsight` command;
//! - [`guard`]: what every command runs under: outputs checked and locked, stale scratch
//!   reclaimed, signals answered.
//!
//! Only this crate does command-line parsing, plotting and report I/O; the method crates
//! return values and typed errors.

pub mod cli;
pub mod datasets;
pub mod experiments;
pub mod fetch;
pub mod guard;
pub mod lod_build;
pub mod output;
pub mod progress;
pub mod shard;
pub mod stats;
pub mod view;
pub mod visible;

/// The method registry (its own crate, shared with the Python package).
pub use registry as methods;
/// Precision, recall, F1, Jaccard (the registry's, shared with the Python package).
pub use registry::score;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};

use crate::cli::{Cli, Command};

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    let data_dir = cli.data_dir;
    datasets::use_manifest(datasets::manifest::Manifest::discover(
        cli.manifest.as_deref(),
    )?);
    registry::register_external(&cli.methods_dir)?;
    // Outputs checked and locked, stale scratch reclaimed, signals answered (issue 41).
    let _guard = guard::begin(&cli.command)?;
    match cli.command {
        Command::Fetch => {
            let report = fetch::fetch(&data_dir)?;
            for f in &report.present {
                println!("{f}: present, checksum ok");
            }
            for f in &report.written {
                println!("{f}: fetched, checksum ok");
            }
            println!("data folder: {}", data_dir.display());
        }
        Command::Datasets => {
            list_datasets(&data_dir, cli.manifest.as_deref())?;
        }
        Command::Methods => {
            list_methods()?;
        }
        Command::Export { dataset, out } => {
            export(&dataset, &out, &data_dir)?;
        }
        Command::ScaleCell {
            dataset,
            method,
            n,
            setting,
        } => {
            let setting = registry::Setting::parse(&setting);
            let out = experiments::scale::cell(
                &dataset,
                &method,
                &setting,
                n,
                &data_dir,
                experiments::scale::print_prepared,
            )?;
            println!("{}", serde_json::to_string(&out)?);
        }
        Command::LodBuild {
            cloud,
            method,
            memory_limit,
            out,
            in_memory,
        } => {
            let built = if in_memory {
                lod_build::build_in_memory(&cloud, &method, &out)?
            } else {
                let limit = lod_build::parse_size(&memory_limit)?;
                let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
                lod_build::build(&cloud, &method, limit, &out, tty)?
            };
            println!(
                "points={} seconds={:.3} points_per_second={:.0} peak_rss_bytes={} chunks={} \
                 top_levels={} leaf_radius={:e} file_bytes={} scratch_bytes={} \
                 scratch_peak_bytes={}",
                built.points,
                built.seconds,
                built.points as f64 / built.seconds.max(1e-9),
                built.peak_rss_bytes,
                built.chunks,
                built.top_levels,
                built.leaf_radius,
                built.file_bytes,
                built.scratch_bytes,
                built.scratch_peak_bytes
            );
        }
        Command::Inspect {
            file,
            format,
            classes,
            scan,
        } => {
            inspect(&file, format, classes, scan)?;
        }
        Command::Views {
            dataset,
            out,
            format,
        } => {
            let ds = datasets::load(&dataset, &data_dir)?;
            let text = match format {
                cli::ViewsFormat::Csv => views_csv(&ds.views)?,
                cli::ViewsFormat::Jsonl => cloud::io::views::write_views(&ds.views),
            };
            match out {
                Some(path) => output::write_atomic(&path, text.as_bytes())?,
                None => std::io::stdout().write_all(text.as_bytes())?,
            }
        }
        Command::Visible {
            source,
            view,
            method,
            set,
            out,
            score,
            parallel_views,
            repeat,
        } => {
            // A views file alone means every camera in it.
            let view =
                view.unwrap_or_else(|| if source.views.is_some() { "all" } else { "0" }.into());
            visible::run(
                &visible::Request {
                    source: source_of(source)?,
                    view,
                    method,
                    set,
                    out,
                    score,
                    parallel_views,
                    repeat,
                },
                &data_dir,
            )
            .map_err(cli::frame_set)?
        }
        Command::View {
            source,
            view,
            methods,
            set,
            max_points,
            png,
            out,
            lod,
            distance,
        } => {
            let req = view::Request {
                source: source_of(source)?,
                view,
                methods,
                set,
                max_points,
                png,
                out,
            };
            let page = if lod {
                view::lod::run(&req, view::lod::LodRequest { distance }, &data_dir)?
            } else {
                if distance != view::lod::DEFAULT_DISTANCE {
                    anyhow::bail!("--distance is for level-of-detail pages (--lod)");
                }
                view::run(&req, &data_dir)?
            };
            println!("{}", page.line());
        }
        Command::Run {
            experiment,
            datasets,
            quick,
            out,
            views,
            sweep,
        } => {
            return run_experiment(&experiment, datasets, quick, out, views, &sweep, data_dir);
        }
        Command::Bench {
            quick,
            datasets: chosen,
            reports,
            sweep,
        } => {
            bench(quick, chosen, &reports, &sweep, &data_dir)?;
        }
        Command::Merge { out, shards } => {
            for name in experiments::merge::merge(&out, &shards)? {
                println!("{name}: merged into {}", out.join(&name).display());
            }
            assemble_report(&out)?;
        }
        Command::Sweeps => {
            print!("{}", registry::sweep::BUILTIN);
        }
        Command::Clean { folders, remove } => {
            let folders = if folders.is_empty() {
                vec![PathBuf::from(".")]
            } else {
                folders
            };
            for line in guard::clean(&folders, remove)? {
                println!("{line}");
            }
        }
        Command::Report { reports } => {
            view::report::write_all(&reports, &data_dir)?;
            assemble_report(&reports)?;
            println!("wrote {}", reports.join("README.md").display());
        }
        Command::Tables { reports } => {
            tables(&reports)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The source flags of `visible` and `view` as a [`visible::Source`].
fn source_of(a: cli::SourceArgs) -> Result<visible::Source> {
    Ok(visible::Source {
        dataset: a.dataset,
        cloud: a.cloud,
        mesh: a.mesh,
        read: cloud::io::ReadOptions {
            format: parse_format(a.format)?,
            classes: a.classes,
            scan: a.scan,
        },
        merge_scans: a.merge_scans,
        surface_tolerance: a.surface_tolerance,
        camera: visible::CameraFlags {
            eye: a.eye,
            target: a.target,
            up: a.up,
            fov_y_deg: a.fov_y,
            width: a.width,
            height: a.height,
        },
        views: a.views,
    })
}

/// A `--format` name as a reader format, or an error listing the known ones.
fn parse_format(name: Option<String>) -> Result<Option<cloud::io::Format>> {
    name.map(|f| {
        cloud::io::Format::from_name(&f)
            .with_context(|| format!("unknown format {f:?}; known: {}", cloud::io::Format::NAMES))
    })
    .transpose()
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

/// The sweeps (built-in, external methods', `--config`'s) and repeats of `flags`.
fn sweep_settings(flags: &cli::SweepFlags) -> Result<(registry::Sweeps, Option<usize>)> {
    let user = flags
        .config
        .as_deref()
        .map(registry::Sweeps::read)
        .transpose()?;
    let sweeps = registry::Sweeps::resolve(user)?;
    let repeats = flags.repeats.map(|r| r as usize).or(sweeps.repeats);
    Ok((sweeps, repeats))
}

/// `--time-budget` as the experiments take it (`inf`: none).
fn budget(flags: &cli::SweepFlags) -> Option<f64> {
    flags.time_budget.is_finite().then_some(flags.time_budget)
}

/// Writes the report page of `reports` over the experiment registry.
fn assemble_report(reports: &Path) -> Result<()> {
    let sections: Vec<output::report::Section<'_>> = experiments::EXPERIMENTS
        .iter()
        .map(|e| output::report::Section {
            name: e.name(),
            summary: e.summary(),
        })
        .collect();
    output::report::assemble(reports, &sections, &view::report::section(reports)?)
}

fn shard_text(shard: Option<shard::Shard>) -> String {
    shard.map_or_else(|| "-".into(), |s| format!("{}/{}", s.k, s.n))
}

/// `pointsight datasets`.
fn list_datasets(data_dir: &Path, manifest: Option<&Path>) -> Result<()> {
    for d in datasets::REGISTRY {
        let ready = match d.mesh_file() {
            None => "generated",
            Some(m) if fetch::mesh_path(data_dir, &m).exists() => "ready",
            Some(_) => "needs-fetch",
        };
        println!(
            "{:<20} {:>8}  {:<11}  {}",
            d.name, d.n_points, ready, d.description
        );
    }
    if let Some(m) = datasets::manifest::Manifest::discover(manifest)? {
        for (name, e) in &m.datasets {
            let ready = [&e.cloud, &e.mesh, &e.lod_file]
                .into_iter()
                .flatten()
                .all(|p| m.resolve(p).exists());
            println!(
                "{name:<20} {:>8}  {:<11}  {}",
                e.sample.map_or("-".to_owned(), |s| s.n.to_string()),
                if ready { "ready" } else { "missing-file" },
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

/// `pointsight methods`.
fn list_methods() -> Result<()> {
    for m in methods::all() {
        match m.availability() {
            Ok(()) => println!("{:<10} {}", m.name(), m.summary()),
            Err(why) => println!("{:<10} {} [{why}]", m.name(), m.summary()),
        }
        for p in m.params() {
            println!("    --set {}=…  (default {}) {}", p.key, p.default, p.help);
        }
    }
    println!("level of detail (experiment lod; sweeps keys):");
    for m in registry::lod::all() {
        match m.availability() {
            Ok(()) => println!("{:<10} {}", m.name(), m.summary()),
            Err(why) => println!("{:<10} {} [{why}]", m.name(), m.summary()),
        }
        for p in m.params() {
            println!("    {}=…  (default {}) {}", p.key, p.default, p.help);
        }
    }
    Ok(())
}

/// `pointsight export`.
fn export(dataset: &str, out: &Path, data_dir: &Path) -> Result<()> {
    let ds = datasets::load(dataset, data_dir)?;
    // In world coordinates (the recentring and rescaling undone: exact).
    let positions = ds.world_positions();
    let is_las = cloud::io::Format::of_path(out) == Some(cloud::io::Format::Las);
    let n = positions.len();
    if is_las {
        let with_attributes = cloud::PointCloud {
            positions,
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
            ..Default::default()
        };
        cloud::io::ply_write::write_ply(out, &positions_only)?;
        println!("dataset={dataset} points={n} file={}", out.display());
    }
    Ok(())
}

/// `pointsight inspect`.
fn inspect(
    file: &Path,
    format: Option<String>,
    classes: Option<Vec<u8>>,
    scan: Option<usize>,
) -> Result<()> {
    let options = cloud::io::ReadOptions {
        format: parse_format(format)?,
        classes,
        scan,
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

/// `pointsight run`.
fn run_experiment(
    experiment: &str,
    datasets: Option<Vec<String>>,
    quick: bool,
    out: Option<PathBuf>,
    views: Option<PathBuf>,
    sweep: &cli::SweepFlags,
    data_dir: PathBuf,
) -> Result<ExitCode> {
    let exp = experiments::experiment(experiment)?;
    let datasets: Vec<String> = match datasets {
        Some(list) => list,
        None => exp
            .default_datasets(quick)
            .iter()
            .map(|s| s.to_string())
            .collect(),
    };
    for name in &datasets {
        datasets::check(name)?;
    }
    let default_out = out.is_none();
    let out_dir = out.unwrap_or_else(|| PathBuf::from("reports").join(exp.name()));
    let (sweeps, repeats) = sweep_settings(sweep)?;
    let ctx = experiments::Context {
        views,
        sweeps,
        repeats: repeats.unwrap_or(experiments::REPEATS),
        repeats_given: repeats.is_some(),
        time_budget: budget(sweep),
        shard: sweep.shard,
        ..experiments::Context::new(data_dir, out_dir.clone(), quick, datasets)
    };
    if !experiments::run(exp, &ctx)? {
        println!("{}: not in shard {}", exp.name(), shard_text(sweep.shard));
        return Ok(ExitCode::SUCCESS);
    }
    println!("{}: results in {}", exp.name(), out_dir.display());
    if default_out && sweep.shard.is_none() {
        assemble_report(Path::new("reports"))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// `pointsight bench`.
fn bench(
    quick: bool,
    chosen: Option<Vec<String>>,
    reports: &Path,
    sweep: &cli::SweepFlags,
    data_dir: &Path,
) -> Result<()> {
    let (sweeps, repeats) = sweep_settings(sweep)?;
    let start = std::time::Instant::now();
    for name in chosen.iter().flatten() {
        datasets::check(name)?;
    }
    // The report's viewer pages need the viewer's script: say so before measuring for hours.
    let visibility_datasets: Vec<String> = match &chosen {
        Some(list) => list.clone(),
        None => experiments::experiment("visibility")?
            .default_datasets(quick)
            .iter()
            .map(|s| s.to_string())
            .collect(),
    };
    if sweep.shard.is_none()
        && visibility_datasets
            .iter()
            .any(|d| datasets::info(d).is_ok_and(|i| i.needs_fetch()))
    {
        view::page::bundle()?;
    }
    for exp in experiments::EXPERIMENTS {
        let datasets = match &chosen {
            Some(list) => list.clone(),
            None => exp
                .default_datasets(quick)
                .iter()
                .map(|s| s.to_string())
                .collect(),
        };
        let ctx = experiments::Context {
            sweeps: sweeps.clone(),
            repeats: repeats.unwrap_or(experiments::REPEATS),
            repeats_given: repeats.is_some(),
            time_budget: budget(sweep),
            shard: sweep.shard,
            ..experiments::Context::new(
                data_dir.to_path_buf(),
                reports.join(exp.name()),
                quick,
                datasets,
            )
        };
        eprintln!("== {} ({})", exp.name(), exp.summary());
        let t = std::time::Instant::now();
        if experiments::run(*exp, &ctx)? {
            eprintln!("   done in {:.1} s", t.elapsed().as_secs_f64());
        } else {
            eprintln!("   not in shard {}", shard_text(sweep.shard));
        }
    }
    match sweep.shard {
        None => {
            view::report::write_all(reports, data_dir)?;
            assemble_report(reports)?;
            println!(
                "bench: {} experiment(s) in {:.1} s; see {}",
                experiments::EXPERIMENTS.len(),
                start.elapsed().as_secs_f64(),
                reports.join("README.md").display()
            );
        }
        Some(s) => println!(
            "bench: shard {}/{} done in {:.1} s into {}; once every shard has run: pointsight merge --out DIR SHARD_FOLDERS...",
            s.k,
            s.n,
            start.elapsed().as_secs_f64(),
            reports.display()
        ),
    }
    Ok(())
}

/// `pointsight tables`.
fn tables(reports: &Path) -> Result<()> {
    let mut rendered = 0;
    for exp in experiments::EXPERIMENTS {
        let dir = reports.join(exp.name());
        if dir.join("metadata.json").exists() {
            exp.render(&dir)
                .with_context(|| format!("redrawing {}", dir.display()))?;
            rendered += 1;
        }
    }
    if rendered == 0 {
        bail!(
            "no experiment results under {}: run an experiment first",
            reports.display()
        );
    }
    assemble_report(reports)?;
    println!(
        "redrew {rendered} experiment(s); wrote {}",
        reports.join("README.md").display()
    );
    Ok(())
}
