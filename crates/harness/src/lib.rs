//! The pointsight harness: the thin layer between the method crates and a researcher.
//!
//! - [`datasets`]: the dataset registry; [`fetch`]: the real meshes;
//! - [`methods`]: the method registry (one adapter per method), `--set` parameters;
//! - [`score`]: precision, recall, F1, Jaccard against a ground truth;
//! - [`experiments`]: the experiment registry and its frame (measure to CSV, render from CSV);
//! - [`output`]: atomic files, CSV, run metadata, plots, the report page;
//! - [`cli`] and [`run`]: the `pointsight` command.
//!
//! Only this crate does command-line parsing, plotting and report I/O; the method crates
//! return values and typed errors.

pub mod cli;
pub mod datasets;
pub mod experiments;
pub mod fetch;
pub mod methods;
pub mod output;
pub mod progress;
pub mod score;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};

use crate::cli::{Cli, Command};
use crate::methods::Params;

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<ExitCode> {
    let data_dir = cli.data_dir;
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
            for d in datasets::REGISTRY {
                let ready = match d.mesh_file() {
                    None => "generated",
                    Some(m) if datasets::mesh_path(&data_dir, &m).exists() => "ready",
                    Some(_) => "needs-fetch",
                };
                println!(
                    "{:<20} {:>8}  {:<11}  {}",
                    d.name, d.n_points, ready, d.description
                );
            }
        }
        Command::Methods => {
            for m in methods::METHODS {
                println!("{:<10} {}", m.name(), m.summary());
                for p in m.params() {
                    println!("    --set {}=…  (default {}) {}", p.key, p.default, p.help);
                }
            }
        }
        Command::Export { dataset, out } => {
            let ds = datasets::load(&dataset, &data_dir)?;
            let positions_only = cloud::PointCloud {
                positions: ds.cloud.positions,
                ..Default::default()
            };
            cloud::io::ply_write::write_ply(&out, &positions_only)?;
            println!(
                "dataset={dataset} points={} file={}",
                positions_only.len(),
                out.display()
            );
        }
        Command::Views { dataset, out } => {
            let ds = datasets::load(&dataset, &data_dir)?;
            let text = views_csv(&ds.views);
            match out {
                Some(path) => output::write_atomic(&path, text.as_bytes())?,
                None => std::io::stdout().write_all(text.as_bytes())?,
            }
        }
        Command::Visible {
            dataset,
            view,
            method,
            set,
            out,
            score: with_score,
        } => {
            let params = Params::parse(&set)?;
            let method = methods::method(&method)?;
            let ds = datasets::load(&dataset, &data_dir)?;
            let camera = *ds.view(view)?;
            let start = std::time::Instant::now();
            let prepared = methods::prepare(method, &ds, &params)?;
            let prepare_seconds = start.elapsed().as_secs_f64();
            let (output, seconds) = methods::timed(prepared.as_ref(), &camera)?;
            let mut text = String::with_capacity(output.visible.len() * 8);
            for i in &output.visible {
                text.push_str(&i.to_string());
                text.push('\n');
            }
            output::write_atomic(&out, text.as_bytes())?;
            println!("prepare_seconds={prepare_seconds:.6} rays={}", output.rays);
            if with_score {
                let truth = truth::Reference::new(&ds.mesh)?
                    .visibility(
                        &ds.cloud.positions,
                        &camera,
                        &truth::ReferenceParams::default(),
                    )?
                    .visible;
                let s = score::Score::of(&output.visible, &truth);
                println!(
                    "reference_visible={} precision={:.4} recall={:.4} f1={:.4}",
                    truth.iter().filter(|&&t| t).count(),
                    s.precision(),
                    s.recall(),
                    s.f1()
                );
            }
            println!(
                "method={} points={} visible={} seconds={seconds:.6}",
                method.name(),
                ds.cloud.len(),
                output.visible.len()
            );
        }
        Command::Run {
            experiment,
            datasets,
            quick,
            out,
        } => {
            let exp = experiments::experiment(&experiment)?;
            let datasets: Vec<String> = match datasets {
                Some(list) => list,
                None => exp
                    .default_datasets(quick)
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
            };
            for name in &datasets {
                datasets::info(name)?;
            }
            let default_out = out.is_none();
            let out_dir = out.unwrap_or_else(|| PathBuf::from("reports").join(exp.name()));
            let ctx = experiments::Context {
                data_dir,
                out_dir: out_dir.clone(),
                quick,
                datasets,
            };
            experiments::run(exp, &ctx)?;
            println!("{}: results in {}", exp.name(), out_dir.display());
            if default_out {
                output::report::assemble(Path::new("reports"))?;
            }
        }
        Command::Bench {
            quick,
            datasets: chosen,
            reports,
        } => {
            let start = std::time::Instant::now();
            for name in chosen.iter().flatten() {
                datasets::info(name)?;
            }
            for exp in experiments::EXPERIMENTS {
                let ctx = experiments::Context {
                    data_dir: data_dir.clone(),
                    out_dir: reports.join(exp.name()),
                    quick,
                    datasets: match &chosen {
                        Some(list) => list.clone(),
                        None => exp
                            .default_datasets(quick)
                            .iter()
                            .map(|s| s.to_string())
                            .collect(),
                    },
                };
                eprintln!("== {} ({})", exp.name(), exp.summary());
                let t = std::time::Instant::now();
                experiments::run(*exp, &ctx)?;
                eprintln!("   done in {:.1} s", t.elapsed().as_secs_f64());
            }
            output::report::assemble(&reports)?;
            println!(
                "bench: {} experiment(s) in {:.1} s; see {}",
                experiments::EXPERIMENTS.len(),
                start.elapsed().as_secs_f64(),
                reports.join("README.md").display()
            );
        }
        Command::Report { reports } => {
            output::report::assemble(&reports)?;
            println!("wrote {}", reports.join("README.md").display());
        }
        Command::Tables { reports } => {
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
            output::report::assemble(&reports)?;
            println!(
                "redrew {rendered} experiment(s); wrote {}",
                reports.join("README.md").display()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The views CSV of the output contract.
pub fn views_csv(views: &[cloud::Camera]) -> String {
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
            c.fov_y_deg().unwrap_or(f64::NAN),
            c.width,
            c.height
        ));
    }
    s
}
