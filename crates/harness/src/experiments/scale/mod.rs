//! Experiment `scale`: how each method's time and peak memory grow with the cloud size.
//!
//! Clouds of 10^4 … 10^7 points (quick: up to 10^6; `--max-points` up to 10^8 in core and
//! further out of core) are sampled from the dragon mesh (seeded,
//! area-weighted; `ChineseDragon-10kv.off`; `--datasets NAME` takes another dataset's mesh, the
//! first one given) and seen from its first Fibonacci view (pinhole, 1280 × 720). The cells
//! ([`plan::cells`]): every registered visibility method (built-in, registered at run time, external)
//! at its default setting, through the measurement kernel (`registry::kernel`); each hull
//! implementation on HPR's flipped set (γ = 4, the eye included), which measures hulls and so
//! calls `hull` directly; every registered LOD method's build (`NAME-build`) and selection
//! (`NAME-select`) at its default setting, through the kernel's LOD form, on the cloud prepared
//! as the `lod` experiment prepares it; each out-of-core LOD build (`NAME-build-ooc`,
//! [`plan::OOC_SUFFIX`]): the same samples written streamed as LAZ, then `pointsight lod-build` within
//! [`plan::OOC_LIMIT`], at 10^6 to 10^7 points (quick: 10^6; `--max-points N` up to N, such as
//! 10^9) under caps of its own ([`plan::OOC_CAP`]) and
//! a disk check. `seconds` is the operation alone (median of 3 runs up
//! to 10^6 points, one run above; sampling and per-cloud preparation excluded for per-view
//! operations, included for builds, which are the operation); a visibility cell's per-cloud
//! preparation (the ray caster's hierarchy, a learned method's feature pass) is its row's
//! `build_seconds`.
//!
//! Each cell runs in its own process (`pointsight scale-cell`, hidden: [`child::cell_entry`] is the
//! entry point a program that embeds the registry and registers its own methods forwards to,
//! since the cells re-run the current executable), so `peak_rss_bytes` is the cell's own: its
//! `VmHWM` (the sampled cloud plus what the method allocated) plus the largest peak of the
//! programs it waited for (an external method: `getrusage(RUSAGE_CHILDREN)`), and time caps
//! can stop it: the cap (40 s, quick 30 s) on the operation, counted from the line the cell
//! prints when its input is ready ([`child::Prepared`]), and three times that on the preparation
//! before it (sampling; a hull cell's flip; an LOD cell's normals), whose seconds are the row's
//! `prepare_seconds`. A cell is not started when the memory guard refuses its estimate
//! (`cloud::memory`, from the method's declared bytes per point, `registry::Memory`; a method
//! that declares none, such as an external one without `memory_bytes_per_point`, is not run
//! above 10^6 points), nor when the same method's time or preparation at the previous size,
//! grown by the factor it grew over the step before (at least 1; 10 with one size) and times
//! the runs the cell makes (3 up to 10^6 points), would exceed its cap ([`plan::skip_reason`]);
//! each such cell is a row saying so, as is a cell a cap stopped. A method may opt out
//! (`registry::Memory::OptOut`); the report lists it with its reason. The plots fit a slope per method on log–log axes over
//! the sizes that finished.

//!
//! The peer's out-of-core build, `copc_converter-build-ooc` ([`copc`]): copc_converter from the
//! same LAZ, with the same thread count and memory limit, beside ours.
//!
//! The normal-estimation family (`normals-NAME`, [`normals`]): ours, Open3D's and
//! point-cloud-utils' 16-neighbour normals of the same samples, each cell its own process as
//! the others, in alternated rounds at each size, with their accuracy against the mesh's
//! normals; the peers' time over ours is the median of the rounds' ratios.
//!
//! Modules: [`plan`] (cells, sizes, caps, skip rules), [`child`] (a cell in its own process),
//! [`cell`] (a cell's body), [`copc`] (the peer's build), [`normals`] (the normal-estimation
//! family), [`row`] (what a cell reports), [`render`] (the report).

pub mod cell;
pub mod child;
pub mod copc;
pub mod normals;
pub mod plan;
pub mod render;
pub mod row;

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context as _, Result};
use registry::Memory;

use self::child::run_cell;
use self::plan::{
    CellKind, OOC_CAP, OOC_LIMIT, PREPARE_CAP_FACTOR, SEED, cells, disk_free, ooc_sizes, sizes,
    skip_reason,
};
use self::row::Row;
use super::{Context, Experiment};
use crate::output::write_csv;

/// The experiment.
pub struct ScaleExperiment;

impl Experiment for ScaleExperiment {
    fn name(&self) -> &'static str {
        "scale"
    }

    fn summary(&self) -> &'static str {
        "time and peak memory of every method from 10^4 points up to --max-points (default 10^7), one process per cell, with fitted log-log slopes"
    }

    fn default_datasets(&self, _quick: bool) -> &'static [&'static str] {
        &["dragon-871414"]
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        // One mesh (the first dataset's; by default the dragon): the cells sample it
        // themselves. Fail early when it is missing; a user's mesh file goes into the run's
        // record with its checksum.
        let dataset = ctx
            .datasets
            .first()
            .context("scale needs a dataset with a mesh")?;
        let (_, files) = ctx.run.datasets.load_mesh_of(dataset, &ctx.data_dir)?;
        ctx.record_files(&files);
        // The run the cells build again (its manifest and methods folders): one file in the
        // staging folder, gone before the folder is published, whatever happens.
        let run_guard = RunFile(ctx.out_dir.join(".cells-run.json"));
        ctx.run.write_for_child(&run_guard.0)?;
        let run_file = run_guard.0.clone();
        let cap = Duration::from_secs(if ctx.quick { 30 } else { 40 });
        let in_core_sizes = sizes(ctx.quick, ctx.max_points);
        let ooc_sizes = ooc_sizes(ctx.quick, ctx.max_points);
        let kinds = cells(&ctx.run.catalogue, &ctx.sweeps);
        let sizes_of = |kind: &CellKind| {
            if kind.out_of_core {
                &ooc_sizes
            } else {
                &in_core_sizes
            }
        };
        let python = normals::python();
        let normal_kinds = normals::kinds(&python);
        let normal_sizes = normals::sizes(&in_core_sizes);
        let bar = crate::progress::bar(
            kinds.iter().map(|k| sizes_of(k).len() as u64).sum::<u64>()
                + (normal_kinds.len() * normal_sizes.len()) as u64,
            "scale",
        );
        let mut rows = Vec::new();
        let mut opted_out = Vec::new();
        for kind in &kinds {
            let method = kind.name.as_str();
            let sizes = sizes_of(kind);
            let cap = if kind.out_of_core { OOC_CAP } else { cap };
            let per_point = match &kind.memory {
                Memory::OptOut(why) => {
                    opted_out.push(serde_json::json!({"method": method, "reason": why}));
                    bar.inc(sizes.len() as u64);
                    continue;
                }
                Memory::PerPoint(b) => Some(*b),
                Memory::Unknown => None,
            };
            // (seconds, prepare seconds) at the previous size and the one before.
            let mut previous: Option<(f64, f64)> = None;
            let mut before: Option<(f64, f64)> = None;
            for &n in sizes {
                crate::progress::at(&format!("{n} points"), method);
                let not_run = |status: String| Row::not_run(method, n, status);
                // An out-of-core cell's disk: its build's (`NAME-build-ooc`).
                let disk_per_point = plan::ooc_disk_per_point(
                    method.strip_suffix(plan::OOC_SUFFIX).unwrap_or(method),
                );
                let needed_disk = n.saturating_mul(disk_per_point);
                let row = if let Some(why) = &kind.unavailable {
                    not_run(format!("skipped: not installed: {why}"))
                } else if per_point.is_none() && n > Memory::UNKNOWN_LIMIT {
                    not_run(format!(
                        "refused: its memory per point is not declared (memory_bytes_per_point \
                         in an external method's method.toml, its card's memory for a built-in one), \
                         so it is not run above {} points",
                        Memory::UNKNOWN_LIMIT
                    ))
                } else if kind.out_of_core
                    && let Err(e) = cloud::memory::ensure(
                        u128::from(OOC_LIMIT + (256 << 20)),
                        &format!("{method} on {n} points within {} MiB", OOC_LIMIT >> 20),
                    )
                {
                    not_run(format!("refused: {e}"))
                } else if kind.out_of_core
                    && let Some(free) = disk_free(&ctx.data_dir)
                        .ok()
                        .filter(|&free| free < needed_disk)
                {
                    not_run(format!(
                        "skipped: the disk under {} has {:.1} GB free, the cell needs about \
                         {:.1} GB ({disk_per_point} bytes per point: input, scratch, file)",
                        ctx.data_dir.display(),
                        free as f64 / 1e9,
                        needed_disk as f64 / 1e9
                    ))
                } else if !kind.out_of_core
                    && let Err(e) = cloud::memory::ensure(
                        u128::from(n) * u128::from(per_point.unwrap_or(0) + 48),
                        &format!("{method} on {n} points"),
                    )
                {
                    not_run(format!("refused: {e}"))
                } else if let Some(why) = skip_reason(previous, before, n, cap) {
                    not_run(why)
                } else {
                    run_cell(
                        &run_file,
                        dataset,
                        method,
                        &kind.setting,
                        n,
                        &ctx.data_dir,
                        cap,
                    )
                };
                before = previous;
                previous = Some((row.seconds, row.prepare_seconds));
                rows.push(row);
                bar.inc(1);
            }
        }
        // The normal-estimation family, in alternated rounds (`normals`); a run's cap has a
        // margin over the peer's own, so that the cell stops its peer before it is stopped.
        rows.extend(normals::measure(
            &normal_kinds,
            &normal_sizes,
            normals::CAP,
            ctx.quick,
            |m, n| {
                let row = run_cell(
                    &run_file,
                    dataset,
                    m,
                    &registry::Setting::default(),
                    n,
                    &ctx.data_dir,
                    normals::CAP + Duration::from_secs(30),
                );
                normals::remove_cell_dir(m, n);
                row
            },
            |m, n| crate::progress::at(&format!("{n} points"), m),
        ));
        bar.inc((normal_kinds.len() * normal_sizes.len()) as u64);
        bar.finish_and_clear();
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        Ok(serde_json::json!({
            "sizes": in_core_sizes,
            "out_of_core": {
                "methods": crate::lod_build::OUT_OF_CORE,
                "peer": copc::COPC_CONVERTER,
                "sizes": ooc_sizes,
                "memory_limit_bytes": OOC_LIMIT,
                "cap_seconds": OOC_CAP.as_secs(),
                "prepare_cap_seconds": (OOC_CAP * PREPARE_CAP_FACTOR).as_secs(),
                "disk_bytes_per_point": crate::lod_build::OOC_DISK_PER_POINT,
                "spt_disk_bytes_per_point": crate::lod_build::SPT_OOC_DISK_PER_POINT,
                "copc_converter_disk_bytes_per_point": plan::COPC_OOC_DISK_PER_POINT,
                "input": "LAZ (point format 0) written streamed by the cell from the same seeded samples",
            },
            "seed": SEED,
            "mesh_of": dataset,
            "view": 0,
            "cap_seconds": cap.as_secs(),
            "prepare_cap_seconds": (cap * PREPARE_CAP_FACTOR).as_secs(),
            "repeats": "3 up to 10^6 points, 1 above",
            "cells": kinds.iter().map(|k| serde_json::json!({
                "method": k.name,
                "setting": k.setting.label(),
                "bytes_per_point": match &k.memory { Memory::PerPoint(b) => Some(b + 48), _ => None },
            })).collect::<Vec<_>>(),
            "opted_out": opted_out,
            "normals": {
                "k": normals::K,
                "rounds": normals::rounds(ctx.quick),
                "cap_seconds": normals::CAP.as_secs(),
                "sizes": normal_sizes,
                "python": python.display().to_string(),
                "cells": normal_kinds.iter().map(|k| serde_json::json!({
                    "method": k.name,
                    "not_installed": k.unavailable,
                })).collect::<Vec<_>>(),
            },
        }))
    }

    fn render(&self, catalogue: &registry::Catalogue, dir: &Path) -> Result<()> {
        render::render(catalogue, dir)
    }
}

/// The run file of the cells ([`crate::run::Run::write_for_child`]), removed when dropped.
struct RunFile(PathBuf);

impl Drop for RunFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}
