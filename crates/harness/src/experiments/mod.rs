//! The experiment registry and the frame every experiment runs in.
//!
//! An experiment measures (writes raw CSV rows and `metadata.json` into its output folder) and
//! renders (reads its CSVs back and writes plots, tables and `summary.md`). The two halves are
//! separate so `pointsight tables` can redraw everything from the CSVs without re-running.
//! Adding an experiment is one module and one line in [`EXPERIMENTS`].

mod background;
mod hull;
mod lod;
mod reference;
mod robustness;
pub mod scale;
mod visibility;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};

use crate::output::meta::RunMeta;

/// Where and how an experiment runs.
#[derive(Debug, Clone)]
pub struct Context {
    /// Fetched data (`bench-data/`).
    pub data_dir: PathBuf,
    /// Output folder of this experiment (`reports/NAME/` by default).
    pub out_dir: PathBuf,
    /// Quick mode: fewer datasets, views and repeats.
    pub quick: bool,
    /// Datasets to cover.
    pub datasets: Vec<String>,
    /// A views file replacing every dataset's own views (`run --views`).
    pub views: Option<PathBuf>,
    /// User files the loaded datasets came from, for the run metadata.
    pub files: std::sync::Arc<std::sync::Mutex<Vec<crate::datasets::SourceFile>>>,
}

impl Context {
    /// Loads dataset `name`, with the views of `--views` when given.
    pub fn dataset(&self, name: &str) -> Result<crate::datasets::Dataset> {
        let mut ds = crate::datasets::load(name, &self.data_dir)?;
        if let Some(path) = &self.views {
            ds.views = cloud::io::views::read_views(path)?
                .iter()
                .map(|c| ds.camera_from_world(c))
                .collect();
        }
        if let Ok(mut files) = self.files.lock() {
            for f in &ds.files {
                if !files.contains(f) {
                    files.push(f.clone());
                }
            }
        }
        Ok(ds)
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
    fn render(&self, dir: &Path) -> Result<()>;
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

/// Runs `exp`: measure, write metadata, render.
///
/// Everything is written into a staging folder beside the output folder
/// (`.NAME.partial`), which replaces the output folder only when the experiment has finished:
/// an interrupted run leaves the previous results as they were.
pub fn run(exp: &dyn Experiment, ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let mut meta = RunMeta::now(
        exp.name(),
        ctx.quick,
        &ctx.datasets,
        serde_json::Value::Null,
    );
    let out = &ctx.out_dir;
    let file_name = out
        .file_name()
        .with_context(|| format!("{} has no folder name", out.display()))?
        .to_string_lossy()
        .into_owned();
    let staging = out.with_file_name(format!(".{file_name}.partial"));
    let previous = out.with_file_name(format!(".{file_name}.previous"));
    for stale in [&staging, &previous] {
        if stale.exists() {
            std::fs::remove_dir_all(stale)
                .with_context(|| format!("cannot remove {}", stale.display()))?;
        }
    }
    std::fs::create_dir_all(&staging)
        .with_context(|| format!("cannot create {}", staging.display()))?;
    let staged = Context {
        out_dir: staging.clone(),
        ..ctx.clone()
    };
    meta.parameters = exp.measure(&staged)?;
    meta.user_files = ctx.files.lock().map(|f| f.clone()).unwrap_or_default();
    meta.seconds = start.elapsed().as_secs_f64();
    meta.write(&staging)?;
    exp.render(&staging)?;
    if out.exists() {
        std::fs::rename(out, &previous)
            .with_context(|| format!("cannot move {} aside", out.display()))?;
    }
    std::fs::rename(&staging, out)
        .with_context(|| format!("cannot move {} into place", out.display()))?;
    if previous.exists() {
        std::fs::remove_dir_all(&previous)
            .with_context(|| format!("cannot remove {}", previous.display()))?;
    }
    Ok(())
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

/// Runs per timed call in the experiments: enough for a median and a spread.
pub const REPEATS: usize = 3;

/// Runs `f` [`REPEATS`] times with the one timing helper (`registry::timing`): its output and
/// the timing (median and spread).
pub(crate) fn timed<T>(f: impl FnMut() -> Result<T>) -> Result<(T, registry::timing::Timing)> {
    registry::timing::measure(REPEATS, f)
}
