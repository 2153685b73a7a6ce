//! The experiment commands: `run` (one experiment), `bench` (every experiment, then the
//! report), `merge` (shards' results into one folder), `report` and `tables` (the report page
//! and tables redrawn from results on disk) and `scale-cell` (one cell of the scale experiment
//! in its own process).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::run::Run;
use crate::{cli, datasets, experiments, output, progress, shard, view, visible};

/// What `pointsight run` was asked.
#[derive(Debug, Clone)]
pub struct RunRequest {
    /// Experiment name.
    pub experiment: String,
    /// `--datasets` (default: the experiment's own list).
    pub datasets: Option<Vec<String>>,
    /// Quick mode.
    pub quick: bool,
    /// `--out` (default: `reports`/EXPERIMENT).
    pub out: Option<PathBuf>,
    /// The user's files (`--cloud`, `--mesh`, ...) and cameras (`--eye`, `--views`).
    pub source: visible::Source,
    /// The reports folder of a run without `--out` (`harness::paths::reports_dir`).
    pub reports: PathBuf,
}

/// `pointsight run`.
pub fn run(run: &Run, req: &RunRequest, sweep: &cli::SweepFlags, data_dir: PathBuf) -> Result<()> {
    let exp = experiments::experiment(&req.experiment)?;
    let on_files = req.source.cloud.is_some();
    let (datasets, seed_tables) = match (&req.source.name(), &req.datasets) {
        (Some(name), _) if on_files => (vec![name.clone()], false),
        (_, Some(list)) => (list.clone(), false),
        _ => (
            exp.default_datasets(req.quick)
                .iter()
                .map(|s| s.to_string())
                .collect(),
            true,
        ),
    };
    if on_files {
        if exp.name() == "scale" {
            bail!(
                "the scale experiment samples a dataset's mesh at sizes it chooses; it does not \
                 take --cloud (give a manifest dataset with a mesh: --datasets NAME)"
            );
        }
    } else {
        for name in &datasets {
            run.datasets.check(name)?;
        }
    }
    let default_out = req.out.is_none();
    let out_dir = req
        .out
        .clone()
        .unwrap_or_else(|| req.reports.join(exp.name()));
    let (sweeps, repeats) = sweep_settings(run, sweep)?;
    let ctx = experiments::Context {
        source: req.source.clone(),
        seed_tables,
        sweeps,
        repeats: repeats.unwrap_or(experiments::REPEATS),
        repeats_given: repeats.is_some(),
        time_budget: budget(sweep),
        shard: sweep.shard,
        max_points: sweep.max_points,
        ..experiments::Context::new(
            std::sync::Arc::new(run.clone()),
            data_dir,
            out_dir.clone(),
            req.quick,
            datasets,
        )
    };
    if !experiments::run(exp, &ctx)? {
        println!("{}: not in shard {}", exp.name(), shard_text(sweep.shard));
        return Ok(());
    }
    // A run into its own folder (a user's data) has its findings beside its results
    // already (`experiments::run`); one into the reports folder also updates the report.
    if default_out && sweep.shard.is_none() {
        assemble_report(run, &req.reports)?;
    }
    println!("{}: results in {}", exp.name(), out_dir.display());
    Ok(())
}

/// `pointsight bench`: every experiment (or those `only` names) into `reports`, then the
/// report; progress on standard error ([`progress::Run`]).
pub fn bench(
    run: &Run,
    quick: bool,
    chosen: Option<Vec<String>>,
    only: Option<Vec<String>>,
    reports: &Path,
    sweep: &cli::SweepFlags,
    data_dir: &Path,
) -> Result<()> {
    let (sweeps, repeats) = sweep_settings(run, sweep)?;
    let start = std::time::Instant::now();
    let shared = std::sync::Arc::new(run.clone());
    for name in chosen.iter().flatten() {
        run.datasets.check(name)?;
    }
    for name in only.iter().flatten() {
        experiments::experiment(name)?;
    }
    // In report order, whatever the order of `--experiments`.
    let to_run: Vec<&'static dyn experiments::Experiment> = experiments::EXPERIMENTS
        .iter()
        .copied()
        .filter(|e| {
            only.as_ref()
                .is_none_or(|o| o.iter().any(|n| n == e.name()))
        })
        .collect();
    let datasets_of = |exp: &dyn experiments::Experiment| -> Vec<String> {
        match &chosen {
            Some(list) => list.clone(),
            None => exp
                .default_datasets(quick)
                .iter()
                .map(|s| s.to_string())
                .collect(),
        }
    };
    // The report's viewer pages (the visibility and lod experiments' fetched datasets) need
    // the viewer's script: say so before measuring for hours.
    let pages = to_run
        .iter()
        .filter(|e| ["visibility", "lod"].contains(&e.name()))
        .flat_map(|e| datasets_of(*e))
        .any(|d| datasets::info(&d).is_ok_and(|i| i.needs_fetch()));
    if sweep.shard.is_none() && pages {
        view::page::bundle()?;
    }
    let progress = progress::Run::start(
        to_run
            .iter()
            .map(|exp| {
                let previous =
                    previous_seconds(&reports.join(exp.name()), quick, &datasets_of(*exp));
                (exp.name().to_owned(), previous)
            })
            .collect(),
    );
    for (k, exp) in to_run.iter().enumerate() {
        let datasets = datasets_of(*exp);
        progress.experiment(k, &datasets);
        let ctx = experiments::Context {
            sweeps: sweeps.clone(),
            repeats: repeats.unwrap_or(experiments::REPEATS),
            repeats_given: repeats.is_some(),
            time_budget: budget(sweep),
            shard: sweep.shard,
            max_points: sweep.max_points,
            seed_tables: true,
            ..experiments::Context::new(
                shared.clone(),
                data_dir.to_path_buf(),
                reports.join(exp.name()),
                quick,
                datasets,
            )
        };
        progress::note(format!(
            "== {} ({}/{}): {}",
            exp.name(),
            k + 1,
            to_run.len(),
            exp.summary()
        ));
        let t = std::time::Instant::now();
        if experiments::run(*exp, &ctx)? {
            progress::note(format!(
                "   {} done in {}",
                exp.name(),
                progress::duration(t.elapsed().as_secs_f64())
            ));
        } else {
            progress::note(format!("   not in shard {}", shard_text(sweep.shard)));
        }
    }
    drop(progress);
    match sweep.shard {
        None => {
            view::report::write_all(run, reports, data_dir)?;
            assemble_report(run, reports)?;
            println!(
                "bench: {} experiment(s) in {:.1} s; see {}",
                to_run.len(),
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

/// The seconds the previous run into `dir` took (its `metadata.json`), when it was a run of the
/// same mode over the same datasets and not a shard's.
fn previous_seconds(dir: &Path, quick: bool, datasets: &[String]) -> Option<f64> {
    let meta = output::meta::RunMeta::read(dir).ok()?;
    (meta.quick == quick && meta.datasets == datasets && meta.shard.is_none() && meta.seconds > 0.0)
        .then_some(meta.seconds)
}

/// `pointsight merge`: the shards' results merged into `out`, then its report page.
pub fn merge(run: &Run, out: &Path, shards: &[PathBuf]) -> Result<()> {
    for name in experiments::merge::merge(&run.catalogue, out, shards)? {
        println!("{name}: merged into {}", out.join(&name).display());
    }
    assemble_report(run, out)
}

/// `pointsight report`: the viewer pages and the report page of `reports`.
pub fn report(run: &Run, reports: &Path, data_dir: &Path) -> Result<()> {
    view::report::write_all(run, reports, data_dir)?;
    assemble_report(run, reports)?;
    println!("wrote {}", reports.join("README.md").display());
    Ok(())
}

/// `pointsight tables`.
pub fn tables(run: &Run, reports: &Path) -> Result<()> {
    let mut rendered = 0;
    for exp in experiments::EXPERIMENTS {
        let dir = reports.join(exp.name());
        if dir.join("metadata.json").exists() {
            exp.render(&run.catalogue, &dir)
                .with_context(|| format!("redrawing {}", dir.display()))?;
            output::folder::seal(&dir)?;
            rendered += 1;
        }
    }
    // An earlier run kept beside the sections (`output::report::kept_runs`) is redrawn by its
    // own experiment, so that its figures follow the same style as the sections'.
    let sections: Vec<output::report::Section<'_>> = experiments::EXPERIMENTS
        .iter()
        .map(|e| output::report::Section {
            name: e.name(),
            summary: e.summary(),
        })
        .collect();
    for (folder, _) in output::report::kept_runs(reports, &sections) {
        let Some(exp) = experiments::EXPERIMENTS.iter().find(|e| {
            folder
                .strip_prefix(e.name())
                .is_some_and(|rest| rest.starts_with('-'))
        }) else {
            continue;
        };
        let dir = reports.join(&folder);
        exp.render(&run.catalogue, &dir)
            .with_context(|| format!("redrawing {}", dir.display()))?;
        output::folder::seal(&dir)?;
    }
    if rendered == 0 {
        bail!(
            "no experiment results under {}: run an experiment first",
            reports.display()
        );
    }
    // The viewer pages keep their measured data; their script, styles and links are redrawn.
    view::report::refresh(run, reports)?;
    assemble_report(run, reports)?;
    println!(
        "redrew {rendered} experiment(s); wrote {}",
        reports.join("README.md").display()
    );
    Ok(())
}

/// `pointsight scale-cell`: one cell of the scale experiment, its JSON line on standard output.
pub fn scale_cell(
    run: &Run,
    cell: &experiments::scale::child::CellArgs,
    data_dir: &Path,
) -> Result<()> {
    experiments::scale::child::run_in_this_process(run, cell, data_dir)
}

/// The sweeps (built-in, external methods', `--config`'s, then `--set`'s over them) and
/// repeats of `flags`. The `--set` pairs must each be for a method with a sweep; the settings
/// they make are typed by each method's card here, before any data is read.
fn sweep_settings(run: &Run, flags: &cli::SweepFlags) -> Result<(registry::Sweeps, Option<usize>)> {
    let set = registry::Assignments::parse(&flags.set).map_err(visible::set_error)?;
    let user = flags
        .config
        .as_deref()
        .map(registry::Sweeps::read)
        .transpose()?;
    let mut sweeps = run.catalogue.sweeps(user)?;
    if !set.is_empty() {
        let cards: Vec<&registry::Card> = sweeps
            .methods
            .keys()
            .filter_map(|name| run.catalogue.card_named(name))
            .collect();
        set.check_targets(&run.catalogue, &cards)
            .map_err(visible::set_error)?;
        for card in cards {
            let Some(sweep) = sweeps.methods.get_mut(card.name) else {
                continue;
            };
            if set.over_sweep(card, sweep) {
                for setting in sweep.grid.iter().chain(&sweep.default) {
                    visible::typed(card, &setting.params(), &set)?;
                }
            }
        }
    }
    let repeats = flags.repeats.map(|r| r as usize).or(sweeps.repeats);
    Ok((sweeps, repeats))
}

/// `--time-budget` as the experiments take it (`inf`: none).
fn budget(flags: &cli::SweepFlags) -> Option<f64> {
    flags.time_budget.is_finite().then_some(flags.time_budget)
}

/// Writes the findings (`findings.csv`, and each experiment's rows as `findings.csv` and
/// `findings.md` in its folder) and the report page of `reports` over the experiment registry; the page is marked indicative when any experiment's results are a quick run's.
fn assemble_report(run: &Run, reports: &Path) -> Result<()> {
    let sections: Vec<output::report::Section<'_>> = experiments::EXPERIMENTS
        .iter()
        .map(|e| output::report::Section {
            name: e.name(),
            summary: e.summary(),
        })
        .collect();
    let names: Vec<&str> = sections.iter().map(|s| s.name).collect();
    let quick = names
        .iter()
        .any(|n| output::meta::RunMeta::read(&reports.join(n)).is_ok_and(|m| m.quick));
    let findings = experiments::findings::findings(reports, &names)?;
    experiments::findings::write(reports, &findings)?;
    // Every ratio against a peer, once (the summaries print the same rows).
    let ratios = experiments::ratios::all(reports)?;
    experiments::ratios::write(reports, &ratios)?;
    output::write_atomic(
        &reports.join(experiments::ratios::MD),
        experiments::ratios::markdown(&ratios).as_bytes(),
    )?;
    // Each experiment's own rows beside its results, every row (the README may leave some
    // out and links here).
    for name in &names {
        let dir = reports.join(name);
        let own: Vec<_> = findings
            .iter()
            .filter(|f| f.experiment == *name)
            .cloned()
            .collect();
        if own.is_empty() || !dir.is_dir() {
            continue;
        }
        let own_quick = output::meta::RunMeta::read(&dir).is_ok_and(|m| m.quick);
        experiments::findings::write(&dir, &own)?;
        output::write_atomic(
            &dir.join("findings.md"),
            experiments::findings::markdown(&own, own_quick).as_bytes(),
        )?;
    }
    output::report::assemble(
        reports,
        &sections,
        &format!(
            "{}{}",
            experiments::findings::readme_markdown(&findings, quick),
            if ratios.is_empty() {
                String::new()
            } else {
                format!(
                    "Every time ratio against a peer ({} rows), by one pairing rule, with the run \
                     it comes from: [ratios.md](ratios.md), machine-readable \
                     [ratios.csv](ratios.csv).\n\n",
                    ratios.len()
                )
            }
        ),
        quick,
        &view::report::section(reports)?,
    )?;
    output::landing::write(reports, &sections, &method_infos(&run.catalogue))?;
    // Each experiment's folder lists what the assembly added (its findings, its results page).
    for name in &names {
        let dir = reports.join(name);
        if dir.join("metadata.json").is_file() {
            output::folder::seal(&dir)?;
        }
    }
    Ok(())
}

/// `k/n`, or `-` without a shard.
fn shard_text(shard: Option<shard::Shard>) -> String {
    shard.map_or_else(|| "-".into(), |s| format!("{}/{}", s.k, s.n))
}

/// What the landing page says of every registered method (its card, in registry order).
fn method_infos(catalogue: &registry::Catalogue) -> Vec<output::landing::MethodInfo> {
    catalogue
        .cards()
        .into_iter()
        .map(|card| output::landing::MethodInfo {
            name: card.name.to_owned(),
            summary: card.summary.to_owned(),
            kind: match card.kind {
                registry::Kind::Visibility(_) => "visibility".into(),
                registry::Kind::Lod(_) => "level of detail".into(),
            },
            peer_of: card.peer_of.map(str::to_owned),
            made_for: card.made_for.as_str().to_owned(),
            exact: card.exact,
            default_setting: card.default_setting().label(),
            params: card
                .params
                .iter()
                .map(|p| {
                    let default = match p.default {
                        registry::ParamDefault::Value(v) => v.to_owned(),
                        registry::ParamDefault::Per { key, values } => values
                            .iter()
                            .map(|(at, v)| format!("{v} at {key}={at}"))
                            .collect::<Vec<_>>()
                            .join(", "),
                        registry::ParamDefault::Rule(rule) => rule.to_owned(),
                    };
                    (p.key.to_owned(), default, p.help.to_owned())
                })
                .collect(),
        })
        .collect()
}
