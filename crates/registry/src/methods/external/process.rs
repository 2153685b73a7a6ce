//! The end of an external program: its process group, the processes that left the group
//! (found by the token every program of a session carries in `POINTSIGHT_PROGRAM` and its
//! descendants inherit), the reaping of what became this process's children, and the
//! program's scratch folder, named so that a later run reclaims it after a `kill -9`.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, killpg};
use nix::sys::wait::{WaitPidFlag, WaitStatus};
use nix::unistd::Pid;

/// The environment variable every program of a session carries, its value the session's
/// token (its scratch folder's name): inherited by whatever the program starts, so that a
/// descendant that left the process group (`setsid`) is still found ([`kill_group`]).
pub(super) const TOKEN_VARIABLE: &str = "POINTSIGHT_PROGRAM";

/// The processes to end with a program, read from `/proc` before anything is killed (a dead
/// process's environment can no longer be read): the members of process group `pgid`, and the
/// processes whose environment holds a variable `carries` accepts (those that left the group
/// with the token). Linux; elsewhere none.
fn members(pgid: Option<Pid>, carries: &dyn Fn(&[u8]) -> bool) -> Vec<Pid> {
    let me = std::process::id();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for entry in entries.flatten() {
        let Some(pid) = entry
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<i32>().ok())
        else {
            continue;
        };
        if pid.cast_unsigned() == me {
            continue;
        }
        // `stat` after the command's closing parenthesis: state, ppid, pgrp, ...
        let group = std::fs::read_to_string(entry.path().join("stat"))
            .ok()
            .and_then(|stat| {
                stat.rsplit(')')
                    .next()?
                    .split_whitespace()
                    .nth(2)?
                    .parse::<i32>()
                    .ok()
            });
        let in_group = group.is_some() && group == pgid.map(Pid::as_raw);
        let escaped = !in_group
            && std::fs::read(entry.path().join("environ")).is_ok_and(|environ| {
                environ
                    .split(|&b| b == 0)
                    .any(|var| !var.is_empty() && carries(var))
            });
        if in_group || escaped {
            out.push(Pid::from_raw(pid));
        }
    }
    out
}

/// Kills process group `pgid`, whatever is left of it, and the processes that left it
/// carrying `token` (a double fork with `setsid`): every process whose environment holds
/// `POINTSIGHT_PROGRAM=token`. Returns them all, for [`reap`].
pub(super) fn kill_group(pgid: Pid, token: &str) -> Vec<Pid> {
    let var = format!("{TOKEN_VARIABLE}={token}").into_bytes();
    let pids = members(Some(pgid), &|v| v == var.as_slice());
    let _ = killpg(pgid, Signal::SIGKILL);
    for &pid in &pids {
        let _ = nix::sys::signal::kill(pid, Signal::SIGKILL);
    }
    pids
}

/// Reaps those of `pids` (killed) other than `leader` (its owner's to reap) that are, or
/// become within half a second, this process's children: the `pointsight` binary is the
/// subreaper of what its programs start, so a killed group's members and escapees are
/// reparented to it when their parent dies. Never blocks on one.
pub(super) fn reap(pids: &[Pid], leader: Pid) {
    let mut left: Vec<Pid> = pids.iter().copied().filter(|&p| p != leader).collect();
    let deadline = Instant::now() + Duration::from_millis(500);
    while !left.is_empty() {
        left.retain(|&p| {
            matches!(
                nix::sys::wait::waitpid(p, Some(WaitPidFlag::WNOHANG)),
                Ok(WaitStatus::StillAlive) | Err(nix::errno::Errno::ECHILD)
            )
        });
        if left.is_empty() || Instant::now() >= deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Ends the external programs that process `owner` of this host started, and what they
/// started: every process whose token names `owner` as its maker (a scale cell killed at its
/// time cap, which ran no cleanup of its own); reaps those that are this process's children.
pub fn end_programs_of(owner: u32) {
    let prefix = format!(
        "{TOKEN_VARIABLE}=.pointsight.program-{}-{owner}-",
        cloud::scratch::host()
    )
    .into_bytes();
    let pids = members(None, &|v| v.starts_with(&prefix));
    for &pid in &pids {
        let _ = nix::sys::signal::kill(pid, Signal::SIGKILL);
    }
    reap(&pids, Pid::from_raw(0));
}

/// A program's scratch folder ([`cloud::scratch::program_dir`]: named with this host and
/// process, so that the next run and `pointsight clean` reclaim it after a `kill -9`),
/// private to its owner, removed with what it holds when the session ends and by
/// `cloud::scratch::cleanup` on a signal.
pub(super) struct ProgramDir {
    pub(super) path: PathBuf,
    /// Its name: the session's token ([`TOKEN_VARIABLE`]).
    pub(super) token: String,
    _registered: cloud::scratch::Registered,
}

impl ProgramDir {
    pub(super) fn create() -> std::io::Result<Self> {
        use std::os::unix::fs::DirBuilderExt;
        // A name taken (a killed predecessor with this process's id left its folder) is
        // passed over for the next.
        let mut tries = 0;
        let (path, registered) = loop {
            let path = cloud::scratch::program_dir();
            let registered = cloud::scratch::register(&path);
            match std::fs::DirBuilder::new().mode(0o700).create(&path) {
                Ok(()) => break (path, registered),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && tries < 1000 => {
                    tries += 1;
                }
                Err(e) => return Err(e),
            }
        };
        let token = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok(Self {
            path,
            token,
            _registered: registered,
        })
    }
}

impl Drop for ProgramDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}
