//! Run metadata: what ran, where, when, from which revision, with which parameters.

use std::path::Path;
use std::process::Command;

use anyhow::Result;
use serde::{Deserialize, Serialize};

use super::write_atomic;

/// Written as `metadata.json` beside every experiment's results.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunMeta {
    /// Experiment name.
    pub experiment: String,
    /// Start of the run, UTC, RFC 3339.
    pub date_utc: String,
    /// `git rev-parse HEAD`, or "unknown".
    pub git_revision: String,
    /// True when the work tree had uncommitted changes outside `reports/` (results are not code).
    pub git_dirty: bool,
    /// `rustc -V` of the compiler that built the harness.
    pub rustc: String,
    /// CPU model name.
    pub cpu: String,
    /// Logical cores available to the run.
    pub cores: usize,
    /// Operating system and architecture.
    pub os: String,
    /// The command line.
    pub command: String,
    /// Quick mode.
    pub quick: bool,
    /// Datasets the run covered.
    pub datasets: Vec<String>,
    /// Experiment-specific parameters (sweeps, repeats, seeds).
    pub parameters: serde_json::Value,
    /// The user files datasets were read from (manifests), with their SHA-256.
    #[serde(default)]
    pub user_files: Vec<crate::datasets::SourceFile>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
    /// Every registered peer (a method whose `peer_of` names one of ours): what it pairs with
    /// and its version, or why it is not installed.
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub peers: serde_json::Map<String, serde_json::Value>,
    /// For one shard's run (`--shard K/N`): which part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<crate::shard::Shard>,
    /// For a merged run (`pointsight merge`): each shard's own metadata (its machine, revision,
    /// date and seconds).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shards: Vec<RunMeta>,
    /// Every file the run wrote into its folder (relative, `/`-separated), `metadata.json`
    /// aside: what marks them as pointsight's, so that a folder holding anything else is never
    /// replaced (`output::folder`). Written last ([`super::folder::seal`]); absent in the
    /// metadata of a run that has not finished writing, and of older versions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub files: Option<Vec<String>>,
}

impl RunMeta {
    /// Metadata of a run starting now.
    pub fn now(
        experiment: &str,
        quick: bool,
        datasets: &[String],
        parameters: serde_json::Value,
    ) -> Self {
        let (git_revision, git_dirty) = git_state();
        Self {
            experiment: experiment.to_owned(),
            date_utc: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
            git_revision,
            git_dirty,
            rustc: env!("POINTSIGHT_RUSTC").to_owned(),
            cpu: cpu_model(),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
            command: std::env::args().collect::<Vec<_>>().join(" "),
            quick,
            datasets: datasets.to_vec(),
            parameters,
            user_files: Vec::new(),
            peers: serde_json::Map::new(),
            seconds: 0.0,
            shard: None,
            shards: Vec::new(),
            files: None,
        }
    }

    /// Writes `metadata.json` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<()> {
        write_atomic(
            &dir.join("metadata.json"),
            serde_json::to_string_pretty(self)?.as_bytes(),
        )
    }

    /// Reads `dir/metadata.json`.
    pub fn read(dir: &Path) -> Result<Self> {
        Ok(serde_json::from_slice(&std::fs::read(
            dir.join("metadata.json"),
        )?)?)
    }

    /// One line for report pages.
    pub fn describe(&self) -> String {
        format!(
            "{} · git {}{} · {} · {} ({} cores) · {}{}",
            self.date_utc,
            &self.git_revision[..self.git_revision.len().min(10)],
            if self.git_dirty { " (dirty)" } else { "" },
            self.rustc,
            self.cpu,
            self.cores,
            self.os,
            if self.quick { " · quick mode" } else { "" }
        )
    }
}

/// The revision of the code that runs and whether its work tree had changes: `git` in the
/// clone the working directory is in (`crate::paths`), else the revision the binary was built
/// from (an installed binary run elsewhere; its tree's state then unknown, said clean).
fn git_state() -> (String, bool) {
    let Some(clone) = crate::paths::working_clone() else {
        return (crate::paths::BUILD_REVISION.to_owned(), false);
    };
    let run = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(&clone)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            // Not `trim`: a status line starts with a space (" M path").
            .map(|o| String::from_utf8_lossy(&o.stdout).trim_end().to_owned())
    };
    let revision = run(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty =
        run(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| code_changed(&s));
    (revision, dirty)
}

/// Whether `git status --porcelain` output names a changed file outside `reports/`: changes
/// there are results (a bench writes them as it goes), not code.
fn code_changed(porcelain: &str) -> bool {
    porcelain
        .lines()
        .filter_map(|l| l.get(3..))
        .any(|path| !path.starts_with("reports/"))
}

/// The CPU model from `/proc/cpuinfo`, or the architecture where that is not available.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

#[cfg(test)]
mod tests {
    use super::code_changed;

    #[test]
    fn results_under_reports_are_not_code_changes_even_on_the_first_status_line() {
        // The first line keeps its leading space (a trimmed output once read it as
        // "eports/…" and called every bench after its first experiment dirty).
        assert!(!code_changed(
            " M reports/hull/metadata.json\n M reports/lod/results.csv"
        ));
        assert!(!code_changed(" D reports/background/results.html"));
        assert!(!code_changed(""));
        assert!(code_changed(
            " M reports/hull/metadata.json\n M crates/cloud/src/lib.rs"
        ));
        assert!(code_changed("M  justfile"));
    }
}
