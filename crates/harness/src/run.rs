//! The run: what the command line, the manifest and the methods folders say, read once
//! before any data is read, into one value that the commands and experiments are handed
//! (ripgrep's `HiArgs`): the catalogue of methods (built-in and the external folders'), the
//! datasets (built-in and the manifest's) and the methods folders they came from. Nothing of
//! it lives in a process global, so two runs (a test's, a Python session's, an embedding
//! program's) sit side by side; the `scale` experiment's cells, which are child processes,
//! receive it as one file ([`Run::write_for_child`], [`Run::read_for_child`]).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use serde::{Deserialize, Serialize};

use crate::datasets::Datasets;
use crate::datasets::manifest::Manifest;

/// One run's catalogue, datasets and methods folders.
#[derive(Debug, Clone, Default)]
pub struct Run {
    /// Every method: built-in, then the external folders' ([`Run::add_methods`]).
    pub catalogue: registry::Catalogue,
    /// Every dataset: built-in, then the manifest's.
    pub datasets: Datasets,
    /// The methods folders read, in order.
    pub methods_dirs: Vec<PathBuf>,
}

/// What a child process of the run needs to build the same [`Run`]: the files it was read
/// from, which the child reads again.
#[derive(Debug, Serialize, Deserialize)]
struct ChildRun {
    manifest: Option<PathBuf>,
    methods_dirs: Vec<PathBuf>,
}

impl Run {
    /// The built-in methods and datasets alone.
    pub fn builtin() -> Self {
        Self::default()
    }

    /// The built-in methods, and the built-in datasets with `manifest`'s.
    pub fn with_manifest(manifest: Option<Manifest>) -> Self {
        Self {
            datasets: Datasets::new(manifest),
            ..Self::default()
        }
    }

    /// Adds the external methods of the folder `dir`. One whose name an earlier folder's
    /// method took is an error naming both folders (`why`: how the folder was chosen, said in
    /// that error); a built-in name is refused by the catalogue.
    pub fn add_methods(&mut self, dir: &Path, why: &str) -> Result<()> {
        use registry::methods::external::manifest::ExternalMethod;
        for m in ExternalMethod::load_dir(dir)? {
            if let Some(taken) = self
                .catalogue
                .card_named(m.name())
                .filter(|c| c.is_external())
            {
                let earlier = self
                    .methods_dirs
                    .iter()
                    .find(|p| p.join(taken.name).join("method.toml").is_file() && *p != dir)
                    .map_or_else(
                        || "an earlier methods folder".to_owned(),
                        |p| p.display().to_string(),
                    );
                anyhow::bail!(
                    "method {} of {} ({why}) is also in {earlier}: rename one folder's, or leave \
                     the installed methods out with --no-installed-methods",
                    m.name(),
                    dir.display(),
                );
            }
        }
        self.catalogue.add_external(dir)?;
        self.methods_dirs.push(dir.to_owned());
        Ok(())
    }

    /// Writes what a child process needs to build this run again into `path` (JSON: the
    /// manifest's file and the methods folders, absolute).
    pub fn write_for_child(&self, path: &Path) -> Result<()> {
        let child = ChildRun {
            manifest: self.datasets.manifest_path().map(absolute),
            methods_dirs: self.methods_dirs.iter().map(|p| absolute(p)).collect(),
        };
        cloud::io::atomic::write(path, serde_json::to_string(&child)?.as_bytes())
            .with_context(|| format!("writing the run for the cells to {}", path.display()))
    }

    /// The run a parent wrote with [`Run::write_for_child`] into `path`.
    pub fn read_for_child(path: &Path) -> Result<Self> {
        Self::read_for_child_onto(path, Self::builtin())
    }

    /// `base` (a program's own run, with the methods it added) with the parent's manifest and
    /// methods folders from `path` ([`Run::write_for_child`]).
    pub fn read_for_child_onto(path: &Path, base: Self) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading the run file {}", path.display()))?;
        let child: ChildRun = serde_json::from_str(&text)
            .with_context(|| format!("the run file {}", path.display()))?;
        // The parent's manifest or none: a child never discovers one of its own.
        let manifest = child.manifest.as_deref().map(Manifest::read).transpose()?;
        let mut run = Self {
            datasets: Datasets::new(manifest),
            ..base
        };
        for dir in &child.methods_dirs {
            if !run.methods_dirs.iter().any(|d| absolute(d) == *dir) {
                run.add_methods(dir, "the parent run's")?;
            }
        }
        Ok(run)
    }
}

/// `p` made absolute against the current folder (a child may run elsewhere).
pub(crate) fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn external(dir: &Path, name: &str) {
        let folder = dir.join(name);
        std::fs::create_dir_all(&folder).unwrap();
        std::fs::write(
            folder.join("method.toml"),
            "protocol = 1\nsummary = \"test\"\ncommand = [\"true\"]\n",
        )
        .unwrap();
    }

    #[test]
    fn two_runs_side_by_side_know_only_their_own_methods() {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        external(a.path(), "run-test-a");
        external(b.path(), "run-test-b");
        let mut first = Run::builtin();
        first.add_methods(a.path(), "test").unwrap();
        let mut second = Run::builtin();
        second.add_methods(b.path(), "test").unwrap();
        assert!(first.catalogue.card_named("run-test-a").is_some());
        assert!(first.catalogue.card_named("run-test-b").is_none());
        assert!(second.catalogue.card_named("run-test-b").is_some());
        assert!(second.catalogue.card_named("run-test-a").is_none());
        assert!(Run::builtin().catalogue.card_named("run-test-a").is_none());
        // The same name in a second folder is an error naming both.
        let c = tempfile::tempdir().unwrap();
        external(c.path(), "run-test-a");
        let err = first.add_methods(c.path(), "test").unwrap_err().to_string();
        assert!(
            err.contains(&a.path().display().to_string())
                && err.contains(&c.path().display().to_string()),
            "{err}"
        );
    }

    #[test]
    fn a_child_builds_the_same_run_from_one_file() {
        let dir = tempfile::tempdir().unwrap();
        external(dir.path(), "run-test-child");
        let manifest = dir.path().join("pointsight.toml");
        std::fs::write(
            &manifest,
            "[datasets.run-test-data]\nmesh = \"none.off\"\nsample = { n = 10, seed = 1 }\n",
        )
        .unwrap();
        let mut run = Run::with_manifest(Manifest::discover(Some(&manifest)).unwrap());
        run.add_methods(dir.path(), "test").unwrap();
        let file = dir.path().join("run.json");
        run.write_for_child(&file).unwrap();
        let child = Run::read_for_child(&file).unwrap();
        assert!(child.catalogue.card_named("run-test-child").is_some());
        assert!(child.datasets.check("run-test-data").is_ok());
        assert_eq!(child.methods_dirs, run.methods_dirs);
        assert!(Run::read_for_child(&dir.path().join("missing.json")).is_err());
    }
}
