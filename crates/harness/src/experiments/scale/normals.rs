//! The scale experiment's normal-estimation family: 16-neighbour normals of the same sampled
//! points by ours and by the field's libraries, timed and judged against the mesh's normals.
//!
//! The cells ([`Kind`]): ours in memory (`cloud::normals::estimate_normals`, k = [`K`]) with the
//! sign by the centroid (one dot product a point: the estimate alone) and with the orientation
//! the LOD builds run (Hoppe's propagation, `Orientation::Propagated`); Open3D's
//! `estimate_normals(KDTreeSearchParamKNN(16))` (unoriented) and with
//! `orient_normals_consistent_tangent_plane(16)` after it; point-cloud-utils'
//! `estimate_point_cloud_normals_knn(P, 16)`. A peer is a Python program ([`SCRIPT`], run by
//! [`python`]) given the points as a raw file and timed by itself, reading and writing
//! excluded; it is killed when it outlives the cap ([`run_peer`]), its errors name it, and the
//! cell's folder goes whatever happens. A peer whose library does not import is a row saying
//! it is not installed ([`availability`]).
//!
//! Each cell's accuracy ([`accuracy`]): the unsigned angle between each normal and its
//! triangle's normal (median, 95th percentile) and, where the cell orients, the share of
//! normals on the mesh's side. The family runs in [`ROUNDS`] rounds at each size, every cell
//! once a round in the same order ([`measure`]), so that ours and each peer alternate on a
//! shared, noisy machine; a row's seconds are the median of its rounds, and a peer's time over
//! ours is the median of the per-round ratios ([`ratios`]). Sizes: the in-core decades and
//! 2·10^6 ([`sizes`]); a cell whose forecast from the sizes before exceeds [`CAP`] a run, or
//! [`SIZE_BUDGET`] over its rounds, is not started ([`forecast_skip`]).

use std::io::BufRead as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};
use cloud::glam::Vec3;
use cloud::normals::Orientation;
use registry::{Memory, Setting};

use super::plan::CellKind;
use super::row::{Accuracy, CellOutput, Row};
use crate::experiments::rules::ratio::Ratio;
use crate::rss::peak_rss_with_children;

/// Neighbours a normal is estimated from, ours and the peers'.
pub const K: usize = 16;

/// Rounds at every size: each ratio is the median of this many alternated pairs.
pub const ROUNDS: usize = 3;

/// Why a quick run leaves Open3D's orientation out: it takes minutes even at 10^4 points, more
/// than the whole quick run's other cells.
pub const QUICK_SKIP: &str =
    "skipped: quick run (Open3D's orientation takes minutes even at 10^4 points)";

/// Rounds a size runs: [`ROUNDS`], one in a quick run (no ratio is stated from it then).
pub fn rounds(quick: bool) -> usize {
    if quick { 1 } else { ROUNDS }
}

/// The time cap of one run of a normal-estimation cell (the peer program is killed at it).
pub const CAP: Duration = Duration::from_secs(300);

/// The most a kind's rounds at one size may be forecast to take together: a cell whose
/// forecast run times its rounds exceeds it is not started there ([`forecast_skip`]). It keeps
/// the slowest peer (Open3D's orientation, minutes a run from 10^6 points) to the sizes where
/// its ratio costs minutes, not a quarter of an hour.
pub const SIZE_BUDGET: Duration = Duration::from_secs(600);

/// The peers' program, written into the cell's folder and run by [`python`].
pub const SCRIPT: &str = include_str!("normals_peer.py");

/// A normal-estimation cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Ours, the sign by the centroid: the estimate alone.
    Ours,
    /// Ours with the LOD builds' orientation.
    OursOriented,
    /// Open3D's `estimate_normals`.
    Open3d,
    /// Open3D's `estimate_normals`, then `orient_normals_consistent_tangent_plane`.
    Open3dOriented,
    /// point-cloud-utils' `estimate_point_cloud_normals_knn`.
    Pcu,
}

impl Kind {
    /// Every kind, in the order each round runs them.
    pub const ALL: [Kind; 5] = [
        Kind::Ours,
        Kind::Open3d,
        Kind::Pcu,
        Kind::OursOriented,
        Kind::Open3dOriented,
    ];

    /// The cell's method name.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Ours => "normals-ours",
            Kind::OursOriented => "normals-ours-oriented",
            Kind::Open3d => "normals-open3d",
            Kind::Open3dOriented => "normals-open3d-oriented",
            Kind::Pcu => "normals-pcu",
        }
    }

    /// The kind of a cell's method name.
    pub fn named(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether its normals have a sign meant to agree with the surface's.
    pub fn oriented(self) -> bool {
        matches!(self, Kind::OursOriented | Kind::Open3dOriented)
    }

    /// The peer program's mode and the Python module it imports (`None`: ours).
    pub fn peer(self) -> Option<(&'static str, &'static str)> {
        match self {
            Kind::Ours | Kind::OursOriented => None,
            Kind::Open3d => Some(("open3d", "open3d")),
            Kind::Open3dOriented => Some(("open3d-oriented", "open3d")),
            Kind::Pcu => Some(("pcu", "point_cloud_utils")),
        }
    }

    /// Memory a point beyond the sampled cloud's 48 bytes: ours (its grid, normals and
    /// neighbour lists) and a peer's (the points file, the library's copies, its tree, the
    /// normals read back), with margin.
    pub fn bytes_per_point(self) -> u64 {
        match self {
            Kind::Ours => 200,
            Kind::OursOriented => 300,
            Kind::Open3d | Kind::Pcu => 500,
            Kind::Open3dOriented => 1500,
        }
    }

    /// What the cell runs, for its row's detail.
    fn what(self) -> String {
        match self {
            Kind::Ours => format!("estimate_normals k={K}, sign by the centroid"),
            Kind::OursOriented => {
                format!("estimate_normals k={K}, Orientation::Propagated (the LOD builds')")
            }
            Kind::Open3d => {
                format!("Open3D estimate_normals(KDTreeSearchParamKNN({K})), unoriented")
            }
            Kind::Open3dOriented => format!(
                "Open3D estimate_normals(KDTreeSearchParamKNN({K})) and \
                 orient_normals_consistent_tangent_plane({K})"
            ),
            Kind::Pcu => format!("point-cloud-utils estimate_point_cloud_normals_knn(P, {K})"),
        }
    }
}

/// The family's cell kinds, each with why it cannot run here (a library that does not import).
pub fn kinds(python: &Path) -> Vec<CellKind> {
    Kind::ALL
        .into_iter()
        .map(|k| CellKind {
            name: k.name().to_owned(),
            setting: Setting::default(),
            memory: Memory::PerPoint(k.bytes_per_point()),
            unavailable: k
                .peer()
                .and_then(|(_, module)| availability(python, module).err()),
            out_of_core: false,
        })
        .collect()
}

/// The Python the peers run in: `POINTSIGHT_PYTHON` when set, else the peers' environment
/// `.venv/bin/python` in the clone around the working directory (`just peers` makes it),
/// else `python3` on `PATH`.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("POINTSIGHT_PYTHON").filter(|p| !p.is_empty()) {
        return PathBuf::from(p);
    }
    crate::paths::working_clone()
        .map(|c| c.join(".venv/bin/python"))
        .filter(|p| p.is_file())
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// Whether `python` imports `module`; else why not (a peer not installed).
pub fn availability(python: &Path, module: &str) -> std::result::Result<(), String> {
    let ok = Command::new(python)
        .args(["-c", &format!("import {module}")])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{} cannot import {module} (run `just peers`)",
            python.display()
        ))
    }
}

/// Sizes of the family: the in-core decades from 10^4 (`sizes`) and 2·10^6 where the run
/// reaches it.
pub fn sizes(in_core: &[u64]) -> Vec<u64> {
    let mut out = in_core.to_vec();
    if in_core.last().is_some_and(|&n| n >= 10_000_000) {
        out.push(2_000_000);
    }
    out.sort_unstable();
    out
}

/// Why a cell of a kind is not started at `n` points, from its earlier sizes (`done`: points
/// and seconds of a run, NaN when it did not finish): the last time grown as the last two
/// sizes grew (exponent at least 1, at most 3; 1 with one size), over `cap` a run, or over
/// [`SIZE_BUDGET`] for its `rounds` together.
pub fn forecast_skip(done: &[(u64, f64)], n: u64, cap: Duration, rounds: usize) -> Option<String> {
    let &(n1, t1) = done.last()?;
    if !t1.is_finite() {
        return Some("skipped: the previous size did not finish".into());
    }
    let exponent = match done.len().checked_sub(2).map(|i| done[i]) {
        Some((n0, t0)) if t0 > 0.0 && t0.is_finite() && n1 > n0 => {
            ((t1 / t0).ln() / (n1 as f64 / n0 as f64).ln()).clamp(1.0, 3.0)
        }
        _ => 1.0,
    };
    let predicted = t1 * (n as f64 / n1 as f64).powf(exponent);
    let forecast = format!(
        "skipped: {t1:.1} s at {n1} points, so about {predicted:.0} s a run here \
         (exponent {exponent:.2})"
    );
    if predicted > cap.as_secs_f64() {
        Some(format!("{forecast}, over the {} s cap", cap.as_secs()))
    } else if predicted * rounds as f64 > SIZE_BUDGET.as_secs_f64() {
        Some(format!(
            "{forecast}, {:.0} s over its {rounds} rounds, over the {} s budget of a size",
            predicted * rounds as f64,
            SIZE_BUDGET.as_secs()
        ))
    } else {
        None
    }
}

/// Accuracy of `normals` against `reference` (the mesh's), point by point: the unsigned angle
/// (the angle between the two lines, 0 to 90°), its median and 95th percentile (nearest rank),
/// and with `oriented` the share of points whose normals agree in sign. A normal of zero length
/// counts as 90° and as disagreeing.
pub fn accuracy(normals: &[Vec3], reference: &[Vec3], oriented: bool) -> Result<Accuracy> {
    if normals.len() != reference.len() || normals.is_empty() {
        bail!(
            "{} normals against {} reference normals",
            normals.len(),
            reference.len()
        );
    }
    let mut agree = 0_usize;
    let mut angles: Vec<f64> = normals
        .iter()
        .zip(reference)
        .map(|(n, r)| {
            let (n, r) = (n.as_dvec3(), r.as_dvec3());
            let len = n.length() * r.length();
            if len.is_nan() || len <= 0.0 || len.is_infinite() {
                return 90.0;
            }
            let cos = n.dot(r) / len;
            if cos > 0.0 {
                agree += 1;
            }
            cos.abs().min(1.0).acos().to_degrees()
        })
        .collect();
    angles.sort_by(f64::total_cmp);
    let rank =
        |q: f64| angles[((q * angles.len() as f64).ceil() as usize).clamp(1, angles.len()) - 1];
    Ok(Accuracy {
        angle_median_deg: rank(0.5),
        angle_p95_deg: rank(0.95),
        sign_agreement: if oriented {
            agree as f64 / normals.len() as f64
        } else {
            f64::NAN
        },
    })
}

/// A normal-estimation cell's body: the estimate of `kind` on `cloud` (sampled, its normals
/// the mesh's), one run; `ready` is called when the input is ready (a peer's: the points
/// written), the preparation's end. A peer's files are in `dir`, removed here whatever happens.
pub fn cell(
    kind: Kind,
    cloud: &cloud::PointCloud,
    dir: &Path,
    python: &Path,
    ready: impl FnOnce() -> f64,
) -> Result<CellOutput> {
    let reference = cloud
        .normals
        .as_deref()
        .context("the sampled cloud has no mesh normals")?;
    let n = cloud.positions.len();
    let (seconds, normals, prepare_seconds) = match kind.peer() {
        None => {
            let orientation = if kind.oriented() {
                Orientation::Propagated
            } else {
                Orientation::AwayFromCentroid
            };
            let prepare_seconds = ready();
            let start = Instant::now();
            let normals = cloud::normals::estimate_normals(&cloud.positions, K, orientation)?;
            (start.elapsed().as_secs_f64(), normals, prepare_seconds)
        }
        Some((mode, _)) => {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            let outcome = (|| -> Result<(f64, Vec<Vec3>, f64)> {
                let points = dir.join("points.f64");
                let bytes: Vec<u8> = cloud
                    .positions
                    .iter()
                    .flat_map(|p| p.to_array())
                    .flat_map(f64::to_le_bytes)
                    .collect();
                std::fs::write(&points, bytes)
                    .with_context(|| format!("writing {}", points.display()))?;
                let script = dir.join("normals_peer.py");
                std::fs::write(&script, SCRIPT)
                    .with_context(|| format!("writing {}", script.display()))?;
                let out = dir.join("normals.f32");
                let prepare_seconds = ready();
                let args = [
                    script.into_os_string(),
                    mode.into(),
                    points.into_os_string(),
                    out.clone().into_os_string(),
                    K.to_string().into(),
                ];
                let seconds = run_peer(kind.name(), python, &args, CAP)?;
                let raw = std::fs::read(&out).with_context(|| {
                    format!("{} wrote no normals ({})", kind.name(), out.display())
                })?;
                if raw.len() != n * 12 {
                    bail!(
                        "{} wrote {} bytes of normals for {n} points",
                        kind.name(),
                        raw.len()
                    );
                }
                let normals = raw
                    .chunks_exact(12)
                    .map(|c| {
                        let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                        Vec3::new(f(0), f(4), f(8))
                    })
                    .collect();
                Ok((seconds, normals, prepare_seconds))
            })();
            let _ = std::fs::remove_dir_all(dir);
            outcome?
        }
    };
    let accuracy = accuracy(&normals, reference, kind.oriented())?;
    Ok(CellOutput {
        seconds,
        peak_rss_bytes: peak_rss_with_children(),
        prepare_seconds,
        detail: format!("{}; {n} points", kind.what()),
        accuracy,
        build_seconds: f64::NAN,
    })
}

/// Runs a peer program (`name` in what it reports) and returns the seconds its last stdout
/// line gives (`{"seconds": S}`). Killed when it runs over `cap`; an exit other than success is
/// an error naming it with the end of its standard error.
pub fn run_peer(
    name: &str,
    program: &Path,
    args: &[std::ffi::OsString],
    cap: Duration,
) -> Result<f64> {
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("{name}: cannot start {}", program.display()))?;
    let stdout = child.stdout.take().map(|s| {
        std::thread::spawn(move || {
            std::io::BufReader::new(s)
                .lines()
                .map_while(std::result::Result::ok)
                .filter(|l| !l.trim().is_empty())
                .last()
        })
    });
    let stderr = child.stderr.take().map(|s| {
        std::thread::spawn(move || {
            let mut tail: Vec<String> = Vec::new();
            for line in std::io::BufReader::new(s)
                .lines()
                .map_while(std::result::Result::ok)
            {
                tail.push(line);
                if tail.len() > 64 {
                    tail.remove(0);
                }
            }
            tail
        })
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if start.elapsed() > cap {
            let _ = child.kill();
            let _ = child.wait();
            bail!(
                "{name} ({}) did not finish within {} s and was stopped",
                program.display(),
                cap.as_secs()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let last = stdout.and_then(|t| t.join().ok()).flatten();
    let err = stderr.and_then(|t| t.join().ok()).unwrap_or_default();
    if !status.success() {
        let tail: Vec<&str> = err
            .iter()
            .rev()
            .map(|l| l.trim())
            .filter(|l| !l.is_empty())
            .take(3)
            .collect();
        bail!(
            "{name} ({}) exited with {status}: {}",
            program.display(),
            if tail.is_empty() {
                "no error output".to_owned()
            } else {
                tail.into_iter().rev().collect::<Vec<_>>().join(" | ")
            }
        );
    }
    let line = last.with_context(|| format!("{name} printed nothing"))?;
    let v: serde_json::Value = serde_json::from_str(&line)
        .with_context(|| format!("{name}'s last line is not JSON: {line:?}"))?;
    v["seconds"]
        .as_f64()
        .filter(|s| s.is_finite() && *s >= 0.0)
        .with_context(|| format!("{name}'s last line has no seconds: {line:?}"))
}

/// The family's rows at `sizes`: at each size every kind that may run, [`ROUNDS`] rounds of
/// one run each in [`Kind::ALL`]'s order, each run in its own process (`run`: the cell runner,
/// the experiment's `child::run_cell`); a kind that fails or is stopped runs no further round
/// there. Each row's seconds are its rounds' median, its runs listed in `runs_seconds`.
pub fn measure(
    kinds: &[CellKind],
    sizes: &[u64],
    cap: Duration,
    quick: bool,
    mut run: impl FnMut(&str, u64) -> Row,
    mut progress: impl FnMut(&str, u64),
) -> Vec<Row> {
    let mut done: Vec<Vec<(u64, f64)>> = vec![Vec::new(); kinds.len()];
    let mut rows = Vec::new();
    for &n in sizes {
        let mut not_run: Vec<Option<String>> = kinds
            .iter()
            .enumerate()
            .map(|(i, k)| {
                let per_point = match &k.memory {
                    Memory::PerPoint(b) => *b,
                    _ => 0,
                };
                if let Some(why) = &k.unavailable {
                    Some(format!("skipped: not installed: {why}"))
                } else if quick && k.name == Kind::Open3dOriented.name() {
                    Some(QUICK_SKIP.to_owned())
                } else if let Err(e) = cloud::memory::ensure(
                    u128::from(n) * u128::from(per_point + 48),
                    &format!("{} on {n} points", k.name),
                ) {
                    Some(format!("refused: {e}"))
                } else {
                    forecast_skip(&done[i], n, cap, rounds(quick))
                }
            })
            .collect();
        let mut runs: Vec<Vec<Row>> = vec![Vec::new(); kinds.len()];
        for _ in 0..rounds(quick) {
            for (i, k) in kinds.iter().enumerate() {
                if not_run[i].is_some() || runs[i].last().is_some_and(|r| r.status != "ok") {
                    continue;
                }
                progress(&k.name, n);
                runs[i].push(run(&k.name, n));
            }
        }
        for (i, k) in kinds.iter().enumerate() {
            let row = match (not_run[i].take(), runs[i].is_empty()) {
                (Some(status), _) => Row::not_run(&k.name, n, status),
                (None, true) => Row::not_run(&k.name, n, "error: no round ran".into()),
                (None, false) => merge(&runs[i]),
            };
            done[i].push((n, row.seconds));
            rows.push(row);
        }
    }
    rows
}

/// One row of a kind's runs at one size: the last run's status when it failed (its earlier
/// runs listed), else the median of the seconds and of the preparations, the largest peak.
fn merge(runs: &[Row]) -> Row {
    let mut row = runs[runs.len() - 1].clone();
    let listed: Vec<String> = runs
        .iter()
        .map(|r| {
            if r.status == "ok" {
                format!("{:.4}", r.seconds)
            } else {
                "NaN".into()
            }
        })
        .collect();
    row.runs_seconds = listed.join(";");
    if row.status != "ok" {
        return row;
    }
    let median = |f: &dyn Fn(&Row) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    row.seconds = median(&|r| r.seconds);
    row.prepare_seconds = median(&|r| r.prepare_seconds);
    row.peak_rss_bytes = runs.iter().map(|r| r.peak_rss_bytes).max().unwrap_or(0);
    row
}

/// The pairs the family's ratios compare: (peer, ours).
pub const PAIRS: [(Kind, Kind); 3] = [
    (Kind::Open3d, Kind::Ours),
    (Kind::Pcu, Kind::Ours),
    (Kind::Open3dOriented, Kind::OursOriented),
];

/// Per size and pair ([`PAIRS`]) where both finished every round: the peer's time over ours,
/// the median of the per-round ratios (each round ran both, alternated), with its lowest and
/// highest.
pub fn ratios(rows: &[Row]) -> Vec<Ratio> {
    let runs = |r: &Row| -> Vec<f64> {
        r.runs_seconds
            .split(';')
            .filter_map(|s| s.parse::<f64>().ok())
            .collect()
    };
    let mut out = Vec::new();
    for (peer, ours) in PAIRS {
        for p in rows
            .iter()
            .filter(|r| r.method == peer.name() && r.status == "ok")
        {
            let Some(o) = rows
                .iter()
                .find(|r| r.method == ours.name() && r.n_points == p.n_points && r.status == "ok")
            else {
                continue;
            };
            let mut per: Vec<f64> = runs(p)
                .iter()
                .zip(runs(o))
                .map(|(a, b)| a / b)
                .filter(|x| x.is_finite() && *x > 0.0)
                .collect();
            if per.is_empty() {
                continue;
            }
            per.sort_by(f64::total_cmp);
            let median = if per.len() % 2 == 1 {
                per[per.len() / 2]
            } else {
                (per[per.len() / 2 - 1] + per[per.len() / 2]) / 2.0
            };
            out.push(Ratio {
                experiment: "scale".into(),
                dataset: format!("{} points", p.n_points),
                peer: p.method.clone(),
                peer_setting: String::new(),
                ours: o.method.clone(),
                ours_setting: String::new(),
                pairs: per.len(),
                views: per.len(),
                ratio: median,
                low: None,
                high: None,
                min: per[0],
                max: per[per.len() - 1],
                jaccard_min: None,
                note: format!(
                    "angle error median {:.2}° against ours {:.2}°",
                    p.angle_median_deg, o.angle_median_deg
                ),
                run: String::new(),
                machine: String::new(),
                revision: String::new(),
            });
        }
    }
    out
}

/// The family's rows as a markdown section: per size and cell, seconds (median and its
/// runs), accuracy and peak, then the ratios against ours (empty without rows).
pub fn summary(rows: &[Row]) -> String {
    let ours: Vec<&Row> = rows
        .iter()
        .filter(|r| Kind::named(&r.method).is_some())
        .collect();
    if ours.is_empty() {
        return String::new();
    }
    let fmt = |x: f64, d: usize| {
        if x.is_finite() {
            format!("{x:.d$}")
        } else {
            "-".into()
        }
    };
    let table: Vec<Vec<String>> = ours
        .iter()
        .map(|r| {
            vec![
                r.n_points.to_string(),
                r.method.clone(),
                fmt(r.seconds, 3),
                if r.runs_seconds.is_empty() {
                    "-".into()
                } else {
                    r.runs_seconds.replace(';', ", ")
                },
                fmt(r.angle_median_deg, 2),
                fmt(r.angle_p95_deg, 2),
                fmt(r.sign_agreement * 100.0, 2),
                if r.status == "ok" {
                    format!("{:.0}", r.peak_rss_bytes as f64 / 1048576.0)
                } else {
                    r.status.clone()
                },
            ]
        })
        .collect();
    let ratios: Vec<String> = ratios(rows)
        .iter()
        .map(|r| {
            format!(
                "- {}: `{}` over `{}`: {:.2}× (median of {} alternated pairs, {:.2}–{:.2}; {})\n",
                r.dataset, r.peer, r.ours, r.ratio, r.pairs, r.min, r.max, r.note
            )
        })
        .collect();
    format!(
        "\nNormal estimation ({K} neighbours; the same sampled points; a peer's time is its \
         library call alone, reading and writing excluded). Accuracy against the mesh's \
         normals: the unsigned angle (median, 95th percentile) and, for oriented normals, the \
         share on the mesh's side. Each cell ran up to {ROUNDS} rounds (one in a quick run), \
         alternated with the others at its size; seconds are their median.\n\n{}\n{}",
        crate::experiments::markdown_table(
            &[
                "points",
                "cell",
                "seconds",
                "runs",
                "angle median °",
                "angle p95 °",
                "sign agrees %",
                "peak MiB / status",
            ],
            &table
        ),
        if ratios.is_empty() {
            String::new()
        } else {
            format!(
                "\nPeer time over ours (above 1: ours is faster):\n\n{}",
                ratios.concat()
            )
        }
    )
}

/// The folder a peer's cell writes its points and normals in: under the system's temporary
/// folder, named by the cell and by `owner`, the process that runs the experiment (the cell's
/// parent), which removes it after the cell whatever happened ([`remove_cell_dir`]).
pub fn cell_dir(method: &str, n: u64, owner: u32) -> PathBuf {
    std::env::temp_dir().join(format!("pointsight-scale-{method}-{n}-{owner}"))
}

/// Removes the folder of the cell `method` at `n` points that this process started (a cell
/// stopped by its cap leaves it).
pub fn remove_cell_dir(method: &str, n: u64) {
    let dir = cell_dir(method, n, std::process::id());
    if dir.exists() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[cfg(test)]
mod tests;
