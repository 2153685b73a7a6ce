//! External methods, in any language: a folder `methods/NAME/` with a `method.toml` registers a
//! visibility method (or, with `kind = "lod"`, a level-of-detail method) without a Rust
//! change. The protocol (versions 1 and 2; `methods/README.md` is the user's documentation):
//!
//! - The caller writes the cloud once per preparation as binary little-endian PLY: `x y z`
//!   doubles (point k is index k); with protocol 2 also `nx ny nz` floats, the dataset's normals
//!   or, when it has none, the estimates the `lod` experiment uses (16 nearest neighbours,
//!   oriented away from the centroid: [`estimated_normals`]), and the dataset's `red green blue`
//!   and `u v` when it has them. It starts the method's `command` once per setting (the `--set`
//!   pairs), in the method's folder, with `--points FILE --params JSON --protocol P` appended
//!   (`JSON`: the pairs as an object of strings) and, with protocol 2, `--normals dataset` or
//!   `--normals estimated` and `--spacing S`, the cloud's density spacing
//!   (`cloud::spacing::density_spacing`, 8 neighbours, 20 000 samples, seed 1: the unit of our
//!   radius factors; absent on clouds of at most 8 points).
//! - Per view it writes one line on the program's standard input: `{"view": K, "camera":
//!   CAMERA}`, CAMERA being the camera's one serialisation (`cloud::camera::json`), K the
//!   dataset's view index when the caller knows it ([`Prepared::visible_at`]; a caller that
//!   does not gets its calls counted), and reads one line from its standard output:
//!   `{"visible": [indices...], "seconds": T}` (or `"visible_file": PATH` naming a file of
//!   indices, whitespace-separated), `T` the program's own compute seconds for that view, which
//!   is what gets reported; or `{"error": MESSAGE}`. End of input means exit. Before its
//!   first answer a program may write `{"built": true, "seconds": T}`: its own per-cloud set-up
//!   (a BVH, a render window), reported apart from the per-view times
//!   ([`Prepared::reported_build_seconds`]; again after a restart, the last one kept).
//! - The LOD form (`kind = "lod"`, protocol 2): started once per cloud with `--lod --radius R`
//!   appended too (R the full-detail splat radius, world units), the program builds its structure and says so on its first line, `{"built": true,
//!   "seconds": T, "nodes": K, "bytes": B}` (its own build time); then per view and setting it
//!   reads `{"view": K, "camera": CAMERA, "params": JSON}` and answers `{"visible": [...],
//!   "radius": R, "seconds": T}`, R one splat radius (world units) for all or a list, one per
//!   index, and optionally `"bytes_read": B`, the bytes the selection read from the program's
//!   own file (a COPC file), reported as a file selection's reads ([`LodSelector::reads`]).
//! - The answer is checked with bounded memory: a line longer than the cloud's index range
//!   allows ([`answer_limit`]: 1 MiB plus 24 bytes per point), a `visible_file` larger than
//!   that, more indices than points, indices outside 0..N and repeated ones are errors (the
//!   indices are sorted here). The program's standard error goes to a log file. A view that
//!   takes longer than `timeout_seconds` (default 300), a program that exits, or an answer
//!   that is not this protocol is an error naming the method, the view and the log; the
//!   process is killed and the next view starts a fresh one. A program that is done with
//!   (the cell is over, or it failed) has its input closed and 3 s to exit before the kill.
//!
//! `method.toml`:
//!
//! ```toml
//! protocol = 2
//! summary = "peer: Open3D's hidden_point_removal (Qhull Qt), R from gamma as ours"
//! command = [".venv/bin/python", "hpr.py"]   # the first element: a path relative to the
//!                                            # folder, or a program on PATH
//! check = [".venv/bin/python", "-c", "import open3d"]   # exits 0 when installed
//! install = "just peers"                     # said when the check fails
//! version = [".venv/bin/python", "-c", "import open3d; print(open3d.__version__)"]
//! peer_of = "hpr"                            # the family of ours it pairs with
//! kind = "visibility"                        # or "lod"
//! timeout_seconds = 120
//! memory_bytes_per_point = 200               # for the scale experiment's memory guard
//!                                            # (undeclared: not run above 10^6 points)
//! cameras = ["pinhole", "spherical"]         # models it takes (default: all)
//! grid = [{gamma = ["2", "3"]}]             # what the visibility experiment sweeps, in
//! quick_grid = [{gamma = "3"}]               # registry::sweep's format (lists are swept)
//! family = "open3d-hpr"                      # how its rows group in plots (default: name)
//! skip_robustness = "why"                    # leaves the robustness experiment (listed
//!                                            # with the reason); default: it takes part
//! # peer_keys = {point_size = {ours = "radius_px", factor = 0.5}}: for a peer whose key's
//! # name or unit differs from its partner's (ours = factor x the peer's; same names as is)
//! [params.gamma]
//! default = "3"
//! help = "R = max|p - C| * 10^gamma"
//! ```

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use cloud::Camera;
use cloud::glam::Vec3;
use serde::Deserialize;
use splat::render::Splat;

use crate::error::{Error, Result};
use crate::lod::{LodBuilt, LodInput, LodMethod, LodSelector, LodSize, Reads};
use crate::{Input, Method, MethodSweep, Output, ParamSpec, Params, Prepared};

/// The newest protocol version this crate speaks.
pub const PROTOCOL: u32 = 2;

/// The versions it accepts.
pub const PROTOCOLS: &[u32] = &[1, 2];

/// Bytes an answer may take beyond its indices' share (JSON keys, `seconds`, a message).
const ANSWER_SLACK: u64 = 1 << 20;

/// Bytes per index an answer may take (ten digits, a separator, spaces, a radius).
const BYTES_PER_INDEX: u64 = 24;

/// The longest answer line (and `visible_file`) accepted from a method on a cloud of
/// `n_points`: 1 MiB plus 24 bytes per point. Longer is a flood, refused before it is read.
pub fn answer_limit(n_points: usize) -> u64 {
    ANSWER_SLACK.saturating_add(BYTES_PER_INDEX.saturating_mul(n_points as u64))
}

/// The normals protocol 2 sends for a cloud without its own: 16 nearest neighbours (fewer on
/// a smaller cloud), oriented away from the centroid, as the `lod` experiment estimates them.
pub fn estimated_normals(positions: &[cloud::glam::DVec3]) -> Result<Vec<Vec3>> {
    Ok(cloud::normals::estimate_normals(
        positions,
        16.min(positions.len()),
        cloud::normals::Orientation::AwayFromCentroid,
    )?)
}

/// The normals protocol 2 sends (and our disc ray cast, its partner, uses): the cloud's own
/// (`"dataset"`), else [`estimated_normals`] (`"estimated"`).
pub fn cloud_normals(cloud: &cloud::PointCloud) -> Result<(Cow<'_, [Vec3]>, &'static str)> {
    Ok(match &cloud.normals {
        Some(n) => (Cow::Borrowed(&n[..]), "dataset"),
        None => (
            Cow::Owned(estimated_normals(&cloud.positions)?),
            "estimated",
        ),
    })
}

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
    timeout_seconds: Option<f64>,
    cameras: Option<Vec<String>>,
    #[serde(default)]
    params: BTreeMap<String, ParamEntry>,
    grid: Option<toml::Value>,
    quick_grid: Option<toml::Value>,
    default: Option<toml::Value>,
    family: Option<String>,
    memory_bytes_per_point: Option<u64>,
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
    /// A visibility method ([`Method`]).
    Visibility,
    /// A level-of-detail method ([`LodMethod`], the LOD form of the protocol).
    Lod,
}

/// An external method (leaked once per process: the registry's methods live for it).
#[derive(Debug)]
pub struct ExternalMethod {
    name: &'static str,
    summary: &'static str,
    folder: PathBuf,
    protocol: u32,
    kind: Kind,
    command: Vec<String>,
    check: Option<Vec<String>>,
    install: Option<String>,
    version_command: Option<Vec<String>>,
    version: OnceLock<String>,
    peer_of: Option<&'static str>,
    timeout: Duration,
    cameras: Vec<String>,
    params: &'static [ParamSpec],
    sweep: Option<MethodSweep>,
    family: Option<String>,
    memory_bytes_per_point: Option<u64>,
    peer_keys: &'static [crate::PeerKey],
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
        let bad = |what: String| Error::Unsupported(format!("{}: {what}", path.display()));
        if !PROTOCOLS.contains(&m.protocol) {
            return Err(bad(format!(
                "protocol {} (this pointsight speaks {})",
                m.protocol,
                PROTOCOLS
                    .iter()
                    .map(u32::to_string)
                    .collect::<Vec<_>>()
                    .join(" and ")
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
            peer_keys.push(crate::PeerKey {
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
            protocol: m.protocol,
            kind,
            command: m.command,
            check: m.check,
            install: m.install,
            version_command: m.version,
            version: OnceLock::new(),
            peer_of: m.peer_of.map(leak),
            timeout: Duration::from_secs_f64(m.timeout_seconds.unwrap_or(300.0).max(0.001)),
            cameras: m.cameras.unwrap_or_else(|| {
                vec!["pinhole".into(), "orthographic".into(), "spherical".into()]
            }),
            params: Box::leak(params.into_boxed_slice()),
            sweep,
            family: m.family,
            memory_bytes_per_point: m.memory_bytes_per_point,
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

    /// The program's version as its `version` command prints it (the first line of its
    /// standard output, at most 200 characters), run once per process; `None` without one.
    /// A command that fails gives `unknown (why)`.
    pub fn version(&self) -> Option<String> {
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

    fn resolved_command(&self) -> Vec<String> {
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

    /// The `--set` pairs the manifest declares, as a JSON object of strings.
    fn params_json(&self, params: &Params) -> Result<serde_json::Value> {
        let mut pairs = serde_json::Map::new();
        for spec in self.params {
            if let Some(v) = params.get_opt::<String>(spec.key)? {
                pairs.insert(spec.key.to_owned(), serde_json::Value::String(v));
            }
        }
        Ok(serde_json::Value::Object(pairs))
    }

    /// Writes the cloud for the program: `x y z` (protocol 1); with protocol 2 the normals
    /// (`normals`, else the dataset's, else estimated), colours and texture coordinates too.
    /// Returns the `--normals` word (protocol 2).
    fn write_points(
        &self,
        path: &Path,
        cloud: &cloud::PointCloud,
        normals: Option<&[Vec3]>,
    ) -> Result<Option<&'static str>> {
        if self.protocol < 2 {
            let positions_only = cloud::PointCloud {
                positions: cloud.positions.clone(),
                ..Default::default()
            };
            cloud::io::ply_write::write_ply(path, &positions_only)?;
            return Ok(None);
        }
        let (normals, origin) = match normals {
            Some(n) => (Cow::Borrowed(n), "given"),
            None => cloud_normals(cloud).map_err(|e| {
                external_error(self.name, format!("cannot estimate normals to send: {e}"))
            })?,
        };
        let out = cloud::PointCloud {
            positions: cloud.positions.clone(),
            normals: Some(normals.into_owned()),
            colors: cloud.colors.clone(),
            uvs: cloud.uvs.clone(),
            ..Default::default()
        };
        cloud::io::ply_write::write_ply(path, &out)?;
        Ok(Some(origin))
    }

    /// A session for one setting: the points written, the program not started yet.
    fn session(
        &self,
        cloud: &cloud::PointCloud,
        normals: Option<&[Vec3]>,
        params: serde_json::Value,
        lod_radius: Option<f64>,
    ) -> Result<Session> {
        let dir = tempfile::tempdir().map_err(|e| external_error(self.name, e))?;
        let points = dir.path().join("points.ply");
        let origin = self.write_points(&points, cloud, normals)?;
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

    fn peer_of(&self) -> Option<&'static str> {
        self.peer_of
    }

    fn peer_keys(&self) -> &'static [crate::PeerKey] {
        self.peer_keys
    }

    fn version(&self) -> Option<String> {
        ExternalMethod::version(self)
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        if self.kind == Kind::Lod {
            return Err(external_error(
                self.name,
                "it is a level-of-detail method (kind = \"lod\"): the lod experiment runs it",
            ));
        }
        self.availability()
            .map_err(|why| external_error(self.name, why))?;
        // Every key the manifest declares is passed on; others are refused by the caller.
        let pairs = self.params_json(params)?;
        Ok(Box::new(ExternalPrepared {
            session: self.session(input.cloud, None, pairs, None)?,
            cameras: self.cameras.clone(),
            views: Mutex::new(0),
        }))
    }
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
const EXIT_GRACE: Duration = Duration::from_secs(3);

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
fn read_line_bounded(
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
struct Session {
    method: &'static str,
    folder: PathBuf,
    command: Vec<String>,
    args: Vec<OsString>,
    n_points: usize,
    timeout: Duration,
    log: PathBuf,
    _dir: tempfile::TempDir,
    process: Mutex<Option<Running>>,
    /// The LOD form: the program greets with its build line.
    lod: bool,
    /// The LOD form's last build line: its own seconds and the structure's size.
    built: Mutex<Option<(Option<f64>, LodSize)>>,
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
    fn ask(
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
    fn indices(&self, v: &serde_json::Value) -> std::result::Result<Vec<u32>, String> {
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
    fn json(line: &str) -> std::result::Result<serde_json::Value, String> {
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
fn trunc(s: &str) -> String {
    let mut t: String = s.chars().take(200).collect();
    if t.len() < s.len() {
        t.push('…');
    }
    t
}

struct ExternalPrepared {
    session: Session,
    cameras: Vec<String>,
    /// Views asked through [`Prepared::visible`], which does not know the view's index.
    views: Mutex<usize>,
}

impl ExternalPrepared {
    fn ask(&self, view: usize, camera: &Camera) -> Result<Output> {
        if !self.cameras.iter().any(|m| m == camera.model().name()) {
            return Err(Error::Unsupported(format!(
                "external method {} does not support {} cameras (it supports: {})",
                self.session.method,
                camera.model().name(),
                self.cameras.join(", ")
            )));
        }
        let request = format!("{{\"view\":{view},\"camera\":{}}}", camera.to_json());
        let answer = Mutex::new(None);
        let wall = self
            .session
            .ask(&format!("view {view}"), Some(&request), &|line| {
                let v = Session::json(line)?;
                let seconds = v.get("seconds").and_then(serde_json::Value::as_f64);
                let visible = self.session.indices(&v)?;
                *answer.lock().map_err(|_| "lock")? = Some((visible, seconds));
                Ok(())
            })?;
        let (visible, seconds) = answer
            .into_inner()
            .ok()
            .flatten()
            .ok_or_else(|| external_error(self.session.method, "no answer"))?;
        Ok(Output {
            visible,
            reported_seconds: Some(seconds.unwrap_or(wall)),
            ..Output::default()
        })
    }
}

impl Prepared for ExternalPrepared {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let view = {
            let mut v = self
                .views
                .lock()
                .map_err(|_| external_error(self.session.method, "lock"))?;
            *v += 1;
            *v - 1
        };
        self.ask(view, camera)
    }

    fn visible_at(&self, view: usize, camera: &Camera) -> Result<Output> {
        self.ask(view, camera)
    }

    fn reported_build_seconds(&self) -> Option<f64> {
        self.session.built.lock().ok()?.as_ref()?.0
    }
}

// ---- The LOD form. ----

impl LodMethod for ExternalMethod {
    fn scale(&self) -> crate::Scale {
        // The manifest's `memory_bytes_per_point`, as for the visibility form.
        Method::scale(self)
    }
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

    fn peer_of(&self) -> Option<&'static str> {
        self.peer_of
    }

    fn version(&self) -> Option<String> {
        ExternalMethod::version(self)
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        if self.kind != Kind::Lod {
            return Err(external_error(
                self.name,
                "it is a visibility method (kind = \"visibility\"), not a level-of-detail one",
            ));
        }
        self.availability()
            .map_err(|why| external_error(self.name, why))?;
        if input.normals.len() != input.cloud.len() {
            return Err(external_error(
                self.name,
                format!(
                    "{} normals for {} points",
                    input.normals.len(),
                    input.cloud.len()
                ),
            ));
        }
        let session = self.session(
            input.cloud,
            Some(input.normals),
            serde_json::Value::Object(serde_json::Map::new()),
            Some(input.radius),
        )?;
        // Start it now: the build is this call.
        session.ask("build", None, &|_| Ok(()))?;
        let (seconds, size) = session
            .built
            .lock()
            .ok()
            .and_then(|b| *b)
            .ok_or_else(|| external_error(self.name, "no build line"))?;
        Ok(Box::new(ExternalLodBuilt {
            session,
            build_seconds: seconds,
            size,
            params: self.params,
            name: self.name,
            views: Mutex::new(0),
        }))
    }
}

struct ExternalLodBuilt {
    session: Session,
    build_seconds: Option<f64>,
    size: LodSize,
    params: &'static [ParamSpec],
    name: &'static str,
    views: Mutex<usize>,
}

impl LodBuilt for ExternalLodBuilt {
    fn size(&self) -> LodSize {
        self.size
    }

    fn reported_build_seconds(&self) -> Option<f64> {
        self.build_seconds
    }

    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let mut pairs = serde_json::Map::new();
        for spec in self.params {
            if let Some(v) = params.get_opt::<String>(spec.key)? {
                pairs.insert(spec.key.to_owned(), serde_json::Value::String(v));
            }
        }
        params.check_all_read(self.name, self.params)?;
        Ok(Box::new(ExternalLodSel {
            built: self,
            input,
            params: serde_json::Value::Object(pairs).to_string(),
            last: Vec::new(),
            seconds: None,
            bytes_read: None,
        }))
    }
}

struct ExternalLodSel<'s> {
    built: &'s ExternalLodBuilt,
    input: &'s LodInput<'s>,
    params: String,
    last: Vec<(u32, f64)>,
    seconds: Option<f64>,
    /// The last answer's `bytes_read`.
    bytes_read: Option<u64>,
}

impl ExternalLodSel<'_> {
    fn ask(&mut self, view: usize, camera: &Camera) -> Result<()> {
        let session = &self.built.session;
        let request = format!(
            "{{\"view\":{view},\"camera\":{},\"params\":{}}}",
            camera.to_json(),
            self.params
        );
        let answer = Mutex::new(None);
        let wall = session.ask(&format!("view {view}"), Some(&request), &|line| {
            let v = Session::json(line)?;
            let visible = session.indices(&v)?;
            let radii: Vec<f64> = match v.get("radius") {
                Some(serde_json::Value::Array(list)) => {
                    if list.len() != visible.len() {
                        return Err(format!(
                            "{} radii for {} indices",
                            list.len(),
                            visible.len()
                        ));
                    }
                    // The radii follow the answer's order; the indices were sorted, so
                    // re-read the pairs in the answer's order.
                    let order = answer_order(&v, session)?;
                    let mut pairs: Vec<(u32, f64)> = order
                        .into_iter()
                        .zip(list)
                        .map(|(i, r)| r.as_f64().map(|r| (i, r)).ok_or("radius not a number"))
                        .collect::<std::result::Result<_, _>>()?;
                    pairs.sort_unstable_by_key(|p| p.0);
                    pairs.into_iter().map(|p| p.1).collect()
                }
                Some(r) => {
                    let r = r.as_f64().ok_or("\"radius\" is not a number")?;
                    vec![r; visible.len()]
                }
                None => return Err("answer has no \"radius\"".into()),
            };
            if let Some(r) = radii.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
                return Err(format!("splat radius {r} is not a positive number"));
            }
            let seconds = v.get("seconds").and_then(serde_json::Value::as_f64);
            let bytes_read =
                match v.get("bytes_read") {
                    None => None,
                    Some(b) => Some(b.as_u64().ok_or_else(|| {
                        format!("\"bytes_read\" {b} is not a whole number of bytes")
                    })?),
                };
            *answer.lock().map_err(|_| "lock")? = Some((
                visible.into_iter().zip(radii).collect::<Vec<_>>(),
                seconds,
                bytes_read,
            ));
            Ok(())
        })?;
        let (last, seconds, bytes_read) = answer
            .into_inner()
            .ok()
            .flatten()
            .ok_or_else(|| external_error(session.method, "no answer"))?;
        self.last = last;
        self.seconds = Some(seconds.unwrap_or(wall));
        self.bytes_read = bytes_read;
        Ok(())
    }
}

/// The answer's `visible` list in its own order (checked already by [`Session::indices`]).
fn answer_order(v: &serde_json::Value, session: &Session) -> std::result::Result<Vec<u32>, String> {
    match v.get("visible").and_then(serde_json::Value::as_array) {
        Some(list) => Ok(list
            .iter()
            .filter_map(serde_json::Value::as_u64)
            .map(|i| i as u32)
            .collect()),
        None => Err(format!(
            "external method {}: per-index radii need the \"visible\" list (not a file)",
            session.method
        )),
    }
}

impl LodSelector for ExternalLodSel<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let view = {
            let mut v = self
                .built
                .views
                .lock()
                .map_err(|_| external_error(self.built.name, "lock"))?;
            *v += 1;
            *v - 1
        };
        self.ask(view, camera)
    }

    fn select_at(&mut self, view: usize, camera: &Camera) -> Result<()> {
        self.ask(view, camera)
    }

    fn reported_seconds(&self) -> Option<f64> {
        self.seconds
    }

    fn reads(&self) -> Option<Reads> {
        // The program's own file, read as it says; it keeps no cache pointsight knows of.
        self.bytes_read.map(|bytes_read| Reads {
            bytes_read,
            cache_bytes: 0,
            selection_bytes: (self.last.len() * size_of::<Splat>()) as u64,
        })
    }

    fn splats(&self) -> Vec<Splat> {
        self.last
            .iter()
            .map(|&(i, r)| self.input.point_splat(i as usize, r))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bounded_line_is_read_and_a_flood_refused_unread() {
        let mut ok = std::io::Cursor::new(b"abc\ndef".to_vec());
        assert_eq!(
            read_line_bounded(&mut ok, 3).unwrap().as_deref(),
            Some("abc")
        );
        assert_eq!(
            read_line_bounded(&mut ok, 3).unwrap().as_deref(),
            Some("def")
        );
        assert_eq!(read_line_bounded(&mut ok, 3).unwrap(), None);
        // A reader of endless bytes without a newline: refused after the limit.
        let mut flood = BufReader::new(std::io::repeat(b'1'));
        let err = read_line_bounded(&mut flood, 1 << 16).unwrap_err();
        assert!(err.contains("longer than 65536 bytes"), "{err}");
    }

    /// A 64 × 48 pinhole camera 50 units up the z axis, looking at the origin.
    fn test_camera() -> Camera {
        Camera::new(
            cloud::glam::DVec3::new(0.0, 0.0, 50.0),
            cloud::glam::DVec3::ZERO,
            cloud::glam::DVec3::Y,
            60.0,
            64,
            48,
        )
        .unwrap()
    }

    fn folder(manifest: &str, script: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("method.toml"), manifest).unwrap();
        std::fs::write(dir.path().join("m.py"), script).unwrap();
        dir
    }

    #[test]
    fn the_version_is_run_once_and_peer_of_read() {
        let dir = folder(
            "protocol = 2\ncommand = [\"python3\", \"m.py\"]\npeer_of = \"voxel\"\n\
             version = [\"python3\", \"m.py\"]\n",
            "import os\nprint('tool', len(open('count', 'a+').name))\nopen('count', 'a').write('x')\n",
        );
        let m = ExternalMethod::load(dir.path()).unwrap();
        assert_eq!(Method::peer_of(&m), Some("voxel"));
        assert_eq!(m.version().as_deref(), Some("tool 5"));
        assert_eq!(m.version().as_deref(), Some("tool 5"));
        // Run once: the program appended one mark.
        assert_eq!(
            std::fs::read_to_string(dir.path().join("count")).unwrap(),
            "x"
        );
        let none = folder("protocol = 1\ncommand = [\"true\"]\n", "");
        let m = ExternalMethod::load(none.path()).unwrap();
        assert_eq!((m.version(), Method::peer_of(&m)), (None, None));
        let failing = folder(
            "protocol = 1\ncommand = [\"true\"]\nversion = [\"false\"]\n",
            "",
        );
        let m = ExternalMethod::load(failing.path()).unwrap();
        assert!(
            m.version()
                .unwrap()
                .starts_with("unknown (it printed nothing")
        );
    }

    /// End of input means exit: a program the caller is done with has its input closed and
    /// time to clean up (its temporary files), and one that does not exit is killed after
    /// [`EXIT_GRACE`].
    /// Twenty points, not coplanar.
    fn small_cloud() -> cloud::PointCloud {
        cloud::PointCloud {
            positions: (0..20)
                .map(|i| cloud::glam::DVec3::new(f64::from(i), f64::from(i * i % 7), 1.0))
                .collect(),
            ..Default::default()
        }
    }

    /// The external method in `dir` at its default setting over `views`, through the kernel.
    fn run_cell(
        dir: &tempfile::TempDir,
        cloud: &cloud::PointCloud,
        views: &[crate::kernel::View],
    ) -> (Result<crate::kernel::Preparation>, crate::kernel::Answers) {
        let m = ExternalMethod::load(dir.path()).unwrap();
        let input = Input { cloud, mesh: None };
        let cell = crate::kernel::Cell::new(&m, &crate::Setting::parse(""), views, 1);
        crate::kernel::collect(&cell, input)
    }

    #[test]
    fn a_finished_program_gets_end_of_input_then_a_kill() {
        let script = |after: &str| {
            format!(
                "import sys, json, os, time\nopen('alive', 'w').write('x')\n\
                 for line in sys.stdin:\n    json.loads(line)\n    \
                 print(json.dumps({{'visible': [0], 'seconds': 0.0}}), flush=True)\n{after}\n"
            )
        };
        let manifest = "protocol = 2\ncommand = [\"python3\", \"m.py\"]\n";
        let cloud = small_cloud();
        let camera = test_camera();
        let views = crate::kernel::View::all(&[camera, camera]);
        let run = |dir: &tempfile::TempDir| {
            let start = Instant::now();
            let (prepared, answers) = run_cell(dir, &cloud, &views);
            prepared.unwrap();
            assert!(answers.iter().all(|(_, a)| a.is_ok()), "{answers:?}");
            start.elapsed()
        };
        // It takes half a second to remove its file at the end of its input; the caller waits.
        let tidy = folder(manifest, &script("time.sleep(0.5)\nos.remove('alive')"));
        run(&tidy);
        assert!(
            !tidy.path().join("alive").exists(),
            "the program was killed before it cleaned up"
        );
        // One that lingers is killed once the grace is over (not after its 60 s).
        let linger = folder(manifest, &script("time.sleep(60)"));
        let took = run(&linger);
        assert!(linger.path().join("alive").exists());
        assert!(
            took >= EXIT_GRACE && took < EXIT_GRACE + Duration::from_secs(20),
            "{took:?}"
        );
    }

    #[test]
    fn a_built_line_before_the_first_answer_is_its_build_time() {
        // One program says how long its set-up took, once, before its first answer; another
        // says nothing; a third sends a `built` line in place of an answer later (an error).
        let script = |first: &str, later: &str| {
            format!(
                "import sys, json\n{first}\nfor k, line in enumerate(sys.stdin):\n    \
                 json.loads(line)\n    {later}\n    \
                 print(json.dumps({{'visible': [k], 'seconds': 0.5}}), flush=True)\n"
            )
        };
        let built = "print(json.dumps({'built': True, 'seconds': 1.25}), flush=True)";
        let manifest = "protocol = 2\ncommand = [\"python3\", \"m.py\"]\n";
        let cloud = small_cloud();
        let camera = test_camera();
        let views = crate::kernel::View::all(&[camera, camera, camera]);
        let run = |dir: &tempfile::TempDir| run_cell(dir, &cloud, &views);
        let (prep, answers) = run(&folder(manifest, &script(built, "pass")));
        assert_eq!(prep.unwrap().reported_seconds, Some(1.25));
        let visible: Vec<Vec<u32>> = answers
            .iter()
            .map(|(_, a)| a.as_ref().unwrap().output.visible.clone())
            .collect();
        assert_eq!(
            visible,
            [vec![0], vec![1], vec![2]],
            "the built line is no answer"
        );
        assert!(
            answers
                .iter()
                .all(|(_, a)| a.as_ref().unwrap().timing.median == 0.5)
        );
        let (prep, answers) = run(&folder(manifest, &script("", "pass")));
        assert_eq!(prep.unwrap().reported_seconds, None);
        assert!(answers.iter().all(|(_, a)| a.is_ok()));
        // A `built` line where view 1's answer belongs is not an answer.
        let (_, answers) = run(&folder(
            manifest,
            &script(
                built,
                "if k == 1: print(json.dumps({'built': True, 'seconds': 2}), flush=True); continue",
            ),
        ));
        assert!(answers[0].1.is_ok(), "{:?}", answers[0].1);
        let err = answers[1].1.as_ref().unwrap_err();
        assert!(err.contains("neither \"visible\""), "{err}");
        // A build time that is not a number >= 0 is refused, not recorded.
        let lying = "print(json.dumps({'built': True, 'seconds': -1}), flush=True)";
        let (_, answers) = run(&folder(manifest, &script(lying, "pass")));
        let err = answers[0].1.as_ref().unwrap_err();
        assert!(err.contains("not a number >= 0"), "{err}");
    }

    #[test]
    fn the_lod_form_builds_once_and_selects_per_view() {
        let script = r#"
import sys, json
args = sys.argv[1:]
assert "--lod" in args and args[args.index("--protocol") + 1] == "2", args
header = open(args[args.index("--points") + 1], "rb").read(500).split(b"end_header")[0]
assert b"nx" in header and b"red" in header, header
print(json.dumps({"built": True, "seconds": 0.125, "nodes": 7, "bytes": 64}), flush=True)
for line in sys.stdin:
    req = json.loads(line)
    k = int(req["params"]["keep"])
    print(json.dumps({"visible": list(range(k))[::-1], "radius": [0.5 + i for i in range(k)][::-1],
                      "seconds": 0.25 + req["view"], "bytes_read": 1000 * k}), flush=True)
"#;
        let dir = folder(
            "protocol = 2\nkind = \"lod\"\ncommand = [\"python3\", \"m.py\"]\n\
             peer_of = \"lod\"\n[params.keep]\ndefault = \"2\"\nhelp = \"points kept\"\n",
            script,
        );
        let m = ExternalMethod::load(dir.path()).unwrap();
        assert_eq!(m.kind(), Kind::Lod);
        let positions: Vec<cloud::glam::DVec3> = (0..20)
            .map(|i| cloud::glam::DVec3::new(f64::from(i), f64::from(i * i % 7), 1.0))
            .collect();
        let n = positions.len();
        let cloud = cloud::PointCloud {
            positions,
            colors: Some(vec![[10, 20, 30]; n]),
            ..Default::default()
        };
        let normals = vec![Vec3::Z; n];
        let albedo = vec![Vec3::ONE; n];
        let uvs = vec![cloud::glam::Vec2::ZERO; n];
        let texture = srn::texture::Texture::new(1, 1, vec![[0, 0, 0]]).unwrap();
        let input = LodInput {
            cloud: &cloud,
            normals: &normals,
            albedo: &albedo,
            uvs: &uvs,
            texture: Some(&texture),
            radius: 0.1,
            seed: 0,
        };
        let built = LodMethod::build(&m, &input).unwrap();
        assert_eq!(built.reported_build_seconds(), Some(0.125));
        assert_eq!(
            built.size(),
            LodSize {
                nodes: 7,
                bytes: 64.0
            }
        );
        let mut params = Params::parse(&["keep=3".to_owned()]).unwrap();
        let mut sel = built.selector(&input, &params).unwrap();
        let camera = test_camera();
        sel.select_at(4, &camera).unwrap();
        assert_eq!(sel.reported_seconds(), Some(4.25));
        // Its bytes read, as a file selection's reads.
        let reads = sel.reads().unwrap();
        assert_eq!(reads.bytes_read, 3000);
        assert_eq!(reads.cache_bytes, 0);
        assert_eq!(reads.selection_bytes, 3 * size_of::<Splat>() as u64);
        let splats = sel.splats();
        // Sorted by index, each with its own radius (the answer's order was reversed).
        let radii: Vec<f32> = splats.iter().map(|s| s.radius).collect();
        assert_eq!(radii, vec![0.5, 1.5, 2.5]);
        assert_eq!(splats[1].center, cloud.positions[1]);
        // A visibility caller is refused.
        params = Params::parse::<&str>(&[]).unwrap();
        let err = Method::prepare(
            &m,
            Input {
                cloud: &cloud,
                mesh: None,
            },
            &params,
        )
        .err()
        .unwrap();
        assert!(err.to_string().contains("level-of-detail"), "{err}");
        // Through the kernel: the program's own seconds are the build's and the selections'
        // timings, and each selection is told its view's index (not a call count).
        let settings = [crate::Setting::parse("keep=2")];
        let views = [
            crate::kernel::View { index: 7, camera },
            crate::kernel::View { index: 2, camera },
        ];
        let cell = crate::kernel::LodCell {
            method: &m,
            settings: &settings,
            views: &views,
            repeats: 3,
            build_repeats: 1,
        };
        let mut got = Vec::new();
        let built = crate::kernel::run_lod(&cell, &input, |k, v, sel| {
            got.push((
                k,
                v,
                sel.map(|s| (s.splats.len(), s.timing.median, s.timing.samples))
                    .map_err(|e| e.to_string()),
            ));
        })
        .unwrap();
        assert_eq!(built.timing.median, 0.125);
        assert_eq!(
            got,
            vec![(0, 0, Ok((2, 7.25, 3))), (0, 1, Ok((2, 2.25, 3)))]
        );
    }

    #[test]
    fn the_limit_grows_with_the_cloud() {
        assert_eq!(answer_limit(0), 1 << 20);
        assert_eq!(answer_limit(10), (1 << 20) + 240);
        assert_eq!(answer_limit(usize::MAX), u64::MAX);
    }
}
