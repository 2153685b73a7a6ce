//! Experiment `visibility`: every registered visibility method over its sweep, against the
//! reference.
//!
//! A generic loop: for each dataset, every method of `registry::all()` that has a sweep
//! (`registry::sweep`: the built-in grids in `registry/src/sweeps.toml`, an external method's
//! own in its `method.toml`, a user's `--config` file over both) is prepared once per setting
//! and run on every view; the harness scores each answer against the reference (the mesh's
//! z-buffer). Adding a method to this experiment is a registry entry and a grid; nothing here
//! names a method except where a peer is paired with our exact HPR at the same γ.
//!
//! `results.csv`: one row per (dataset, view, method, setting), in that order, with precision,
//! recall and F1 against `reference`; `family` groups rows in plots (HPR's two kernels are two
//! families); `detail` is what a rule chose (HPR's `gamma=auto`: `gamma_value`); `seconds` is
//! the median of `--repeats` runs (`registry::timing`; an external method's own reported
//! seconds), `seconds_min`/`seconds_max` their spread; `status` is `ok` or `error: ...` (a
//! failing view is a row and the run goes on). `pixels.csv`: for the per-pixel methods (ray
//! cast, splat), the share of covered pixels whose point is truly visible and the share of the
//! mesh's pixels (the mesh rasterised at the method's resolution) that got a point.
//! `agreement.csv`: on clouds without a mesh, the Jaccard index of each pair of methods at
//! their default settings. `peers.csv`: an external method with a `gamma` against our exact
//! HPR at that γ, per view. `renders.png`: bunny-69451 (else the first dataset), view 0, every
//! family at its best setting beside the reference.
//!
//! Sharded runs (`--shard K/N`) split the (dataset, view) cells round-robin; every method and
//! setting of one view stays in one shard, because agreement and peers pair methods per view.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use registry::Setting;
use serde::{Deserialize, Serialize};
use truth::{NO_TRIANGLE, Reference, ReferenceParams};

use super::{Context, Experiment, markdown_table};
use crate::datasets;
use crate::output::plot::{Chart, Mark, Series};
use crate::output::render::{classified_panel, compose, footprint};
use crate::output::{read_csv, write_atomic, write_csv};
use crate::progress;
use crate::score::Score;

/// The experiment.
pub struct VisibilityExperiment;

/// One row of `results.csv` (the column order is the output contract).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// Dataset.
    pub dataset: String,
    /// Points.
    pub n_points: usize,
    /// View.
    pub view: usize,
    /// Method name.
    pub method: String,
    /// How its rows group in plots and tables (`registry::Method::family`).
    pub family: String,
    /// Setting, `k=v` pairs sorted by key and joined by `;` (`registry::Setting::label`).
    pub params: String,
    /// What a rule chose for this view (`gamma_value=2.871` for `gamma=auto`), `k=v` pairs.
    pub detail: String,
    /// Median seconds of the method alone (`--repeats` runs).
    pub seconds: f64,
    /// Rays cast (0 for methods that cast none).
    pub rays: u64,
    /// Visible points found.
    pub n_visible: usize,
    /// Precision against the reference.
    pub precision: f64,
    /// Recall.
    pub recall: f64,
    /// F1.
    pub f1: f64,
    /// Off-surface points (farther from the mesh than the dataset's tolerance) the method
    /// called visible; they are left out of precision and recall.
    #[serde(default)]
    pub off_surface_visible: usize,
    /// Fastest of the timed runs.
    #[serde(default)]
    pub seconds_min: f64,
    /// Slowest of the timed runs.
    #[serde(default)]
    pub seconds_max: f64,
    /// Number of timed runs.
    #[serde(default)]
    pub samples: usize,
    /// `ok`, or `error: …` for a view an external method failed (scores NaN).
    #[serde(default = "ok_status")]
    pub status: String,
}

fn ok_status() -> String {
    "ok".into()
}

/// One row of `agreement.csv`: for datasets without a mesh, how far two methods' visible sets
/// agree (their automatic settings, same view).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AgreementRow {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// First method family.
    pub a: String,
    /// Second method family.
    pub b: String,
    /// |A ∩ B| / |A ∪ B|.
    pub jaccard: f64,
}

/// One row of `pixels.csv`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PixelRow {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// Method.
    pub method: String,
    /// Family.
    pub family: String,
    /// Setting.
    pub params: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Pixels that show a point.
    pub covered_pixels: usize,
    /// Covered pixels whose point is truly visible.
    pub true_pixels: usize,
    /// Pixels the mesh covers at this resolution.
    pub mesh_pixels: usize,
    /// Mesh pixels that show a point.
    pub mesh_pixels_covered: usize,
    /// true_pixels / covered_pixels.
    pub pixel_precision: f64,
    /// mesh_pixels_covered / mesh_pixels.
    pub mesh_coverage: f64,
}

/// Every family of `rows`, in the order they first appear.
fn families_of(rows: &[Row]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in rows {
        if !out.contains(&r.family) {
            out.push(r.family.clone());
        }
    }
    out
}

/// One row of `peers.csv`: a peer (external method with a `gamma`) against our exact HPR at
/// the same γ, same view.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerRow {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// The peer method.
    pub peer: String,
    /// γ of both.
    pub gamma: String,
    /// Our HPR's median seconds.
    pub ours_seconds: f64,
    /// The peer's seconds (its own compute time, median).
    pub peer_seconds: f64,
    /// Jaccard index of the two visible sets.
    pub jaccard: f64,
}

fn is_auto(params: &str) -> bool {
    Setting::parse(params).is_auto()
}

/// A visible set kept past its row (for agreement, peers and the renders).
struct Run {
    method: String,
    family: String,
    params: String,
    visible: Vec<u32>,
}

/// Every registered method with a non-empty sweep, in registry order, that can run here; the
/// others (an external method whose environment is missing) are listed with why.
fn methods_to_run(
    ctx: &Context,
) -> (
    Vec<(&'static dyn registry::Method, registry::MethodSweep)>,
    Vec<String>,
) {
    let mut not_run = Vec::new();
    let mut out = Vec::new();
    for m in registry::all() {
        let Some(sweep) = ctx
            .sweeps
            .methods
            .get(m.name())
            .filter(|s| !s.settings(ctx.quick).is_empty())
        else {
            continue;
        };
        match m.availability() {
            Ok(()) => out.push((m, sweep.clone())),
            Err(why) => not_run.push(format!("{}: {why}", m.name())),
        }
    }
    (out, not_run)
}

/// The dataset whose view 0 is drawn in `renders.png`: bunny-69451 when covered, else the
/// first dataset (a fixed choice, so every shard agrees on it).
fn render_dataset(datasets: &[String]) -> Option<&str> {
    datasets
        .iter()
        .find(|d| *d == "bunny-69451")
        .or(datasets.first())
        .map(String::as_str)
}

impl Experiment for VisibilityExperiment {
    fn name(&self) -> &'static str {
        "visibility"
    }

    fn summary(&self) -> &'static str {
        "every registered visibility method over its sweep (HPR two kernels, ray cast, splat, external methods and peers) against the reference"
    }

    fn default_datasets(&self, quick: bool) -> &'static [&'static str] {
        if quick {
            &["bunny", "bunny-69451"]
        } else {
            &[
                "bunny",
                "bunny-69451",
                "dragon-871414",
                "torus-22321",
                "sphere-plane-24000",
            ]
        }
    }

    fn shardable(&self) -> bool {
        true
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let n_views = if ctx.quick { 2 } else { 8 };
        let (methods, mut not_run) = methods_to_run(ctx);
        // The setting that stands for each method (agreement on clouds without a mesh).
        let defaults: BTreeMap<String, String> = methods
            .iter()
            .filter_map(|(m, s)| Some((m.name().to_owned(), s.default_setting()?.label())))
            .collect();
        let peers_wanted = methods.iter().any(|(m, s)| {
            m.is_external()
                && s.settings(ctx.quick)
                    .iter()
                    .any(|x| x.get("gamma").is_some())
        });
        let render_ds = render_dataset(&ctx.datasets);
        let mut rows = Vec::new();
        let mut pixel_rows = Vec::new();
        let mut agreement = Vec::new();
        let mut peers = Vec::new();
        let mut off_surface_meta = serde_json::Map::new();
        for (d_idx, name) in ctx.datasets.iter().enumerate() {
            let owned: Vec<usize> = (0..n_views)
                .filter(|&v| ctx.owns(d_idx, v, n_views))
                .collect();
            if owned.is_empty() {
                continue;
            }
            let ds = ctx.dataset(name)?;
            let views: Vec<usize> = owned.into_iter().filter(|&v| v < ds.views.len()).collect();
            let points = &ds.cloud.positions;
            // No mesh, no ground truth: rows keep speed and counts, F1 is NaN, and the methods'
            // agreement is recorded instead.
            let reference = ds.mesh.as_ref().map(Reference::new).transpose()?;
            let off = ds.off_surface()?;
            if let Some((flags, tolerance)) = &off {
                off_surface_meta.insert(
                    name.clone(),
                    serde_json::json!({
                        "tolerance": tolerance,
                        "off_surface_points": flags.iter().filter(|&&f| f).count(),
                    }),
                );
            }
            let off_flags = off.as_ref().map(|(f, _)| &f[..]);
            let mut truths: BTreeMap<usize, Option<Vec<bool>>> = BTreeMap::new();
            for &v in &views {
                let truth = match &reference {
                    Some(r) => Some(
                        r.visibility(ds.truth_points(), ds.view(v)?, &ReferenceParams::default())?
                            .visible,
                    ),
                    None => None,
                };
                truths.insert(v, truth);
            }
            // The mesh's pixels per view and image size, for the per-pixel methods.
            let mut mesh_masks: BTreeMap<(usize, u32, u32), Vec<bool>> = BTreeMap::new();
            let mut kept: BTreeMap<usize, Vec<Run>> = BTreeMap::new();
            let mut ds_rows: Vec<Row> = Vec::new();
            let mut ds_pixels: Vec<PixelRow> = Vec::new();
            let cells: usize = methods
                .iter()
                .map(|(_, s)| s.settings(ctx.quick).len())
                .sum::<usize>()
                * views.len();
            let bar = progress::bar(cells as u64, format!("visibility {name}"));
            for (m, sweep) in &methods {
                for setting in sweep.settings(ctx.quick) {
                    let label = setting.label();
                    let family = m.family(setting);
                    // One preparation per setting, every view; a failure is a row per view.
                    let prepared = registry::prepare(*m, ds.input(), &setting.params());
                    for &view in &views {
                        let cam = *ds.view(view)?;
                        let truth = truths.get(&view).and_then(Option::as_deref);
                        let mut row = Row {
                            dataset: name.clone(),
                            n_points: points.len(),
                            view,
                            method: m.name().to_owned(),
                            family: family.clone(),
                            params: label.clone(),
                            detail: String::new(),
                            seconds: f64::NAN,
                            rays: 0,
                            n_visible: 0,
                            precision: f64::NAN,
                            recall: f64::NAN,
                            f1: f64::NAN,
                            off_surface_visible: 0,
                            seconds_min: f64::NAN,
                            seconds_max: f64::NAN,
                            samples: 0,
                            status: ok_status(),
                        };
                        let outcome = match &prepared {
                            Ok(p) => registry::timed(p.as_ref(), &cam, ctx.repeats)
                                .map_err(|e| e.to_string()),
                            Err(e) => Err(e.to_string()),
                        };
                        match outcome {
                            Ok((out, t)) => {
                                if let Some(t) = truth {
                                    let s = Score::of_on_surface(&out.visible, t, off_flags);
                                    (row.precision, row.recall, row.f1) =
                                        (s.precision(), s.recall(), s.f1());
                                }
                                row.off_surface_visible = off_flags.map_or(0, |f| {
                                    out.visible.iter().filter(|&&i| f[i as usize]).count()
                                });
                                row.n_visible = out.visible.len();
                                row.rays = out.rays;
                                (row.seconds, row.seconds_min, row.seconds_max, row.samples) =
                                    (t.median, t.min, t.max, t.samples);
                                row.detail = out
                                    .detail
                                    .iter()
                                    .map(|(k, v)| format!("{k}={v}"))
                                    .collect::<Vec<_>>()
                                    .join(";");
                                if let (Some(px), Some(truth), Some(mesh)) =
                                    (&out.pixels, truth, &ds.mesh)
                                {
                                    let c = cam.with_resolution(px.width, px.height)?;
                                    if c.has_frustum() {
                                        let mask = match mesh_masks.entry((view, c.width, c.height))
                                        {
                                            std::collections::btree_map::Entry::Occupied(e) => {
                                                e.into_mut()
                                            }
                                            std::collections::btree_map::Entry::Vacant(e) => e
                                                .insert(
                                                    truth::rasterize(mesh, &c)?
                                                        .triangle
                                                        .iter()
                                                        .map(|&t| t != NO_TRIANGLE)
                                                        .collect(),
                                                ),
                                        };
                                        ds_pixels.push(pixel_row(&row, px, truth, mask));
                                    }
                                }
                                let keep = (truth.is_none()
                                    && defaults.get(m.name()) == Some(&label))
                                    || (peers_wanted
                                        && (m.is_external() || is_peer_partner(m.name(), setting)))
                                    || (Some(name.as_str()) == render_ds && view == 0);
                                if keep {
                                    kept.entry(view).or_default().push(Run {
                                        method: m.name().to_owned(),
                                        family: family.clone(),
                                        params: label.clone(),
                                        visible: out.visible,
                                    });
                                }
                            }
                            Err(e) => {
                                eprintln!("visibility: {} {label} view {view}: {e}", m.name());
                                row.status = format!("error: {e}");
                            }
                        }
                        ds_rows.push(row);
                        bar.inc(1);
                    }
                }
            }
            bar.finish_and_clear();
            // Rows in (view, method, setting) order, whatever the loop order was.
            ds_rows.sort_by_key(|r| r.view);
            ds_pixels.sort_by_key(|r| r.view);
            for (&view, runs) in &kept {
                if truths.get(&view).is_some_and(Option::is_none) {
                    agreement.extend(agreement_rows(name, view, runs, &defaults));
                }
                peers.extend(peer_rows(name, view, runs, &ds_rows));
            }
            if let (Some(reference), Some(runs)) = (
                reference
                    .as_ref()
                    .filter(|_| Some(name.as_str()) == render_ds),
                kept.remove(&0).filter(|_| Some(name.as_str()) == render_ds),
            ) {
                render_bunny(&ctx.out_dir, &ds, reference, &ds_rows, runs)?;
            }
            rows.extend(ds_rows);
            pixel_rows.extend(ds_pixels);
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        write_csv(&ctx.out_dir.join("pixels.csv"), &pixel_rows)?;
        write_csv(&ctx.out_dir.join("agreement.csv"), &agreement)?;
        write_csv(&ctx.out_dir.join("peers.csv"), &peers)?;
        not_run.sort();
        not_run.dedup();
        let sweeps: serde_json::Map<String, serde_json::Value> = methods
            .iter()
            .map(|(m, s)| {
                (
                    m.name().to_owned(),
                    serde_json::json!(
                        s.settings(ctx.quick)
                            .iter()
                            .map(Setting::label)
                            .collect::<Vec<_>>()
                    ),
                )
            })
            .collect();
        Ok(serde_json::json!({
            "views": n_views,
            "sweeps": sweeps,
            "default_settings": defaults,
            "hpr_hull": "own",
            "hpr_auto_rule": format!("gamma = log10(kappa * D * d^2 / (s^2 * m)), kappa = {}", hpr::auto::KAPPA),
            "raycast_auto_rule": format!("radius = {} x density spacing (k = 8)", raycast::auto::RADIUS_FACTOR),
            "repeats": ctx.repeats,
            "timing": format!("median of {} runs (seconds_min, seconds_max: their spread); external methods: their own reported seconds", ctx.repeats),
            "off_surface": off_surface_meta,
            "external_methods_not_run": not_run,
            "render_dataset": render_ds,
        }))
    }

    fn render(&self, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let pixels: Vec<PixelRow> = read_csv(&dir.join("pixels.csv"))?;
        let agreement: Vec<AgreementRow> = read_csv(&dir.join("agreement.csv"))?;
        let peers: Vec<PeerRow> = read_csv(&dir.join("peers.csv"))?;
        let meta = crate::output::meta::RunMeta::read(dir)?;
        let not_run: Vec<String> =
            serde_json::from_value(meta.parameters["external_methods_not_run"].clone())
                .unwrap_or_default();
        let defaults: BTreeMap<String, String> =
            serde_json::from_value(meta.parameters["default_settings"].clone()).unwrap_or_default();
        let peers_md = peers_summary(&peers, &not_run);
        let render_ds = meta.parameters["render_dataset"].as_str();
        render(
            dir, &rows, &pixels, &agreement, &peers_md, &defaults, render_ds,
        )
    }
}

/// The image-space figures of one per-pixel run: which covered pixels show a truly visible
/// point, and how much of the mesh's footprint got a point.
fn pixel_row(row: &Row, px: &registry::PixelChoice, truth: &[bool], mesh: &[bool]) -> PixelRow {
    let covered = px.point.iter().filter(|&&p| p != raycast::NONE).count();
    let true_pixels = px
        .point
        .iter()
        .filter(|&&p| p != raycast::NONE && truth[p as usize])
        .count();
    let mesh_total = mesh.iter().filter(|&&m| m).count();
    let mesh_covered = mesh
        .iter()
        .zip(&px.point)
        .filter(|&(&m, &p)| m && p != raycast::NONE)
        .count();
    PixelRow {
        dataset: row.dataset.clone(),
        view: row.view,
        method: row.method.clone(),
        family: row.family.clone(),
        params: row.params.clone(),
        width: px.width,
        height: px.height,
        covered_pixels: covered,
        true_pixels,
        mesh_pixels: mesh_total,
        mesh_pixels_covered: mesh_covered,
        pixel_precision: true_pixels as f64 / covered.max(1) as f64,
        mesh_coverage: mesh_covered as f64 / mesh_total.max(1) as f64,
    }
}

/// True for the settings of ours a peer is paired with: exact HPR, linear kernel, a fixed γ, no
/// perturbation.
fn is_peer_partner(method: &str, setting: &Setting) -> bool {
    method == "hpr"
        && setting.text("kernel").as_deref() != Some("exp")
        && setting.number("perturb").unwrap_or(0.0) == 0.0
        && setting.number("gamma").is_some()
}

/// Each external run with a `gamma` against our exact HPR at the same γ, same view.
fn peer_rows(dataset: &str, view: usize, runs: &[Run], rows: &[Row]) -> Vec<PeerRow> {
    let mut out = Vec::new();
    for peer in runs
        .iter()
        .filter(|r| registry::method(&r.method).is_ok_and(|m| m.is_external()))
    {
        let Some(g) = Setting::parse(&peer.params).number("gamma") else {
            continue;
        };
        let Some(ours) = runs.iter().find(|r| {
            let s = Setting::parse(&r.params);
            is_peer_partner(&r.method, &s) && s.number("gamma") == Some(g)
        }) else {
            continue;
        };
        let seconds = |r: &Run| {
            rows.iter()
                .find(|x| x.view == view && x.method == r.method && x.params == r.params)
                .map_or(f64::NAN, |x| x.seconds)
        };
        out.push(PeerRow {
            dataset: dataset.to_owned(),
            view,
            peer: peer.method.clone(),
            gamma: format!("{g}"),
            ours_seconds: seconds(ours),
            peer_seconds: seconds(peer),
            jaccard: Score::of_sets(&peer.visible, &ours.visible).jaccard(),
        });
    }
    out
}

/// On a cloud without a mesh: how far each pair of methods agree at their default settings.
fn agreement_rows(
    dataset: &str,
    view: usize,
    runs: &[Run],
    defaults: &BTreeMap<String, String>,
) -> Vec<AgreementRow> {
    let chosen: Vec<&Run> = runs
        .iter()
        .filter(|r| defaults.get(&r.method) == Some(&r.params))
        .collect();
    let mut out = Vec::new();
    for (i, a) in chosen.iter().enumerate() {
        for b in &chosen[i + 1..] {
            out.push(AgreementRow {
                dataset: dataset.to_owned(),
                view,
                a: a.family.clone(),
                b: b.family.clone(),
                jaccard: Score::of_sets(&a.visible, &b.visible).jaccard(),
            });
        }
    }
    out
}

/// The setting of `family` with the best mean F1 on `dataset` (automatic settings excluded).
fn best_setting(rows: &[Row], dataset: &str, fam: &str) -> Option<(String, f64)> {
    let mut by: BTreeMap<&str, (f64, usize)> = BTreeMap::new();
    for r in rows.iter().filter(|r| {
        r.dataset == dataset && r.family == fam && !is_auto(&r.params) && r.status == "ok"
    }) {
        let e = by.entry(&r.params).or_default();
        e.0 += r.f1;
        e.1 += 1;
    }
    by.into_iter()
        .map(|(p, (s, n))| (p.to_owned(), s / n as f64))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

fn render_bunny(
    dir: &Path,
    ds: &datasets::Dataset,
    reference: &Reference,
    rows: &[Row],
    runs: Vec<Run>,
) -> Result<()> {
    let cam = ds.views[0];
    let points = &ds.cloud.positions;
    let truth = reference
        .visibility(ds.truth_points(), &cam, &ReferenceParams::default())?
        .visible;
    // Drawn at the view's resolution, cropped to the object.
    let small = cam;
    let (cx0, cy0, cx1, cy1) = footprint(&small, points, 12);
    let mut panels = vec![classified_panel(
        &format!(
            "reference: {} of {} visible",
            truth.iter().filter(|&&t| t).count(),
            points.len()
        ),
        &small,
        points,
        &truth,
        None,
    )];
    for fam in families_of(rows) {
        let Some((best, _)) = best_setting(rows, ds.name(), &fam) else {
            continue;
        };
        let Some(run) = runs.iter().find(|r| r.family == fam && r.params == best) else {
            continue;
        };
        let mut flags = vec![false; points.len()];
        for &i in &run.visible {
            flags[i as usize] = true;
        }
        let s = Score::of(&run.visible, &truth);
        panels.push(classified_panel(
            &format!("{fam} {} (F1 {:.3})", short(&best), s.f1()),
            &small,
            points,
            &truth,
            Some(&flags),
        ));
    }
    let panels: Vec<_> = panels.iter().map(|p| p.crop(cx0, cy0, cx1, cy1)).collect();
    compose(
        &panels,
        3,
        &format!(
            "{}, view 0. green: visible and found; blue: visible, missed; red: hidden, reported visible; grey: hidden",
            ds.name()
        ),
        &dir.join("renders.png"),
    )
}

/// A setting in few characters, for captions.
fn short(params: &str) -> String {
    let mut out = Vec::new();
    let (mut w, mut h) = (None, None);
    for kv in params.split(';') {
        match kv.split_once('=') {
            Some(("kernel", _)) | Some(("perturb", "0")) => {}
            Some(("width", v)) => w = Some(v),
            Some(("height", v)) => h = Some(v),
            Some(("radius_factor", v)) => out.push(format!("r={v}s")),
            Some(("depth_tolerance", v)) => out.push(format!("tol={v}")),
            Some(("radius_px", v)) => out.push(format!("r={v}px")),
            Some(("gamma", v)) => out.push(format!("γ={v}")),
            _ => out.push(kv.to_owned()),
        }
    }
    if let (Some(w), Some(h)) = (w, h) {
        out.push(format!("{w}x{h}"));
    }
    out.join(" ")
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Each family at its best setting against exact HPR (linear kernel) at its best, paired per
/// view: the speed ratio (geometric mean of per-view ratios) and the F1 difference (mean of
/// per-view differences), each with its bootstrap 95 % interval.
fn versus_table(rows: &[Row], datasets: &[String], families: &[String]) -> String {
    const BASE: &str = "hpr-linear";
    let mut table = Vec::new();
    for d in datasets {
        let Some((base, _)) = best_setting(rows, d, BASE) else {
            continue;
        };
        let by_view = |fam: &str, params: &str| -> BTreeMap<usize, (f64, f64)> {
            rows.iter()
                .filter(|r| {
                    r.dataset == *d && r.family == fam && r.params == params && r.status == "ok"
                })
                .map(|r| (r.view, (r.seconds, r.f1)))
                .collect()
        };
        let ours = by_view(BASE, &base);
        for fam in families.iter().filter(|f| *f != BASE) {
            let Some((best, _)) = best_setting(rows, d, fam) else {
                continue;
            };
            let theirs = by_view(fam, &best);
            let paired: Vec<((f64, f64), (f64, f64))> = theirs
                .iter()
                .filter_map(|(v, t)| Some((*t, *ours.get(v)?)))
                .collect();
            if paired.is_empty() {
                continue;
            }
            let (ts, os): (Vec<f64>, Vec<f64>) = paired.iter().map(|(t, o)| (t.0, o.0)).unzip();
            let df: Vec<f64> = paired.iter().map(|(t, o)| t.1 - o.1).collect();
            let ratio = crate::stats::paired_ratio(&ts, &os, 2007)
                .map_or("-".to_owned(), |(r, lo, hi)| format!("{r:.2}× [{lo:.2}, {hi:.2}]"));
            let diff = crate::stats::bootstrap_mean(&df, 2007)
                .map_or("-".to_owned(), |(m, lo, hi)| format!("{m:+.4} [{lo:+.4}, {hi:+.4}]"));
            table.push(vec![
                d.clone(),
                fam.clone(),
                best.replace(';', " "),
                paired.len().to_string(),
                ratio,
                diff,
            ]);
        }
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "### Against exact HPR, paired per view

Each method at its best setting against \
         `hpr-linear` at its best (same dataset, same views). `time ratio`: the method's \
         seconds over HPR's, geometric mean of the per-view ratios (below 1: faster than HPR); \
         `F1 − HPR`: mean of the per-view differences; both with a bootstrap 95 % interval \
         (views resampled, 10,000 times).\n\n{}\n",
        markdown_table(
            &[
                "dataset",
                "method",
                "its best setting",
                "views",
                "time ratio [95 % CI]",
                "F1 − HPR [95 % CI]",
            ],
            &table
        )
    )
}

/// True when a fixed setting `o` agrees with the automatic `rule` on every key both set,
/// the rule's own `auto` keys aside.
fn comparable(rule: &Setting, o: &Setting) -> bool {
    rule.0.iter().all(|(k, v)| {
        *v == registry::sweep::Value::Text("auto".into()) || o.get(k).is_none_or(|w| w == v)
    })
}

/// F1 against a family's main parameter (the numeric key with the most values over its fixed
/// settings), one line per dataset and per combination of the other varying keys; `None` when
/// the family sweeps no number. Negative parameters (the exponential kernel's γ) are negated
/// and spans over two decades get a log axis.
fn param_chart(dir: &Path, rows: &[Row], datasets: &[String], fam: &str) -> Result<Option<String>> {
    let fixed: Vec<(&Row, Setting)> = rows
        .iter()
        .filter(|r| r.family == fam && r.status == "ok" && !r.f1.is_nan() && !is_auto(&r.params))
        .map(|r| (r, Setting::parse(&r.params)))
        .collect();
    // Distinct values per key.
    let mut values: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for (_, s) in &fixed {
        for (k, v) in &s.0 {
            let e = values.entry(k.as_str()).or_default();
            let t = v.to_string();
            if !e.contains(&t) {
                e.push(t);
            }
        }
    }
    let Some(key) = values
        .iter()
        .filter(|(k, vs)| {
            vs.len() > 1
                && fixed
                    .iter()
                    .all(|(_, s)| s.get(k).is_none_or(|v| v.as_f64().is_some()))
        })
        .max_by_key(|(_, vs)| vs.len())
        .map(|(k, _)| (*k).to_owned())
    else {
        return Ok(None);
    };
    let others: Vec<&str> = values
        .iter()
        .filter(|(k, vs)| **k != key && vs.len() > 1)
        .map(|(k, _)| *k)
        .collect();
    let xs: Vec<f64> = fixed.iter().filter_map(|(_, s)| s.number(&key)).collect();
    let negate = xs.iter().all(|&x| x < 0.0);
    let (lo, hi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            let x = if negate { -x } else { x };
            (a.min(x), b.max(x))
        });
    let x_log = lo > 0.0 && hi / lo > 100.0;
    let mut series = Vec::new();
    for d in datasets {
        let mut lines: BTreeMap<String, BTreeMap<i64, (f64, Vec<f64>)>> = BTreeMap::new();
        for (r, s) in fixed.iter().filter(|(r, _)| r.dataset == *d) {
            let Some(x) = s.number(&key) else { continue };
            let x = if negate { -x } else { x };
            let line = others
                .iter()
                .map(|k| format!("{k}={}", s.text(k).unwrap_or_default()))
                .collect::<Vec<_>>()
                .join(" ");
            let e = lines
                .entry(line)
                .or_default()
                .entry((x * 1e9).round() as i64)
                .or_insert((x, Vec::new()));
            e.1.push(r.f1);
        }
        for (line, pts) in lines {
            let label = if line.is_empty() {
                d.clone()
            } else {
                format!("{d} {line}")
            };
            let mut sr = Series::new(
                label,
                pts.values()
                    .map(|(x, f)| (*x, mean(f.iter().copied())))
                    .collect(),
                Mark::LinePoints,
            );
            sr.y_spread = pts
                .values()
                .map(|(_, f)| {
                    f.iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                            (a.min(v), b.max(v))
                        })
                })
                .collect();
            series.push(sr);
        }
    }
    if series.is_empty() {
        return Ok(None);
    }
    let file = format!("f1_{fam}.png");
    let shown = if negate {
        format!("-{key}")
    } else {
        key.clone()
    };
    Chart {
        title: format!("{fam}: F1 against {shown}"),
        x_label: format!("{shown}{}", if x_log { " (log)" } else { "" }),
        y_label: "F1 (mean over views; bars: lowest to highest view)".into(),
        x_log,
        series,
        ..Chart::default()
    }
    .save(&dir.join(&file), 900, 500)?;
    Ok(Some(file))
}

/// The peers' section: per dataset, peer and γ, our exact HPR's speed ratio against the peer
/// (geometric mean over views of the paired per-view ratios, bootstrap 95 % interval) and the
/// Jaccard index of the two visible sets; the peers that were not run, and why.
fn peers_summary(peers: &[PeerRow], not_run: &[String]) -> String {
    let mut s = String::from("### Peers, measured in the same run\n\n");
    let mut groups: BTreeMap<(&str, &str, &str), Vec<&PeerRow>> = BTreeMap::new();
    for p in peers {
        groups
            .entry((&p.dataset, &p.peer, &p.gamma))
            .or_default()
            .push(p);
    }
    if groups.is_empty() && not_run.is_empty() {
        s.push_str("No external peer method has a grid in methods/: none was run.\n\n");
        return s;
    }
    if !groups.is_empty() {
        s.push_str(
            "`speed ratio`: the peer's seconds over our exact HPR's (own hull) at the same γ and \
             view, geometric mean over the views, with its bootstrap 95 % interval (views \
             resampled, 10,000 times); above 1 means ours is faster. `Jaccard`: of the two visible \
             sets, mean over views.\n\n",
        );
        let rows: Vec<Vec<String>> = groups
            .iter()
            .map(|((d, peer, g), ps)| {
                let peer_s: Vec<f64> = ps.iter().map(|p| p.peer_seconds).collect();
                let ours_s: Vec<f64> = ps.iter().map(|p| p.ours_seconds).collect();
                let ratio = crate::stats::paired_ratio(&peer_s, &ours_s, 2007)
                    .map_or("-".to_owned(), |(r, lo, hi)| {
                        format!("{r:.2}× [{lo:.2}, {hi:.2}]")
                    });
                vec![
                    (*d).to_owned(),
                    (*peer).to_owned(),
                    (*g).to_owned(),
                    ps.len().to_string(),
                    format!("{:.4}", mean(ours_s.iter().copied())),
                    format!("{:.4}", mean(peer_s.iter().copied())),
                    ratio,
                    format!("{:.6}", mean(ps.iter().map(|p| p.jaccard))),
                ]
            })
            .collect();
        s.push_str(&markdown_table(
            &[
                "dataset",
                "peer",
                "γ",
                "views",
                "hpr (ours) s",
                "peer s",
                "speed ratio [95 % CI]",
                "Jaccard",
            ],
            &rows,
        ));
        s.push('\n');
    }
    for n in not_run {
        s.push_str(&format!("- not run: {n}\n"));
    }
    if !not_run.is_empty() {
        s.push('\n');
    }
    s
}

fn render(
    dir: &Path,
    rows: &[Row],
    pixels: &[PixelRow],
    agreement: &[AgreementRow],
    peers_md: &str,
    defaults: &BTreeMap<String, String>,
    render_ds: Option<&str>,
) -> Result<()> {
    let all_datasets: Vec<String> = rows.iter().fold(Vec::new(), |mut acc, r| {
        if !acc.contains(&r.dataset) {
            acc.push(r.dataset.clone());
        }
        acc
    });
    // Datasets without a ground truth (no mesh) have NaN F1: they get the agreement table.
    let (datasets, unscored): (Vec<String>, Vec<String>) = all_datasets
        .into_iter()
        .partition(|d| rows.iter().any(|r| r.dataset == *d && !r.f1.is_nan()));
    let mut no_mesh = String::new();
    for d in &unscored {
        let mut by: BTreeMap<(&str, &str), Vec<f64>> = BTreeMap::new();
        for a in agreement.iter().filter(|a| a.dataset == *d) {
            by.entry((&a.a, &a.b)).or_default().push(a.jaccard);
        }
        let mut speed: BTreeMap<&str, Vec<(f64, usize)>> = BTreeMap::new();
        for r in rows
            .iter()
            .filter(|r| r.dataset == *d && defaults.get(&r.method) == Some(&r.params))
        {
            speed
                .entry(r.family.as_str())
                .or_default()
                .push((r.seconds, r.n_visible));
        }
        no_mesh.push_str(&format!(
            "#### {d}: no mesh, no ground truth\n\nThis dataset has no mesh, so there is nothing \
             to score against: its F1 columns are empty (NaN in results.csv). What can be \
             measured is reported: each method's time and visible count at its default \
             setting (its automatic rule where it has one), and how far the methods agree (Jaccard index of their visible sets, mean \
             over views).\n\n{}\n{}\n",
            markdown_table(
                &["method", "seconds", "visible points"],
                &speed
                    .iter()
                    .map(|(m, v)| {
                        vec![
                            (*m).to_owned(),
                            format!("{:.4}", mean(v.iter().map(|x| x.0))),
                            format!("{:.0}", mean(v.iter().map(|x| x.1 as f64))),
                        ]
                    })
                    .collect::<Vec<_>>()
            ),
            markdown_table(
                &["method A", "method B", "Jaccard (mean over views)"],
                &by.iter()
                    .map(|((a, b), j)| {
                        vec![
                            (*a).to_owned(),
                            (*b).to_owned(),
                            format!("{:.4}", mean(j.iter().copied())),
                        ]
                    })
                    .collect::<Vec<_>>()
            )
        ));
    }
    let mut off_surface = String::new();
    for d in &datasets {
        let flagged: usize = rows
            .iter()
            .filter(|r| r.dataset == *d)
            .map(|r| r.off_surface_visible)
            .max()
            .unwrap_or(0);
        if flagged > 0 {
            off_surface.push_str(&format!(
                "- {d}: up to {flagged} points called visible lie farther from the mesh than the \
                 surface tolerance (see metadata.json); they are left out of precision and \
                 recall.\n"
            ));
        }
    }
    let families = families_of(rows);
    let mut pictures = String::new();

    // F1 against seconds, every setting (mean over views; bars: the views' fastest and slowest
    // timed runs and the lowest and highest F1), Pareto front marked, per dataset.
    for d in &datasets {
        let mut series = Vec::new();
        let mut all: Vec<(f64, f64)> = Vec::new();
        for (k, fam) in families.iter().enumerate() {
            let mut by: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
            for r in rows
                .iter()
                .filter(|r| r.dataset == *d && r.family == *fam && r.status == "ok")
            {
                by.entry(&r.params).or_default().push(r);
            }
            let pts: Vec<(f64, f64)> = by
                .values()
                .map(|rs| {
                    (
                        mean(rs.iter().map(|r| r.seconds)),
                        mean(rs.iter().map(|r| r.f1)),
                    )
                })
                .collect();
            let spread = |f: &dyn Fn(&Row) -> (f64, f64)| -> Vec<(f64, f64)> {
                by.values()
                    .map(|rs| {
                        rs.iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                                let (a, b) = f(r);
                                (lo.min(a), hi.max(b))
                            })
                    })
                    .collect()
            };
            all.extend(&pts);
            let mut s = Series::new(fam.clone(), pts, Mark::Points);
            s.color = Some(k);
            s.x_spread = spread(&|r| (r.seconds_min, r.seconds_max));
            s.y_spread = spread(&|r| (r.f1, r.f1));
            series.push(s);
        }
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut front: Vec<(f64, f64)> = Vec::new();
        for p in all {
            if front.last().is_none_or(|l| p.1 > l.1) {
                front.push(p);
            }
        }
        let mut ring = Series::new("Pareto front", front.clone(), Mark::Rings);
        ring.color = Some(7);
        series.push(ring);
        let mut line = Series::new("", front, Mark::Line);
        line.color = Some(7);
        series.push(line);
        let file = format!("pareto_{d}.png");
        Chart {
            title: format!("{d}: F1 against time, every method and setting (mean over views)"),
            x_label: "seconds per view (log; bars: fastest to slowest run over the views)".into(),
            y_label: "F1 against the reference (bars: lowest to highest view)".into(),
            x_log: true,
            series,
            ..Chart::default()
        }
        .save(&dir.join(&file), 1000, 560)?;
        pictures.push_str(&format!("![{d} Pareto]({file})\n\n"));
    }

    // F1 against each family's main parameter.
    for fam in &families {
        if let Some(file) = param_chart(dir, rows, &datasets, fam)? {
            pictures.push_str(&format!("![{file}]({file})\n\n"));
        }
    }

    // Best setting per family and dataset.
    let mut best_table = Vec::new();
    for d in &datasets {
        for fam in families.iter().map(String::as_str) {
            let Some((p, f1)) = best_setting(rows, d, fam) else {
                continue;
            };
            let rs: Vec<&Row> = rows
                .iter()
                .filter(|r| r.dataset == *d && r.params == p && r.family == fam)
                .collect();
            best_table.push(vec![
                d.clone(),
                fam.to_owned(),
                p.replace(';', " "),
                format!("{f1:.4}"),
                format!("{:.4}", mean(rs.iter().map(|r| r.precision))),
                format!("{:.4}", mean(rs.iter().map(|r| r.recall))),
                format!("{:.4}", mean(rs.iter().map(|r| r.seconds))),
            ]);
        }
    }

    let versus = versus_table(rows, &datasets, &families);

    // The automatic rules against the best fixed setting of the same family, view by view:
    // fixed settings that agree with the rule's setting on every fixed key both have (the ray
    // cast at the same resolution, HPR without perturbation).
    let mut auto_table = Vec::new();
    let mut worst: BTreeMap<(String, &str), f64> = BTreeMap::new();
    let mut gaps: BTreeMap<(String, &str), Vec<f64>> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| is_auto(&r.params) && r.status == "ok" && !r.f1.is_nan())
    {
        let rule = Setting::parse(&r.params);
        let best = rows
            .iter()
            .filter(|o| {
                o.dataset == r.dataset
                    && o.view == r.view
                    && o.family == r.family
                    && o.status == "ok"
                    && !is_auto(&o.params)
                    && comparable(&rule, &Setting::parse(&o.params))
            })
            .map(|o| o.f1)
            .fold(f64::NEG_INFINITY, f64::max);
        if best == f64::NEG_INFINITY {
            continue;
        }
        let gap = best - r.f1;
        let key = (r.dataset.clone(), r.family.as_str());
        gaps.entry(key.clone()).or_default().push(gap);
        let w = worst.entry(key).or_insert(f64::NEG_INFINITY);
        *w = w.max(gap);
        auto_table.push(vec![
            r.dataset.clone(),
            r.view.to_string(),
            r.family.clone(),
            format!(
                "{}{}",
                r.params.replace(';', " "),
                if r.detail.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", r.detail.replace(';', " "))
                }
            ),
            format!("{:.4}", r.f1),
            format!("{best:.4}"),
            format!("{gap:+.4}"),
        ]);
    }
    let worst_lines: Vec<String> = worst
        .iter()
        .map(|((d, fam), g)| {
            let mean = gaps
                .get(&(d.clone(), *fam))
                .and_then(|v| crate::stats::bootstrap_mean(v, 2007))
                .map_or(String::new(), |(m, lo, hi)| {
                    format!("; mean gap {m:+.4} [{lo:+.4}, {hi:+.4}]")
                });
            format!(
                "- {d}, {fam}: worst gap {g:.4} ({}){mean}",
                if *g <= 0.02 {
                    "within 0.02"
                } else {
                    "**over 0.02**"
                }
            )
        })
        .collect();

    // Image-space figures of the per-pixel families at their best setting.
    let mut pixel_table = Vec::new();
    let pixel_families: Vec<String> = pixels.iter().fold(Vec::new(), |mut acc, p| {
        if !acc.contains(&p.family) {
            acc.push(p.family.clone());
        }
        acc
    });
    for d in &datasets {
        for fam in &pixel_families {
            let Some((params, _)) = best_setting(rows, d, fam) else {
                continue;
            };
            let ps: Vec<&PixelRow> = pixels
                .iter()
                .filter(|p| p.dataset == *d && p.family == *fam && p.params == params)
                .collect();
            if !ps.is_empty() {
                pixel_table.push(vec![
                    d.clone(),
                    fam.clone(),
                    params.replace(';', " "),
                    format!("{:.4}", mean(ps.iter().map(|p| p.pixel_precision))),
                    format!("{:.4}", mean(ps.iter().map(|p| p.mesh_coverage))),
                    format!("{:.0}", mean(ps.iter().map(|p| p.covered_pixels as f64))),
                    format!("{:.0}", mean(ps.iter().map(|p| p.mesh_pixels as f64))),
                ]);
            }
        }
    }

    let renders = match (dir.join("renders.png").exists(), render_ds) {
        (true, Some(d)) => {
            format!("![{d}, view 0: every method at its best setting](renders.png)\n\n")
        }
        _ => String::new(),
    };
    let summary = format!(
        "Every visibility method against the reference (mesh depth buffer), F1 = harmonic mean of \
         precision and recall of the visible set, mean over the views. `seconds`: the method \
         alone, median of 3 runs (their spread in results.csv).\n\n{renders}### Best setting per method\n\n{}\n\
         {versus}### Choosing the parameter automatically\n\nHPR's γ from the cloud alone: \
         γ = log10(κ·D·d²/(s²·m)) (`hpr::auto`, κ = {} fitted on the synthetic scenes); the ray \
         cast's radius: {} density spacings (`raycast::auto`, fitted on these datasets). The gap is the best fixed setting's F1 \
         (same view; same resolution for the ray cast) minus the rule's; the goal is at most \
         0.02.\n\n{}\n\n<details><summary>View by view</summary>\n\n{}\n</details>\n\n\
         ### Image space (per-pixel methods)\n\nA ray cast shows at most one point per pixel: \
         `pixel precision` is the share of covered pixels whose point is truly visible, `mesh \
         coverage` the share of the mesh's pixels that got a point.\n\n{}\n{pictures}\
         {peers_md}{off_surface}{no_mesh}Raw rows: [results.csv](results.csv), [pixels.csv](pixels.csv){}.\n",
        markdown_table(
            &[
                "dataset",
                "method",
                "best setting",
                "F1",
                "precision",
                "recall",
                "seconds"
            ],
            &best_table
        ),
        hpr::auto::KAPPA,
        raycast::auto::RADIUS_FACTOR,
        worst_lines.join("\n"),
        markdown_table(
            &[
                "dataset",
                "view",
                "method",
                "rule",
                "F1",
                "best fixed F1",
                "gap"
            ],
            &auto_table
        ),
        markdown_table(
            &[
                "dataset",
                "method",
                "setting",
                "pixel precision",
                "mesh coverage",
                "covered pixels",
                "mesh pixels"
            ],
            &pixel_table
        ),
        if agreement.is_empty() {
            ""
        } else {
            ", [agreement.csv](agreement.csv)"
        },
    );
    let summary = if dir.join("peers.csv").exists() {
        summary.replace(
            "[pixels.csv](pixels.csv)",
            "[pixels.csv](pixels.csv), [peers.csv](peers.csv)",
        )
    } else {
        summary
    };
    write_atomic(&dir.join("summary.md"), summary.as_bytes())
}
