//! The experiment commands: `run` (one experiment), `bench` (every experiment, then the
//! report), `merge` (shards' results into one folder), `report` and `tables` (the report page
//! and tables redrawn from results on disk) and `scale-cell` (one cell of the scale experiment
//! in its own process).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::{cli, datasets, experiments, output, shard, view};

/// `pointsight run`.
pub fn run(
    experiment: &str,
    datasets: Option<Vec<String>>,
    quick: bool,
    out: Option<PathBuf>,
    views: Option<PathBuf>,
    sweep: &cli::SweepFlags,
    data_dir: PathBuf,
) -> Result<()> {
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
        return Ok(());
    }
    println!("{}: results in {}", exp.name(), out_dir.display());
    if default_out && sweep.shard.is_none() {
        assemble_report(Path::new("reports"))?;
    }
    Ok(())
}

/// `pointsight bench`.
pub fn bench(
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

/// `pointsight merge`: the shards' results merged into `out`, then its report page.
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<()> {
    for name in experiments::merge::merge(out, shards)? {
        println!("{name}: merged into {}", out.join(&name).display());
    }
    assemble_report(out)
}

/// `pointsight report`: the viewer pages and the report page of `reports`.
pub fn report(reports: &Path, data_dir: &Path) -> Result<()> {
    view::report::write_all(reports, data_dir)?;
    assemble_report(reports)?;
    println!("wrote {}", reports.join("README.md").display());
    Ok(())
}

/// `pointsight tables`.
pub fn tables(reports: &Path) -> Result<()> {
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

/// `pointsight scale-cell`: one cell of the scale experiment, its JSON line on standard output.
pub fn scale_cell(cell: &experiments::scale::child::CellArgs, data_dir: &Path) -> Result<()> {
    experiments::scale::child::run_in_this_process(cell, data_dir)
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

/// `k/n`, or `-` without a shard.
fn shard_text(shard: Option<shard::Shard>) -> String {
    shard.map_or_else(|| "-".into(), |s| format!("{}/{}", s.k, s.n))
}
