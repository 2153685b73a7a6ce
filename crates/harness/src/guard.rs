//! The guards every command runs under: what it writes is checked, locked and
//! cleaned up, whatever stops it.
//!
//! - **Outputs checked before any work**: a file output (`--out` of `visible` for one view,
//!   `export`, `views`, `view` and its `--png`, `lod-build`) may replace only a regular file
//!   (`cloud::io::atomic::target`: a directory, FIFO, socket or device is refused; a symbolic
//!   link is written through); a folder output (`run --out`, `bench --reports`, `merge --out`,
//!   `report` and `tables`' `--reports`, `visible --out` for many views) must be missing,
//!   empty, or a folder pointsight wrote holding nothing else, and hold no input and not the
//!   working folder (`crate::output::folder`); no output may be one of the command's input
//!   files (the same file by device and inode: `lod-build --cloud x.laz --out x.laz` is
//!   refused, and `cloud::io::atomic` refuses to replace any file the process has read).
//! - **A lock per output**: an advisory lock (`flock`) on `.NAME.lock` beside each output, held
//!   for the whole command; the file names its holder (host and process id), so a second
//!   command into the same output is refused with a message naming the running one. The lock
//!   file is removed when the command ends (while still held; a taker checks that the file it
//!   locked is still the one at the path, so removing it races with no one). `bench` locks its
//!   reports folder and every experiment's folder in it.
//! - **Stale scratch reclaimed**: beside each output, the scratch and staging paths of this
//!   host's dead processes are removed (`cloud::scratch`); `pointsight clean` lists them, and
//!   removes them with `--remove`.
//! - **Signals**: SIGINT, SIGTERM and SIGHUP run `cloud::scratch::cleanup` (the hooks that end
//!   what the process started, then every registered scratch and staging path, lock files
//!   included) and exit with 128 + the signal's number, as a shell reports a process killed by
//!   it.

use std::fs::File;
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{Context, Result, bail};
use nix::fcntl::{Flock, FlockArg};

use crate::cli::Command;
use crate::output::folder::Role;

/// Whether an output is a file or a folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A file, written whole through `cloud::io::atomic`.
    File,
    /// A folder of files, holding what `Role` says.
    Folder(Role),
}

/// One output of a command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Output {
    /// Where.
    pub path: PathBuf,
    /// File or folder.
    pub kind: Kind,
}

/// The outputs and input files of a command (the files it names on its command line; the
/// files of datasets are noted as they are read, `cloud::io::atomic::note_input`).
pub fn outputs_and_inputs(
    command: &Command,
    reports: &dyn Fn(Option<PathBuf>, bool) -> PathBuf,
) -> (Vec<Output>, Vec<PathBuf>) {
    let file = |p: &Path| Output {
        path: p.to_owned(),
        kind: Kind::File,
    };
    let folder = |p: &Path, role: Role| Output {
        path: p.to_owned(),
        kind: Kind::Folder(role),
    };
    let source_inputs = |s: &crate::cli::SourceArgs| -> Vec<PathBuf> {
        [&s.files.cloud, &s.files.mesh, &s.camera.views]
            .into_iter()
            .flatten()
            .cloned()
            .collect()
    };
    match command {
        Command::Export { out, .. } => (vec![file(out)], Vec::new()),
        Command::Views { out, .. } => (out.iter().map(|o| file(o)).collect(), Vec::new()),
        Command::Visible {
            source, view, out, ..
        } => {
            // As `visible` decides: a views file, `all` or a list make a folder.
            let many = source.camera.views.is_some()
                || view.as_deref().is_some_and(|v| v.parse::<usize>().is_err());
            // `--out -`: one view's indices on standard output, no file.
            let outs = match (many, out.as_os_str() == "-") {
                (false, true) => Vec::new(),
                (true, _) => vec![folder(out, Role::Views)],
                (false, false) => vec![file(out)],
            };
            (outs, source_inputs(source))
        }
        Command::View {
            source, out, png, ..
        } => {
            let mut outs = vec![file(out)];
            outs.extend(png.iter().map(|p| file(p)));
            (outs, source_inputs(source))
        }
        Command::LodBuild { cloud, out, .. } => (vec![file(out)], vec![cloud.clone()]),
        Command::Run {
            experiment,
            quick,
            out,
            files,
            camera,
            sweep,
            ..
        } => {
            let out = out
                .clone()
                .unwrap_or_else(|| reports(None, *quick).join(experiment));
            let inputs = [&files.cloud, &files.mesh, &camera.views, &sweep.config]
                .into_iter()
                .flatten()
                .cloned();
            (vec![folder(&out, Role::Experiment)], inputs.collect())
        }
        Command::Bench {
            reports: given,
            quick,
            sweep,
            ..
        } => {
            let reports = reports(given.clone(), *quick);
            let mut outs = vec![folder(&reports, Role::Reports)];
            outs.extend(
                crate::experiments::EXPERIMENTS
                    .iter()
                    .map(|e| folder(&reports.join(e.name()), Role::Experiment)),
            );
            (outs, sweep.config.iter().cloned().collect())
        }
        Command::Merge { out, shards } => (vec![folder(out, Role::Reports)], shards.clone()),
        Command::Report { reports: given } | Command::Tables { reports: given } => (
            vec![folder(&reports(given.clone(), false), Role::Reports)],
            Vec::new(),
        ),
        Command::Fetch
        | Command::Paths
        | Command::Datasets
        | Command::Methods { .. }
        | Command::ScaleCell { .. }
        | Command::Inspect { .. }
        | Command::Sweeps
        | Command::Clean { .. } => (Vec::new(), Vec::new()),
    }
}

/// What a command holds while it runs: its output locks (released, their files removed, when
/// it is dropped).
#[derive(Debug)]
pub struct RunGuard {
    locks: Vec<OutputLock>,
}

impl RunGuard {
    /// The outputs locked.
    pub fn locked(&self) -> Vec<&Path> {
        self.locks.iter().map(|l| l.output.as_path()).collect()
    }
}

/// Installs the signal handler, checks `command`'s outputs against its inputs and what is at
/// their paths, reclaims stale scratch beside them, and locks them. Call once, before any work.
pub fn begin(
    command: &Command,
    reports: &dyn Fn(Option<PathBuf>, bool) -> PathBuf,
) -> Result<RunGuard> {
    install_signal_handler();
    if !matches!(command, Command::Clean { .. }) {
        // External methods' scratch folders left by a run that was killed (`clean` lists
        // them, and removes them when asked).
        cloud::scratch::remove_stale_programs();
    }
    let (outputs, inputs) = outputs_and_inputs(command, reports);
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    let mut locks = Vec::new();
    for out in &outputs {
        check_output(out, &inputs)?;
        locks.push(OutputLock::take(&out.path)?);
        cloud::scratch::remove_stale_in(parent_of(&out.path));
    }
    Ok(RunGuard { locks })
}

/// Fails unless `out` may be written ([`Kind::File`]: nothing, a regular file, or a link to
/// one; [`Kind::Folder`]: nothing, an empty folder or one pointsight wrote in that role,
/// `crate::output::folder::check`) and is none of `inputs` nor holds one.
pub fn check_output(out: &Output, inputs: &[&Path]) -> Result<()> {
    match out.kind {
        Kind::File => cloud::io::atomic::check_output(&out.path, inputs)?,
        Kind::Folder(role) => {
            let target = cloud::io::atomic::folder_target(&out.path)?;
            cloud::io::atomic::check_not_input(&out.path, inputs)?;
            crate::output::folder::check(&target, role, inputs)?;
        }
    }
    Ok(())
}

/// The folder `path` is in (`.` for a bare name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `.NAME.lock` beside `output`.
pub fn lock_path(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    output.with_file_name(format!(".{name}.lock"))
}

/// An exclusive advisory lock on an output's lock file.
#[derive(Debug)]
pub struct OutputLock {
    output: PathBuf,
    path: PathBuf,
    /// Folders made to hold the lock file (removed at the end when still empty).
    made: Vec<PathBuf>,
    lock: Option<Flock<File>>,
    _registered: cloud::scratch::Registered,
}

impl OutputLock {
    /// Locks `output`'s lock file, or fails naming the process that holds it.
    pub fn take(output: &Path) -> Result<Self> {
        let path = lock_path(output);
        let made = make_parents(parent_of(&path))?;
        let registered = cloud::scratch::register(&path);
        for _ in 0..100 {
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .with_context(|| format!("cannot open the lock file {}", path.display()))?;
            let mut lock = match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
                Ok(l) => l,
                Err((mut file, nix::errno::Errno::EWOULDBLOCK)) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    bail!(
                        "{} is being written by another pointsight ({}): wait for it to end or \
                         stop it (its lock: {})",
                        output.display(),
                        describe_holder(&holder),
                        path.display()
                    );
                }
                Err((_, e)) => {
                    return Err(e).with_context(|| format!("cannot lock {}", path.display()));
                }
            };
            // The file locked must still be the one at the path (a finishing holder removes
            // its lock file; a taker that opened it just before must try again).
            if !same_file(&lock, &path) {
                continue;
            }
            lock.set_len(0)?;
            lock.rewind()?;
            writeln!(
                lock,
                "host={} pid={}",
                cloud::scratch::host(),
                std::process::id()
            )?;
            lock.flush()?;
            return Ok(Self {
                output: output.to_owned(),
                path,
                made,
                lock: Some(lock),
                _registered: registered,
            });
        }
        bail!("cannot lock {}: it keeps being replaced", path.display())
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still held, then released.
        let _ = std::fs::remove_file(&self.path);
        drop(self.lock.take());
        for dir in self.made.iter().rev() {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

/// Whether the open `file` is the file at `path` (device and inode).
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// "host H, process P" from a lock file's `host=H pid=P`.
fn describe_holder(text: &str) -> String {
    let field = |key: &str| {
        text.split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .map(str::to_owned)
    };
    match (field("host="), field("pid=")) {
        (Some(h), Some(p)) => format!("host {h}, process {p}"),
        _ => "a process that has not written its name yet".to_owned(),
    }
}

/// Creates `dir` and its missing parents; returns those it made, outermost first.
fn make_parents(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut missing = Vec::new();
    let mut at = Some(dir);
    while let Some(d) = at {
        if d.as_os_str().is_empty() || d.exists() {
            break;
        }
        missing.push(d.to_owned());
        at = d.parent();
    }
    missing.reverse();
    for d in &missing {
        std::fs::create_dir(d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    Ok(missing)
}

/// Installs (once) the thread that answers SIGINT, SIGTERM and SIGHUP: it runs
/// `cloud::scratch::cleanup` and exits with 128 + the signal's number.
pub fn install_signal_handler() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            // Without a handler a signal ends the process as before; the next run reclaims.
            return;
        };
        let spawned = std::thread::Builder::new()
            .name("pointsight-signals".into())
            .spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    let removed = cloud::scratch::cleanup();
                    let name = match signal {
                        SIGINT => "SIGINT",
                        SIGTERM => "SIGTERM",
                        _ => "SIGHUP",
                    };
                    eprintln!(
                        "pointsight: {name}: stopped; removed {} scratch path(s)",
                        removed.len()
                    );
                    std::process::exit(128 + signal);
                }
            });
        drop(spawned);
    });
}

/// `pointsight clean`: the scratch and staging paths in `folders` and their subfolders (links
/// not followed), and the external methods' scratch folders in the temporary folder, each
/// with its owner and state; with `remove`, the stale ones (this host's, their process gone)
/// are removed (a `previous` folder whose output is missing is put back) and unheld lock
/// files removed. Returns the lines printed.
pub fn clean(folders: &[PathBuf], remove: bool) -> Result<Vec<String>> {
    let mut lines = Vec::new();
    let mut stale = 0usize;
    let mut seen = std::collections::BTreeSet::new();
    let mut describe = |l: &cloud::scratch::Leftover, lines: &mut Vec<String>| {
        if !seen.insert(l.path.clone()) {
            return;
        }
        let state = match l.state {
            cloud::scratch::State::Stale => {
                stale += 1;
                if remove {
                    match cloud::scratch::reclaim(l) {
                        Ok(done) => done.to_owned(),
                        Err(e) => format!("stale, cannot remove: {e}"),
                    }
                } else {
                    "stale".to_owned()
                }
            }
            cloud::scratch::State::Running => "in use".to_owned(),
            cloud::scratch::State::OtherHost => "another host's, left".to_owned(),
        };
        lines.push(format!(
            "{} kind={} host={} pid={} state={state}",
            l.path.display(),
            l.kind,
            l.host,
            l.pid
        ));
    };
    for l in &cloud::scratch::programs() {
        describe(l, &mut lines);
    }
    for root in folders {
        if !root.is_dir() {
            bail!("{} is not a folder", root.display());
        }
        let mut stack = vec![root.clone()];
        while let Some(dir) = stack.pop() {
            let leftovers = cloud::scratch::leftovers_in(&dir);
            for l in &leftovers {
                describe(l, &mut lines);
            }
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for e in entries.flatten() {
                let path = e.path();
                let name = e.file_name().to_string_lossy().into_owned();
                let Ok(kind) = e.file_type() else { continue };
                if kind.is_dir() && !leftovers.iter().any(|l| l.path == path) {
                    stack.push(path);
                } else if kind.is_file() && name.starts_with('.') && name.ends_with(".lock") {
                    lines.push(clean_lock(&path, remove));
                }
            }
        }
    }
    lines.push(format!(
        "{stale} stale path(s){}",
        if remove {
            " reclaimed"
        } else if stale > 0 {
            ": pointsight clean --remove reclaims them"
        } else {
            ""
        }
    ));
    Ok(lines)
}

/// `pointsight clean`: [`clean`] over `folders` (the working directory when none), printed.
pub fn clean_command(folders: Vec<PathBuf>, remove: bool) -> Result<()> {
    let folders = if folders.is_empty() {
        vec![PathBuf::from(".")]
    } else {
        folders
    };
    for line in clean(&folders, remove)? {
        println!("{line}");
    }
    Ok(())
}

/// A lock file's line for `clean`: held (by whom) or not; removed when not held and `remove`.
fn clean_lock(path: &Path, remove: bool) -> String {
    let Ok(file) = File::open(path) else {
        return format!("{} kind=lock state=unreadable", path.display());
    };
    match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
        Ok(lock) => {
            if remove && same_file(&lock, path) {
                let _ = std::fs::remove_file(path);
                format!("{} kind=lock state=removed", path.display())
            } else {
                format!("{} kind=lock state=stale", path.display())
            }
        }
        Err((mut file, _)) => {
            let mut holder = String::new();
            let _ = file.read_to_string(&mut holder);
            format!(
                "{} kind=lock state=held ({})",
                path.display(),
                describe_holder(&holder)
            )
        }
    }
}

/// An error as `main` prints it: the chain of causes joined by `: ` (as `{:#}` does), a
/// cause left out when its text is already in what came before (an error that quotes its
/// source, such as `cloud::Error::Write`'s "PATH: cannot write: CAUSE", printed the operating
/// system's message twice).
pub fn error_text(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_that_quotes_its_source_is_printed_once() {
        let io = std::io::Error::from_raw_os_error(28);
        let os = io.to_string();
        let err = anyhow::Error::from(cloud::Error::Write {
            path: PathBuf::from("/tmp/x.ply"),
            source: io,
        })
        .context("export");
        assert_eq!(format!("{err:#}").matches(&os).count(), 2, "{err:#}");
        let text = error_text(&err);
        assert_eq!(text, format!("export: /tmp/x.ply: cannot write: {os}"));
    }

    #[test]
    fn a_second_lock_is_refused_naming_the_first() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("new/deeper/results");
        let first = OutputLock::take(&out).unwrap();
        let text = std::fs::read_to_string(lock_path(&out)).unwrap();
        assert_eq!(
            text,
            format!(
                "host={} pid={}\n",
                cloud::scratch::host(),
                std::process::id()
            )
        );
        let err = OutputLock::take(&out).unwrap_err().to_string();
        assert!(
            err.contains("is being written by another pointsight")
                && err.contains(&format!("process {}", std::process::id())),
            "{err}"
        );
        drop(first);
        // Released, its file and the folders made for it removed.
        assert!(!dir.path().join("new").exists());
        let again = OutputLock::take(&out).unwrap();
        drop(again);
    }

    #[test]
    fn clean_lists_then_removes_stale_paths() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("reports");
        std::fs::create_dir(&sub).unwrap();
        let dead = std::fs::read_to_string("/proc/sys/kernel/pid_max")
            .ok()
            .and_then(|s| s.trim().parse::<u32>().ok())
            .map_or(u32::MAX - 1, |m| m + 1);
        let stale = sub.join(format!(".lod.partial-{}-{dead}-0", cloud::scratch::host()));
        std::fs::create_dir(&stale).unwrap();
        std::fs::write(sub.join(".lod.lock"), "host=x pid=1\n").unwrap();
        let lines = clean(&[dir.path().to_owned()], false).unwrap();
        assert!(lines.iter().any(|l| l.contains("state=stale")), "{lines:?}");
        assert!(stale.exists());
        let lines = clean(&[dir.path().to_owned()], true).unwrap();
        assert!(
            lines.iter().any(|l| l.contains("state=removed")),
            "{lines:?}"
        );
        assert!(!stale.exists() && !sub.join(".lod.lock").exists());
    }
}
