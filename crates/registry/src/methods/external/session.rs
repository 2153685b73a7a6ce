//! The wire protocol of an external method: one program per setting ([`Session`]), started in
//! its folder with the points file and the setting, asked one JSON line per view (and setting,
//! for the LOD form), its answers read with bounded memory ([`answer_limit`]) and checked; a
//! program that fails is killed and the next request starts a fresh one, and one the caller is
//! done with gets the end of its input and [`EXIT_GRACE`] to exit.

use std::ffi::OsString;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use cloud::glam::Vec3;

use super::manifest::{ExternalMethod, external_error};
use super::points::write_points;
use crate::error::Result;
use crate::lod::LodSize;

/// Bytes an answer may take beyond its indices' share (JSON keys, `seconds`, a message).
const ANSWER_SLACK: u64 = 1 << 20;

/// Bytes per index an answer may take (ten digits, a separator, spaces, a radius).
const BYTES_PER_INDEX: u64 = 24;

/// The longest answer line (and `visible_file`) accepted from a method on a cloud of
/// `n_points`: 1 MiB plus 24 bytes per point. Longer is a flood, refused before it is read.
pub fn answer_limit(n_points: usize) -> u64 {
    ANSWER_SLACK.saturating_add(BYTES_PER_INDEX.saturating_mul(n_points as u64))
}

/// A running program.
struct Running {
    child: Child,
    /// Its input; `None` once closed (end of input means exit).
    stdin: Option<ChildStdin>,
    lines: Receiver<std::result::Result<String, String>>,
    /// No line of it has been read yet (the visibility form's optional `built` line comes
    /// first).
    fresh: bool,
}

/// How long a program whose input was closed has to exit before it is killed.
pub(super) const EXIT_GRACE: Duration = Duration::from_secs(3);

impl Drop for Running {
    /// Closes the program's input and gives it [`EXIT_GRACE`] to exit (to remove its temporary
    /// files, say), then kills it.
    fn drop(&mut self) {
        drop(self.stdin.take());
        let deadline = Instant::now() + EXIT_GRACE;
        while Instant::now() < deadline {
            match self.child.try_wait() {
                Ok(None) => std::thread::sleep(Duration::from_millis(5)),
                Ok(Some(_)) | Err(_) => break,
            }
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
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
                 allows (1 MiB + 24 bytes per point): refused unread"
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

/// One program per setting, answering requests line by line.
pub(super) struct Session {
    pub(super) method: &'static str,
    pub(super) folder: PathBuf,
    command: Vec<String>,
    args: Vec<OsString>,
    pub(super) n_points: usize,
    timeout: Duration,
    log: PathBuf,
    _dir: tempfile::TempDir,
    process: Mutex<Option<Running>>,
    /// The LOD form: the program greets with its build line.
    lod: bool,
    /// The LOD form's last build line: its own seconds and the structure's size.
    pub(super) built: Mutex<Option<(Option<f64>, LodSize)>>,
}

impl Session {
    fn start(&self) -> Result<Running> {
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&self.log)
            .map_err(|e| external_error(self.method, e))?;
        let (program, args) = self
            .command
            .split_first()
            .ok_or_else(|| external_error(self.method, "empty command"))?;
        let mut child = Command::new(program)
            .args(args)
            .args(&self.args)
            .current_dir(&self.folder)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(log))
            .spawn()
            .map_err(|e| external_error(self.method, format!("cannot start {program}: {e}")))?;
        let stdin = child
            .stdin
            .take()
            .ok_or_else(|| external_error(self.method, "no stdin"))?;
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| external_error(self.method, "no stdout"))?;
        let (tx, rx) = channel();
        let limit = answer_limit(self.n_points);
        std::thread::spawn(move || {
            let mut reader = BufReader::new(stdout);
            loop {
                match read_line_bounded(&mut reader, limit) {
                    Ok(Some(line)) => {
                        if tx.send(Ok(line)).is_err() {
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
        Ok(Running {
            child,
            stdin: Some(stdin),
            lines: rx,
            fresh: true,
        })
    }

    fn log_tail(&self) -> String {
        // The log's last 4 KiB: a program may write gigabytes there too.
        let text = std::fs::File::open(&self.log)
            .and_then(|mut f| {
                let len = f.metadata()?.len();
                std::io::Seek::seek(&mut f, std::io::SeekFrom::Start(len.saturating_sub(4096)))?;
                let mut bytes = Vec::new();
                f.read_to_end(&mut bytes)?;
                Ok(String::from_utf8_lossy(&bytes).into_owned())
            })
            .unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(5).collect();
        if tail.is_empty() {
            format!("(log {} is empty)", self.log.display())
        } else {
            format!(
                "last lines of its stderr ({}): {}",
                self.log.display(),
                tail.into_iter()
                    .rev()
                    .map(|l| l.chars().take(300).collect::<String>())
                    .collect::<Vec<_>>()
                    .join(" | ")
            )
        }
    }

    /// Waits for one line (the first start's greeting, or an answer).
    fn receive(running: &mut Running, timeout: Duration) -> std::result::Result<String, String> {
        match running.lines.recv_timeout(timeout) {
            Ok(Ok(line)) => Ok(line),
            Ok(Err(e)) => Err(e),
            Err(RecvTimeoutError::Timeout) => {
                Err(format!("no answer within {:.1} s", timeout.as_secs_f64()))
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = running.child.wait().map(|s| s.to_string());
                Err(format!(
                    "the program exited ({}) without an answer",
                    status.unwrap_or_else(|e| e.to_string())
                ))
            }
        }
    }

    /// Sends `request` (one JSON line) and reads the answer line; the process is started
    /// first when none runs (`greet` then reads and checks its first line). Errors kill the
    /// process and name the view `what` and the log.
    pub(super) fn ask(
        &self,
        what: &str,
        request: Option<&str>,
        parse: &dyn Fn(&str) -> std::result::Result<(), String>,
    ) -> Result<f64> {
        let mut guard = self
            .process
            .lock()
            .map_err(|_| external_error(self.method, "process lock poisoned"))?;
        let fail = |guard: &mut Option<Running>, why: String| {
            // Kill it: the next request starts a fresh process.
            *guard = None;
            Err(external_error(
                self.method,
                format!("{what}: {why}; {}", self.log_tail()),
            ))
        };
        if guard.is_none() {
            let mut running = self.start()?;
            if self.lod {
                // The LOD form builds first and says so (again after a restart).
                let first = Self::receive(&mut running, self.timeout).and_then(|l| self.greet(&l));
                if let Err(why) = first {
                    drop(running);
                    return fail(&mut guard, why);
                }
                running.fresh = false;
            }
            *guard = Some(running);
        }
        let Some(request) = request else {
            return Ok(0.0);
        };
        let running = guard
            .as_mut()
            .ok_or_else(|| external_error(self.method, "no process"))?;
        let start = Instant::now();
        let sent = match running.stdin.as_mut() {
            Some(stdin) => stdin
                .write_all(request.as_bytes())
                .and_then(|()| stdin.write_all(b"\n"))
                .and_then(|()| stdin.flush()),
            None => Err(std::io::Error::other("its input is closed")),
        };
        if let Err(e) = sent {
            return fail(&mut guard, format!("the program is gone ({e})"));
        }
        let mut start = start;
        let mut line = match Self::receive(running, self.timeout) {
            Ok(line) => line,
            Err(why) => return fail(&mut guard, why),
        };
        if std::mem::take(&mut running.fresh) && is_built_line(&line) {
            // The visibility form's optional first line: the program's own set-up time.
            if let Err(why) = self.greet(&line) {
                return fail(&mut guard, why);
            }
            start = Instant::now();
            line = match Self::receive(running, self.timeout) {
                Ok(line) => line,
                Err(why) => return fail(&mut guard, why),
            };
        }
        let wall = start.elapsed().as_secs_f64();
        match parse(&line) {
            Ok(()) => Ok(wall),
            Err(why) => fail(&mut guard, why),
        }
    }

    /// The LOD form's first line: `{"built": true, "seconds": T, "nodes": K, "bytes": B}`.
    fn greet(&self, line: &str) -> std::result::Result<(), String> {
        let v = Self::json(line)?;
        if v.get("built").and_then(serde_json::Value::as_bool) != Some(true) {
            return Err(format!(
                "its first line is not {{\"built\": true, ...}}: {}",
                trunc(line)
            ));
        }
        let num = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
        if let Some(t) = v.get("seconds").filter(|t| !t.is_null())
            && !t.as_f64().is_some_and(|t| t.is_finite() && t >= 0.0)
        {
            return Err(format!(
                "its built line's \"seconds\" is not a number >= 0: {}",
                trunc(line)
            ));
        }
        *self.built.lock().map_err(|_| "lock")? = Some((
            num("seconds"),
            LodSize {
                nodes: num("nodes").unwrap_or(0.0).max(0.0) as usize,
                bytes: num("bytes").unwrap_or(0.0).max(0.0),
            },
        ));
        Ok(())
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
            let path = self.folder.join(path);
            let limit = answer_limit(n);
            let file = std::fs::File::open(&path)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            let len = file
                .metadata()
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?
                .len();
            if len > limit {
                return Err(format!(
                    "visible_file {} is {len} bytes, more than the {limit} bytes the cloud's \
                     index range allows (1 MiB + 24 bytes per point): refused unread",
                    path.display()
                ));
            }
            let mut text = String::new();
            file.take(limit)
                .read_to_string(&mut text)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            for t in text.split_whitespace() {
                take(
                    t.parse::<i64>()
                        .map_err(|_| format!("index {:?} is not an integer", trunc(t)))?,
                )?;
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

    /// A parsed answer line: `{"error": ...}` is an error, else the JSON.
    pub(super) fn json(line: &str) -> std::result::Result<serde_json::Value, String> {
        let v: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| format!("answer is not JSON ({e}): {}", trunc(line)))?;
        if let Some(msg) = v.get("error") {
            return Err(format!("it reported an error: {}", trunc(&msg.to_string())));
        }
        Ok(v)
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
        let dir = tempfile::tempdir().map_err(|e| external_error(self.name, e))?;
        let points = dir.path().join("points.ply");
        let origin = write_points(self.name, self.protocol, &points, cloud, normals)?;
        let mut args: Vec<OsString> = vec![
            "--points".into(),
            points.into(),
            "--params".into(),
            params.to_string().into(),
            "--protocol".into(),
            self.protocol.to_string().into(),
        ];
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
            log: dir.path().join("stderr.log"),
            _dir: dir,
            process: Mutex::new(None),
            lod: lod_radius.is_some(),
            built: Mutex::new(None),
        })
    }
}
