//! Scratch and staging paths: named after their owner, registered while they live, and found
//! again when their owner died.
//!
//! Every hidden path a run makes beside its output (an out-of-core build's `.NAME.chunks-…`
//! folder, [`crate::io::atomic`]'s `.NAME.partial-…` file, an experiment's `.NAME.partial-…`
//! staging folder and `.NAME.previous-…`, the previous results moved aside) is named
//! `.NAME.KIND-HOST-PID-K`: the host and the process that made it, and a counter. So:
//!
//! - while the process lives, the path is in this process's registry ([`register`]);
//!   [`cleanup`] removes every registered path, after running the hooks that end what the
//!   process started ([`on_cleanup`]): the harness calls it on SIGINT, SIGTERM and SIGHUP
//!   before it exits, so a signal leaves nothing behind;
//! - after a crash or `kill -9` nothing runs, so a later run looks ([`leftovers_in`],
//!   [`remove_stale_in`]): a path of this host whose process is gone is stale and removed (a
//!   `previous` folder is put back when its output is missing, so that nothing is lost); a path
//!   of another host is left alone, since a shared file system under a cluster holds other
//!   machines' live runs, and so is a path whose process still runs. `pointsight clean` lists
//!   and removes them on request.
//!
//! Liveness is `/proc/PID` (Linux; elsewhere every owner counts as alive and nothing is
//! removed). A process id reused by a later process keeps its predecessor's leftovers until
//! that process ends: the safe side.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// The kinds of path, as they appear in names (`.NAME.KIND-HOST-PID-K`): `program` is an
/// external method's scratch folder in the temporary folder ([`program_dir`]).
pub const KINDS: [&str; 4] = ["chunks", "partial", "previous", "program"];

/// This machine's name as paths carry it: the kernel's host name (`/proc/sys/kernel/hostname`,
/// else `$HOSTNAME`, else `localhost`), every character but letters, digits, `.`, `_` and `-`
/// made `_` (names are parsed from the right, so a `-` in a host name is read back whole).
pub fn host() -> &'static str {
    static HOST: OnceLock<String> = OnceLock::new();
    HOST.get_or_init(|| {
        let raw = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_default();
        let clean: String = raw
            .trim()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if clean.is_empty() {
            "localhost".to_owned()
        } else {
            clean
        }
    })
}

/// `HOST-PID` of this process.
pub fn owner_tag() -> String {
    format!("{}-{}", host(), std::process::id())
}

/// A fresh path `.NAME.KIND-HOST-PID-K` beside `out` (`NAME` its file name).
pub fn beside(out: &Path, kind: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = out
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    out.with_file_name(format!(".{name}.{kind}-{}-{k}", owner_tag()))
}

/// A fresh path for an external method's scratch folder (its points file, its `TMPDIR`):
/// `.pointsight.program-HOST-PID-K` in the temporary folder (`$TMPDIR`, else `/tmp`), so that
/// after a `kill -9` the next run and `pointsight clean` find it ([`programs`]).
pub fn program_dir() -> PathBuf {
    beside(&std::env::temp_dir().join("pointsight"), "program")
}

/// The external methods' scratch folders in the temporary folder ([`program_dir`]), each
/// with its state.
pub fn programs() -> Vec<Leftover> {
    leftovers_in(&std::env::temp_dir())
        .into_iter()
        .filter(|l| l.kind == "program")
        .collect()
}

/// Removes the stale external methods' scratch folders in the temporary folder (this host's,
/// their process gone): what a run does before it starts. Returns the paths removed.
pub fn remove_stale_programs() -> Vec<PathBuf> {
    programs()
        .into_iter()
        .filter(|l| l.state == State::Stale)
        .filter(|l| reclaim(l).is_ok())
        .map(|l| l.path)
        .collect()
}

type Hook = Box<dyn Fn() + Send + Sync>;

/// The live paths and hooks of this process.
struct Live {
    paths: Vec<(u64, PathBuf)>,
    hooks: Vec<(u64, Hook)>,
    next: u64,
}

static LIVE: Mutex<Live> = Mutex::new(Live {
    paths: Vec::new(),
    hooks: Vec::new(),
    next: 0,
});

fn live() -> std::sync::MutexGuard<'static, Live> {
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A registered path: removed by [`cleanup`] until this is dropped (which removes nothing:
/// the owner removes its path, or keeps it when it becomes the output).
#[derive(Debug)]
pub struct Registered {
    id: u64,
    path: PathBuf,
}

impl Registered {
    /// The path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        live().paths.retain(|(id, _)| *id != self.id);
    }
}

/// Registers `path` (call before creating it) for [`cleanup`].
pub fn register(path: &Path) -> Registered {
    let mut l = live();
    let id = l.next;
    l.next += 1;
    l.paths.push((id, path.to_owned()));
    Registered {
        id,
        path: path.to_owned(),
    }
}

/// A registered cleanup hook, run by [`cleanup`] until this is dropped.
pub struct HookGuard(u64);

impl std::fmt::Debug for HookGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "HookGuard({})", self.0)
    }
}

impl Drop for HookGuard {
    fn drop(&mut self) {
        live().hooks.retain(|(id, _)| *id != self.0);
    }
}

/// Runs `hook` at [`cleanup`] (before the paths are removed): where a part of the process
/// ends what it started (an external program's process group) when the process is stopped.
pub fn on_cleanup(hook: impl Fn() + Send + Sync + 'static) -> HookGuard {
    let mut l = live();
    let id = l.next;
    l.next += 1;
    l.hooks.push((id, Box::new(hook)));
    HookGuard(id)
}

/// Runs every hook, then removes every registered path (folders with their contents), and
/// keeps the registry locked: the process is about to exit, and no thread may register a new
/// path after the sweep. Returns the paths removed.
pub fn cleanup() -> Vec<PathBuf> {
    let l = live();
    for (_, hook) in &l.hooks {
        hook();
    }
    let mut removed = Vec::new();
    for (_, path) in &l.paths {
        if remove(path) {
            removed.push(path.clone());
        }
    }
    // Held until the process exits.
    std::mem::forget(l);
    removed
}

/// Removes a file or a folder with its contents; whether something was there.
fn remove(path: &Path) -> bool {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(path).is_ok(),
        Ok(_) => std::fs::remove_file(path).is_ok(),
        Err(_) => false,
    }
}

/// Whether a process with id `pid` runs on this machine (`true` where that cannot be told).
pub fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return true;
    }
    proc.join(pid.to_string()).exists()
}

/// What a leftover is to this process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    /// This host's, its process gone: safe to remove.
    Stale,
    /// This host's, its process still running.
    Running,
    /// Another host's: left alone.
    OtherHost,
}

/// A scratch or staging path found in a folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Leftover {
    /// The path.
    pub path: PathBuf,
    /// The output it belongs to (`NAME` beside it).
    pub output: PathBuf,
    /// Its kind (one of [`KINDS`]).
    pub kind: &'static str,
    /// The host that made it.
    pub host: String,
    /// The process that made it.
    pub pid: u32,
    /// Stale, running or another host's.
    pub state: State,
}

/// Parses `.NAME.KIND-HOST-PID-K` into (NAME, KIND, HOST, PID).
fn parse(file_name: &str) -> Option<(&str, &'static str, &str, u32)> {
    let rest = file_name.strip_prefix('.')?;
    let mut parts = rest.rsplitn(3, '-');
    let _k: u64 = parts.next()?.parse().ok()?;
    let pid: u32 = parts.next()?.parse().ok()?;
    let head = parts.next()?;
    KINDS.iter().find_map(|&kind| {
        let marker = format!(".{kind}-");
        let at = head.rfind(&marker)?;
        let (name, host) = (&head[..at], &head[at + marker.len()..]);
        (!name.is_empty() && !host.is_empty()).then_some((name, kind, host, pid))
    })
}

/// True when `file_name` is a scratch or staging path's (`.NAME.KIND-HOST-PID-K`): a running
/// or dead process's, nobody's results.
pub fn is_scratch_name(file_name: &str) -> bool {
    parse(file_name).is_some()
}

/// The scratch and staging paths in `dir` (not below it).
pub fn leftovers_in(dir: &Path) -> Vec<Leftover> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<Leftover> = entries
        .flatten()
        .filter_map(|e| {
            let file_name = e.file_name().to_string_lossy().into_owned();
            let (name, kind, owner, pid) = parse(&file_name)?;
            let state = if owner != host() {
                State::OtherHost
            } else if process_alive(pid) {
                State::Running
            } else {
                State::Stale
            };
            Some(Leftover {
                path: e.path(),
                output: dir.join(name),
                kind,
                host: owner.to_owned(),
                pid,
                state,
            })
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out
}

/// Removes a stale leftover: a `previous` folder goes back to its output's place when that is
/// missing (a run stopped between moving the old results aside and putting the new ones in),
/// anything else is removed. Returns what was done.
pub fn reclaim(leftover: &Leftover) -> std::io::Result<&'static str> {
    if leftover.kind == "previous" && std::fs::symlink_metadata(&leftover.output).is_err() {
        std::fs::rename(&leftover.path, &leftover.output)?;
        return Ok("restored");
    }
    let meta = std::fs::symlink_metadata(&leftover.path)?;
    if meta.is_dir() {
        std::fs::remove_dir_all(&leftover.path)?;
    } else {
        std::fs::remove_file(&leftover.path)?;
    }
    Ok("removed")
}

/// Reclaims ([`reclaim`]) every stale leftover in `dir`: what a run does beside its output
/// before it starts. Returns the paths reclaimed; a failure to remove one is left for
/// `pointsight clean` to report.
pub fn remove_stale_in(dir: &Path) -> Vec<PathBuf> {
    leftovers_in(dir)
        .into_iter()
        .filter(|l| l.state == State::Stale)
        .filter(|l| reclaim(l).is_ok())
        .map(|l| l.path)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_from_the_right() {
        assert_eq!(
            parse(".x.qsplat.chunks-node-12-4567-3"),
            Some(("x.qsplat", "chunks", "node-12", 4567))
        );
        assert_eq!(
            parse(".results.partial-a.b-1-0"),
            Some(("results", "partial", "a.b", 1))
        );
        assert_eq!(parse(".x.chunks-1-0"), None);
        assert_eq!(parse("x.chunks-h-1-0"), None);
        assert_eq!(parse(".x.lock"), None);
        assert_eq!(parse(".x.partial-h-p-0"), None);
    }

    /// A process id that no process has: above the kernel's maximum.
    fn dead_pid() -> u32 {
        std::fs::read_to_string("/proc/sys/kernel/pid_max")
            .ok()
            .and_then(|s| s.trim().parse::<u32>().ok())
            .map_or(u32::MAX - 1, |m| m + 1)
    }

    #[test]
    fn stale_paths_of_this_host_go_others_stay() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let me = std::process::id();
        let dead = dead_pid();
        let mine_dead = d.join(format!(".out.qsplat.chunks-{}-{dead}-0", host()));
        let mine_live = d.join(format!(".out.qsplat.chunks-{}-{me}-1", host()));
        let other = d.join(format!(".out.qsplat.chunks-not-{}-{dead}-0", host()));
        let partial = d.join(format!(".out.qsplat.partial-{}-{dead}-7", host()));
        for p in [&mine_dead, &mine_live, &other] {
            std::fs::create_dir(p).unwrap();
            std::fs::write(p.join("0.bin"), b"x").unwrap();
        }
        std::fs::write(&partial, b"half").unwrap();
        // A previous folder whose output is missing goes back; one beside its output goes.
        let previous = d.join(format!(".run.previous-{}-{dead}-0", host()));
        std::fs::create_dir(&previous).unwrap();
        std::fs::write(previous.join("results.csv"), b"old").unwrap();
        let states: Vec<(PathBuf, State)> = leftovers_in(d)
            .into_iter()
            .map(|l| (l.path, l.state))
            .collect();
        assert_eq!(states.len(), 5, "{states:?}");
        assert!(states.contains(&(mine_live.clone(), State::Running)));
        assert!(states.contains(&(other.clone(), State::OtherHost)));
        let mut removed = remove_stale_in(d);
        removed.sort();
        let mut want = vec![mine_dead.clone(), partial.clone(), previous.clone()];
        want.sort();
        assert_eq!(removed, want);
        assert!(!mine_dead.exists() && !partial.exists() && !previous.exists());
        assert!(mine_live.exists() && other.exists());
        assert_eq!(std::fs::read(d.join("run/results.csv")).unwrap(), b"old");
    }

    #[test]
    fn cleanup_runs_hooks_and_removes_registered_paths() {
        // (Not `cleanup` itself, which keeps the registry locked for the exiting process: the
        // same steps on a registration and a hook.)
        let dir = tempfile::tempdir().unwrap();
        let p = beside(&dir.path().join("out.bin"), "partial");
        assert!(
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(&format!(".out.bin.partial-{}-", owner_tag()))
        );
        let r = register(&p);
        std::fs::write(&p, b"x").unwrap();
        let ran = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = ran.clone();
        let hook = on_cleanup(move || flag.store(true, Ordering::SeqCst));
        {
            let l = live();
            assert!(l.paths.iter().any(|(_, q)| q == &p));
            for (_, h) in &l.hooks {
                h();
            }
            for (_, q) in &l.paths {
                if q == &p {
                    assert!(remove(q));
                }
            }
        }
        assert!(ran.load(Ordering::SeqCst) && !p.exists());
        drop((r, hook));
        assert!(live().paths.iter().all(|(_, q)| q != &p));
    }
}
