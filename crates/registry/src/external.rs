//! External methods, in any language: a folder `methods/NAME/` with a `method.toml` registers a
//! visibility method without a Rust change. The protocol (version 1; `methods/README.md` is the
//! user's documentation):
//!
//! - The caller writes the cloud's points once per preparation, as binary little-endian PLY
//!   (`x y z` doubles), and starts the method's `command` once per setting (the `--set` pairs),
//!   in the method's folder, with three arguments appended: `--points FILE --params JSON
//!   --protocol 1` (`JSON`: the pairs as an object of strings).
//! - Per view it writes one line on the program's standard input: `{"view": K, "camera":
//!   CAMERA}`, CAMERA being the camera's one serialisation (`cloud::camera::json`), and reads
//!   one line from its standard output: `{"visible": [indices...], "seconds": T}` (or
//!   `"visible_file": PATH` naming a file of indices, one per line or whitespace-separated),
//!   `T` the program's own compute seconds for that view, which is what gets reported; or
//!   `{"error": MESSAGE}`. End of input means exit.
//! - The answer is checked: indices must be integers in 0..N without repeats (they are sorted
//!   here). The program's standard error goes to a log file. A view that takes longer than
//!   `timeout_seconds` (default 300), a program that exits, or an answer that is not this
//!   protocol is an error naming the method, the view and the log; the process is killed and
//!   the next view starts a fresh one.
//!
//! `method.toml`:
//!
//! ```toml
//! protocol = 1
//! summary = "Open3D's hidden_point_removal (Qhull Qt), R from gamma as ours"
//! command = [".venv/bin/python", "hpr.py"]   # the first element: a path relative to the
//!                                            # folder, or a program on PATH
//! check = [".venv/bin/python", "-c", "import open3d"]   # exits 0 when installed
//! install = "just peers"                     # said when the check fails
//! timeout_seconds = 120
//! memory_bytes_per_point = 200               # for the scale experiment's memory guard
//!                                            # (undeclared: not run above 10^6 points)
//! cameras = ["pinhole", "spherical"]         # models it takes (default: all)
//! grid = [{gamma = ["2", "3"]}]             # what the visibility experiment sweeps, in
//! quick_grid = [{gamma = "3"}]               # registry::sweep's format (lists are swept)
//! family = "open3d-hpr"                      # how its rows group in plots (default: name)
//! [params.gamma]
//! default = "3"
//! help = "R = max|p - C| * 10^gamma"
//! ```

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use cloud::Camera;
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::{Input, Method, MethodSweep, Output, ParamSpec, Params, Prepared};

/// The protocol version this crate speaks.
pub const PROTOCOL: u32 = 1;

/// A parameter of an external method.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParamEntry {
    #[serde(default)]
    default: String,
    #[serde(default)]
    help: String,
}

/// `method.toml`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    protocol: u32,
    name: Option<String>,
    #[serde(default)]
    summary: String,
    command: Vec<String>,
    check: Option<Vec<String>>,
    install: Option<String>,
    timeout_seconds: Option<f64>,
    cameras: Option<Vec<String>>,
    #[serde(default)]
    params: BTreeMap<String, ParamEntry>,
    grid: Option<toml::Value>,
    quick_grid: Option<toml::Value>,
    default: Option<toml::Value>,
    family: Option<String>,
    memory_bytes_per_point: Option<u64>,
}

/// An external method (leaked once per process: the registry's methods live for it).
#[derive(Debug)]
pub struct ExternalMethod {
    name: &'static str,
    summary: &'static str,
    folder: PathBuf,
    command: Vec<String>,
    check: Option<Vec<String>>,
    install: Option<String>,
    timeout: Duration,
    cameras: Vec<String>,
    params: &'static [ParamSpec],
    sweep: Option<MethodSweep>,
    family: Option<String>,
    memory_bytes_per_point: Option<u64>,
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

fn external_error(method: &str, what: impl std::fmt::Display) -> Error {
    Error::Unsupported(format!("external method {method}: {what}"))
}

impl ExternalMethod {
    /// Reads `folder/method.toml`.
    pub fn load(folder: &Path) -> Result<Self> {
        // Absolute, so that relative programs resolve against it whatever the working folder.
        let folder = &folder
            .canonicalize()
            .map_err(|e| Error::Unsupported(format!("{}: {e}", folder.display())))?;
        let path = folder.join("method.toml");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| Error::Unsupported(format!("{}: {e}", path.display())))?;
        let m: Manifest = toml::from_str(&text)
            .map_err(|e| Error::Unsupported(format!("{}: {e}", path.display())))?;
        if m.protocol != PROTOCOL {
            return Err(Error::Unsupported(format!(
                "{}: protocol {} (this pointsight speaks {PROTOCOL})",
                path.display(),
                m.protocol
            )));
        }
        if m.command.is_empty() {
            return Err(Error::Unsupported(format!(
                "{}: command is empty",
                path.display()
            )));
        }
        let name = m.name.clone().unwrap_or_else(|| {
            folder
                .file_name()
                .map_or_else(|| "external".into(), |n| n.to_string_lossy().into_owned())
        });
        // The grid in `registry::sweep`'s format (a list of blocks, lists swept).
        let mut table = toml::Table::new();
        for (key, value) in [
            ("grid", &m.grid),
            ("quick_grid", &m.quick_grid),
            ("default", &m.default),
        ] {
            if let Some(v) = value {
                table.insert(key.to_owned(), v.clone());
            }
        }
        let sweep = if table.contains_key("grid") {
            Some(MethodSweep::from_toml(&table, &path.display().to_string())?)
        } else {
            None
        };
        let params: Vec<ParamSpec> = m
            .params
            .into_iter()
            .map(|(k, p)| ParamSpec {
                key: leak(k),
                default: leak(if p.default.is_empty() {
                    "-".into()
                } else {
                    p.default
                }),
                help: leak(p.help),
            })
            .collect();
        Ok(Self {
            name: leak(name),
            summary: leak(if m.summary.is_empty() {
                format!("external method in {}", folder.display())
            } else {
                m.summary
            }),
            folder: folder.to_owned(),
            command: m.command,
            check: m.check,
            install: m.install,
            timeout: Duration::from_secs_f64(m.timeout_seconds.unwrap_or(300.0).max(0.001)),
            cameras: m.cameras.unwrap_or_else(|| {
                vec!["pinhole".into(), "orthographic".into(), "spherical".into()]
            }),
            params: Box::leak(params.into_boxed_slice()),
            sweep,
            family: m.family,
            memory_bytes_per_point: m.memory_bytes_per_point,
        })
    }

    /// Every `*/method.toml` under `dir` (none when `dir` does not exist), by name.
    pub fn load_dir(dir: &Path) -> Result<Vec<Self>> {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return Ok(Vec::new());
        };
        let mut folders: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join("method.toml").exists())
            .collect();
        folders.sort();
        folders.iter().map(|f| Self::load(f)).collect()
    }

    fn resolve(&self, program: &str) -> PathBuf {
        let local = self.folder.join(program);
        if program.contains('/') || local.exists() {
            local
        } else {
            PathBuf::from(program)
        }
    }

    /// `Ok` when the method's check passes (or it has none), else why it is not installed.
    pub fn availability(&self) -> std::result::Result<(), String> {
        let Some(check) = &self.check else {
            return Ok(());
        };
        let Some((program, args)) = check.split_first() else {
            return Ok(());
        };
        let status = Command::new(self.resolve(program))
            .args(args)
            .current_dir(&self.folder)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        let install = self
            .install
            .as_deref()
            .map_or(String::new(), |i| format!("; install it with `{i}`"));
        match status {
            Ok(s) if s.success() => Ok(()),
            Ok(s) => Err(format!(
                "not installed (its check exited with {s}){install}"
            )),
            Err(e) => Err(format!(
                "not installed (its check could not start: {e}){install}"
            )),
        }
    }
}

impl Method for ExternalMethod {
    fn name(&self) -> &'static str {
        self.name
    }

    fn summary(&self) -> &'static str {
        self.summary
    }

    fn params(&self) -> &'static [ParamSpec] {
        self.params
    }

    fn availability(&self) -> std::result::Result<(), String> {
        ExternalMethod::availability(self)
    }

    fn sweep(&self) -> Option<MethodSweep> {
        self.sweep.clone()
    }

    fn family(&self, _setting: &crate::Setting) -> String {
        self.family.clone().unwrap_or_else(|| self.name.to_owned())
    }

    fn is_external(&self) -> bool {
        true
    }
    fn scale(&self) -> crate::Scale {
        // What the program and this process together need per point beyond the cloud, as the
        // method.toml declares it; undeclared: not run above Scale::UNKNOWN_LIMIT points.
        self.memory_bytes_per_point
            .map_or(crate::Scale::Unknown, crate::Scale::PerPoint)
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        self.availability()
            .map_err(|why| external_error(self.name, why))?;
        // Every key the manifest declares is passed on; others are refused by the caller.
        let mut pairs = serde_json::Map::new();
        for spec in self.params {
            if let Some(v) = params.get_opt::<String>(spec.key)? {
                pairs.insert(spec.key.to_owned(), serde_json::Value::String(v));
            }
        }
        let dir = tempfile::tempdir().map_err(|e| external_error(self.name, e))?;
        let points = dir.path().join("points.ply");
        let positions_only = cloud::PointCloud {
            positions: input.cloud.positions.clone(),
            ..Default::default()
        };
        cloud::io::ply_write::write_ply(&points, &positions_only)?;
        Ok(Box::new(ExternalPrepared {
            method: self.name,
            folder: self.folder.clone(),
            command: self
                .command
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    if k == 0 {
                        self.resolve(c).to_string_lossy().into_owned()
                    } else {
                        c.clone()
                    }
                })
                .collect(),
            params: serde_json::Value::Object(pairs).to_string(),
            points,
            n_points: input.cloud.len(),
            timeout: self.timeout,
            cameras: self.cameras.clone(),
            log: dir.path().join("stderr.log"),
            _dir: dir,
            process: Mutex::new(None),
            views: Mutex::new(0),
        }))
    }
}

/// A running program.
struct Running {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<std::io::Result<String>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

struct ExternalPrepared {
    method: &'static str,
    folder: PathBuf,
    command: Vec<String>,
    params: String,
    points: PathBuf,
    n_points: usize,
    timeout: Duration,
    cameras: Vec<String>,
    log: PathBuf,
    _dir: tempfile::TempDir,
    process: Mutex<Option<Running>>,
    views: Mutex<usize>,
}

impl ExternalPrepared {
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
            .arg("--points")
            .arg(&self.points)
            .arg("--params")
            .arg(&self.params)
            .arg("--protocol")
            .arg(PROTOCOL.to_string())
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
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Running {
            child,
            stdin,
            lines: rx,
        })
    }

    fn log_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(5).collect();
        if tail.is_empty() {
            format!("(log {} is empty)", self.log.display())
        } else {
            format!(
                "last lines of its stderr ({}): {}",
                self.log.display(),
                tail.into_iter().rev().collect::<Vec<_>>().join(" | ")
            )
        }
    }

    fn parse_answer(&self, line: &str) -> std::result::Result<(Vec<u32>, Option<f64>), String> {
        let v: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| format!("answer is not JSON ({e}): {line:.200}"))?;
        if let Some(msg) = v.get("error") {
            return Err(format!("it reported an error: {msg}"));
        }
        let seconds = v.get("seconds").and_then(serde_json::Value::as_f64);
        let raw: Vec<i64> = if let Some(list) = v.get("visible") {
            list.as_array()
                .ok_or("\"visible\" is not a list")?
                .iter()
                .map(|x| {
                    x.as_i64()
                        .ok_or_else(|| format!("index {x} is not an integer"))
                })
                .collect::<std::result::Result<_, _>>()?
        } else if let Some(path) = v.get("visible_file").and_then(serde_json::Value::as_str) {
            let path = self.folder.join(path);
            let text = std::fs::read_to_string(&path)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            text.split_whitespace()
                .map(|t| {
                    t.parse::<i64>()
                        .map_err(|_| format!("index {t:?} is not an integer"))
                })
                .collect::<std::result::Result<_, _>>()?
        } else {
            return Err(format!(
                "answer has neither \"visible\" nor \"visible_file\": {line:.200}"
            ));
        };
        let mut out = Vec::with_capacity(raw.len());
        for i in raw {
            if i < 0 || i as usize >= self.n_points {
                return Err(format!("index {i} is outside 0..{}", self.n_points));
            }
            out.push(i as u32);
        }
        out.sort_unstable();
        if let Some(w) = out.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("index {} is repeated", w[0]));
        }
        Ok((out, seconds))
    }
}

impl Prepared for ExternalPrepared {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        if !self.cameras.iter().any(|m| m == camera.model().name()) {
            return Err(Error::Unsupported(format!(
                "external method {} does not support {} cameras (it supports: {})",
                self.method,
                camera.model().name(),
                self.cameras.join(", ")
            )));
        }
        let view = {
            let mut v = self
                .views
                .lock()
                .map_err(|_| external_error(self.method, "lock"))?;
            *v += 1;
            *v - 1
        };
        let mut guard = self
            .process
            .lock()
            .map_err(|_| external_error(self.method, "process lock poisoned"))?;
        if guard.is_none() {
            *guard = Some(self.start()?);
        }
        let fail = |guard: &mut Option<Running>, what: String| {
            // Kill it: the next view starts a fresh process.
            *guard = None;
            Err(external_error(
                self.method,
                format!("view {view}: {what}; {}", self.log_tail()),
            ))
        };
        let running = guard
            .as_mut()
            .ok_or_else(|| external_error(self.method, "no process"))?;
        let request = format!("{{\"view\":{view},\"camera\":{}}}\n", camera.to_json());
        let start = Instant::now();
        if let Err(e) = running
            .stdin
            .write_all(request.as_bytes())
            .and_then(|()| running.stdin.flush())
        {
            return fail(&mut guard, format!("the program is gone ({e})"));
        }
        let line = match running.lines.recv_timeout(self.timeout) {
            Ok(Ok(line)) => line,
            Ok(Err(e)) => return fail(&mut guard, format!("cannot read its answer: {e}")),
            Err(RecvTimeoutError::Timeout) => {
                return fail(
                    &mut guard,
                    format!("no answer within {:.1} s", self.timeout.as_secs_f64()),
                );
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = running.child.wait().map(|s| s.to_string());
                return fail(
                    &mut guard,
                    format!(
                        "the program exited ({}) without an answer",
                        status.unwrap_or_else(|e| e.to_string())
                    ),
                );
            }
        };
        let wall = start.elapsed().as_secs_f64();
        match self.parse_answer(&line) {
            Ok((visible, seconds)) => Ok(Output {
                visible,
                reported_seconds: Some(seconds.unwrap_or(wall)),
                ..Output::default()
            }),
            Err(what) => fail(&mut guard, what),
        }
    }
}
