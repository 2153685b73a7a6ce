//! The experiment registry and the frame every experiment runs in.
//!
//! An experiment measures (writes raw CSV rows and `metadata.json` into its output folder) and
//! renders (reads its CSVs back and writes plots, tables and `summary.md`). The two halves are
//! separate so `pointsight tables` can redraw everything from the CSVs without re-running.
//! Adding an experiment is one module and one line in [`EXPERIMENTS`].

mod background;
pub mod findings;
pub mod hull;
pub(crate) mod lod;
pub mod merge;
pub mod ratios;
mod reference;
mod robustness;
pub mod rules;
pub mod scale;
mod visibility;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};

use crate::output::meta::RunMeta;
use crate::shard::Shard;

/// Where and how an experiment runs.
#[derive(Debug, Clone)]
pub struct Context {
    /// The run: its catalogue of methods and its datasets.
    pub run: std::sync::Arc<crate::run::Run>,
    /// Fetched data (`bench-data/`).
    pub data_dir: PathBuf,
    /// Output folder of this experiment (`reports/NAME/` by default).
    pub out_dir: PathBuf,
    /// Quick mode: fewer datasets, views and repeats.
    pub quick: bool,
    /// Datasets to cover.
    pub datasets: Vec<String>,
    /// The user's files (`run --cloud FILE`, a dataset named by [`crate::visible::Source::name`])
    /// and the cameras (`--eye`, `--views`) replacing every dataset's own views: loaded by
    /// [`crate::visible::load_source`], as `visible` and `view` load theirs. Empty by default.
    pub source: crate::visible::Source,
    /// Run the seed tables replicated inside an experiment on their own datasets (seed 003's
    /// Table 1 in `lod`) whether or not [`Context::datasets`] names them: true for `bench` and
    /// for `run` with the experiment's own datasets; otherwise a table covers only its datasets
    /// that are named, and never a user's files.
    pub seed_tables: bool,
    /// User files the loaded datasets came from, for the run metadata.
    pub files: std::sync::Arc<std::sync::Mutex<Vec<crate::datasets::SourceFile>>>,
    /// Every method's sweep: the built-in grids, the external methods' and `--config`'s.
    pub sweeps: registry::Sweeps,
    /// Timed runs per call (`--repeats`, or the sweeps file's `repeats`; default [`REPEATS`]).
    pub repeats: usize,
    /// True when the user set `repeats` (`--repeats` or the sweeps file): experiments that
    /// measure accuracy rather than speed (`robustness`) time one run per call otherwise.
    pub repeats_given: bool,
    /// Seconds after which a call stops repeating (`--time-budget`; default [`TIME_BUDGET`]);
    /// `None`: always `repeats` runs.
    pub time_budget: Option<f64>,
    /// The part of the cells this process runs (`--shard K/N`); `None`: all.
    pub shard: Option<Shard>,
    /// `scale`: the largest cloud size (`--max-points`; [`scale`]'s `plan::sizes` and
    /// `plan::ooc_sizes` say what it does to each kind of cell).
    pub max_points: Option<u64>,
}

impl Context {
    /// A context of `run` with the built-in sweeps, [`REPEATS`] and no shard.
    pub fn new(
        run: std::sync::Arc<crate::run::Run>,
        data_dir: PathBuf,
        out_dir: PathBuf,
        quick: bool,
        datasets: Vec<String>,
    ) -> Self {
        Self {
            run,
            data_dir,
            out_dir,
            quick,
            datasets,
            source: Default::default(),
            seed_tables: false,
            files: Default::default(),
            sweeps: registry::Sweeps::builtin(),
            repeats: REPEATS,
            repeats_given: false,
            time_budget: Some(TIME_BUDGET),
            shard: None,
            max_points: None,
        }
    }

    /// Runs `f` [`Context::repeats`] times with the one timing helper (`registry::timing`):
    /// its output and the timing (median and spread).
    pub fn timed<T>(&self, f: impl FnMut() -> Result<T>) -> Result<(T, registry::timing::Timing)> {
        registry::timing::measure(self.repeats, f)
    }

    /// Timed runs per call of an experiment that measures accuracy: [`Context::repeats`] when
    /// the user set it, else one.
    pub fn accuracy_repeats(&self) -> usize {
        if self.repeats_given { self.repeats } else { 1 }
    }

    /// Every registered visibility method with a non-empty sweep, in registry order, that can
    /// run here; the others (an external method whose environment is missing) listed with why.
    pub fn methods_to_run(
        &self,
    ) -> (
        Vec<(&'static registry::Card, registry::MethodSweep)>,
        Vec<String>,
    ) {
        let mut not_run = Vec::new();
        let mut out = Vec::new();
        for m in self.run.catalogue.visibility_cards() {
            let Some(sweep) = self
                .sweeps
                .methods
                .get(m.name)
                .filter(|s| !s.settings(self.quick).is_empty())
            else {
                continue;
            };
            match m.availability() {
                Ok(()) => out.push((m, sweep.clone())),
                Err(why) => not_run.push(format!("{}: {why}", m.name)),
            }
        }
        (out, not_run)
    }

    /// True when this process runs view `view` of the `dataset`-th dataset (of an experiment
    /// that covers `views_per_dataset` views of each): cells are numbered dataset-major and
    /// dealt round-robin to the shards.
    pub fn owns(&self, dataset: usize, view: usize, views_per_dataset: usize) -> bool {
        self.shard
            .is_none_or(|s| s.owns(dataset * views_per_dataset.max(1) + view))
    }
}

impl Context {
    /// Loads dataset `name` ([`Context::source`]'s files when it names them), with the
    /// cameras of `--eye` or `--views` when given.
    pub fn dataset(&self, name: &str) -> Result<crate::datasets::Dataset> {
        let source = if self.source.cloud.is_some() && self.source.name().as_deref() == Some(name) {
            self.source.clone()
        } else {
            self.source.for_dataset(name)
        };
        let ds = crate::visible::load_source(&self.run, &source, &self.data_dir)?;
        self.record_files(&ds.files);
        Ok(ds)
    }

    /// True when the user's files of `run --cloud` are the run's datasets.
    pub fn on_user_files(&self) -> bool {
        self.source.cloud.is_some()
    }

    /// Records user files a dataset came from, for the run metadata.
    pub fn record_files(&self, source: &[crate::datasets::SourceFile]) {
        if let Ok(mut files) = self.files.lock() {
            for f in source {
                if !files.contains(f) {
                    files.push(f.clone());
                }
            }
        }
    }
}

/// An experiment.
pub trait Experiment: Sync {
    /// Name on the command line and folder name under `reports/`.
    fn name(&self) -> &'static str;
    /// One line for listings and the report page.
    fn summary(&self) -> &'static str;
    /// Datasets covered when `--datasets` is not given.
    fn default_datasets(&self, quick: bool) -> &'static [&'static str];
    /// Measures; writes CSVs into `ctx.out_dir`; returns the parameters for the metadata.
    fn measure(&self, ctx: &Context) -> Result<serde_json::Value>;
    /// Reads the CSVs in `dir` and writes plots, tables and `summary.md`.
    fn render(&self, catalogue: &registry::Catalogue, dir: &Path) -> Result<()>;
    /// True when the experiment splits its (dataset, view) cells over shards
    /// ([`Context::owns`]) and its CSVs are rows of those cells, which `pointsight merge`
    /// concatenates. Otherwise a sharded run gives the whole experiment to one shard.
    fn shardable(&self) -> bool {
        false
    }
}

/// Every experiment, in report order.
pub static EXPERIMENTS: &[&dyn Experiment] = &[
    &reference::ReferenceExperiment,
    &hull::HullExperiment,
    &background::BackgroundExperiment,
    &visibility::VisibilityExperiment,
    &robustness::RobustnessExperiment,
    &lod::LodExperiment,
    &scale::ScaleExperiment,
];

/// Looks an experiment up by name.
pub fn experiment(name: &str) -> Result<&'static dyn Experiment> {
    EXPERIMENTS
        .iter()
        .copied()
        .find(|e| e.name() == name)
        .with_context(|| {
            format!(
                "unknown experiment {name:?}; known experiments: {}",
                EXPERIMENTS
                    .iter()
                    .map(|e| e.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
}

/// Runs `exp`: measure, write metadata, render, and (unsharded) its findings beside them.
/// Returns false (and does nothing) when a sharded run gives this experiment to another shard:
/// an experiment that does not split its cells ([`Experiment::shardable`]) is one cell, dealt
/// by its position in [`EXPERIMENTS`].
///
/// The output folder is written whole ([`crate::output::folder::replace`]): everything goes
/// into a staging folder beside it (`.NAME.partial-HOST-PID-K`, this process's own), which
/// replaces the output folder only when the experiment has finished and the folder holds
/// nothing pointsight did not write. An interrupted run leaves the previous results as they
/// were, and a run that fails removes its staging folder too; a signal removes it through
/// `cloud::scratch`'s registry, and a run killed outright leaves it to the next run beside the
/// same output, which reclaims it.
pub fn run(exp: &dyn Experiment, ctx: &Context) -> Result<bool> {
    if let Some(shard) = ctx.shard
        && !exp.shardable()
    {
        let position = EXPERIMENTS
            .iter()
            .position(|e| e.name() == exp.name())
            .unwrap_or(0);
        if !shard.owns(position) {
            return Ok(false);
        }
    }
    let start = Instant::now();
    let meta = RunMeta::now(
        exp.name(),
        ctx.quick,
        &ctx.datasets,
        serde_json::Value::Null,
    );
    crate::output::folder::replace(
        &ctx.out_dir,
        crate::output::folder::Role::Experiment,
        |staging| stage(exp, ctx, meta, start, staging),
    )?;
    Ok(true)
}

/// Every peer of `catalogue`, visibility and LOD (a method whose `peer_of` names one of ours),
/// with what it pairs with and its version (its `version` command, run once per process), or
/// `not installed` and why: the run metadata's `peers`.
pub fn peers_metadata(
    catalogue: &registry::Catalogue,
) -> serde_json::Map<String, serde_json::Value> {
    let mut out = serde_json::Map::new();
    let mut add = |name: &str,
                   peer_of: &str,
                   availability: std::result::Result<(), String>,
                   version: &dyn Fn() -> Option<String>| {
        let entry = match availability {
            Ok(()) => serde_json::json!({
                "peer_of": peer_of,
                "version": version().unwrap_or_else(|| "unknown (no version command)".into()),
            }),
            Err(why) => serde_json::json!({
                "peer_of": peer_of,
                "version": "not installed",
                "why": why,
            }),
        };
        out.insert(name.to_owned(), entry);
    };
    for m in catalogue.cards() {
        if let Some(p) = m.peer_of {
            add(m.name, p, m.availability(), &|| m.version());
        }
    }
    out
}

/// Measures, writes the metadata and renders into `staging`.
fn stage(
    exp: &dyn Experiment,
    ctx: &Context,
    mut meta: RunMeta,
    start: Instant,
    staging: &Path,
) -> Result<()> {
    let staged = Context {
        out_dir: staging.to_owned(),
        ..ctx.clone()
    };
    meta.shard = ctx.shard;
    meta.parameters = exp.measure(&staged)?;
    meta.user_files = ctx.files.lock().map(|f| f.clone()).unwrap_or_default();
    meta.peers = peers_metadata(&ctx.run.catalogue);
    meta.seconds = start.elapsed().as_secs_f64();
    meta.write(staging)?;
    // A shard's output is drawn once merged (`pointsight merge`); a shard alone may hold too
    // few cells for some plots.
    if ctx.shard.is_none() {
        exp.render(&ctx.run.catalogue, staging)?;
        findings::write_in(staging, exp.name())?;
    }
    crate::output::folder::seal(staging)
}

/// Markdown table from a header and rows.
pub fn markdown_table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = format!(
        "| {} |\n|{}|\n",
        header.join(" | "),
        header.iter().map(|_| "---").collect::<Vec<_>>().join("|")
    );
    for row in rows {
        s.push_str(&format!("| {} |\n", row.join(" | ")));
    }
    s
}

/// Runs per timed call in the experiments by default: enough for a median and a spread.
pub const REPEATS: usize = 3;

/// Seconds of timed runs after which a call stops repeating (`registry::timing::measure_within`):
/// a call of 0.25 s or more is timed twice, one of half a second or more once (the dragon's
/// HPR cells and every peer on it, Qhull's and CGAL's hulls), instead of three times. Their
/// spread is then the views', which is what the paired comparisons bootstrap over; a single
/// run of half a second is long beside the scheduler's and the clock's noise. From the
/// committed runs' rows, 0.5 instead of 1 s takes about 90 s off `visibility` and 30 s off
/// `hull` (out of 1,150 and 420 s of timed calls).
pub const TIME_BUDGET: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes a result into its output folder, then fails in `measure` or in `render`.
    struct Failing {
        in_render: bool,
    }

    impl Experiment for Failing {
        fn name(&self) -> &'static str {
            "failing"
        }
        fn summary(&self) -> &'static str {
            "fails after writing"
        }
        fn default_datasets(&self, _quick: bool) -> &'static [&'static str] {
            &[]
        }
        fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
            std::fs::write(ctx.out_dir.join("results.csv"), "a\n1\n")?;
            if self.in_render {
                Ok(serde_json::Value::Null)
            } else {
                anyhow::bail!("injected failure in measure")
            }
        }
        fn render(&self, _: &registry::Catalogue, _dir: &Path) -> Result<()> {
            anyhow::bail!("injected failure in render")
        }
    }

    #[test]
    fn a_failed_run_removes_its_staging_folder_and_keeps_the_previous_results() {
        for in_render in [false, true] {
            let dir = tempfile::tempdir().unwrap();
            let out = dir.path().join("failing");
            std::fs::create_dir_all(&out).unwrap();
            std::fs::write(out.join("results.csv"), "previous").unwrap();
            let ctx = Context::new(
                Default::default(),
                dir.path().into(),
                out.clone(),
                true,
                Vec::new(),
            );
            let err = run(&Failing { in_render }, &ctx).unwrap_err().to_string();
            let stage = if in_render { "render" } else { "measure" };
            assert_eq!(err, format!("injected failure in {stage}"));
            let left: Vec<String> = std::fs::read_dir(dir.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(left, vec!["failing".to_owned()], "{stage}");
            assert_eq!(
                std::fs::read_to_string(out.join("results.csv")).unwrap(),
                "previous"
            );
            assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
        }
    }
}
