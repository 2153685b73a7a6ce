//! The wire protocol of an external method: one program ([`Session`]) per setting (protocols
//! 1 and 2) or per cloud (protocol 3, whose requests carry their setting and an id the
//! answer echoes), started in its folder with the points file, asked one JSON line per view
//! (and setting, for the LOD form), its answers read with bounded memory ([`answer_limit`])
//! and checked (one line per request, the echoed id, `seconds`, a `visible_file` confined to
//! its scratch folder); its standard error kept as a bounded tail in memory
//! ([`STDERR_TAIL`]). Each program runs in a process group of its own, ended as a group: one
//! that fails is killed at once and the next request starts a fresh one, one the caller is
//! done with gets the end of its input and [`EXIT_GRACE`] to exit, and a signal to
//! pointsight kills what still runs (a `cloud::scratch` hook, with the scratch folder
//! registered there too). The first answer of a program just started is its cold call
//! ([`Cold`]), timed from its start.

use std::collections::VecDeque;
use std::ffi::OsString;
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cloud::glam::Vec3;
use nix::fcntl::OFlag;
use nix::sys::wait::{Id, WaitPidFlag, WaitStatus, waitid};
use nix::unistd::Pid;

use super::manifest::{ExternalMethod, external_error};
use super::points::write_points;
use super::process::{ProgramDir, TOKEN_VARIABLE, kill_group, reap};
use crate::error::Result;
use crate::lod::LodSize;

/// Bytes an answer may take beyond its indices' share (JSON keys, `seconds`, a message).
const ANSWER_SLACK: u64 = 1 << 20;

/// Bytes per index an answer may take: ten digits, a separator and a space, and for an LOD
/// answer its radius as the shortest text of a float (up to 24 characters, `-1.2345678901234567e-300`)
/// with its separator. 24 was too few for radii written by Python's `json` (py3dtiles-lod's
/// answers on the 871k-point dragon were refused at 21,962,512 bytes).
const BYTES_PER_INDEX: u64 = 48;

/// The longest answer line (and `visible_file`) accepted from a method on a cloud of
/// `n_points`: 1 MiB plus 48 bytes per point. Longer is a flood, refused before it is read.
pub fn answer_limit(n_points: usize) -> u64 {
    ANSWER_SLACK.saturating_add(BYTES_PER_INDEX.saturating_mul(n_points as u64))
}

/// The bytes of a program's standard error kept in memory: its last 64 KiB (nothing on disk).
pub(super) const STDERR_TAIL: usize = 64 << 10;

/// The end of a program's standard error: the last [`STDERR_TAIL`] bytes, and how many it
/// wrote in all.
#[derive(Default)]
struct Tail {
    bytes: VecDeque<u8>,
    total: u64,
}

impl Tail {
    fn push(&mut self, chunk: &[u8]) {
        self.total += chunk.len() as u64;
        let chunk = &chunk[chunk.len().saturating_sub(STDERR_TAIL)..];
        let over = (self.bytes.len() + chunk.len()).saturating_sub(STDERR_TAIL);
        self.bytes.drain(..over);
        self.bytes.extend(chunk);
    }

    /// Its last five lines (300 characters each at most), for an error message.
    fn quote(&self) -> String {
        let (a, b) = self.bytes.as_slices();
        let text = String::from_utf8_lossy(&[a, b].concat()).into_owned();
        let tail: Vec<&str> = text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .rev()
            .take(5)
            .collect();
        if tail.is_empty() {
            return "its stderr was empty".to_owned();
        }
        let kept = if self.total > self.bytes.len() as u64 {
            format!(" (of {} bytes; the last 64 KiB kept)", self.total)
        } else {
            String::new()
        };
        format!(
            "last lines of its stderr{kept}: {}",
            tail.into_iter()
                .rev()
                .map(|l| l.chars().take(300).collect::<String>())
                .collect::<Vec<_>>()
                .join(" | ")
        )
    }
}

/// A running program, in a process group of its own (its children with it): ended as a
/// group, when it is done with, when it fails, and by `cloud::scratch::cleanup` when
/// pointsight is stopped by a signal.
struct Running {
    child: Child,
    /// Its process group (its own id).
    pgid: Pid,
    /// Its input; `None` once closed (end of input means exit).
    stdin: Option<ChildStdin>,
    /// Its output's lines, each with whether more bytes had come with it (written before
    /// the line was taken: a second line to one request).
    lines: Receiver<std::result::Result<(String, bool), String>>,
    /// No line of it has been read yet (the visibility form's optional `built` line comes
    /// first).
    fresh: bool,
    /// The request last answered (for a second answer line to it).
    answered: Option<String>,
    /// When it was started (its cold call's clock).
    started: Instant,
    /// Protocol 3: the id of its next request (1, 2, 3, … per program).
    next_id: u64,
    /// The end of its standard error, and word when it is read to its end.
    stderr: Arc<Mutex<Tail>>,
    stderr_done: Receiver<()>,
    /// Kills the group at `cloud::scratch::cleanup` while it runs.
    hook: Option<cloud::scratch::HookGuard>,
    /// The session's token ([`TOKEN_VARIABLE`]).
    token: String,
}

/// How long a program whose input was closed has to exit before it is killed.
pub(super) const EXIT_GRACE: Duration = Duration::from_secs(3);

impl Running {
    /// Whether the program (the group's leader) has exited; it is not reaped, so its id
    /// (the group's) is not reused before the group is killed.
    fn exited(&self) -> bool {
        !matches!(
            waitid(
                Id::Pid(self.pgid),
                WaitPidFlag::WEXITED | WaitPidFlag::WNOHANG | WaitPidFlag::WNOWAIT
            ),
            Ok(WaitStatus::StillAlive)
        )
    }
}

impl Drop for Running {
    /// Closes the program's input and gives it [`EXIT_GRACE`] to exit (to remove its temporary
    /// files, say), then kills its process group: the program if it is still there, and
    /// whatever it started.
    fn drop(&mut self) {
        drop(self.stdin.take());
        let deadline = Instant::now() + EXIT_GRACE;
        while Instant::now() < deadline && !self.exited() {
            std::thread::sleep(Duration::from_millis(5));
        }
        let killed = kill_group(self.pgid, &self.token);
        drop(self.hook.take());
        let _ = self.child.wait();
        reap(&killed, self.pgid);
    }
}

/// Reads one line of at most `limit` bytes (without its newline): `Ok(None)` at the end of
/// input, `Err` for a longer line (read no further than `limit` + one buffer) or a read error.
pub(super) fn read_line_bounded(
    reader: &mut impl BufRead,
    limit: u64,
) -> std::result::Result<Option<String>, String> {
    let mut line = Vec::new();
    loop {
        let buf = reader
            .fill_buf()
            .map_err(|e| format!("cannot read its answer: {e}"))?;
        if buf.is_empty() {
            if line.is_empty() {
                return Ok(None);
            }
            break;
        }
        let (chunk, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(k) => (&buf[..k], k + 1),
            None => (buf, buf.len()),
        };
        if (line.len() + chunk.len()) as u64 > limit {
            return Err(format!(
                "its answer line is longer than {limit} bytes, more than the cloud's index range \
                 allows (1 MiB + 48 bytes per point): refused unread"
            ));
        }
        line.extend_from_slice(chunk);
        let newline = done > chunk.len();
        reader.consume(done);
        if newline {
            break;
        }
    }
    String::from_utf8(line)
        .map(Some)
        .map_err(|_| "its answer is not UTF-8".to_owned())
}

/// One program (per setting, or with protocol 3 per cloud), answering requests line by line.
pub(super) struct Session {
    pub(super) method: &'static str,
    pub(super) folder: PathBuf,
    command: Vec<String>,
    args: Vec<OsString>,
    pub(super) n_points: usize,
    timeout: Duration,
    /// The running program (declared before the folder: it ends before the folder goes).
    process: Mutex<Option<Running>>,
    /// The program's own scratch folder (the points file's; its `TMPDIR`), resolved: the one
    /// place a `visible_file` may be.
    scratch: PathBuf,
    dir: ProgramDir,
    /// The LOD form: the program greets with its build line.
    lod: bool,
    /// Its protocol version (3: requests carry ids its answers echo).
    protocol: u32,
    /// The LOD form's last build line: its own seconds and the structure's size.
    pub(super) built: Mutex<Option<(Option<f64>, LodSize)>>,
}

impl Session {
    fn start(&self) -> Result<Running> {
        let (program, args) = self
            .command
            .split_first()
            .ok_or_else(|| external_error(self.method, "empty command"))?;
        let started = Instant::now();
        let mut child = Command::new(program)
            .args(args)
            .args(&self.args)
            .current_dir(&self.folder)
            .env("TMPDIR", &self.scratch)
            .env(TOKEN_VARIABLE, &self.dir.token)
            .process_group(0)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| external_error(self.method, format!("cannot start {program}: {e}")))?;
        let pgid = Pid::from_raw(child.id().cast_signed());
        // From here on the group is killed whatever happens: on drop, and on a signal.
        let token = self.dir.token.clone();
        let hook = cloud::scratch::on_cleanup(move || {
            kill_group(pgid, &token);
        });
        let (stdin, stdout, stderr) =
            (child.stdin.take(), child.stdout.take(), child.stderr.take());
        let mut running = Running {
            child,
            pgid,
            stdin,
            lines: channel().1,
            fresh: true,
            answered: None,
            started,
            next_id: 1,
            stderr: Arc::default(),
            stderr_done: channel().1,
            hook: Some(hook),
            token: self.dir.token.clone(),
        };
        let (Some(stdout), Some(mut stderr)) = (stdout, stderr) else {
            return Err(external_error(self.method, "no stdout or stderr"));
        };
        let (done_tx, done_rx) = channel();
        let tail = Arc::clone(&running.stderr);
        std::thread::spawn(move || {
            // Read to its end, keeping the last 64 KiB: a program may write gigabytes there.
            let mut buf = vec![0_u8; 8192];
            while let Ok(n) = stderr.read(&mut buf) {
                if n == 0 {
                    break;
                }
                match tail.lock() {
                    Ok(mut t) => t.push(&buf[..n]),
                    Err(_) => break,
                }
            }
            let _ = done_tx.send(());
        });
        running.stderr_done = done_rx;
        let (tx, rx) = channel();
        let limit = answer_limit(self.n_points);
        std::thread::spawn(move || {
            let mut reader = BufReader::new(stdout);
            loop {
                match read_line_bounded(&mut reader, limit) {
                    Ok(Some(line)) => {
                        let more = !reader.buffer().is_empty();
                        if tx.send(Ok((line, more))).is_err() {
                            break;
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        // Stop reading: the caller kills the program.
                        let _ = tx.send(Err(e));
                        break;
                    }
                }
            }
        });
        running.lines = rx;
        Ok(running)
    }

    /// Waits for one line (the first start's greeting, or an answer).
    fn receive(
        running: &mut Running,
        timeout: Duration,
    ) -> std::result::Result<(String, bool), String> {
        match running.lines.recv_timeout(timeout) {
            Ok(Ok(line)) => Ok(line),
            Ok(Err(e)) => Err(e),
            Err(RecvTimeoutError::Timeout) => {
                Err(format!("no answer within {:.1} s", timeout.as_secs_f64()))
            }
            Err(RecvTimeoutError::Disconnected) => {
                // Its output closed: it exited, or it closed it and goes on (not waited for
                // long; it is killed). It is not reaped here, so its group id stays its own.
                let deadline = Instant::now() + Duration::from_secs(2);
                loop {
                    let status = waitid(
                        Id::Pid(running.pgid),
                        WaitPidFlag::WEXITED | WaitPidFlag::WNOHANG | WaitPidFlag::WNOWAIT,
                    );
                    let said = match status {
                        Ok(WaitStatus::Exited(_, code)) => format!("exit status: {code}"),
                        Ok(WaitStatus::Signaled(_, signal, _)) => {
                            format!("signal: {} ({})", signal as i32, signal.as_str())
                        }
                        Ok(WaitStatus::StillAlive) if Instant::now() < deadline => {
                            std::thread::sleep(Duration::from_millis(5));
                            continue;
                        }
                        Ok(WaitStatus::StillAlive) => {
                            return Err("the program closed its output without an answer".into());
                        }
                        Ok(other) => format!("{other:?}"),
                        Err(e) => e.to_string(),
                    };
                    return Err(format!("the program exited ({said}) without an answer"));
                }
            }
        }
    }

    /// Sends `request` (one JSON object) and reads the answer line; the process is started
    /// first when none runs (the LOD form's then reads and checks its first line). With
    /// protocol 3 the request gets the program's next id as its first key, and an answer must
    /// echo it. `parse` gets the answer's JSON (an `{"error": ...}` answer is an error before
    /// it). Errors kill the process (its group) and name the request `what`, quoting the end
    /// of its stderr.
    pub(super) fn ask(
        &self,
        what: &str,
        request: Option<&str>,
        parse: &dyn Fn(&serde_json::Value) -> std::result::Result<(), String>,
    ) -> Result<Answered> {
        let mut guard = self
            .process
            .lock()
            .map_err(|_| external_error(self.method, "process lock poisoned"))?;
        let fail = |guard: &mut Option<Running>, what: &str, why: String| {
            // Kill it (its group): the next request starts a fresh process.
            let quote = guard.take().map_or_else(String::new, |mut running| {
                // No grace: it failed.
                let _ = kill_group(running.pgid, &running.token);
                let tail = Arc::clone(&running.stderr);
                let done = std::mem::replace(&mut running.stderr_done, channel().1);
                drop(running);
                // The group is dead: its stderr ends now.
                let _ = done.recv_timeout(Duration::from_secs(1));
                tail.lock()
                    .map_or_else(|_| String::new(), |t| format!("; {}", t.quote()))
            });
            Err(external_error(self.method, format!("{what}: {why}{quote}")))
        };
        if guard.is_none() {
            let mut running = self.start()?;
            if self.lod {
                // The LOD form builds first and says so (again after a restart).
                let first =
                    Self::receive(&mut running, self.timeout).and_then(|(l, _)| self.greet(&l));
                if let Err(why) = first {
                    *guard = Some(running);
                    return fail(&mut guard, what, why);
                }
                running.fresh = false;
            }
            *guard = Some(running);
        }
        let Some(request) = request else {
            return Ok(Answered {
                wall: 0.0,
                cold: None,
            });
        };
        let running = guard
            .as_mut()
            .ok_or_else(|| external_error(self.method, "no process"))?;
        let id = (self.protocol >= 3).then(|| {
            running.next_id += 1;
            running.next_id - 1
        });
        let (what, request) = match id {
            Some(id) => (
                format!("{what} (request {id})"),
                match request.trim().strip_prefix('{').map(str::trim_start) {
                    Some(rest) if rest.starts_with('}') => format!("{{\"id\":{id}}}"),
                    Some(rest) => format!("{{\"id\":{id},{rest}"),
                    None => {
                        return Err(external_error(
                            self.method,
                            format!("{what}: the request is not a JSON object"),
                        ));
                    }
                },
            ),
            None => (what.to_owned(), request.to_owned()),
        };
        let what = what.as_str();
        let cold_call = running.answered.is_none();
        if !running.fresh {
            // Exactly one answer line per request: a line here answers nothing asked (a
            // second answer to the last request would shift every later answer by one).
            let extra = match running.lines.try_recv() {
                Ok(Ok((line, _))) => Some(trunc(&line)),
                Ok(Err(e)) => Some(e),
                Err(_) => None,
            };
            if let Some(extra) = extra {
                let last = running
                    .answered
                    .clone()
                    .unwrap_or_else(|| "the build".to_owned());
                return fail(
                    &mut guard,
                    what,
                    format!(
                        "a second answer line to {last} (one line per request; the answers \
                         would shift by one): {extra}"
                    ),
                );
            }
        }
        let start = Instant::now();
        let sent = match running.stdin.as_mut() {
            Some(stdin) => stdin
                .write_all(request.as_bytes())
                .and_then(|()| stdin.write_all(b"\n"))
                .and_then(|()| stdin.flush()),
            None => Err(std::io::Error::other("its input is closed")),
        };
        if let Err(e) = sent {
            return fail(&mut guard, what, format!("the program is gone ({e})"));
        }
        let mut start = start;
        let (mut line, mut more) = match Self::receive(running, self.timeout) {
            Ok(line) => line,
            Err(why) => return fail(&mut guard, what, why),
        };
        let mut built = None;
        if std::mem::take(&mut running.fresh) && is_built_line(&line) {
            // The visibility form's optional first line: the program's own set-up time.
            match self.greet(&line) {
                Ok(seconds) => built = Some(seconds),
                Err(why) => return fail(&mut guard, what, why),
            }
            start = Instant::now();
            (line, more) = match Self::receive(running, self.timeout) {
                Ok(line) => line,
                Err(why) => return fail(&mut guard, what, why),
            };
        }
        let wall = start.elapsed().as_secs_f64();
        let cold = cold_call.then(|| Cold {
            seconds: running.started.elapsed().as_secs_f64(),
            built: built.flatten(),
        });
        if more {
            // More came with the answer: which line answers this request is not known.
            return fail(
                &mut guard,
                what,
                format!(
                    "more than one answer line to {what} (one line per request; the answers \
                     would shift by one): {}",
                    trunc(&line)
                ),
            );
        }
        running.fresh = false;
        running.answered = Some(what.to_owned());
        let answer = serde_json::from_str::<serde_json::Value>(&line)
            .map_err(|e| format!("answer is not JSON ({e}): {}", trunc(&line)))
            .and_then(|v| {
                // Another request's answer first (an error of the last request included);
                // then this request's error, with or without its id; then a missing id.
                let other = id.is_some() && v.get("id").is_some();
                match (id, v.get("error")) {
                    (Some(id), _) if other => check_id(&v, id).map(|()| v),
                    (_, Some(msg)) => {
                        Err(format!("it reported an error: {}", trunc(&msg.to_string())))
                    }
                    (Some(id), None) => check_id(&v, id).map(|()| v),
                    (None, None) => Ok(v),
                }
            })
            .and_then(|v| parse(&v));
        match answer {
            Ok(()) => Ok(Answered { wall, cold }),
            Err(why) => fail(&mut guard, what, why),
        }
    }

    /// A program's build line, `{"built": true, "seconds": T}` and for the LOD form `"nodes": K,
    /// "bytes": B` too: kept (the LOD form's size), its seconds returned.
    fn greet(&self, line: &str) -> std::result::Result<Option<f64>, String> {
        let v: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| format!("its first line is not JSON ({e}): {}", trunc(line)))?;
        if let Some(msg) = v.get("error") {
            return Err(format!("it reported an error: {}", trunc(&msg.to_string())));
        }
        if v.get("built").and_then(serde_json::Value::as_bool) != Some(true) {
            return Err(format!(
                "its first line is not {{\"built\": true, ...}}: {}",
                trunc(line)
            ));
        }
        let num = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
        let seconds = self
            .seconds(&v)
            .map_err(|e| format!("its built line's {e}"))?;
        *self.built.lock().map_err(|_| "lock")? = Some((
            seconds,
            LodSize {
                nodes: num("nodes").unwrap_or(0.0).max(0.0) as usize,
                bytes: num("bytes").unwrap_or(0.0).max(0.0),
            },
        ));
        Ok(seconds)
    }

    /// An answer's (or build line's) `seconds`, when given: a number of seconds from 0 to the
    /// method's `timeout_seconds` (no request may take longer), else an error naming it.
    pub(super) fn seconds(
        &self,
        v: &serde_json::Value,
    ) -> std::result::Result<Option<f64>, String> {
        self.seconds_at(v, "seconds")
    }

    /// The seconds under `key` (`seconds`, or protocol 3's `built_seconds`), checked as
    /// [`Session::seconds`].
    pub(super) fn seconds_at(
        &self,
        v: &serde_json::Value,
        key: &str,
    ) -> std::result::Result<Option<f64>, String> {
        let Some(t) = v.get(key).filter(|t| !t.is_null()) else {
            return Ok(None);
        };
        let limit = self.timeout.as_secs_f64();
        match t.as_f64() {
            Some(s) if s.is_finite() && (0.0..=limit).contains(&s) => Ok(Some(s)),
            _ => Err(format!(
                "\"{key}\" {} is not a number >= 0 and at most its timeout of {limit} s",
                trunc(&t.to_string())
            )),
        }
    }

    /// The answer's indices, checked against the cloud (bounded: at most `n_points` kept).
    pub(super) fn indices(&self, v: &serde_json::Value) -> std::result::Result<Vec<u32>, String> {
        let n = self.n_points;
        let mut seen = vec![false; n];
        let mut out = Vec::new();
        let mut take = |i: i64| -> std::result::Result<(), String> {
            if out.len() >= n {
                return Err(format!(
                    "it answered more indices than the cloud's {n} points"
                ));
            }
            if i < 0 || i as u64 >= n as u64 {
                return Err(format!("index {i} is outside 0..{n}"));
            }
            let k = i as usize;
            if seen[k] {
                return Err(format!("index {i} is repeated"));
            }
            seen[k] = true;
            out.push(k as u32);
            Ok(())
        };
        if let Some(list) = v.get("visible") {
            let list = list.as_array().ok_or("\"visible\" is not a list")?;
            if list.len() > n {
                return Err(format!(
                    "it answered {} indices, more than the cloud's {n} points",
                    list.len()
                ));
            }
            for x in list {
                take(
                    x.as_i64()
                        .ok_or_else(|| format!("index {x} is not an integer"))?,
                )?;
            }
        } else if let Some(path) = v.get("visible_file").and_then(serde_json::Value::as_str) {
            for (k, t) in self.visible_file(path)?.split_whitespace().enumerate() {
                // Not quoted: only what the program put in its own folder is read, but the
                // message need not show a file's content.
                take(t.parse::<i64>().map_err(|_| {
                    format!("visible_file {path}: its word {} is not an integer", k + 1)
                })?)?;
            }
        } else {
            return Err(format!(
                "answer has neither \"visible\" nor \"visible_file\": {}",
                trunc(&v.to_string())
            ));
        }
        out.sort_unstable();
        Ok(out)
    }

    /// The text of a `visible_file`: a regular file inside the program's scratch folder (a
    /// relative path is relative to it), at most [`answer_limit`] bytes. Any other path is
    /// refused unread, and a refusal never quotes what the file holds.
    fn visible_file(&self, path: &str) -> std::result::Result<String, String> {
        // Outside as written (`..` taken as written), or once links are resolved.
        let mut written = PathBuf::new();
        for part in self.scratch.join(path).components() {
            match part {
                std::path::Component::ParentDir => {
                    written.pop();
                }
                std::path::Component::CurDir => {}
                other => written.push(other),
            }
        }
        let resolved = written
            .starts_with(&self.scratch)
            .then(|| written.canonicalize())
            .transpose()
            .map_err(|e| format!("cannot read visible_file {path}: {e}"))?;
        let Some(resolved) = resolved.filter(|r| r.starts_with(&self.scratch)) else {
            return Err(format!(
                "visible_file {path} is outside its scratch folder {} (the folder of its \
                 --points file): refused unread",
                self.scratch.display()
            ));
        };
        // Not through a link swapped in since, and not blocking on a FIFO.
        let file = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags((OFlag::O_NOFOLLOW | OFlag::O_NONBLOCK).bits())
            .open(&resolved)
            .map_err(|e| format!("cannot read visible_file {path}: {e}"))?;
        let meta = file
            .metadata()
            .map_err(|e| format!("cannot read visible_file {path}: {e}"))?;
        if !meta.is_file() {
            return Err(format!("visible_file {path} is not a regular file"));
        }
        let limit = answer_limit(self.n_points);
        if meta.len() > limit {
            return Err(format!(
                "visible_file {path} is {} bytes, more than the {limit} bytes the cloud's \
                 index range allows (1 MiB + 48 bytes per point): refused unread",
                meta.len()
            ));
        }
        let mut text = String::new();
        file.take(limit)
            .read_to_string(&mut text)
            .map_err(|e| format!("cannot read visible_file {path}: {e}"))?;
        Ok(text)
    }
}

/// What answering a request took.
pub(super) struct Answered {
    /// Wall seconds from sending the request to its answer (after a build line, from that).
    pub(super) wall: f64,
    /// For the first answer of a program just started: its cold call.
    pub(super) cold: Option<Cold>,
}

/// A program's cold call: from starting it to its first answer (its interpreter, its
/// imports, reading the points, its build and the first request), reported apart from the
/// requests' own seconds.
#[derive(Debug, Clone, Copy)]
pub(super) struct Cold {
    /// Wall seconds from starting the program to its first answer.
    pub(super) seconds: f64,
    /// Its build line's own seconds, when it sent one.
    pub(super) built: Option<f64>,
}

/// Protocol 3: the answer echoes request `id`'s id, else an error naming both.
fn check_id(v: &serde_json::Value, id: u64) -> std::result::Result<(), String> {
    match v.get("id") {
        Some(got) if got.as_u64() == Some(id) => Ok(()),
        Some(got) => Err(format!(
            "the answer carries id {} while request {id} is the one outstanding (a protocol 3 \
             answer echoes its request's id; another request's answer would shift the results)",
            trunc(&got.to_string())
        )),
        None => Err(format!(
            "the answer has no \"id\" (a protocol 3 answer echoes its request's id, {id} here): {}",
            trunc(&v.to_string())
        )),
    }
}

/// A line that says `{"built": true, ...}` (cheap to ask: answers can be long).
fn is_built_line(line: &str) -> bool {
    line.len() < 4096
        && serde_json::from_str::<serde_json::Value>(line)
            .is_ok_and(|v| v.get("built").and_then(serde_json::Value::as_bool) == Some(true))
}

/// At most 200 characters of `s`.
pub(super) fn trunc(s: &str) -> String {
    let mut t: String = s.chars().take(200).collect();
    if t.len() < s.len() {
        t.push('…');
    }
    t
}

impl ExternalMethod {
    /// A session for one setting: the points written, the program not started yet.
    pub(super) fn session(
        &self,
        cloud: &cloud::PointCloud,
        normals: Option<&[Vec3]>,
        params: serde_json::Value,
        lod_radius: Option<f64>,
    ) -> Result<Session> {
        let dir = ProgramDir::create().map_err(|e| external_error(self.name, e))?;
        let scratch = dir
            .path
            .canonicalize()
            .map_err(|e| external_error(self.name, e))?;
        let points = dir.path.join("points.ply");
        let origin = write_points(self, &points, cloud, normals)?;
        let mut args: Vec<OsString> = vec!["--points".into(), points.into()];
        if self.protocol < 3 {
            // Protocol 3's requests carry their setting: one program serves every setting.
            args.extend(["--params".into(), params.to_string().into()]);
        }
        args.extend(["--protocol".into(), self.protocol.to_string().into()]);
        if let Some(origin) = origin {
            // "given" (the caller's normals, the LOD input's) reads as the dataset's or the
            // estimated ones the lod experiment made; say which the program gets.
            let word = if origin == "given" {
                if cloud.normals.is_some() {
                    "dataset"
                } else {
                    "estimated"
                }
            } else {
                origin
            };
            args.extend(["--normals".into(), word.into()]);
        }
        if self.protocol >= 2
            && let Ok(spacing) = cloud::spacing::density_spacing(&cloud.positions, 8, 20_000, 1)
        {
            // The unit of our radius factors, so that a peer's radius can match ours.
            args.extend(["--spacing".into(), format!("{spacing:e}").into()]);
        }
        if let Some(radius) = lod_radius {
            args.extend([
                "--lod".into(),
                "--radius".into(),
                format!("{radius:e}").into(),
            ]);
        }
        Ok(Session {
            method: self.name,
            folder: self.folder.clone(),
            command: self.resolved_command(),
            args,
            n_points: cloud.len(),
            timeout: self.timeout,
            process: Mutex::new(None),
            scratch,
            dir,
            lod: lod_radius.is_some(),
            protocol: self.protocol,
            built: Mutex::new(None),
        })
    }
}
