//! An external method's `method.toml` (its format: the [`super`] module's documentation and
//! `methods/README.md`), read and checked into an [`ExternalMethod`]: the program's command,
//! check, version, peer pairing, timeout, cameras, parameters and own sweep, and the program's
//! availability and version ([`Program`]).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::sync::mpsc::channel;
use std::time::Duration;

use serde::Deserialize;

use crate::card::{Metric, PeerKey, Program};
use crate::error::{Error, Result};
use crate::params::Param;
use crate::setting::{Setting, Value};
use crate::sweep::MethodSweep;

/// The newest protocol version this crate speaks.
pub const PROTOCOL: u32 = 3;

/// The versions it accepts.
pub const PROTOCOLS: &[u32] = &[1, 2, 3];

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
    version: Option<Vec<String>>,
    peer_of: Option<String>,
    kind: Option<String>,
    made_for: Option<String>,
    #[serde(default)]
    exact: bool,
    timeout_seconds: Option<f64>,
    cameras: Option<Vec<String>>,
    #[serde(default)]
    params: BTreeMap<String, ParamEntry>,
    grid: Option<toml::Value>,
    quick_grid: Option<toml::Value>,
    default: Option<toml::Value>,
    family: Option<String>,
    memory_bytes_per_point: Option<u64>,
    normals: Option<bool>,
    skip_robustness: Option<toml::Value>,
    #[serde(default)]
    peer_keys: BTreeMap<String, PeerKeyEntry>,
}

/// `[peer_keys]`: `point_size = {ours = "radius_px", factor = 0.5}`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PeerKeyEntry {
    ours: String,
    #[serde(default = "one")]
    factor: f64,
}

fn one() -> f64 {
    1.0
}

/// What an external method is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A visibility method.
    Visibility,
    /// A level-of-detail method (the LOD form of the protocol).
    Lod,
}

/// An external method (leaked once per process: the registry's methods live for it).
#[derive(Debug)]
pub struct ExternalMethod {
    pub(super) name: &'static str,
    pub(super) summary: &'static str,
    pub(super) folder: PathBuf,
    pub(super) protocol: u32,
    pub(super) kind: Kind,
    pub(super) made_for: Metric,
    pub(super) exact: bool,
    pub(super) command: Vec<String>,
    pub(super) check: Option<Vec<String>>,
    pub(super) install: Option<String>,
    pub(super) version_command: Option<Vec<String>>,
    pub(super) version: OnceLock<String>,
    /// Set once the check has passed in this process: a setting's preparation does not start
    /// the check's program again (importing VTK took about 2 s a setting, 12 settings a
    /// dataset). A failed check is not remembered, so an install in between is seen.
    pub(super) check_passed: std::sync::atomic::AtomicBool,
    pub(super) peer_of: Option<&'static str>,
    pub(super) timeout: Duration,
    pub(super) cameras: Vec<String>,
    pub(super) params: &'static [Param],
    pub(super) sweep: Option<MethodSweep>,
    pub(super) family: Option<String>,
    pub(super) memory_bytes_per_point: Option<u64>,
    /// Protocol 2 and later: the points file carries normals (`normals = false`: the program
    /// reads none, so none are estimated for it).
    pub(super) sends_normals: bool,
    pub(super) peer_keys: &'static [PeerKey],
}

pub(super) fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

pub(super) fn external_error(method: &str, what: impl std::fmt::Display) -> Error {
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
        let bad = |what: String| Error::Unsupported(format!("{}: {what}", path.display()));
        if !PROTOCOLS.contains(&m.protocol) {
            let (last, first) = PROTOCOLS.split_last().unwrap_or((&PROTOCOL, &[]));
            let first: Vec<String> = first.iter().map(u32::to_string).collect();
            return Err(bad(format!(
                "protocol {} (this pointsight speaks {} and {last})",
                m.protocol,
                first.join(", ")
            )));
        }
        if m.command.is_empty() {
            return Err(bad("command is empty".into()));
        }
        if m.version.as_ref().is_some_and(Vec::is_empty) {
            return Err(bad("version is an empty command".into()));
        }
        let kind = match m.kind.as_deref() {
            None | Some("visibility") => Kind::Visibility,
            Some("lod") if m.protocol >= 2 => Kind::Lod,
            Some("lod") => return Err(bad("kind = \"lod\" needs protocol = 2".into())),
            Some(other) => {
                return Err(bad(format!(
                    "kind = {other:?}: expected \"visibility\" or \"lod\""
                )));
            }
        };
        // The score it was made for: `points` unless it says `pixels` (an LOD method's
        // rendered image is judged per pixel).
        let made_for = match (m.made_for.as_deref(), kind) {
            (None, Kind::Lod) | (Some("pixels"), _) => Metric::Pixels,
            (None, Kind::Visibility) | (Some("points"), _) => Metric::Points,
            (Some(other), _) => {
                return Err(bad(format!(
                    "made_for = {other:?}: expected \"points\" or \"pixels\""
                )));
            }
        };
        if let Some(p) = &m.peer_of
            && (p.is_empty()
                || !p
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'))
        {
            return Err(bad(format!(
                "peer_of = {p:?}: expected a family name (lower-case letters, digits, '-'), \
                 e.g. \"hpr\", \"raycast\", \"splat\", \"hull\", \"voxel\", \"lod\""
            )));
        }
        if !m.peer_keys.is_empty() && m.peer_of.is_none() {
            return Err(bad("peer_keys without peer_of".into()));
        }
        let mut peer_keys = Vec::new();
        for (k, e) in &m.peer_keys {
            if !m.params.contains_key(k) {
                return Err(bad(format!("peer_keys.{k}: not one of its [params]")));
            }
            if !(e.factor.is_finite() && e.factor > 0.0) || e.ours.is_empty() {
                return Err(bad(format!(
                    "peer_keys.{k}: expected a key of ours and a positive factor"
                )));
            }
            peer_keys.push(PeerKey {
                peer: leak(k.clone()),
                ours: leak(e.ours.clone()),
                factor: e.factor,
            });
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
            ("skip_robustness", &m.skip_robustness),
        ] {
            if let Some(v) = value {
                table.insert(key.to_owned(), v.clone());
            }
        }
        let origin = path.display().to_string();
        // The one default setting, the same in every command: the `default` table, else every
        // `[params]` default that is a value (`-` or none: the program's own rule, not sent).
        let default = match &m.default {
            Some(v) => {
                let only: toml::Table = [("default".to_owned(), v.clone())].into_iter().collect();
                MethodSweep::from_toml(&only, &origin)?
                    .default
                    .unwrap_or_default()
            }
            None => Setting(
                m.params
                    .iter()
                    .filter(|(_, p)| !p.default.is_empty() && p.default != "-")
                    .map(|(k, p)| (k.clone(), Value::parse(&p.default)))
                    .collect(),
            ),
        };
        if let Some(k) = default.0.keys().find(|k| !m.params.contains_key(*k)) {
            return Err(bad(format!("default.{k}: not one of its [params]")));
        }
        let sweep = if table.contains_key("grid") {
            let mut sweep = MethodSweep::from_toml(&table, &origin)?;
            sweep.default = Some(default.clone());
            Some(sweep)
        } else {
            None
        };
        // A key of the default setting is sent at its default when not given (so the setting
        // a command prints is the one the program ran); any other is the program's own rule.
        let params: Vec<Param> = m
            .params
            .into_iter()
            .map(|(k, p)| match default.0.get(&k) {
                Some(v) => Param::value(leak(k), leak(v.to_string()), leak(p.help)),
                None => Param::rule(
                    leak(k),
                    leak(if p.default.is_empty() {
                        "-".into()
                    } else {
                        p.default
                    }),
                    leak(p.help),
                ),
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
            protocol: m.protocol,
            kind,
            made_for,
            exact: m.exact,
            command: m.command,
            check: m.check,
            install: m.install,
            version_command: m.version,
            version: OnceLock::new(),
            check_passed: std::sync::atomic::AtomicBool::new(false),
            peer_of: m.peer_of.map(leak),
            timeout: Duration::from_secs_f64(m.timeout_seconds.unwrap_or(300.0).max(0.001)),
            cameras: m.cameras.unwrap_or_else(|| {
                vec!["pinhole".into(), "orthographic".into(), "spherical".into()]
            }),
            params: Box::leak(params.into_boxed_slice()),
            sweep,
            family: m.family,
            memory_bytes_per_point: m.memory_bytes_per_point,
            sends_normals: m.normals.unwrap_or(true),
            peer_keys: Box::leak(peer_keys.into_boxed_slice()),
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

    /// Its name (the folder's, unless `name` gives one).
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// Visibility or LOD.
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// Its protocol version.
    pub fn protocol(&self) -> u32 {
        self.protocol
    }

    pub(super) fn resolve(&self, program: &str) -> PathBuf {
        let local = self.folder.join(program);
        if program.contains('/') || local.exists() {
            local
        } else {
            PathBuf::from(program)
        }
    }

    /// `Ok` when the method's check passes (or it has none), else why it is not installed. A
    /// check that passed once in this process is not run again.
    pub(super) fn check(&self) -> std::result::Result<(), String> {
        use std::sync::atomic::Ordering;
        if self.check_passed.load(Ordering::Relaxed) {
            return Ok(());
        }
        let passed = self.run_check();
        if passed.is_ok() {
            self.check_passed.store(true, Ordering::Relaxed);
        }
        passed
    }

    fn run_check(&self) -> std::result::Result<(), String> {
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

    /// The program's version as its `version` command prints it (the first line of its
    /// standard output, at most 200 characters), run once per process; `None` without one.
    /// A command that fails gives `unknown (why)`.
    fn run_version_once(&self) -> Option<String> {
        let command = self.version_command.as_ref()?;
        Some(
            self.version
                .get_or_init(|| match self.run_version(command) {
                    Ok(v) => v,
                    Err(why) => format!("unknown ({why})"),
                })
                .clone(),
        )
    }

    fn run_version(&self, command: &[String]) -> std::result::Result<String, String> {
        let (program, args) = command.split_first().ok_or("empty command")?;
        let mut child = Command::new(self.resolve(program))
            .args(args)
            .current_dir(&self.folder)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {program}: {e}"))?;
        let stdout = child.stdout.take().ok_or("no stdout")?;
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut text = String::new();
            let read = stdout.take(4096).read_to_string(&mut text);
            let _ = tx.send(read.map(|_| text));
        });
        let got = rx.recv_timeout(Duration::from_secs(30));
        let _ = child.kill();
        let status = child.wait().map_err(|e| e.to_string())?;
        let text = match got {
            Ok(Ok(t)) => t,
            Ok(Err(e)) => return Err(format!("cannot read its output: {e}")),
            Err(_) => return Err("no answer within 30 s".into()),
        };
        let line: String = text
            .lines()
            .next()
            .unwrap_or("")
            .trim()
            .chars()
            .take(200)
            .collect();
        if line.is_empty() {
            return Err(format!("it printed nothing ({status})"));
        }
        Ok(line)
    }

    pub(super) fn resolved_command(&self) -> Vec<String> {
        self.command
            .iter()
            .enumerate()
            .map(|(k, c)| {
                if k == 0 {
                    self.resolve(c).to_string_lossy().into_owned()
                } else {
                    c.clone()
                }
            })
            .collect()
    }
}

impl Program for ExternalMethod {
    fn availability(&self) -> std::result::Result<(), String> {
        self.check()
    }

    fn version(&self) -> Option<String> {
        self.run_version_once()
    }
}
