//! Experiment `scale`: how each method's time and peak memory grow with the cloud size.
//!
//! Clouds of 10^4 … 10^8 points (quick: up to 10^6) are sampled from the dragon mesh (seeded,
//! area-weighted; `ChineseDragon-10kv.off`; `--datasets NAME` takes another dataset's mesh, the
//! first one given) and seen from its first Fibonacci view (pinhole, 1280 × 720). The cells
//! ([`cells`]): every registered visibility method (built-in, registered at run time, external)
//! at its default setting, through the measurement kernel (`registry::kernel`); each hull
//! implementation on HPR's flipped set (γ = 4, the eye included), which measures hulls and so
//! calls `hull` directly; every registered LOD method's build (`NAME-build`) and selection
//! (`NAME-select`) at its default setting, through the kernel's LOD form, on the cloud prepared
//! as the `lod` experiment prepares it; each out-of-core LOD build (`NAME-build-ooc`,
//! [`OOC_SUFFIX`]): the same samples written streamed as LAZ, then `pointsight lod-build` within
//! [`OOC_LIMIT`], at 10^6 to 10^9 points (quick: 10^6) under caps of its own ([`OOC_CAP`]) and
//! a disk check. `seconds` is the operation alone (median of 3 runs up
//! to 10^6 points, one run above; sampling and per-cloud preparation excluded for per-view
//! operations, included for builds, which are the operation).
//!
//! Each cell runs in its own process (`pointsight scale-cell`, hidden: [`cell_entry`] is the
//! entry point a program that embeds the registry and registers its own methods forwards to,
//! since the cells re-run the current executable), so `peak_rss_bytes` is the cell's own: its
//! `VmHWM` (the sampled cloud plus what the method allocated) plus the largest peak of the
//! programs it waited for (an external method: `getrusage(RUSAGE_CHILDREN)`), and time caps
//! can stop it: the cap (40 s, quick 30 s) on the operation, counted from the line the cell
//! prints when its input is ready ([`Prepared`]), and three times that on the preparation
//! before it (sampling; a hull cell's flip; an LOD cell's normals), whose seconds are the row's
//! `prepare_seconds`. A cell is not started when the memory guard refuses its estimate
//! (`cloud::memory`, from the method's declared bytes per point, `registry::Scale`; a method
//! that declares none, such as an external one without `memory_bytes_per_point`, is not run
//! above 10^6 points), nor when the same method's time or preparation at the previous size,
//! grown by the factor it grew over the step before (at least 1; 10 with one size) and times
//! the runs the cell makes (3 up to 10^6 points), would exceed its cap ([`skip_reason`]);
//! each such cell is a row saying so, as is a cell a cap stopped. A method may opt out
//! (`registry::Scale::OptOut`); the report lists it with its reason. The plots fit a slope per method on log–log axes over
//! the sizes that finished.

use std::io::Read as _;
use std::path::Path;
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};
use registry::{Memory as Scale, Setting, kernel};
use serde::{Deserialize, Serialize};

use super::{Context, Experiment, markdown_table};
use crate::output::plot::{Chart, Mark, Series};
use crate::output::{read_csv, write_atomic, write_csv};

/// The experiment.
pub struct ScaleExperiment;

/// Sampling seed.
const SEED: u64 = 16;

/// The hull implementations measured on HPR's flipped set, with their memory budget in bytes
/// per point beyond the 48 of the sampled cloud (1.25 times the peak per point measured at 10^7
/// points, 10^6 for those that stop there).
const HULLS: &[(&str, u64)] = &[
    ("own", 135),
    ("qhull", 275),
    ("parry", 800),
    ("quickhull", 305),
    ("chull", 800),
];

/// One cell kind of the experiment.
#[derive(Debug, Clone)]
pub struct CellKind {
    /// Name (the CSV `method`).
    pub name: String,
    /// The setting it runs at (empty for hulls).
    pub setting: Setting,
    /// Its memory, as the guard knows it.
    pub scale: Scale,
    /// Why it cannot run here (an external method that is not installed).
    pub unavailable: Option<String>,
    /// An out-of-core LOD build (`NAME-build-ooc`): its own sizes, caps, memory limit and
    /// disk check ([`OOC_LIMIT`], [`OOC_CAP`]).
    pub out_of_core: bool,
}

/// Suffix of an out-of-core LOD build's cell: `pointsight lod-build` of a LAZ file the cell
/// writes first (the dragon sampled as the other cells sample it, streamed, never held),
/// within [`OOC_LIMIT`].
pub const OOC_SUFFIX: &str = "-build-ooc";

/// The memory limit of an out-of-core build cell (`lod-build --memory-limit`).
pub const OOC_LIMIT: u64 = 1 << 30;

/// The time cap of an out-of-core build cell (its preparation, writing the LAZ input, has
/// [`PREPARE_CAP_FACTOR`] times it): long enough for 10^9 points at the rates measured.
pub const OOC_CAP: Duration = Duration::from_secs(3600);

/// Disk a `qsplat` out-of-core cell needs per point: the LAZ input takes 11.4 bytes per point
/// and the written file 6.8; the scratch files held at most 120.7 bytes per point at once at
/// 10^7 points (1151 MiB, 13 chunks) and at 10^8 (11,515 MiB, 154 chunks;
/// `Scratch::peak_bytes`), of 382 and 604 written in all: 139 in all, and a quarter more for
/// margin.
pub const OOC_DISK_PER_POINT: u64 = 175;

/// Disk an `spt` out-of-core cell needs per point: the LAZ (11.4), the preparation's scratch
/// (120.7, as QSplat's) while the points it hands on are written (47), then the sorted runs
/// (about 91) beside the file (84.6 at 10^7): about 188, and a quarter more for margin.
pub const SPT_OOC_DISK_PER_POINT: u64 = 235;

/// Disk the out-of-core cell of `method` needs per point.
fn ooc_disk_per_point(method: &str) -> u64 {
    if method.starts_with("spt") {
        SPT_OOC_DISK_PER_POINT
    } else {
        OOC_DISK_PER_POINT
    }
}

/// Sizes of the out-of-core cells: from 10^6 (quick: only 10^6) to 10^9 points.
fn ooc_sizes(quick: bool, max_points: Option<u64>) -> Vec<u64> {
    decades(6, if quick { 6 } else { 9 }, max_points)
}

/// 10^from to 10^to, those above `max_points` left out.
fn decades(from: u32, to: u32, max_points: Option<u64>) -> Vec<u64> {
    (from..=to)
        .map(|e| 10u64.pow(e))
        .filter(|&n| max_points.is_none_or(|m| n <= m))
        .collect()
}

/// The folder an out-of-core cell writes its input, scratch and output in (removed after the
/// cell by the process that started it, also when a cap stopped it).
fn ooc_dir(data_dir: &Path, method: &str, n: u64) -> std::path::PathBuf {
    data_dir.join(".scale-ooc").join(format!("{method}-{n}"))
}

/// Bytes free for an unprivileged user on the file system of `dir` (or of its nearest
/// existing ancestor).
fn disk_free(dir: &Path) -> Result<u64> {
    let mut at = dir;
    while !at.exists() {
        at = at
            .parent()
            .context("no existing folder above the data folder")?;
    }
    let st = nix::sys::statvfs::statvfs(at)
        .with_context(|| format!("free space of {}", at.display()))?;
    Ok(st.blocks_available() as u64 * st.fragment_size() as u64)
}

/// Every cell kind, in report order: visibility methods, hulls, then each LOD method's build
/// and selection.
pub fn cells(sweeps: &registry::Sweeps) -> Vec<CellKind> {
    let default_of = |name: &str| {
        sweeps
            .methods
            .get(name)
            .and_then(registry::MethodSweep::default_setting)
            .unwrap_or_default()
    };
    let mut out: Vec<CellKind> = registry::visibility_cards()
        .into_iter()
        .map(|m| CellKind {
            name: m.name.to_owned(),
            setting: default_of(m.name),
            scale: m.memory.clone(),
            unavailable: m.availability().err(),
            out_of_core: false,
        })
        .collect();
    out.extend(HULLS.iter().map(|&(h, bytes)| CellKind {
        name: format!("hull-{h}"),
        setting: Setting::default(),
        scale: Scale::PerPoint(bytes),
        unavailable: None,
        out_of_core: false,
    }));
    for m in registry::lod_cards() {
        for part in ["build", "select"] {
            out.push(CellKind {
                name: format!("{}-{part}", m.name),
                setting: default_of(m.name),
                scale: m.memory.clone(),
                unavailable: None,
                out_of_core: false,
            });
        }
    }
    out.extend(crate::lod_build::OUT_OF_CORE.iter().map(|m| CellKind {
        name: format!("{m}{OOC_SUFFIX}"),
        // The setting of the selection from the built file.
        setting: default_of(m),
        scale: Scale::PerPoint(0),
        unavailable: None,
        out_of_core: true,
    }));
    out
}

/// One cell.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// Method (cell kind).
    pub method: String,
    /// Points.
    pub n_points: u64,
    /// Seconds of the operation (NaN when it did not finish).
    pub seconds: f64,
    /// Peak resident memory of the cell's process and the programs it waited for (0 when it
    /// did not run).
    pub peak_rss_bytes: u64,
    /// `ok`, `timeout after S s`, `skipped: ...`, `refused: ...`, `error: ...`.
    pub status: String,
    /// Seconds the cell took to prepare its input before the operation (see
    /// [`CellOutput::prepare_seconds`]); NaN when it did not get that far (and in reports
    /// written before the column existed).
    #[serde(default = "nan")]
    pub prepare_seconds: f64,
    /// What else the cell reports (an out-of-core build: its limit, chunks, rate and files);
    /// empty for the others.
    #[serde(default)]
    pub detail: String,
}

/// What a cell process prints last (one JSON line).
#[derive(Debug, Serialize, Deserialize)]
pub struct CellOutput {
    /// Seconds (median of the runs).
    pub seconds: f64,
    /// Peak RSS of the process and of the largest child it waited for.
    pub peak_rss_bytes: u64,
    /// Seconds the cell took to prepare its input: sampling the cloud, and for a hull cell its
    /// flip, for an LOD cell the `lod` experiment's normals and spacing.
    #[serde(default = "nan")]
    pub prepare_seconds: f64,
    /// See [`Row::detail`].
    #[serde(default)]
    pub detail: String,
}

fn nan() -> f64 {
    f64::NAN
}

/// The line a cell process prints when its input is ready (before the timed operation): the
/// time cap of [`run_cell`] covers what comes after it, and the line's seconds are the row's
/// `prepare_seconds`.
#[derive(Debug, Serialize, Deserialize)]
pub struct Prepared {
    /// Always true: tells this line from the final [`CellOutput`].
    pub prepared: bool,
    /// Seconds the preparation took.
    pub seconds: f64,
}

/// Prints the [`Prepared`] line on stdout and flushes it (the `on_prepared` of [`cell`] in a
/// cell process).
pub fn print_prepared(seconds: f64) {
    use std::io::Write as _;
    let line = serde_json::json!({ "prepared": true, "seconds": seconds });
    let mut out = std::io::stdout().lock();
    // A parent that stopped reading only loses the time cap's restart.
    let _ = writeln!(out, "{line}").and_then(|()| out.flush());
}

fn sizes(quick: bool, max_points: Option<u64>) -> Vec<u64> {
    decades(4, if quick { 6 } else { 8 }, max_points)
}

/// Peak resident set size of this process (`VmHWM`) plus that of the largest child process it
/// waited for (`getrusage(RUSAGE_CHILDREN)`: an external method's program), bytes.
fn peak_rss() -> u64 {
    let own = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024);
    // ru_maxrss is in kilobytes on Linux.
    let children = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
        .map_or(0, |u| u64::try_from(u.max_rss()).unwrap_or(0) * 1024);
    own + children
}

/// The entry point of a cell process: when `args` (the process's arguments, program name
/// first) ask for a scale cell, runs it, prints its one JSON line and returns the exit code;
/// else `None`. `pointsight` reaches it through its own command line; a program that embeds
/// the registry, registers its own methods and runs the scale experiment (whose cells re-run
/// the current executable) calls it first thing in `main`, after registering.
pub fn cell_entry(args: &[String], data_dir: &Path) -> Option<ExitCode> {
    let rest = args.get(1..)?;
    if rest.first().map(String::as_str) != Some("scale-cell") {
        return None;
    }
    let arg = |flag: &str| {
        rest.iter()
            .position(|a| a == flag)
            .and_then(|i| rest.get(i + 1))
            .cloned()
    };
    let run = || -> Result<CellOutput> {
        let dataset = arg("--dataset").context("scale-cell needs --dataset")?;
        let method = arg("--method").context("scale-cell needs --method")?;
        let n: u64 = arg("--n").context("scale-cell needs --n")?.parse()?;
        let setting = Setting::parse(&arg("--setting").unwrap_or_default());
        let data_dir = arg("--data-dir").map_or_else(|| data_dir.to_path_buf(), Into::into);
        cell(&dataset, &method, &setting, n, &data_dir, print_prepared)
    };
    Some(match run().and_then(|o| Ok(serde_json::to_string(&o)?)) {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    })
}

/// Runs one cell in this process: samples `n` points of the dataset's mesh, calls
/// `on_prepared` with the seconds the input took (sampling, and a hull cell's flip or an LOD
/// cell's normals), runs `method` at `setting`, returns its seconds and this process's peak RSS.
pub fn cell(
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    on_prepared: impl Fn(f64),
) -> Result<CellOutput> {
    let started = Instant::now();
    // Each branch below calls it once its input is ready.
    let ready = |on_prepared: &dyn Fn(f64)| {
        let seconds = started.elapsed().as_secs_f64();
        on_prepared(seconds);
        seconds
    };
    // The mesh alone (not the dataset's own cloud: it would count in the peak).
    let mesh = crate::datasets::load_mesh_of(dataset, data_dir)?;
    let bbox = mesh.bbox().context("the mesh has no vertices")?;
    let cam = cloud::views::fibonacci_views(&bbox, &cloud::ViewSpec::default())?[0];
    if let Some(m) = method.strip_suffix(OOC_SUFFIX) {
        let view = kernel::View {
            index: 0,
            camera: cam,
        };
        return ooc_cell(m, &mesh, &bbox, n, data_dir, (setting, &view), || {
            ready(&on_prepared)
        });
    }
    let n = usize::try_from(n)?;
    cloud::memory::ensure(
        48 * n as u128,
        &format!("{n} sampled points with their surface samples"),
    )?;
    let mut cloud = cloud::sample::sample_surface(&mesh, n, SEED)?;
    cloud.samples = None;
    let repeats = repeats(n as u64);
    let views = [kernel::View {
        index: 0,
        camera: cam,
    }];
    let prepare_seconds;
    let seconds = if let Some(h) = method.strip_prefix("hull-") {
        let hull = hull::by_name(h)?;
        let mut flipped = hpr::transform::transform(
            &cloud.positions,
            cam.eye,
            hpr::Kernel::Linear(hpr::Radius::Gamma(4.0)),
        )?
        .points;
        flipped.push(cam.eye.to_array());
        prepare_seconds = ready(&on_prepared);
        let (_, t) = registry::timing::measure(repeats, || hull.vertices(&flipped))?;
        t.median
    } else if let Some(m) = registry::card_named(method).filter(|m| !m.is_lod()) {
        prepare_seconds = ready(&on_prepared);
        let input = registry::Input {
            cloud: &cloud,
            mesh: Some(&mesh),
        };
        let (prepared, answers) =
            kernel::collect(&kernel::Cell::new(m, setting, &views, repeats), input);
        prepared?;
        match answers.into_iter().next() {
            Some((_, Ok(a))) => a.timing.median,
            Some((_, Err(e))) => bail!(e),
            None => bail!("the kernel answered no view"),
        }
    } else if let Some((m, build)) = lod_cell(method) {
        let data = super::lod::lod_data(cloud)?;
        prepare_seconds = ready(&on_prepared);
        let settings = [setting.clone()];
        let cell = kernel::LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: if build { 1 } else { repeats },
            build_repeats: if build { repeats } else { 1 },
        };
        let mut selection = None;
        let built = kernel::run_lod(&cell, &data.input(), |_, _, s| {
            selection = Some(s.map(|s| s.timing.median).map_err(|e| e.to_string()));
        })?;
        if build {
            built.timing.median
        } else {
            selection
                .context("the kernel made no selection")?
                .map_err(anyhow::Error::msg)?
        }
    } else {
        bail!("unknown scale cell {method:?}")
    };
    Ok(CellOutput {
        seconds,
        peak_rss_bytes: peak_rss(),
        prepare_seconds,
        detail: String::new(),
    })
}

/// An out-of-core build cell: writes `n` points sampled from `mesh` (seed [`SEED`], the
/// points the other cells hold) as LAZ without holding them, calls `ready` (the preparation
/// ends there), then builds `method`'s file from it with `pointsight lod-build`'s code within
/// [`OOC_LIMIT`]. One run: the build reads and decodes the file, which is the operation.
/// Then the built file is selected from without loading it (`registry::lod_file`, a cache of
/// [`super::lod::FILE_CACHE_BYTES`]) at `select`'s setting and view, through the kernel,
/// [`repeats`] timed runs: its time, splats and reads go in the detail, beside the in-memory
/// `NAME-select` cell's.
fn ooc_cell(
    method: &str,
    mesh: &cloud::TriMesh,
    bbox: &cloud::Aabb,
    n: u64,
    data_dir: &Path,
    select: (&Setting, &kernel::View),
    ready: impl FnOnce() -> f64,
) -> Result<CellOutput> {
    let dir = ooc_dir(data_dir, &format!("{method}{OOC_SUFFIX}"), n);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    // The work in a closure, so that the folder goes whatever it returns.
    let outcome = (|| -> Result<CellOutput> {
        let input = dir.join("input.laz");
        let mut sampler = cloud::sample::SurfaceSampler::new(mesh, SEED)?;
        // A sample's weights sum to 1 only up to rounding: pad the box by a few ulps of its size.
        let pad = cloud::glam::DVec3::splat((bbox.max - bbox.min).max_element() * 1e-9 + 1e-12);
        let mut left = n;
        cloud::io::las::write_las_streamed(&input, bbox.min - pad, bbox.max + pad, |batch| {
            let k = left.min(1 << 16);
            sampler.positions_into(k as usize, batch);
            left -= k;
            left > 0
        })?;
        let prepare_seconds = ready();
        let out = dir.join(format!("{method}.lod"));
        let built = crate::lod_build::build(&input, method, OOC_LIMIT, &out, false)?;
        let input_bytes = std::fs::metadata(&input).map_or(0, |m| m.len());
        let mib = |b: u64| b as f64 / 1048576.0;
        let (setting, view) = select;
        let file = registry::lod_file::open_file(&out, super::lod::FILE_CACHE_BYTES)?;
        let m = registry::card(method)?;
        let settings = [setting.clone()];
        let views = [*view];
        let cell = kernel::LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: repeats(n),
            build_repeats: 1,
        };
        let data = registry::lod::LodData::none(SEED);
        let mut selection = None;
        kernel::select_lod(&cell, file.as_ref(), &data.input(), |_, _, s| {
            selection = Some(s.map_err(|e| anyhow::anyhow!("selection from the file: {e}")));
        });
        let s = selection.context("the kernel made no selection")??;
        let reads = s.reads.unwrap_or_default();
        Ok(CellOutput {
            seconds: built.seconds,
            peak_rss_bytes: peak_rss(),
            prepare_seconds,
            detail: format!(
                "limit {:.0} MiB, peak {:.0} MiB, {:.2} M points/s, {} chunks, {} {}, \
                 LAZ {:.0} MiB, scratch {:.0} MiB written, {:.0} MiB at most, file {:.0} MiB; \
                 selection from the file \
                 ({}, view 0): {:.3} ms median of {}, {} splats, read {:.1} MiB, cache {:.1} \
                 MiB, peak after {:.0} MiB",
                mib(OOC_LIMIT),
                mib(built.peak_rss_bytes),
                built.points as f64 / built.seconds / 1e6,
                built.chunks,
                built.top_levels,
                if method == "spt" {
                    "top nodes"
                } else {
                    "top levels"
                },
                mib(input_bytes),
                mib(built.scratch_bytes),
                mib(built.scratch_peak_bytes),
                mib(built.file_bytes),
                setting.label(),
                s.timing.median * 1e3,
                s.timing.samples,
                s.splats.len(),
                mib(reads.bytes_read),
                mib(reads.cache_bytes),
                mib(peak_rss()),
            ),
        })
    })();
    let _ = std::fs::remove_dir_all(&dir);
    outcome
}

/// Timed runs of a cell's operation at `n` points (the median is its seconds): all of them
/// fall under the cap.
fn repeats(n: u64) -> usize {
    if n <= 1_000_000 { 3 } else { 1 }
}

/// The LOD method of a `NAME-build` or `NAME-select` cell, and whether it is the build.
fn lod_cell(name: &str) -> Option<(&'static registry::Card, bool)> {
    let (m, build) = name
        .strip_suffix("-build")
        .map(|m| (m, true))
        .or_else(|| name.strip_suffix("-select").map(|m| (m, false)))?;
    Some((registry::card_named(m).filter(|m| m.is_lod())?, build))
}

/// The cap on a cell's preparation (sampling the cloud, a hull cell's flip, an LOD cell's
/// normals), which the operation's cap does not cover: this many times the operation's cap.
const PREPARE_CAP_FACTOR: u32 = 3;

/// Runs a cell in a child process with two time caps: `cap` on the operation (from the
/// child's [`Prepared`] line on), `PREPARE_CAP_FACTOR` times it on the preparation before.
/// The child's stdout and stderr are read by threads as it writes, so a chatty child cannot
/// block on a full pipe.
fn run_cell(
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    cap: Duration,
) -> Row {
    let row = run_child(dataset, method, setting, n, data_dir, cap);
    // An out-of-core cell's files, whether it finished, failed or was killed.
    let dir = ooc_dir(data_dir, method, n);
    if dir.exists() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    row
}

fn run_child(
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    cap: Duration,
) -> Row {
    let row = |seconds: f64, peak: u64, status: String, prepare_seconds: f64| Row {
        method: method.to_owned(),
        n_points: n,
        seconds,
        peak_rss_bytes: peak,
        status,
        prepare_seconds,
        detail: String::new(),
    };
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => return row(f64::NAN, 0, format!("error: {e}"), f64::NAN),
    };
    let child = Command::new(exe)
        .args([
            "scale-cell",
            "--dataset",
            dataset,
            "--method",
            method,
            "--n",
            &n.to_string(),
            "--setting",
            &setting.label(),
            "--data-dir",
        ])
        .arg(data_dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => {
            return row(
                f64::NAN,
                0,
                format!("error: cannot start the cell: {e}"),
                f64::NAN,
            );
        }
    };
    // stdout line by line (the prepared line restarts the clock; the last other line is the
    // answer); of stderr the last 64 to 128 KiB.
    let (lines_tx, lines) = std::sync::mpsc::channel::<String>();
    let stdout = child.stdout.take().map(|s| {
        std::thread::spawn(move || {
            use std::io::BufRead as _;
            for line in std::io::BufReader::new(s).lines().map_while(Result::ok) {
                if lines_tx.send(line).is_err() {
                    break;
                }
            }
        })
    });
    let stderr = child.stderr.take().map(|mut s| {
        std::thread::spawn(move || {
            let mut tail: Vec<u8> = Vec::new();
            let mut buf = [0u8; 8192];
            while let Ok(k) = s.read(&mut buf) {
                if k == 0 {
                    break;
                }
                tail.extend_from_slice(&buf[..k]);
                if tail.len() > 1 << 17 {
                    tail.drain(..tail.len() - (1 << 16));
                }
            }
            String::from_utf8_lossy(&tail).into_owned()
        })
    });
    let mut start = Instant::now();
    let mut prepare_seconds = f64::NAN;
    let mut last: Option<String> = None;
    let take_lines = |last: &mut Option<String>, prepare_seconds: &mut f64, start: &mut Instant| {
        for line in lines.try_iter() {
            match serde_json::from_str::<Prepared>(&line) {
                Ok(p) if p.prepared && prepare_seconds.is_nan() => {
                    *prepare_seconds = p.seconds;
                    *start = Instant::now();
                }
                _ => *last = Some(line),
            }
        }
    };
    loop {
        take_lines(&mut last, &mut prepare_seconds, &mut start);
        match child.try_wait() {
            Ok(Some(status)) => {
                if let Some(t) = stdout {
                    let _ = t.join();
                }
                take_lines(&mut last, &mut prepare_seconds, &mut start);
                let err = stderr.and_then(|t| t.join().ok()).unwrap_or_default();
                if !status.success() {
                    let last = err
                        .lines()
                        .last()
                        .unwrap_or("")
                        .trim_start_matches("error: ");
                    let refused = last.contains("refused before allocating");
                    return row(
                        f64::NAN,
                        0,
                        format!("{}: {last}", if refused { "refused" } else { "error" }),
                        prepare_seconds,
                    );
                }
                return match last.as_deref().map(serde_json::from_str::<CellOutput>) {
                    Some(Ok(o)) => Row {
                        detail: o.detail,
                        ..row(o.seconds, o.peak_rss_bytes, "ok".into(), o.prepare_seconds)
                    },
                    _ => row(
                        f64::NAN,
                        0,
                        format!(
                            "error: unreadable cell output {:?}",
                            last.unwrap_or_default()
                        ),
                        prepare_seconds,
                    ),
                };
            }
            Ok(None) => {
                let preparing = prepare_seconds.is_nan();
                let limit = if preparing {
                    cap * PREPARE_CAP_FACTOR
                } else {
                    cap
                };
                if start.elapsed() > limit {
                    let _ = child.kill();
                    let _ = child.wait();
                    let status = if preparing {
                        format!(
                            "timeout: preparing the input took over {} s",
                            limit.as_secs()
                        )
                    } else {
                        format!("timeout after {} s", cap.as_secs())
                    };
                    return row(f64::NAN, 0, status, prepare_seconds);
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => return row(f64::NAN, 0, format!("error: {e}"), prepare_seconds),
        }
    }
}

/// Why a cell is not started, judging by the same method at the previous size (`previous`:
/// seconds and prepare seconds there, NaN when it did not finish; `before`: the size before
/// that): time grows by the factor it grew over the last step (at least 1), and a cell whose
/// [`repeats`] runs of the operation, or whose preparation, would so exceed its cap would only
/// hit it. `None`: run it.
fn skip_reason(
    previous: Option<(f64, f64)>,
    before: Option<(f64, f64)>,
    n: u64,
    cap: Duration,
) -> Option<String> {
    let (p, prep) = previous?;
    if p.is_nan() {
        return Some("skipped: the previous size did not finish".into());
    }
    let growth = |now: f64, then: Option<f64>| {
        then.filter(|&t| t > 0.0 && t.is_finite())
            .map_or(10.0, |t| (now / t).max(1.0))
    };
    let runs = repeats(n);
    let predicted = p * growth(p, before.map(|b| b.0)) * runs as f64;
    if predicted > cap.as_secs_f64() {
        return Some(format!(
            "skipped: {p:.1} s at {} points, so about {predicted:.0} s here for {runs} run{}, \
             over the {} s cap",
            n / 10,
            if runs == 1 { "" } else { "s" },
            cap.as_secs()
        ));
    }
    let prep_cap = (cap * PREPARE_CAP_FACTOR).as_secs_f64();
    if prep.is_finite() {
        let predicted = prep * growth(prep, before.map(|b| b.1));
        if predicted > prep_cap {
            return Some(format!(
                "skipped: its input took {prep:.1} s to prepare at {} points, so about \
                 {predicted:.0} s here, over the {prep_cap:.0} s cap on preparation",
                n / 10
            ));
        }
    }
    None
}

/// Least-squares slope and intercept of log10 y against log10 x.
fn fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && y.is_finite())
        .map(|(x, y)| (x.log10(), y.log10()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    })
}

impl Experiment for ScaleExperiment {
    fn name(&self) -> &'static str {
        "scale"
    }

    fn summary(&self) -> &'static str {
        "time and peak memory of every method from 10^4 to 10^8 points, one process per cell, with fitted log-log slopes"
    }

    fn default_datasets(&self, _quick: bool) -> &'static [&'static str] {
        &["dragon-871414"]
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        // One mesh (the first dataset's; by default the dragon): the cells sample it
        // themselves. Fail early when it is missing.
        let dataset = ctx
            .datasets
            .first()
            .context("scale needs a dataset with a mesh")?;
        crate::datasets::load_mesh_of(dataset, &ctx.data_dir)?;
        let cap = Duration::from_secs(if ctx.quick { 30 } else { 40 });
        let in_core_sizes = sizes(ctx.quick, ctx.max_points);
        let ooc_sizes = ooc_sizes(ctx.quick, ctx.max_points);
        let kinds = cells(&ctx.sweeps);
        let sizes_of = |kind: &CellKind| {
            if kind.out_of_core {
                &ooc_sizes
            } else {
                &in_core_sizes
            }
        };
        let bar = crate::progress::bar(
            kinds.iter().map(|k| sizes_of(k).len() as u64).sum(),
            "scale",
        );
        let mut rows = Vec::new();
        let mut opted_out = Vec::new();
        for kind in &kinds {
            let method = kind.name.as_str();
            let sizes = sizes_of(kind);
            let cap = if kind.out_of_core { OOC_CAP } else { cap };
            let per_point = match &kind.scale {
                Scale::OptOut(why) => {
                    opted_out.push(serde_json::json!({"method": method, "reason": why}));
                    bar.inc(sizes.len() as u64);
                    continue;
                }
                Scale::PerPoint(b) => Some(*b),
                Scale::Unknown => None,
            };
            // (seconds, prepare seconds) at the previous size and the one before.
            let mut previous: Option<(f64, f64)> = None;
            let mut before: Option<(f64, f64)> = None;
            for &n in sizes {
                let not_run = |status: String| Row {
                    method: method.to_owned(),
                    n_points: n,
                    seconds: f64::NAN,
                    peak_rss_bytes: 0,
                    status,
                    prepare_seconds: f64::NAN,
                    detail: String::new(),
                };
                let disk_per_point = ooc_disk_per_point(method);
                let needed_disk = n.saturating_mul(disk_per_point);
                let row = if let Some(why) = &kind.unavailable {
                    not_run(format!("skipped: not installed: {why}"))
                } else if per_point.is_none() && n > Scale::UNKNOWN_LIMIT {
                    not_run(format!(
                        "refused: its memory per point is not declared (memory_bytes_per_point \
                         in an external method's method.toml, Method::scale for a built-in one), \
                         so it is not run above {} points",
                        Scale::UNKNOWN_LIMIT
                    ))
                } else if kind.out_of_core
                    && let Err(e) = cloud::memory::ensure(
                        u128::from(OOC_LIMIT + (256 << 20)),
                        &format!("{method} on {n} points within {} MiB", OOC_LIMIT >> 20),
                    )
                {
                    not_run(format!("refused: {e}"))
                } else if kind.out_of_core
                    && let Some(free) = disk_free(&ctx.data_dir)
                        .ok()
                        .filter(|&free| free < needed_disk)
                {
                    not_run(format!(
                        "skipped: the disk under {} has {:.1} GB free, the cell needs about \
                         {:.1} GB ({disk_per_point} bytes per point: input, scratch, file)",
                        ctx.data_dir.display(),
                        free as f64 / 1e9,
                        needed_disk as f64 / 1e9
                    ))
                } else if !kind.out_of_core
                    && let Err(e) = cloud::memory::ensure(
                        u128::from(n) * u128::from(per_point.unwrap_or(0) + 48),
                        &format!("{method} on {n} points"),
                    )
                {
                    not_run(format!("refused: {e}"))
                } else if let Some(why) = skip_reason(previous, before, n, cap) {
                    not_run(why)
                } else {
                    run_cell(dataset, method, &kind.setting, n, &ctx.data_dir, cap)
                };
                before = previous;
                previous = Some((row.seconds, row.prepare_seconds));
                rows.push(row);
                bar.inc(1);
            }
        }
        bar.finish_and_clear();
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        Ok(serde_json::json!({
            "sizes": in_core_sizes,
            "out_of_core": {
                "methods": crate::lod_build::OUT_OF_CORE,
                "sizes": ooc_sizes,
                "memory_limit_bytes": OOC_LIMIT,
                "cap_seconds": OOC_CAP.as_secs(),
                "prepare_cap_seconds": (OOC_CAP * PREPARE_CAP_FACTOR).as_secs(),
                "disk_bytes_per_point": OOC_DISK_PER_POINT,
                "spt_disk_bytes_per_point": SPT_OOC_DISK_PER_POINT,
                "input": "LAZ (point format 0) written streamed by the cell from the same seeded samples",
            },
            "seed": SEED,
            "mesh_of": dataset,
            "view": 0,
            "cap_seconds": cap.as_secs(),
            "prepare_cap_seconds": (cap * PREPARE_CAP_FACTOR).as_secs(),
            "repeats": "3 up to 10^6 points, 1 above",
            "cells": kinds.iter().map(|k| serde_json::json!({
                "method": k.name,
                "setting": k.setting.label(),
                "bytes_per_point": match &k.scale { Scale::PerPoint(b) => Some(b + 48), _ => None },
            })).collect::<Vec<_>>(),
            "opted_out": opted_out,
        }))
    }

    fn render(&self, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let mut methods: Vec<String> = rows.iter().map(|r| r.method.clone()).collect();
        methods.dedup();
        let mut table = Vec::new();
        // Three families, a chart each (time and memory), so colours stay distinct.
        let family = |m: &str| {
            if m.starts_with("hull-") {
                1
            } else if m.ends_with("-build") || m.ends_with("-select") || m.ends_with(OOC_SUFFIX) {
                2
            } else {
                0
            }
        };
        let mut time_series: [Vec<Series>; 3] = Default::default();
        let mut memory_series: [Vec<Series>; 3] = Default::default();
        for m in &methods {
            let f = family(m);
            let color = time_series[f].len();
            let ok: Vec<&Row> = rows
                .iter()
                .filter(|r| &r.method == m && r.status == "ok")
                .collect();
            let times: Vec<(f64, f64)> =
                ok.iter().map(|r| (r.n_points as f64, r.seconds)).collect();
            let mems: Vec<(f64, f64)> = ok
                .iter()
                .map(|r| (r.n_points as f64, r.peak_rss_bytes as f64))
                .collect();
            let t_fit = fit(&times);
            let m_fit = fit(&mems);
            let slope = |f: Option<(f64, f64)>| f.map_or("-".into(), |(s, _)| format!("{s:.2}"));
            time_series[f].push(Series {
                color: Some(color),
                ..Series::new(
                    format!("{m} (slope {}, {} sizes)", slope(t_fit), times.len()),
                    times,
                    Mark::LinePoints,
                )
            });
            memory_series[f].push(Series {
                color: Some(color),
                ..Series::new(
                    format!("{m} (slope {}, {} sizes)", slope(m_fit), mems.len()),
                    mems,
                    Mark::LinePoints,
                )
            });
            let largest = ok.iter().map(|r| r.n_points).max().unwrap_or(0);
            let not_ok: Vec<String> = rows
                .iter()
                .filter(|r| &r.method == m && r.status != "ok")
                .map(|r| format!("{}: {}", r.n_points, r.status))
                .collect();
            table.push(vec![
                m.clone(),
                slope(t_fit),
                slope(m_fit),
                ok.len().to_string(),
                largest.to_string(),
                ok.iter()
                    .find(|r| r.n_points == largest)
                    .map_or("-".into(), |r| format!("{:.3}", r.seconds)),
                ok.iter()
                    .find(|r| r.n_points == largest)
                    .filter(|r| r.prepare_seconds.is_finite())
                    .map_or("-".into(), |r| format!("{:.2}", r.prepare_seconds)),
                ok.iter()
                    .find(|r| r.n_points == largest)
                    .map_or("-".into(), |r| {
                        format!("{:.0}", r.peak_rss_bytes as f64 / 1048576.0)
                    }),
                if not_ok.is_empty() {
                    "-".into()
                } else {
                    not_ok.join("; ")
                },
            ]);
        }
        let names = ["visibility", "hulls", "lod"];
        let captions = [
            "visibility methods",
            "hull implementations on HPR's flipped set",
            "LOD builds and selections",
        ];
        let mut images = String::new();
        for (k, (times, mems)) in time_series.into_iter().zip(memory_series).enumerate() {
            if times.is_empty() {
                continue;
            }
            Chart {
                title: format!("Time against cloud size: {}", captions[k]),
                x_label: "points".into(),
                y_label: "seconds".into(),
                x_log: true,
                y_log: true,
                series: times,
                ..Chart::default()
            }
            .save(&dir.join(format!("seconds_{}.png", names[k])), 1000, 600)?;
            Chart {
                title: format!("Peak memory (the cell process's RSS): {}", captions[k]),
                x_label: "points".into(),
                y_label: "bytes".into(),
                x_log: true,
                y_log: true,
                series: mems,
                ..Chart::default()
            }
            .save(&dir.join(format!("memory_{}.png", names[k])), 1000, 600)?;
            images.push_str(&format!(
                "![time, {c}](seconds_{n}.png)\n\n![memory, {c}](memory_{n}.png)\n\n",
                c = captions[k],
                n = names[k]
            ));
        }
        let meta = crate::output::meta::RunMeta::read(dir).ok();
        let parameter = |key: &str| {
            meta.as_ref()
                .and_then(|m| m.parameters[key].as_u64())
                .map_or("?".to_owned(), |v| v.to_string())
        };
        let (cap, prepare_cap) = (parameter("cap_seconds"), parameter("prepare_cap_seconds"));
        let opted_out: Vec<String> = meta
            .as_ref()
            .and_then(|m| m.parameters["opted_out"].as_array().cloned())
            .unwrap_or_default()
            .iter()
            .map(|o| {
                format!(
                    "- `{}` takes no part: {}\n",
                    o["method"].as_str().unwrap_or("?"),
                    o["reason"].as_str().unwrap_or("?")
                )
            })
            .collect();
        let ooc: Vec<String> = rows
            .iter()
            .filter(|r| r.method.ends_with(OOC_SUFFIX) && !r.detail.is_empty())
            .map(|r| format!("- `{}`, {} points: {}\n", r.method, r.n_points, r.detail))
            .collect();
        let ooc = if ooc.is_empty() {
            String::new()
        } else {
            format!(
                "\nOut-of-core builds (`pointsight lod-build` of a LAZ file the cell wrote from \
                 the same samples; `seconds` includes reading and decoding it):\n\n{}",
                ooc.concat()
            )
        };
        let opted_out = if opted_out.is_empty() {
            String::new()
        } else {
            format!("\nMethods that opted out:\n\n{}", opted_out.concat())
        };
        let text = format!(
            "How each method's time and peak memory grow with the cloud size: clouds sampled \
             from the dragon mesh, view 0, one process per cell (peak RSS is the cell's own: \
             the sampled cloud plus the method, and the largest program it waited for). Slopes are least-squares fits of log10 against \
             log10 over the sizes that finished (1: linear; memory slopes are lowered by the \
             process's fixed overhead at the small sizes). `seconds` is the operation alone; \
             `prepare s` the cell's input before it (sampling the cloud; a hull's flip; an LOD \
             method's normals), under a cap of its own ({} s on the operation, {} s on the \
             preparation). Cells not run or stopped say why.\n\n\
             {images}{}{ooc}{opted_out}\nRaw rows: [results.csv](results.csv).\n",
            cap,
            prepare_cap,
            markdown_table(
                &[
                    "method",
                    "time slope",
                    "memory slope",
                    "sizes fitted",
                    "largest finished",
                    "seconds there",
                    "prepare s there",
                    "peak MiB there",
                    "not finished",
                ],
                &table
            )
        );
        write_atomic(&dir.join("summary.md"), text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_out_of_core_cell_builds_from_its_own_laz_and_leaves_nothing() {
        let mesh = cloud::synth::icosphere(3);
        let bbox = mesh.bbox().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let view = kernel::View {
            index: 0,
            camera: cloud::views::fibonacci_views(&bbox, &cloud::ViewSpec::default()).unwrap()[0],
        };
        let setting = Setting::parse("threshold_px=2");
        let out = ooc_cell(
            "qsplat",
            &mesh,
            &bbox,
            5_000,
            dir.path(),
            (&setting, &view),
            || 0.5,
        )
        .unwrap();
        assert!(out.seconds > 0.0 && out.prepare_seconds == 0.5);
        assert!(
            out.detail.contains("1 chunks") && out.detail.contains("limit 1024 MiB"),
            "{}",
            out.detail
        );
        // The built file was selected from.
        let splats: u64 = out
            .detail
            .split("ms median of ")
            .nth(1)
            .and_then(|t| t.split(", ").nth(1))
            .and_then(|t| t.strip_suffix(" splats"))
            .and_then(|t| t.parse().ok())
            .unwrap_or(0);
        assert!(splats > 0 && splats <= 5_000, "{}", out.detail);
        assert!(!ooc_dir(dir.path(), "qsplat-build-ooc", 5_000).exists());
        assert!(
            ooc_cell(
                "spt",
                &mesh,
                &bbox,
                100,
                dir.path(),
                (&setting, &view),
                || 0.0
            )
            .is_err()
        );
        assert!(!ooc_dir(dir.path(), "spt-build-ooc", 100).exists());
        assert_eq!(ooc_sizes(true, None), vec![1_000_000]);
        assert_eq!(ooc_sizes(false, Some(10u64.pow(8))).len(), 3);
        assert!(disk_free(&dir.path().join("not/yet")).unwrap() > 0);
    }

    #[test]
    fn the_fit_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 1e5, 1e6]
            .iter()
            .map(|&n: &f64| (n, 3e-8 * n.powf(1.2)))
            .collect();
        let (slope, intercept) = fit(&pts).unwrap();
        assert!((slope - 1.2).abs() < 1e-9);
        assert!((intercept - 3e-8f64.log10()).abs() < 1e-9);
        assert!(fit(&pts[..1]).is_none());
        assert!(fit(&[(1e4, f64::NAN), (1e5, 1.0)]).is_none());
    }

    #[test]
    fn a_cell_is_skipped_only_when_its_growth_would_pass_a_cap() {
        let cap = Duration::from_secs(40);
        // The first size always runs; a previous size that did not finish stops the method.
        assert_eq!(skip_reason(None, None, 10_000, cap), None);
        assert!(
            skip_reason(Some((f64::NAN, 1.0)), None, 100_000, cap)
                .unwrap()
                .contains("did not finish")
        );
        // 4.4 s after 0.5 s (growth 8.8): about 39 s, under the cap; after 0.4 s (11x): over.
        assert_eq!(
            skip_reason(Some((4.4, 9.0)), Some((0.5, 1.0)), 10u64.pow(8), cap),
            None
        );
        let why = skip_reason(Some((4.4, 9.0)), Some((0.4, 1.0)), 10u64.pow(8), cap).unwrap();
        assert!(
            why.contains("4.4 s at 10000000 points") && why.contains("48 s"),
            "{why}"
        );
        // One size only: grows tenfold. Shrinking time counts as growth 1 (sizes above 10^6:
        // one run each).
        let big = 10u64.pow(8);
        assert!(skip_reason(Some((4.1, 0.1)), None, big, cap).is_some());
        assert_eq!(skip_reason(Some((3.9, 0.1)), None, big, cap), None);
        assert_eq!(
            skip_reason(Some((39.0, 0.1)), Some((50.0, 0.1)), big, cap),
            None
        );
        // Up to 10^6 points a cell makes three runs, all under the cap: 7 s doubling is 14 s a
        // run, 42 s for three at 10^6 (skipped), 14 s for the one run at 10^7.
        let why = skip_reason(Some((7.0, 0.1)), Some((3.5, 0.1)), 1_000_000, cap).unwrap();
        assert!(why.contains("for 3 runs") && why.contains("42 s"), "{why}");
        assert_eq!(
            skip_reason(Some((7.0, 0.1)), Some((3.5, 0.1)), 10_000_000, cap),
            None
        );
        // The preparation has its own cap (three times the operation's).
        let why = skip_reason(Some((1.0, 20.0)), Some((0.5, 1.0)), 100, cap).unwrap();
        assert!(
            why.contains("prepare") && why.contains("120 s cap"),
            "{why}"
        );
        assert_eq!(
            skip_reason(Some((1.0, 20.0)), Some((0.5, 10.0)), 100, cap),
            None
        );
    }
}
