//! Output folders: which folder a command may write, and how it replaces one.
//!
//! A folder output (`run --out`, `merge --out`, `bench --reports`, `report` and `tables`'
//! `--reports`, `visible --out` for many views) is pointsight's or it is refused:
//!
//! - a missing folder is created, an empty one is used;
//! - a folder pointsight wrote is replaced whole (the new results written beside it, then
//!   swapped in: [`replace`]), but only when it holds nothing pointsight did not write. An
//!   experiment's folder and a `visible` views folder are marked by their `metadata.json`,
//!   whose `files` lists every file the run wrote there ([`seal`]); a reports folder (what
//!   `bench` writes) holds experiment folders (each with its `metadata.json`), the report
//!   page's files ([`REPORT_FILES`]) and `viewer/`, whose `pages.json` lists its pages;
//! - anything else, a folder that is not pointsight's or one with a user's files added, is
//!   refused before any work, naming what is in it ([`check`]).
//!
//! No input of the command is ever inside a folder that is replaced, nor the folder the
//! command runs in (`--out .`). Scratch and staging paths (`cloud::scratch`'s
//! `.NAME.KIND-HOST-PID-K`) and lock files (`.NAME.lock`) belong to their processes and are
//! not counted as anyone's files.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};

use super::meta::RunMeta;

/// What a folder output holds, and so which folder of pointsight's it may replace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// One experiment's results (`run --out`, an experiment's folder in a reports folder).
    Experiment,
    /// `visible`'s answers for many views (`view-K.txt`).
    Views,
    /// A reports folder: experiment folders and the report page (`bench --reports`, `merge
    /// --out`, `report`, `tables`).
    Reports,
}

impl Role {
    /// The `experiment` of a views folder's `metadata.json`.
    pub const VIEWS: &'static str = "visible";

    fn describe(self) -> &'static str {
        match self {
            Role::Experiment => "an experiment's results",
            Role::Views => "visible's answers for many views",
            Role::Reports => "a reports folder",
        }
    }
}

/// The files the report assembly writes at the top of a reports folder.
pub const REPORT_FILES: &[&str] = &["README.md", "findings.csv", "index.html"];

/// The viewer pages' folder in a reports folder, and the file in it that lists its pages.
pub const VIEWER: (&str, &str) = ("viewer", "pages.json");

/// Entries named in a refusal, at most.
const NAMED: usize = 8;

/// Fails unless `dir` may be written as a folder output in `role`: missing, empty, or written
/// by pointsight in that role and holding nothing else; never the working folder or a folder
/// that holds it, never a folder that holds one of `inputs`. What a command checks before any
/// work, and [`replace`] again before it swaps.
pub fn check(dir: &Path, role: Role, inputs: &[&Path]) -> Result<()> {
    let resolved = resolve(dir);
    if let Some(cwd) = std::env::current_dir().ok().map(|c| resolve(&c)) {
        if cwd == resolved {
            bail!(
                "`{}` is the folder you are in: an output folder is replaced whole, so pointsight \
                 never writes into the working folder; give a folder of its own (for example \
                 `{}`)",
                dir.display(),
                suggestion(dir)
            );
        }
        if cwd.starts_with(&resolved) {
            bail!(
                "{} holds the folder you are in ({}): an output folder is replaced whole; give \
                 a folder of its own",
                dir.display(),
                cwd.display()
            );
        }
    }
    for input in inputs {
        if resolve(input).starts_with(&resolved) {
            bail!(
                "{} holds {}, an input of this command: an output folder is replaced whole and \
                 an input is never removed; give another output folder (for example `{}`)",
                dir.display(),
                input.display(),
                suggestion(dir)
            );
        }
    }
    let meta = match std::fs::metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", dir.display())),
    };
    if !meta.is_dir() {
        bail!(
            "{} is not a folder: a folder output is a directory",
            dir.display()
        );
    }
    let foreign = foreign(dir, role)?;
    if foreign.is_empty() {
        return Ok(());
    }
    let named: Vec<&str> = foreign.iter().take(NAMED).map(String::as_str).collect();
    let more = foreign.len() - named.len();
    bail!(
        "{} holds files pointsight did not write ({}{}): an output folder is replaced whole, \
         so pointsight writes only a new or empty folder, or one it wrote itself as {}; choose \
         another folder (for example `{}`) or move those files out",
        dir.display(),
        named.join(", "),
        if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        },
        role.describe(),
        suggestion(dir)
    )
}

/// A folder beside nothing of the user's: `DIR/pointsight-run` (`run-1` for the working
/// folder).
fn suggestion(dir: &Path) -> String {
    if dir.as_os_str().is_empty() || dir == Path::new(".") {
        "run-1".to_owned()
    } else {
        dir.join("pointsight-run").display().to_string()
    }
}

/// `path` made absolute with its links resolved as far as it exists (the rest appended), so
/// that a folder and what is inside it compare by prefix.
fn resolve(path: &Path) -> PathBuf {
    let absolute = if path.is_absolute() {
        path.to_owned()
    } else {
        std::env::current_dir().map_or_else(|_| path.to_owned(), |c| c.join(path))
    };
    let mut head = absolute.clone();
    let mut tail = Vec::new();
    loop {
        if let Ok(real) = std::fs::canonicalize(&head) {
            return tail.iter().rev().fold(real, |p, part| p.join(part));
        }
        match (head.file_name().map(ToOwned::to_owned), head.parent()) {
            (Some(name), Some(parent)) => {
                tail.push(name);
                head = parent.to_owned();
            }
            _ => return absolute,
        }
    }
}

/// True for the entries that belong to a running or dead process rather than to anyone's
/// results: scratch and staging paths, and lock files.
fn is_process_entry(name: &str) -> bool {
    cloud::scratch::is_scratch_name(name) || (name.starts_with('.') && name.ends_with(".lock"))
}

/// The entries of `dir` (relative, `/`-separated, folders ending in `/`) that pointsight did
/// not write in `role`; empty for an empty folder. Fails when the folder is pointsight's but
/// in another role, or written by a pointsight that did not list its files.
fn foreign(dir: &Path, role: Role) -> Result<Vec<String>> {
    let top = entries(dir)?;
    if top.is_empty() {
        return Ok(Vec::new());
    }
    match role {
        Role::Experiment | Role::Views => {
            let Ok(meta) = RunMeta::read(dir) else {
                return Ok(top.into_iter().map(|(name, _)| name).collect());
            };
            let is_views = meta.experiment == Role::VIEWS;
            if is_views != (role == Role::Views) {
                bail!(
                    "{} holds pointsight's {} ({} in its metadata.json), not {}: choose another \
                     folder",
                    dir.display(),
                    if is_views {
                        Role::Views.describe()
                    } else {
                        Role::Experiment.describe()
                    },
                    meta.experiment,
                    role.describe()
                );
            }
            let Some(files) = meta.files else {
                bail!(
                    "{} was written by an earlier pointsight, which did not list the files it \
                     wrote (metadata.json has no `files`), so files of yours in it cannot be \
                     told from its own: move it aside, or choose another folder",
                    dir.display()
                );
            };
            let listed: BTreeSet<String> = files.into_iter().collect();
            Ok(listing(dir)?
                .into_iter()
                .filter(|f| f != "metadata.json" && !listed.contains(f))
                .collect())
        }
        Role::Reports => {
            let mut out = Vec::new();
            for (name, is_dir) in top {
                let bare = name.trim_end_matches('/');
                let sub = dir.join(bare);
                if !is_dir && REPORT_FILES.contains(&bare) {
                    continue;
                }
                let found = if is_dir && bare == VIEWER.0 {
                    foreign_in_viewer(&sub)?
                } else if is_dir && sub.join("metadata.json").is_file() {
                    // An experiment's folder (any experiment: it names itself).
                    foreign(&sub, Role::Experiment)?
                } else {
                    out.push(name);
                    continue;
                };
                out.extend(found.into_iter().map(|f| format!("{bare}/{f}")));
            }
            Ok(out)
        }
    }
}

/// The entries of a reports folder's `viewer/` that its `pages.json` does not list.
fn foreign_in_viewer(dir: &Path) -> Result<Vec<String>> {
    #[derive(serde::Deserialize)]
    struct Page {
        file: String,
    }
    let listed: BTreeSet<String> = std::fs::read(dir.join(VIEWER.1))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Vec<Page>>(&bytes).ok())
        .map(|pages| pages.into_iter().map(|p| p.file).collect())
        .unwrap_or_default();
    Ok(listing(dir)?
        .into_iter()
        .filter(|f| f != VIEWER.1 && !listed.contains(f))
        .collect())
}

/// The entries of `dir` (not below it) other than process entries: names, folders ending in
/// `/`, with whether each is a folder.
fn entries(dir: &Path) -> Result<Vec<(String, bool)>> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))? {
        let e = e.with_context(|| format!("cannot read {}", dir.display()))?;
        let name = e.file_name().to_string_lossy().into_owned();
        if is_process_entry(&name) {
            continue;
        }
        let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
        out.push((if is_dir { format!("{name}/") } else { name }, is_dir));
    }
    out.sort();
    Ok(out)
}

/// Every file below `dir` (links not followed, listed as files), relative and `/`-separated,
/// sorted; an empty folder is listed as `NAME/`. Process entries are left out at every level.
pub fn listing(dir: &Path) -> Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack = vec![(dir.to_owned(), String::new())];
    while let Some((at, prefix)) = stack.pop() {
        let found = entries(&at)?;
        if found.is_empty() && !prefix.is_empty() {
            out.push(prefix.clone());
        }
        for (name, is_dir) in found {
            if is_dir {
                let bare = name.trim_end_matches('/');
                stack.push((at.join(bare), format!("{prefix}{name}")));
            } else {
                out.push(format!("{prefix}{name}"));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Lists every file in `dir` (an experiment's or a views folder, its `metadata.json` already
/// written) in its `metadata.json`'s `files`: what marks them as pointsight's. Called whenever
/// a command has finished writing into such a folder.
pub fn seal(dir: &Path) -> Result<()> {
    let mut meta = RunMeta::read(dir)
        .with_context(|| format!("{}: cannot read metadata.json", dir.display()))?;
    let files: Vec<String> = listing(dir)?
        .into_iter()
        .filter(|f| f != "metadata.json")
        .collect();
    if meta.files.as_ref() == Some(&files) {
        return Ok(());
    }
    meta.files = Some(files);
    meta.write(dir)
}

/// Writes a folder output whole: `fill` writes into a staging folder beside `out`
/// (`.NAME.partial-HOST-PID-K`, this process's own, removed on an error or a signal), which
/// then replaces `out` (checked again in `role` first: files may have been added while the
/// command ran; and no file this process has read may be inside it). On an error nothing
/// changes: `out` stays as it was.
pub fn replace(out: &Path, role: Role, fill: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    // A link to a folder is written through (the folder it names is replaced).
    let out = &cloud::io::atomic::folder_target(out)?;
    out.file_name()
        .with_context(|| format!("{} has no folder name", out.display()))?;
    let parent = out.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(parent) = parent {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    // Those of dead runs on this host beside it are reclaimed first (`cloud::scratch`).
    cloud::scratch::remove_stale_in(parent.unwrap_or(Path::new(".")));
    let staging = cloud::scratch::beside(out, "partial");
    let previous = cloud::scratch::beside(out, "previous");
    let registered = cloud::scratch::register(&staging);
    std::fs::create_dir(&staging)
        .with_context(|| format!("cannot create {}", staging.display()))?;
    let result = fill(&staging)
        .and_then(|()| check(out, role, &[]))
        .and_then(|()| check_no_input_inside(out))
        .and_then(|()| swap_in(&staging, out, &previous));
    if result.is_err() {
        // Best effort: the error that stopped the command is the one to report.
        let _ = std::fs::remove_dir_all(&staging);
    }
    drop(registered);
    result
}

/// Fails when a file this process has read is inside `dir`.
fn check_no_input_inside(dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        return Ok(());
    }
    for file in listing(dir)? {
        let path = dir.join(&file);
        if cloud::io::atomic::was_read(&path) {
            bail!(
                "{} holds {}, which this command read: an output folder is replaced whole and \
                 an input is never removed; give another output folder",
                dir.display(),
                path.display()
            );
        }
    }
    Ok(())
}

/// Replaces `out` by `staging`, through `previous`; puts `out` back if the swap fails.
fn swap_in(staging: &Path, out: &Path, previous: &Path) -> Result<()> {
    if out.exists() {
        std::fs::rename(out, previous)
            .with_context(|| format!("cannot move {} aside", out.display()))?;
    }
    if let Err(e) = std::fs::rename(staging, out) {
        if previous.exists() {
            let _ = std::fs::rename(previous, out);
        }
        return Err(e).with_context(|| format!("cannot move {} into place", out.display()));
    }
    if previous.exists() {
        std::fs::remove_dir_all(previous)
            .with_context(|| format!("cannot remove {}", previous.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(dir: &Path, experiment: &str) {
        RunMeta::now(experiment, true, &[], serde_json::Value::Null)
            .write(dir)
            .unwrap();
    }

    #[test]
    fn a_missing_or_empty_folder_may_be_written() {
        let root = tempfile::tempdir().unwrap();
        check(&root.path().join("new"), Role::Experiment, &[]).unwrap();
        let empty = root.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        // Another process's lock file is not a file of anyone's.
        std::fs::write(empty.join(".x.lock"), "").unwrap();
        check(&empty, Role::Reports, &[]).unwrap();
    }

    #[test]
    fn a_folder_that_is_not_ours_is_refused_naming_its_files() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("mythesis");
        std::fs::create_dir_all(dir.join("figs")).unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        for role in [Role::Experiment, Role::Views, Role::Reports] {
            let err = check(&dir, role, &[]).unwrap_err().to_string();
            assert!(
                err.contains("holds files pointsight did not write (figs/, notes.txt)"),
                "{err}"
            );
            assert!(err.contains("mythesis/pointsight-run"), "{err}");
        }
    }

    #[test]
    fn our_folder_is_ours_until_a_file_is_added() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("run");
        std::fs::create_dir_all(dir.join("srn")).unwrap();
        std::fs::write(dir.join("results.csv"), "a\n").unwrap();
        std::fs::write(dir.join("srn/table.md"), "|a|\n").unwrap();
        meta(&dir, "lod");
        // Not sealed: written by a pointsight that did not list its files.
        let err = check(&dir, Role::Experiment, &[]).unwrap_err().to_string();
        assert!(err.contains("did not list the files it wrote"), "{err}");
        seal(&dir).unwrap();
        assert_eq!(
            RunMeta::read(&dir).unwrap().files.unwrap(),
            ["results.csv", "srn/table.md"]
        );
        check(&dir, Role::Experiment, &[]).unwrap();
        let err = check(&dir, Role::Views, &[]).unwrap_err().to_string();
        assert!(err.contains("not visible's answers"), "{err}");
        std::fs::write(dir.join("srn/notes.txt"), "mine").unwrap();
        let err = check(&dir, Role::Experiment, &[]).unwrap_err().to_string();
        assert!(err.contains("(srn/notes.txt)"), "{err}");
    }

    #[test]
    fn a_reports_folder_holds_experiments_the_report_and_listed_viewer_pages() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("reports");
        let exp = dir.join("visibility");
        std::fs::create_dir_all(&exp).unwrap();
        std::fs::write(exp.join("results.csv"), "a\n").unwrap();
        meta(&exp, "visibility");
        seal(&exp).unwrap();
        std::fs::write(dir.join("README.md"), "# r\n").unwrap();
        std::fs::create_dir(dir.join("viewer")).unwrap();
        std::fs::write(dir.join("viewer/bunny.html"), "<p>").unwrap();
        std::fs::write(dir.join("viewer/pages.json"), r#"[{"file": "bunny.html"}]"#).unwrap();
        check(&dir, Role::Reports, &[]).unwrap();
        std::fs::write(dir.join("viewer/mine.html"), "<p>").unwrap();
        std::fs::write(exp.join("notes.txt"), "mine").unwrap();
        let err = check(&dir, Role::Reports, &[]).unwrap_err().to_string();
        assert!(
            err.contains("(viewer/mine.html, visibility/notes.txt)"),
            "{err}"
        );
    }

    #[test]
    fn an_input_or_the_working_folder_inside_is_refused() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("proj");
        std::fs::create_dir(&dir).unwrap();
        let cloud = dir.join("cloud.ply");
        std::fs::write(&cloud, "ply").unwrap();
        let err = check(&dir, Role::Experiment, &[&cloud])
            .unwrap_err()
            .to_string();
        assert!(err.contains("an input of this command"), "{err}");
        // The working folder (a test may not change it: its ancestors stand in).
        let cwd = std::env::current_dir().unwrap();
        let err = check(&cwd, Role::Experiment, &[]).unwrap_err().to_string();
        assert!(err.contains("is the folder you are in"), "{err}");
        let err = check(cwd.parent().unwrap(), Role::Experiment, &[])
            .unwrap_err()
            .to_string();
        assert!(err.contains("holds the folder you are in"), "{err}");
    }

    #[test]
    fn replace_swaps_ours_and_keeps_what_is_refused() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("run");
        let write = |body: &'static str| {
            move |dir: &Path| -> Result<()> {
                std::fs::write(dir.join("results.csv"), body)?;
                meta(dir, "visibility");
                seal(dir)
            }
        };
        replace(&out, Role::Experiment, write("1\n")).unwrap();
        replace(&out, Role::Experiment, write("2\n")).unwrap();
        assert_eq!(
            std::fs::read_to_string(out.join("results.csv")).unwrap(),
            "2\n"
        );
        // A file added while the command ran: the swap is refused, the folder kept.
        let err = replace(&out, Role::Experiment, |dir| {
            std::fs::write(out.join("notes.txt"), "mine")?;
            write("3\n")(dir)
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("(notes.txt)"), "{err}");
        assert_eq!(
            std::fs::read_to_string(out.join("results.csv")).unwrap(),
            "2\n"
        );
        assert_eq!(
            std::fs::read_dir(root.path()).unwrap().count(),
            1,
            "no staging folder left"
        );
    }
}
