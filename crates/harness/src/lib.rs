//! The pointsight harness: the benchmark and the `pointsight` command, between the method
//! registry (the `registry` crate: methods, `--set` parameters, scores) and a researcher.
//!
//! - [`datasets`]: the datasets (built-in table, user files, manifests); [`fetch`]: the real
//!   meshes;
//! - [`lod_build`]: LOD files built within a memory limit, out of core (`lod-build`);
//! - [`experiments`]: the experiment registry and its frame (measure to CSV, render from CSV);
//! - [`output`]: atomic files, CSV, run metadata, plots, the report page; [`rss`]: peak memory;
//! - [`paths`]: where the data, methods and reports folders and the page scripts are (the one
//!   rule, from any working directory); [`progress`]: bars and the run's line on standard
//!   error;
//! - [`visible`]: one method on one view or many; [`view`]: the interactive 3D page of
//!   every method's visible set; [`cli`], [`run`] (the dispatcher) and [`commands`] (their
//!   bodies): the `pointsight` command;
//! - [`guard`]: what every command runs under: outputs checked and locked, stale scratch
//!   reclaimed, signals answered.
//!
//! Only this crate does command-line parsing, plotting and report I/O; the method crates
//! return values and typed errors.

pub mod cli;
pub mod commands;
pub mod datasets;
pub mod experiments;
pub mod fetch;
pub mod guard;
pub mod lod_build;
pub mod output;
pub mod paths;
pub mod progress;
pub mod rss;
pub mod run;
pub mod shard;
pub mod stats;
pub mod view;
pub mod visible;

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::{Cli, Command};

/// Runs a parsed command line: resolves the folders ([`paths`]), reads the manifest and the
/// external methods into the run's one value ([`run::Run`]), then hands the command and the
/// run to its body in [`commands`]. A scale cell given its parent's run file builds its run
/// from that file alone.
pub fn run(cli: Cli) -> Result<ExitCode> {
    progress::set_quiet(cli.quiet);
    let clone = paths::working_clone();
    let data = paths::data_dir(cli.data_dir, clone.as_deref())?;
    let data_dir = data.path.clone();
    let methods = paths::methods_folders(
        std::env::var_os("POINTSIGHT_METHODS").as_deref(),
        clone.as_deref(),
        cli.no_installed_methods,
        &cli.methods_dir,
    );
    let parents_run = match &cli.command {
        Command::ScaleCell(cell) => cell.run.clone(),
        _ => None,
    };
    let the_run = match parents_run {
        Some(file) => run::Run::read_for_child(&file)?,
        None => {
            let mut the_run = run::Run::with_manifest(datasets::manifest::Manifest::discover(
                cli.manifest.as_deref(),
            )?);
            for folder in &methods {
                match folder.warning() {
                    // Said where methods matter; the scale experiment's cells are its
                    // children, which the parent has warned for.
                    Some(warning) => {
                        if uses_methods(&cli.command) {
                            eprintln!("{warning}");
                        }
                    }
                    None => the_run.add_methods(&folder.path, &folder.why())?,
                }
            }
            the_run
        }
    };
    let reports = |given: Option<std::path::PathBuf>, quick: bool| {
        given.unwrap_or_else(|| paths::reports_dir(quick, clone.as_deref()))
    };
    // Outputs checked and locked, stale scratch reclaimed, signals answered.
    let _guard = guard::begin(&cli.command, &reports)?;
    // Dropped before the guard: the warm programs end before the run's outputs are released.
    let _programs = the_run.catalogue.end_programs_on_drop();
    match cli.command {
        Command::Fetch => commands::data::fetch(&data_dir)?,
        Command::Paths => commands::data::paths(&data, &methods, clone.as_deref()),
        Command::Datasets => commands::data::list_datasets(&the_run, &data_dir)?,
        Command::Methods { check } => commands::catalogue::list_methods(&the_run, check)?,
        Command::Sweeps => commands::catalogue::sweeps(),
        Command::Clean { folders, remove } => guard::clean_command(folders, remove)?,
        Command::Export {
            dataset,
            out,
            normals,
        } => commands::data::export(&the_run, &dataset, &out, normals, &data_dir)?,
        Command::Inspect {
            file,
            format,
            classes,
            scan,
            columns,
        } => commands::data::inspect(&file, format, classes, scan, columns)?,
        Command::Views {
            dataset,
            out,
            format,
        } => commands::data::views(&the_run, &dataset, out.as_deref(), format, &data_dir)?,
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
            let request = visible::Request {
                view: commands::visible_view::default_view(view, &source),
                source: commands::visible_view::source_of(source)?,
                method,
                set,
                out,
                score,
                parallel_views,
                repeat,
            };
            commands::visible_view::visible(&the_run, &request, &data_dir)?
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
            let request = view::Request {
                source: commands::visible_view::source_of(source)?,
                view,
                methods,
                set,
                max_points,
                png,
                out,
            };
            commands::visible_view::view(&the_run, &request, lod, distance, &data_dir)?
        }
        Command::LodBuild {
            cloud,
            method,
            memory_limit,
            out,
            in_memory,
        } => commands::lod::lod_build(&cloud, &method, &memory_limit, &out, in_memory)?,
        Command::ScaleCell(cell) => commands::experiments::scale_cell(&the_run, &cell, &data_dir)?,
        Command::Run {
            experiment,
            datasets,
            quick,
            out,
            files,
            camera,
            sweep,
        } => {
            let request = commands::experiments::RunRequest {
                experiment,
                datasets,
                quick,
                out,
                source: commands::visible_view::source_from(None, files, camera)?,
                reports: reports(None, quick),
            };
            commands::experiments::run(&the_run, &request, &sweep, data_dir)?
        }
        Command::Bench {
            quick,
            datasets,
            experiments,
            reports: given,
            sweep,
        } => commands::experiments::bench(
            &the_run,
            quick,
            datasets,
            experiments,
            &reports(given, quick),
            &sweep,
            &data_dir,
        )?,
        Command::Merge { out, shards } => commands::experiments::merge(&the_run, &out, &shards)?,
        Command::Report { reports: given } => {
            commands::experiments::report(&the_run, &reports(given, false), &data_dir)?
        }
        Command::Tables { reports: given } => {
            commands::experiments::tables(&the_run, &reports(given, false))?
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// True for the commands that run or list external methods, which say when the methods folder
/// cannot be read.
fn uses_methods(command: &Command) -> bool {
    matches!(
        command,
        Command::Methods { .. }
            | Command::Visible { .. }
            | Command::View { .. }
            | Command::Run { .. }
            | Command::Bench { .. }
            | Command::Report { .. }
    )
}
