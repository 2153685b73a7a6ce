//! The pointsight harness: the benchmark and the `pointsight` command, between the method
//! registry (the `registry` crate: methods, `--set` parameters, scores) and a researcher.
//!
//! - [`datasets`]: the datasets (built-in table, user files, manifests); [`fetch`]: the real
//!   meshes;
//! - [`lod_build`]: LOD files built within a memory limit, out of core (`lod-build`);
//! - [`experiments`]: the experiment registry and its frame (measure to CSV, render from CSV);
//! - [`output`]: atomic files, CSV, run metadata, plots, the report page; [`rss`]: peak memory;
//! - [`visible`]: one method on one view or many; [`view`]: the interactive 3D page of
//!   every method's visible set; [`cli`], [`run`] (the dispatcher) and [`commands`] (their
//!   bodies): the `pointsight` command.
//!
//! Only this crate does command-line parsing, plotting and report I/O; the method crates
//! return values and typed errors.

pub mod cli;
pub mod commands;
pub mod datasets;
pub mod experiments;
pub mod fetch;
pub mod lod_build;
pub mod output;
pub mod progress;
pub mod rss;
pub mod shard;
pub mod stats;
pub mod view;
pub mod visible;

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::{Cli, Command};

/// Runs a parsed command line: reads the manifest and the external methods, then hands the
/// command to its body in [`commands`].
pub fn run(cli: Cli) -> Result<ExitCode> {
    let data_dir = cli.data_dir;
    datasets::use_manifest(datasets::manifest::Manifest::discover(
        cli.manifest.as_deref(),
    )?);
    registry::register_external(&cli.methods_dir)?;
    match cli.command {
        Command::Fetch => commands::data::fetch(&data_dir)?,
        Command::Datasets => commands::data::list_datasets(&data_dir, cli.manifest.as_deref())?,
        Command::Methods => commands::catalogue::list_methods()?,
        Command::Sweeps => commands::catalogue::sweeps(),
        Command::Export { dataset, out } => commands::data::export(&dataset, &out, &data_dir)?,
        Command::Inspect {
            file,
            format,
            classes,
            scan,
        } => commands::data::inspect(&file, format, classes, scan)?,
        Command::Views {
            dataset,
            out,
            format,
        } => commands::data::views(&dataset, out.as_deref(), format, &data_dir)?,
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
                view: commands::look::default_view(view, &source),
                source: commands::look::source_of(source)?,
                method,
                set,
                out,
                score,
                parallel_views,
                repeat,
            };
            commands::look::visible(&request, &data_dir)?
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
                source: commands::look::source_of(source)?,
                view,
                methods,
                set,
                max_points,
                png,
                out,
            };
            commands::look::view(&request, lod, distance, &data_dir)?
        }
        Command::LodBuild {
            cloud,
            method,
            memory_limit,
            out,
            in_memory,
        } => commands::lod::lod_build(&cloud, &method, &memory_limit, &out, in_memory)?,
        Command::ScaleCell(cell) => commands::experiments::scale_cell(&cell, &data_dir)?,
        Command::Run {
            experiment,
            datasets,
            quick,
            out,
            views,
            sweep,
        } => {
            commands::experiments::run(&experiment, datasets, quick, out, views, &sweep, data_dir)?
        }
        Command::Bench {
            quick,
            datasets,
            reports,
            sweep,
        } => commands::experiments::bench(quick, datasets, &reports, &sweep, &data_dir)?,
        Command::Merge { out, shards } => commands::experiments::merge(&out, &shards)?,
        Command::Report { reports } => commands::experiments::report(&reports, &data_dir)?,
        Command::Tables { reports } => commands::experiments::tables(&reports)?,
    }
    Ok(ExitCode::SUCCESS)
}
