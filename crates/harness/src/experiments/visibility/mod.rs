//! Experiment `visibility`: every registered visibility method over its sweep, against the
//! reference.
//!
//! A generic loop: for each dataset, every visibility method of the registry that has a sweep
//! (`registry::sweep`: the built-in grids in `registry/src/sweeps.toml`, an external method's
//! own in its `method.toml`, a user's `--config` file over both) is prepared once per setting
//! and run on every view; the harness scores each answer against the reference (the mesh's
//! z-buffer). Adding a method to this experiment is a registry entry and a grid; nothing here
//! names a method (a peer names its partner in its `method.toml`: `peer_of`).
//!
//! `results.csv`: one row per (dataset, view, method, setting), in that order, with precision,
//! recall and F1 against `reference`; `family` groups rows in plots (HPR's two kernels are two
//! families); `detail` is what a rule chose (HPR's `gamma=auto`: `gamma_value`); `seconds` is
//! the median of `--repeats` runs, fewer for a call slower than `--time-budget`
//! (`registry::timing`; an external method's own reported seconds), `seconds_min`/`seconds_max`
//! their spread, `samples` how many; `status` is `ok` or `error: ...` (a
//! failing view is a row and the run goes on); `made_for` is the score the method was made
//! for (`registry::Card::made_for`: `points` or `pixels`), the one the findings judge it by;
//! `mesh_fit` is `off-surface` on a user's dataset whose mesh does not fit its points, scored
//! anyway (`--allow-off-surface`, `datasets::fit`), `ok` otherwise, empty without a mesh.
//! `pixels.csv`: for every method on a dataset with a mesh, one row per (view, setting): the
//! share of covered pixels whose point is truly visible (`pixel_precision`), the share of the
//! mesh's pixels (the mesh rasterised at the same camera) that got a point (`mesh_coverage`)
//! and their harmonic mean (`pixel_f1`, the per-pixel score methods are ranked by), from the
//! method's own per-pixel choice (`source = method`: ray cast, splat, the screen-space
//! operators, at their setting's resolution) or, for a method that returns a visible set only,
//! from that set drawn at the view's resolution by `registry::scoring::pixels::projected`
//! (`source = projected`: each visible point a sphere of the ray cast's automatic radius, 1.5
//! density spacings, each pixel the first sphere its ray enters; that module's doc says how
//! far the two are comparable).
//! `agreement.csv`: on clouds without a mesh, the Jaccard index of each pair of methods at
//! their default settings. `peers.csv`: each peer (a method whose `peer_of` names one of ours)
//! at each of its settings against the method it names at the matching setting ([`peers`]:
//! ours is run at that setting too when its sweep lacks it), per view: both seconds, both F1,
//! the Jaccard index of the two sets; a peer whose `peer_of` names no visibility method of ours
//! (PCL's voxel occlusion) has rows without a partner. `renders.png`: bunny-69451 (else the
//! first dataset), view 0, every family at its tuned setting beside the reference.
//!
//! The full sweep runs on every dataset, tuning and evaluation alike (`datasets::Role`, written
//! into the metadata as `dataset_roles`); the tables report each family at its setting tuned
//! on the tuning datasets' rows alone, the oracle beside it ([`tuning`]).
//!
//! Sharded runs (`--shard K/N`) split the (dataset, view) cells round-robin; every method and
//! setting of one view stays in one shard, because agreement and peers pair methods per view.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use registry::{Setting, kernel};
use serde::{Deserialize, Serialize};
use truth::{NO_TRIANGLE, Reference, ReferenceParams};

use super::{Context, Experiment};

mod auto_rules;
mod builds;
mod papers;
mod peers;
mod pixel_table;
mod render;
mod tuned_table;
pub(crate) mod tuning;
use crate::output::{read_csv, write_csv};
use crate::progress;
pub use builds::BuildRow;
use registry::scoring::{PixelScore, Score, pixels};
use render::{peers_summary, render, render_bunny};

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
    /// How its rows group in plots and tables (`registry::Card::family`).
    pub family: String,
    /// Setting, `k=v` pairs sorted by key and joined by `;` (`registry::Setting::label`).
    pub params: String,
    /// What a rule chose for this view (`gamma_value=2.871` for `gamma=auto`), `k=v` pairs.
    pub detail: String,
    /// Median seconds of the method alone (`--repeats` runs, fewer past `--time-budget`).
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
    /// The score the method was made for (`registry::Card::made_for`): `points` (F1 here)
    /// or `pixels` (pixels.csv's per-pixel F1); the findings judge it by that one.
    #[serde(default = "points")]
    pub made_for: String,
    /// SHA-256 of the visible set ([`set_digest`]): two methods with the same have the
    /// same answer (the findings name such a runner-up identical); empty for a failed view.
    #[serde(default)]
    pub visible_sha256: String,
    /// `ok` when the dataset's mesh fits its points, `off-surface` when a user's mesh that does
    /// not fit was used anyway (`--allow-off-surface`: `datasets::fit`), empty without a mesh.
    #[serde(default)]
    pub mesh_fit: String,
    /// Median wall seconds around each run, as the harness timed it: `seconds` for our
    /// methods; for an external program its own seconds are `seconds`, and this adds the
    /// protocol (the request, the answer's transfer and checks) and, on the first view after
    /// the program started, its start (its cold call, also in `builds.csv`).
    #[serde(default = "nan")]
    pub wall_seconds: f64,
}

/// SHA-256 of the visible set, its indices sorted, as little-endian `u32`s.
fn set_digest(visible: &[u32]) -> String {
    let mut sorted = visible.to_vec();
    sorted.sort_unstable();
    let bytes: Vec<u8> = sorted.iter().flat_map(|i| i.to_le_bytes()).collect();
    crate::fetch::sha256_hex(&bytes)
}

fn ok_status() -> String {
    "ok".into()
}

fn points() -> String {
    "points".into()
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
    /// The harmonic mean of pixel_precision and mesh_coverage: the per-pixel score methods
    /// are ranked by (`registry::scoring::pixels::f1`).
    #[serde(default = "nan")]
    pub pixel_f1: f64,
    /// Where the pixels come from: `method` (its own per-pixel choice) or `projected` (its
    /// visible set through `registry::scoring::pixels::projected`).
    #[serde(default = "method_source")]
    pub source: String,
    /// The score the method was made for, as in results.csv.
    #[serde(default = "pixels")]
    pub made_for: String,
    /// As in results.csv.
    #[serde(default)]
    pub mesh_fit: String,
}

fn method_source() -> String {
    "method".into()
}

fn pixels() -> String {
    "pixels".into()
}

/// One row of `peers.csv`: a peer at one setting against the method of ours its `peer_of`
/// names at the matching setting, same view.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerRow {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// The peer method.
    pub peer: String,
    /// Its setting (label).
    pub peer_params: String,
    /// What its `peer_of` names.
    pub peer_of: String,
    /// The method of ours it is paired with (empty: `peer_of` names no visibility method).
    pub partner: String,
    /// The partner's setting (label).
    pub partner_params: String,
    /// The peer's seconds (its own compute time, median).
    pub peer_seconds: f64,
    /// The partner's median seconds.
    pub partner_seconds: f64,
    /// The peer's F1 (NaN without a ground truth).
    pub peer_f1: f64,
    /// The partner's F1.
    pub partner_f1: f64,
    /// Jaccard index of the two visible sets (NaN without a partner).
    pub jaccard: f64,
    /// The peer's own build seconds for this cloud and setting (its `built` line; NaN when it
    /// reported none).
    #[serde(default = "nan")]
    pub peer_build_seconds: f64,
    /// The partner's structure build, seconds (the ray caster's point hierarchy; else its whole
    /// preparation).
    #[serde(default = "nan")]
    pub partner_build_seconds: f64,
    /// Whether the peer's card claims exactness (`registry::Card::exact`): its sets must then
    /// equal our partner's (the findings' wrong answers otherwise).
    #[serde(default)]
    pub claims_exact: bool,
}

impl PeerRow {
    /// The row as the ratios read it (`rules::ratio`).
    pub fn pair(&self) -> crate::experiments::rules::ratio::PeerPair {
        crate::experiments::rules::ratio::PeerPair {
            dataset: self.dataset.clone(),
            view: self.view,
            peer: self.peer.clone(),
            peer_params: self.peer_params.clone(),
            partner: self.partner.clone(),
            partner_params: self.partner_params.clone(),
            peer_seconds: self.peer_seconds,
            partner_seconds: self.partner_seconds,
            jaccard: self.jaccard,
            claims_exact: self.claims_exact,
        }
    }
}

fn nan() -> f64 {
    f64::NAN
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

/// Views measured per dataset, its first ones (a dataset with fewer, a user's `--eye`, gives
/// those it has): [`crate::stats::MIN_VIEWS`], the fewest an interval is stated from, in a
/// full run (nine datasets, the full sweep each, within the benchmark's hour; the evaluation
/// datasets pooled give 20 views), 2 in a quick run.
fn views_of(quick: bool) -> usize {
    match quick {
        true => 2,
        false => crate::stats::MIN_VIEWS,
    }
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
            // The tuning datasets, then the evaluation ones (`datasets::Role`: settings are
            // tuned on the first five alone, [`tuning`]).
            &[
                "bunny",
                "bunny-69451",
                "dragon-871414",
                "torus-22321",
                "sphere-plane-24000",
                "elephant-50000",
                "camel-50000",
                "triceratops-50000",
                "mannequin-50000",
            ]
        }
    }

    fn shardable(&self) -> bool {
        true
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let (mut methods, mut not_run) = ctx.methods_to_run();
        // Each peer's settings with its partner's; ours run at those the sweep lacks.
        let pairing = pair_peers(&ctx.run.catalogue, &mut methods, &ctx.sweeps, ctx.quick);
        let partner_runs: std::collections::BTreeSet<(String, String)> =
            pairing.values().flatten().cloned().collect();
        // The setting that stands for each method (agreement on clouds without a mesh).
        let defaults: BTreeMap<String, String> = methods
            .iter()
            .filter_map(|(m, s)| Some((m.name.to_owned(), s.default_setting()?.label())))
            .collect();
        let render_ds = render_dataset(&ctx.datasets);
        // Tuning or evaluation ([`tuning`]): a user's own files are neither.
        let roles: BTreeMap<String, crate::datasets::Role> = ctx
            .datasets
            .iter()
            .map(|d| match ctx.on_user_files() {
                true => (d.clone(), crate::datasets::Role::Own),
                false => (d.clone(), crate::datasets::role(d)),
            })
            .collect();
        // renders.png is drawn once every dataset's rows are in (the tuned settings need them).
        let mut to_render = None;
        let mut rows = Vec::new();
        let mut pixel_rows = Vec::new();
        let mut agreement = Vec::new();
        let mut peers = Vec::new();
        let mut builds = Vec::new();
        let mut off_surface_meta = serde_json::Map::new();
        let mut views_meta = serde_json::Map::new();
        for (d_idx, name) in ctx.datasets.iter().enumerate() {
            let n_views = views_of(ctx.quick);
            views_meta.insert(name.clone(), n_views.into());
            let owned: Vec<usize> = (0..n_views)
                .filter(|&v| ctx.owns(d_idx, v, n_views))
                .collect();
            if owned.is_empty() {
                continue;
            }
            let ds = ctx.dataset(name)?;
            let views: Vec<usize> = owned.into_iter().filter(|&v| v < ds.views.len()).collect();
            let kviews: Vec<kernel::View> = views
                .iter()
                .map(|&index| kernel::View {
                    index,
                    camera: ds.views[index],
                })
                .collect();
            let points = &ds.cloud.positions;
            // No mesh, no ground truth: rows keep speed and counts, F1 is NaN, and the methods'
            // agreement is recorded instead.
            let reference = ds.mesh.as_ref().map(Reference::new).transpose()?;
            let off = ds.off_surface()?;
            if let Some((flags, tolerance)) = &off {
                let mut entry = serde_json::json!({
                    "tolerance": tolerance,
                    "off_surface_points": flags.iter().filter(|&&f| f).count(),
                });
                if let Some(fit) = &ds.mesh_fit {
                    entry["mesh_fit"] = serde_json::json!({
                        "fits": fit.fits(),
                        "far_share": fit.far_share,
                        "far_limit": fit.limit,
                        "median_distance": fit.median_distance,
                        "likely_cause": fit.cause,
                    });
                }
                off_surface_meta.insert(name.clone(), entry);
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
            let mut ds_builds: Vec<BuildRow> = Vec::new();
            let mut footprint: Option<f64> = None;
            let cells: usize = methods
                .iter()
                .map(|(_, s)| s.settings(ctx.quick).len())
                .sum::<usize>()
                * views.len();
            let bar = progress::bar(cells as u64, format!("visibility {name}"));
            for (m, sweep) in &methods {
                progress::at(name, m.name);
                for setting in sweep.settings(ctx.quick) {
                    let label = setting.label();
                    let family = m.family(setting);
                    // One cell per setting (one preparation, every view through the kernel); a
                    // failure is a row per view.
                    let cell = kernel::Cell {
                        budget: ctx.time_budget,
                        ..kernel::Cell::new(m, setting, &kviews, ctx.repeats)
                    };
                    let (prepared, answers) = kernel::collect(&cell, ds.input());
                    if let Ok(p) = prepared {
                        ds_builds.push(BuildRow {
                            dataset: name.clone(),
                            method: m.name.to_owned(),
                            params: label.clone(),
                            views: kviews.len(),
                            prepare_seconds: p.seconds,
                            build_seconds: p.reported_seconds.unwrap_or(f64::NAN),
                            cold_call_seconds: p.cold_call_seconds.unwrap_or(f64::NAN),
                        });
                    }
                    for (v, outcome) in answers {
                        let (view, cam) = (v.index, v.camera);
                        let truth = truths.get(&view).and_then(Option::as_deref);
                        let mut row = Row {
                            dataset: name.clone(),
                            n_points: points.len(),
                            view,
                            method: m.name.to_owned(),
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
                            made_for: m.made_for.as_str().to_owned(),
                            visible_sha256: String::new(),
                            mesh_fit: ds.mesh_fit_mark().to_owned(),
                            wall_seconds: f64::NAN,
                        };
                        match outcome {
                            Ok(kernel::Answer {
                                output: mut out,
                                timing: t,
                                wall,
                            }) => {
                                if let Some(t) = truth {
                                    let s = Score::of_on_surface(&out.visible, t, off_flags);
                                    (row.precision, row.recall, row.f1) =
                                        (s.precision(), s.recall(), s.f1());
                                }
                                row.off_surface_visible = off_flags.map_or(0, |f| {
                                    out.visible.iter().filter(|&&i| f[i as usize]).count()
                                });
                                row.n_visible = out.visible.len();
                                row.visible_sha256 = set_digest(&out.visible);
                                row.rays = out.rays;
                                (row.seconds, row.seconds_min, row.seconds_max, row.samples) =
                                    (t.median, t.min, t.max, t.samples);
                                row.wall_seconds = wall.median;
                                row.detail = out
                                    .detail
                                    .iter()
                                    .map(|(k, v)| format!("{k}={v}"))
                                    .collect::<Vec<_>>()
                                    .join(";");
                                if let (Some(truth), Some(mesh)) = (truth, &ds.mesh)
                                    && cam.has_frustum()
                                {
                                    // The method's own pixels, else its visible set's at the
                                    // view's resolution (one footprint radius per dataset).
                                    let (px, source) = match out.pixels.take() {
                                        Some(px) => (px, "method"),
                                        None => {
                                            let r = match footprint {
                                                Some(r) => r,
                                                None => *footprint
                                                    .insert(pixels::footprint_radius(points)?),
                                            };
                                            (
                                                pixels::projected(points, &out.visible, &cam, r)?,
                                                "projected",
                                            )
                                        }
                                    };
                                    let c = cam.with_resolution(px.width, px.height)?;
                                    let mask = match mesh_masks.entry((view, c.width, c.height)) {
                                        std::collections::btree_map::Entry::Occupied(e) => {
                                            e.into_mut()
                                        }
                                        std::collections::btree_map::Entry::Vacant(e) => e.insert(
                                            truth::rasterize(mesh, &c)?
                                                .triangle
                                                .iter()
                                                .map(|&t| t != NO_TRIANGLE)
                                                .collect(),
                                        ),
                                    };
                                    ds_pixels.push(pixel_row(&row, &px, source, truth, mask)?);
                                }
                                let keep = (truth.is_none()
                                    && defaults.get(m.name) == Some(&label))
                                    || m.peer_of.is_some()
                                    || partner_runs.contains(&(m.name.to_owned(), label.clone()))
                                    || (Some(name.as_str()) == render_ds && view == 0);
                                if keep {
                                    kept.entry(view).or_default().push(Run {
                                        method: m.name.to_owned(),
                                        family: family.clone(),
                                        params: label.clone(),
                                        visible: out.visible,
                                    });
                                }
                            }
                            Err(e) => {
                                eprintln!("visibility: {} {label} view {view}: {e}", m.name);
                                row.status = format!("error: {e}");
                            }
                        }
                        ds_rows.push(row);
                        bar.inc(1);
                    }
                }
                // Its warm program (protocol 3) ends with its settings: it holds no memory or
                // core while the next methods are timed.
                ctx.run.catalogue.end_programs();
            }
            bar.finish_and_clear();
            // Rows in (view, method, setting) order, whatever the loop order was.
            ds_rows.sort_by_key(|r| r.view);
            ds_pixels.sort_by_key(|r| r.view);
            for (&view, runs) in &kept {
                if truths.get(&view).is_some_and(Option::is_none) {
                    agreement.extend(agreement_rows(name, view, runs, &defaults));
                }
                peers.extend(peer_rows(
                    &ctx.run.catalogue,
                    name,
                    view,
                    runs,
                    &ds_rows,
                    &ds_builds,
                    &pairing,
                ));
            }
            if let (Some(reference), Some(runs)) = (
                reference.filter(|_| Some(name.as_str()) == render_ds),
                kept.remove(&0).filter(|_| Some(name.as_str()) == render_ds),
            ) {
                to_render = Some((ds, reference, runs));
            }
            rows.extend(ds_rows);
            pixel_rows.extend(ds_pixels);
            builds.extend(ds_builds);
        }
        if let Some((ds, reference, runs)) = to_render {
            let protocol = tuning::Protocol::new(tuning::observations(&rows), roles.clone());
            render_bunny(&ctx.out_dir, &ds, &reference, &rows, runs, &protocol)?;
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        write_csv(&ctx.out_dir.join("pixels.csv"), &pixel_rows)?;
        write_csv(&ctx.out_dir.join("agreement.csv"), &agreement)?;
        write_csv(&ctx.out_dir.join("peers.csv"), &peers)?;
        write_csv(&ctx.out_dir.join("builds.csv"), &builds)?;
        not_run.sort();
        not_run.dedup();
        let sweeps: serde_json::Map<String, serde_json::Value> = methods
            .iter()
            .map(|(m, s)| {
                (
                    m.name.to_owned(),
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
            "views": views_meta,
            "sweeps": sweeps,
            "default_settings": defaults,
            "hpr_hull": "own",
            "hpr_auto_rule": format!("gamma = log10(kappa * D * d^2 / (s^2 * m)), kappa = {}", hpr::auto::KAPPA),
            "raycast_auto_rule": format!("radius = {} x density spacing (k = 8)", raycast::auto::RADIUS_FACTOR),
            "repeats": ctx.repeats,
            "time_budget_s": ctx.time_budget,
            "timing": format!("median of {} runs, fewer once a call's runs took {} s (samples: how many; seconds_min, seconds_max: their spread); external methods: their own reported seconds", ctx.repeats, ctx.time_budget.map_or("unbounded".to_string(), |b| b.to_string())),
            "off_surface": off_surface_meta,
            "external_methods_not_run": not_run,
            "render_dataset": render_ds,
            "dataset_roles": roles,
        }))
    }

    fn render(&self, catalogue: &registry::Catalogue, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let pixels: Vec<PixelRow> = read_csv(&dir.join("pixels.csv"))?;
        let agreement: Vec<AgreementRow> = read_csv(&dir.join("agreement.csv"))?;
        // A peers.csv of the Open3D-only layout (before protocol 2's pairing) cannot be read
        // as pairs: the report says so instead of failing every other table.
        let (peers, old_peers): (Vec<PeerRow>, Option<String>) = match read_csv(
            &dir.join("peers.csv"),
        ) {
            Ok(p) => (p, None),
            Err(e) => {
                let header = std::fs::read_to_string(dir.join("peers.csv"))
                    .ok()
                    .and_then(|t| t.lines().next().map(str::to_owned))
                    .unwrap_or_default();
                if header.starts_with("dataset,view,peer,gamma,") {
                    (
                        Vec::new(),
                        Some(format!(
                            "peers.csv has the layout of an older revision (`{header}`), not \
                             the pairs this report draws: run `pointsight run visibility` again.\n\n"
                        )),
                    )
                } else {
                    return Err(e);
                }
            }
        };
        let meta = crate::output::meta::RunMeta::read(dir)?;
        let not_run: Vec<String> =
            serde_json::from_value(meta.parameters["external_methods_not_run"].clone())
                .unwrap_or_default();
        let defaults: BTreeMap<String, String> =
            serde_json::from_value(meta.parameters["default_settings"].clone()).unwrap_or_default();
        let peers_md = format!(
            "{}{}",
            old_peers.unwrap_or_default(),
            peers_summary(&peers, &not_run)
        );
        let render_ds = meta.parameters["render_dataset"].as_str();
        render(
            catalogue, dir, &rows, &pixels, &agreement, &peers_md, &defaults, render_ds,
        )
    }
}

/// The image-space figures of one run: which covered pixels show a truly visible point, and
/// how much of the mesh's footprint got a point (`source`: whose pixels, see [`PixelRow`]).
fn pixel_row(
    row: &Row,
    px: &registry::PixelChoice,
    source: &str,
    truth: &[bool],
    mesh: &[bool],
) -> Result<PixelRow> {
    let s = PixelScore::of(px, truth, mesh)?;
    Ok(PixelRow {
        dataset: row.dataset.clone(),
        view: row.view,
        method: row.method.clone(),
        family: row.family.clone(),
        params: row.params.clone(),
        width: px.width,
        height: px.height,
        covered_pixels: s.covered,
        true_pixels: s.true_pixels,
        mesh_pixels: s.mesh_pixels,
        mesh_pixels_covered: s.mesh_covered,
        pixel_precision: s.precision(),
        mesh_coverage: s.coverage(),
        pixel_f1: s.f1(),
        source: source.to_owned(),
        made_for: row.made_for.clone(),
        mesh_fit: row.mesh_fit.clone(),
    })
}

/// Each peer's settings (by label) with the partner and setting they are paired with (`None`:
/// its `peer_of` names no visibility method of ours); the partners' settings their sweeps lack
/// are added to them (a partner without a sweep joins with those alone).
fn pair_peers(
    catalogue: &registry::Catalogue,
    methods: &mut Vec<(&'static registry::Card, registry::MethodSweep)>,
    sweeps: &registry::Sweeps,
    quick: bool,
) -> BTreeMap<(String, String), Option<(String, String)>> {
    let mut pairing = BTreeMap::new();
    let peers: Vec<(&'static registry::Card, Vec<Setting>)> = methods
        .iter()
        .filter(|(m, _)| m.peer_of.is_some())
        .map(|(m, s)| (*m, s.settings(quick).to_vec()))
        .collect();
    for (peer, settings) in peers {
        let partner = peer
            .peer_of
            .and_then(|p| catalogue.card_named(p))
            .filter(|p| !p.is_lod())
            .filter(|p| p.peer_of.is_none() && p.availability().is_ok());
        for setting in settings {
            let key = (peer.name.to_owned(), setting.label());
            let Some(partner) = partner else {
                pairing.insert(key, None);
                continue;
            };
            let at = methods.iter().position(|(m, _)| m.name == partner.name);
            let sweep = at
                .map(|k| methods[k].1.clone())
                .or_else(|| sweeps.methods.get(partner.name).cloned());
            let ours = peers::partner_setting(peer, &setting, partner, sweep.as_ref());
            let label = ours.label();
            match at {
                Some(k) => {
                    let s = &mut methods[k].1;
                    if !s.settings(quick).iter().any(|x| x.label() == label) {
                        if quick && !s.quick_grid.is_empty() {
                            s.quick_grid.push(ours);
                        } else {
                            s.grid.push(ours);
                        }
                    }
                }
                None => methods.push((
                    partner,
                    registry::MethodSweep {
                        grid: vec![ours],
                        ..Default::default()
                    },
                )),
            }
            pairing.insert(key, Some((partner.name.to_owned(), label)));
        }
    }
    pairing
}

/// Each peer's run against its partner's at the paired setting, same view (a peer without a
/// partner: its own figures alone).
fn peer_rows(
    catalogue: &registry::Catalogue,
    dataset: &str,
    view: usize,
    runs: &[Run],
    rows: &[Row],
    builds: &[BuildRow],
    pairing: &BTreeMap<(String, String), Option<(String, String)>>,
) -> Vec<PeerRow> {
    let mut out = Vec::new();
    let row = |method: &str, params: &str| {
        rows.iter()
            .find(|x| x.view == view && x.method == method && x.params == params)
    };
    let build = |method: &str, params: &str, external: bool| {
        builds
            .iter()
            .find(|b| b.method == method && b.params == params)
            .map_or(f64::NAN, |b| b.structure_seconds(external))
    };
    for peer in runs {
        let Some(paired) = pairing.get(&(peer.method.clone(), peer.params.clone())) else {
            continue;
        };
        let peer_of = catalogue
            .card(&peer.method)
            .ok()
            .and_then(|m| m.peer_of)
            .unwrap_or_default();
        let ours = paired
            .as_ref()
            .and_then(|(m, p)| runs.iter().find(|r| r.method == *m && r.params == *p));
        if paired.is_some() && ours.is_none() {
            // The partner failed on this view: its row says why.
            continue;
        }
        let mine = row(&peer.method, &peer.params);
        let theirs = ours.and_then(|o| row(&o.method, &o.params));
        out.push(PeerRow {
            dataset: dataset.to_owned(),
            view,
            peer: peer.method.clone(),
            peer_params: peer.params.clone(),
            peer_of: peer_of.to_owned(),
            partner: ours.map_or(String::new(), |o| o.method.clone()),
            partner_params: ours.map_or(String::new(), |o| o.params.clone()),
            peer_seconds: mine.map_or(f64::NAN, |r| r.seconds),
            partner_seconds: theirs.map_or(f64::NAN, |r| r.seconds),
            peer_f1: mine.map_or(f64::NAN, |r| r.f1),
            partner_f1: theirs.map_or(f64::NAN, |r| r.f1),
            jaccard: ours.map_or(f64::NAN, |o| {
                Score::of_sets(&peer.visible, &o.visible).jaccard()
            }),
            peer_build_seconds: build(&peer.method, &peer.params, true),
            partner_build_seconds: ours.map_or(f64::NAN, |o| build(&o.method, &o.params, false)),
            claims_exact: catalogue.card(&peer.method).is_ok_and(|m| m.exact),
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
