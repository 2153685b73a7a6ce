//! Experiment `visibility`: every visibility method and setting against the reference.
//!
//! Sweeps, on each dataset and view:
//! - `hpr`, linear kernel: γ ∈ [`GAMMAS`] without perturbation, and γ ∈ [`PERTURBED_GAMMAS`]
//!   with a perturbation of k = [`PERTURB`];
//! - `hpr`, exponential kernel: γ ∈ [`EXP_GAMMAS`];
//! - `raycast` (exact traversal): radius ∈ [`RADIUS_FACTORS`] density spacings × resolution ∈
//!   [`RESOLUTIONS`];
//! - `splat`: radius ∈ [`SPLAT_RADII`] pixels × depth tolerance ∈ {0.01, 0.03};
//! - the automatic rules: `hpr` with γ from `hpr::auto` and `raycast` with the radius of
//!   `raycast::auto`, from the cloud alone.
//!
//! `results.csv`: one row per (dataset, view, method, setting) with precision, recall and F1
//! against `reference`; `seconds` is the median of [`super::REPEATS`] runs (`registry::timing`),
//! `seconds_min`/`seconds_max` their spread. `pixels.csv`: for the per-pixel methods (ray cast, splat), the share of
//! covered pixels whose point is truly visible and the share of the mesh's pixels (the mesh
//! rasterised at the method's resolution) that got a point. Renders of bunny-69451, view 0,
//! every family at its best setting beside the reference: `renders.png`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use cloud::Camera;
use hpr::{HprParams, Kernel, Radius};
use raycast::{CastParams, RayCaster, RayList, Traversal};
use serde::{Deserialize, Serialize};
use splat::{SplatParams, SplatScratch, Splatter};
use truth::{NO_TRIANGLE, Reference, ReferenceParams};

use super::{Context, Experiment, markdown_table, timed};
use crate::datasets;
use crate::output::plot::{Chart, Mark, Series};
use crate::output::render::{classified_panel, compose, footprint};
use crate::output::{read_csv, write_atomic, write_csv};
use crate::progress;
use crate::score::Score;

/// Katz's γ (linear kernel).
pub const GAMMAS: &[f64] = &[1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5];
/// Exponents of the exponential kernel.
pub const EXP_GAMMAS: &[f64] = &[-1e-5, -3e-5, -1e-4, -3e-4, -1e-3, -3e-3, -1e-2];
/// Perturbation used for the "with perturbation" HPR rows.
pub const PERTURB: f64 = 1e-5;
/// The γ values also run with the perturbation.
pub const PERTURBED_GAMMAS: &[f64] = &[2.0, 3.0, 4.0];
/// Ray-cast radii, in density spacings (1/sqrt(points per unit area)).
pub const RADIUS_FACTORS: &[f64] = &[0.5, 0.75, 1.0, 1.5, 2.0, 3.0];
/// Ray-cast resolutions (one ray per pixel), same field of view.
pub const RESOLUTIONS: &[(u32, u32)] = &[(640, 360), (1280, 720), (1920, 1080)];
/// Splat radii in pixels.
pub const SPLAT_RADII: &[f64] = &[0.5, 1.0, 1.5, 2.0, 3.0, 4.0];
/// Splat depth tolerances.
pub const SPLAT_TOLERANCES: &[f64] = &[0.01, 0.03];

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
    /// Setting, `k=v` pairs joined by `;`.
    pub params: String,
    /// Median seconds of the method alone (`REPEATS` runs).
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

/// The family a row belongs to, for plots and tables (an external method is its own family).
pub fn family<'a>(method: &'a str, params: &str) -> &'a str {
    match method {
        "hpr" if params.contains("kernel=exp") => "hpr-exp",
        "hpr" => "hpr-linear",
        other => other,
    }
}

/// The built-in families, in plotting order; external methods follow in the order they
/// appear.
const FAMILIES: &[&str] = &["hpr-linear", "hpr-exp", "raycast", "splat"];

/// Every family of `rows`: the built-in ones, then the others.
fn families_of(rows: &[Row]) -> Vec<String> {
    let mut out: Vec<String> = FAMILIES.iter().map(|f| (*f).to_owned()).collect();
    for r in rows {
        let f = family(&r.method, &r.params);
        if !out.iter().any(|o| o == f) {
            out.push(f.to_owned());
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
    params.contains("=auto")
}

/// Runs `f` once, and twice more if it took under a tenth of a second; returns the median time.
struct Run {
    method: &'static str,
    params: String,
    visible: Vec<u32>,
    timing: registry::timing::Timing,
    rays: u64,
    pixels: Option<(Camera, Vec<u32>)>,
}

impl Experiment for VisibilityExperiment {
    fn name(&self) -> &'static str {
        "visibility"
    }

    fn summary(&self) -> &'static str {
        "HPR (two kernels, with and without perturbation), ray casting and splatting against the reference"
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

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let n_views = if ctx.quick { 2 } else { 8 };
        let mut rows = Vec::new();
        let mut pixel_rows = Vec::new();
        let mut agreement = Vec::new();
        let mut peers = Vec::new();
        let mut not_run: Vec<String> = Vec::new();
        let mut off_surface_meta = serde_json::Map::new();
        for name in &ctx.datasets {
            let ds = ctx.dataset(name)?;
            let n_views = n_views.min(ds.views.len());
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
            let scale = hpr::auto::CloudScale::of(points)?;
            let caster = RayCaster::new(points)?;
            let splatter = Splatter::new(points)?;
            let mut splat_scratch = SplatScratch::default();
            let own = hull::by_name("own")?;
            let mut ray_lists: BTreeMap<(u32, u32), RayList> = BTreeMap::new();
            let bar = progress::bar(n_views as u64, format!("visibility {name}"));
            let mut kept_for_render: Vec<(usize, Run)> = Vec::new();
            // For the peers: each view's truth, and our exact HPR's sets and times by γ.
            let mut truths: Vec<Option<Vec<bool>>> = Vec::new();
            let mut ours: BTreeMap<(usize, String), (Vec<u32>, f64)> = BTreeMap::new();
            for view in 0..n_views {
                let cam = *ds.view(view)?;
                let truth = match &reference {
                    Some(r) => Some(
                        r.visibility(ds.truth_points(), &cam, &ReferenceParams::default())?
                            .visible,
                    ),
                    None => None,
                };
                truths.push(truth.clone());
                let mut runs: Vec<Run> = Vec::new();
                let max_distance = points
                    .iter()
                    .map(|p| (*p - cam.eye).length())
                    .fold(0.0, f64::max);

                let hpr_run = |kernel: Kernel, perturb: f64, label: String| -> Result<Run> {
                    let params = HprParams {
                        kernel,
                        perturb,
                        seed: 2007,
                    };
                    let (v, timing) =
                        timed(|| Ok(hpr::visible(points, cam.eye, &params, own.as_ref())?))?;
                    Ok(Run {
                        method: "hpr",
                        params: label,
                        visible: v.visible,
                        timing,
                        rays: 0,
                        pixels: None,
                    })
                };
                for &g in GAMMAS {
                    let perturbs: &[f64] = if PERTURBED_GAMMAS.contains(&g) {
                        &[0.0, PERTURB]
                    } else {
                        &[0.0]
                    };
                    for &perturb in perturbs {
                        runs.push(hpr_run(
                            Kernel::Linear(Radius::Gamma(g)),
                            perturb,
                            format!("kernel=linear;gamma={g};perturb={perturb}"),
                        )?);
                    }
                }
                for &g in EXP_GAMMAS {
                    runs.push(hpr_run(
                        Kernel::Exponential(g),
                        0.0,
                        format!("kernel=exp;gamma={g};perturb=0"),
                    )?);
                }
                let g_auto = hpr::auto::auto_gamma(&scale, cam.eye, max_distance);
                runs.push(hpr_run(
                    Kernel::Linear(Radius::Gamma(g_auto)),
                    0.0,
                    format!("kernel=linear;gamma=auto;gamma_value={g_auto:.3};perturb=0"),
                )?);

                let cast_factors = RADIUS_FACTORS
                    .iter()
                    .map(|&f| (f, false))
                    .chain([(raycast::auto::RADIUS_FACTOR, true)]);
                for (factor, auto) in cast_factors {
                    for &(w, h) in RESOLUTIONS {
                        let c = cam.with_resolution(w, h)?;
                        let rays = match ray_lists.entry((w, h)) {
                            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
                            std::collections::btree_map::Entry::Vacant(e) => {
                                e.insert(RayList::new(&c)?)
                            }
                        };
                        // `scale.spacing` is the density spacing, the unit of both rules.
                        let params = CastParams {
                            radius: factor * scale.spacing,
                            traversal: Traversal::Exact,
                        };
                        let (frame, timing) = timed(|| Ok(caster.cast(rays, &c, &params)?))?;
                        let label = if auto {
                            format!("radius=auto;radius_factor_value={factor};width={w};height={h}")
                        } else {
                            format!("radius_factor={factor};width={w};height={h}")
                        };
                        runs.push(Run {
                            method: "raycast",
                            params: label,
                            visible: frame.visible,
                            timing,
                            rays: frame.rays,
                            pixels: Some((c, frame.pixel_point)),
                        });
                    }
                }
                for &radius_px in SPLAT_RADII {
                    for &depth_tolerance in SPLAT_TOLERANCES {
                        let params = SplatParams {
                            radius_px,
                            depth_tolerance,
                        };
                        let (out, timing) = timed(|| {
                            Ok(splatter.visibility(&cam, &params, &mut splat_scratch, true)?)
                        })?;
                        runs.push(Run {
                            method: "splat",
                            params: format!(
                                "radius_px={radius_px};depth_tolerance={depth_tolerance}"
                            ),
                            visible: out.visible,
                            timing,
                            rays: 0,
                            pixels: Some((cam, out.pixel_point)),
                        });
                    }
                }

                // Score; image-space figures for the per-pixel methods.
                let mut mesh_pixels: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
                if truth.is_none() {
                    agreement.extend(agreement_rows(name, view, &runs));
                }
                for run in &runs {
                    if let Some(g) = run
                        .params
                        .strip_prefix("kernel=linear;gamma=")
                        .and_then(|rest| rest.strip_suffix(";perturb=0"))
                    {
                        ours.insert(
                            (view, g.to_owned()),
                            (run.visible.clone(), run.timing.median),
                        );
                    }
                }
                let off_flags = off.as_ref().map(|(f, _)| &f[..]);
                for run in runs {
                    let s = truth
                        .as_ref()
                        .map(|t| Score::of_on_surface(&run.visible, t, off_flags));
                    let off_surface_visible = off_flags.map_or(0, |f| {
                        run.visible.iter().filter(|&&i| f[i as usize]).count()
                    });
                    rows.push(Row {
                        dataset: name.clone(),
                        n_points: points.len(),
                        view,
                        method: run.method.into(),
                        params: run.params.clone(),
                        seconds: run.timing.median,
                        seconds_min: run.timing.min,
                        seconds_max: run.timing.max,
                        samples: run.timing.samples,
                        status: ok_status(),
                        rays: run.rays,
                        n_visible: run.visible.len(),
                        precision: s.map_or(f64::NAN, |s| s.precision()),
                        recall: s.map_or(f64::NAN, |s| s.recall()),
                        f1: s.map_or(f64::NAN, |s| s.f1()),
                        off_surface_visible,
                    });
                    if let (Some((c, pixel_point)), Some(truth), Some(mesh)) = (
                        run.pixels.as_ref().filter(|(c, _)| c.has_frustum()),
                        &truth,
                        &ds.mesh,
                    ) {
                        let mesh = match mesh_pixels.entry((c.width, c.height)) {
                            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
                            std::collections::btree_map::Entry::Vacant(e) => {
                                e.insert(truth::rasterize(mesh, c)?.triangle)
                            }
                        };
                        let covered = pixel_point.iter().filter(|&&p| p != raycast::NONE).count();
                        let true_pixels = pixel_point
                            .iter()
                            .filter(|&&p| p != raycast::NONE && truth[p as usize])
                            .count();
                        let mesh_total = mesh.iter().filter(|&&t| t != NO_TRIANGLE).count();
                        let mesh_covered = mesh
                            .iter()
                            .zip(pixel_point)
                            .filter(|&(&t, &p)| t != NO_TRIANGLE && p != raycast::NONE)
                            .count();
                        pixel_rows.push(PixelRow {
                            dataset: name.clone(),
                            view,
                            method: run.method.into(),
                            params: run.params.clone(),
                            width: c.width,
                            height: c.height,
                            covered_pixels: covered,
                            true_pixels,
                            mesh_pixels: mesh_total,
                            mesh_pixels_covered: mesh_covered,
                            pixel_precision: true_pixels as f64 / covered.max(1) as f64,
                            mesh_coverage: mesh_covered as f64 / mesh_total.max(1) as f64,
                        });
                    }
                    if name == "bunny-69451" && view == 0 {
                        kept_for_render.push((view, run));
                    }
                }
                bar.inc(1);
            }
            bar.finish_and_clear();
            let off_flags = off.as_ref().map(|(f, _)| &f[..]);
            measure_externals(
                ctx,
                &ds,
                &truths,
                off_flags,
                &ours,
                &mut rows,
                &mut peers,
                &mut not_run,
            )?;
            if let Some(reference) = reference.as_ref().filter(|_| !kept_for_render.is_empty()) {
                render_bunny(&ctx.out_dir, &ds, reference, &rows, kept_for_render)?;
            }
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        write_csv(&ctx.out_dir.join("pixels.csv"), &pixel_rows)?;
        write_csv(&ctx.out_dir.join("agreement.csv"), &agreement)?;
        write_csv(&ctx.out_dir.join("peers.csv"), &peers)?;
        not_run.sort();
        not_run.dedup();
        Ok(serde_json::json!({
            "views": n_views,
            "hpr_linear_gammas": GAMMAS,
            "hpr_perturbation": PERTURB,
            "hpr_exp_gammas": EXP_GAMMAS,
            "hpr_hull": "own",
            "hpr_auto_rule": format!("gamma = log10(kappa * D * d^2 / (s^2 * m)), kappa = {}", hpr::auto::KAPPA),
            "raycast_radius_factors_density_spacings": RADIUS_FACTORS,
            "raycast_resolutions": RESOLUTIONS,
            "raycast_auto_rule": format!("radius = {} x density spacing (k = 8)", raycast::auto::RADIUS_FACTOR),
            "splat_radii_px": SPLAT_RADII,
            "splat_tolerances": SPLAT_TOLERANCES,
            "timing": format!("median of {} runs (seconds_min, seconds_max: their spread)", super::REPEATS),
            "off_surface": off_surface_meta,
            "external_methods_not_run": not_run,
        }))
    }

    fn render(&self, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let pixels: Vec<PixelRow> = read_csv(&dir.join("pixels.csv"))?;
        // Runs before agreement.csv existed have none.
        let agreement: Vec<AgreementRow> = if dir.join("agreement.csv").exists() {
            read_csv(&dir.join("agreement.csv"))?
        } else {
            Vec::new()
        };
        let peers: Vec<PeerRow> = if dir.join("peers.csv").exists() {
            read_csv(&dir.join("peers.csv"))?
        } else {
            Vec::new()
        };
        let not_run: Vec<String> = crate::output::meta::RunMeta::read(dir)
            .ok()
            .and_then(|m| {
                serde_json::from_value(m.parameters["external_methods_not_run"].clone()).ok()
            })
            .unwrap_or_default();
        let peers_md = peers_summary(&peers, &not_run);
        render(dir, &rows, &pixels, &agreement, &peers_md)
    }
}

/// Runs every available external method with a grid (methods/NAME/method.toml) on `ds`: one
/// preparation and process per setting, every view, scored like the built-in methods; a
/// failing view is a row with NaN scores and its error on stderr (the run goes on). Peers with
/// a `gamma` are paired with our exact HPR at the same γ (`peers.csv`). Methods that are not
/// installed are listed in `not_run`.
#[allow(clippy::too_many_arguments)]
fn measure_externals(
    ctx: &Context,
    ds: &datasets::Dataset,
    truths: &[Option<Vec<bool>>],
    off: Option<&[bool]>,
    ours: &BTreeMap<(usize, String), (Vec<u32>, f64)>,
    rows: &mut Vec<Row>,
    peers: &mut Vec<PeerRow>,
    not_run: &mut Vec<String>,
) -> Result<()> {
    let points = &ds.cloud.positions;
    for m in registry::all().into_iter().filter(|m| m.is_external()) {
        let grid = m.grid(ctx.quick);
        if grid.is_empty() {
            continue;
        }
        if let Err(why) = m.availability() {
            not_run.push(format!("{}: {why}", m.name()));
            continue;
        }
        for setting in grid {
            let params = registry::Params::from_pairs(
                &setting
                    .iter()
                    .map(|(k, v)| (k.as_str(), v.clone()))
                    .collect::<Vec<_>>(),
            );
            let label = params.canonical();
            let prepared = registry::prepare(m, ds.input(), &params)?;
            for (view, truth) in truths.iter().enumerate() {
                let cam = *ds.view(view)?;
                let row = |visible: &[u32], t: registry::timing::Timing| {
                    let s = truth
                        .as_ref()
                        .map(|t| Score::of_on_surface(visible, t, off));
                    Row {
                        dataset: ds.name().to_owned(),
                        n_points: points.len(),
                        view,
                        method: m.name().to_owned(),
                        params: label.clone(),
                        seconds: t.median,
                        rays: 0,
                        n_visible: visible.len(),
                        precision: s.map_or(f64::NAN, |s| s.precision()),
                        recall: s.map_or(f64::NAN, |s| s.recall()),
                        f1: s.map_or(f64::NAN, |s| s.f1()),
                        off_surface_visible: off
                            .map_or(0, |f| visible.iter().filter(|&&i| f[i as usize]).count()),
                        seconds_min: t.min,
                        seconds_max: t.max,
                        samples: t.samples,
                        status: ok_status(),
                    }
                };
                // The program's own seconds are the time (wall time includes the protocol).
                let mut reported = Vec::new();
                let outcome = registry::timing::measure(super::REPEATS, || {
                    let out = prepared.visible(&cam)?;
                    reported.push(out.reported_seconds.unwrap_or(f64::NAN));
                    Ok::<_, registry::Error>(out)
                });
                match outcome {
                    Ok((out, wall)) => {
                        let t = if reported.iter().all(|s| s.is_finite()) {
                            registry::timing::Timing::of(&reported)
                        } else {
                            wall
                        };
                        rows.push(row(&out.visible, t));
                        if let Some(g) = setting.iter().find(|(k, _)| k == "gamma").map(|p| &p.1)
                            && let Some((our_set, our_seconds)) = ours.get(&(view, g.clone()))
                        {
                            peers.push(PeerRow {
                                dataset: ds.name().to_owned(),
                                view,
                                peer: m.name().to_owned(),
                                gamma: g.clone(),
                                ours_seconds: *our_seconds,
                                peer_seconds: t.median,
                                jaccard: Score::of_sets(&out.visible, our_set).jaccard(),
                            });
                        }
                    }
                    Err(e) => {
                        eprintln!("visibility: {} {label} view {view}: {e}", m.name());
                        let mut r = row(&[], registry::timing::Timing::of(&[f64::NAN]));
                        r.precision = f64::NAN;
                        r.recall = f64::NAN;
                        r.f1 = f64::NAN;
                        r.status = format!("error: {e}");
                        rows.push(r);
                    }
                }
            }
        }
    }
    Ok(())
}

/// The settings compared on datasets without a mesh: each family's automatic rule (the ray
/// cast at 1280 × 720) and the splat baseline's default.
fn agreement_setting(method: &str, params: &str) -> bool {
    match method {
        "hpr" => params.contains("gamma=auto"),
        "raycast" => params.contains("radius=auto") && params.contains("width=1280"),
        "splat" => params == "radius_px=2;depth_tolerance=0.01",
        _ => false,
    }
}

fn agreement_rows(dataset: &str, view: usize, runs: &[Run]) -> Vec<AgreementRow> {
    let chosen: Vec<&Run> = runs
        .iter()
        .filter(|r| agreement_setting(r.method, &r.params))
        .collect();
    let mut out = Vec::new();
    for (i, a) in chosen.iter().enumerate() {
        for b in &chosen[i + 1..] {
            out.push(AgreementRow {
                dataset: dataset.to_owned(),
                view,
                a: family(a.method, &a.params).to_owned(),
                b: family(b.method, &b.params).to_owned(),
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
        r.dataset == dataset && family(&r.method, &r.params) == fam && !is_auto(&r.params)
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
    runs: Vec<(usize, Run)>,
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
    for fam in ["hpr-linear", "hpr-exp", "raycast", "splat"] {
        let Some((best, _)) = best_setting(rows, ds.name(), fam) else {
            continue;
        };
        let Some((_, run)) = runs
            .iter()
            .find(|(_, r)| family(r.method, &r.params) == fam && r.params == best)
        else {
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
        "bunny-69451, view 0. green: visible and found; blue: visible, missed; red: hidden, reported visible; grey: hidden",
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

fn param(params: &str, key: &str) -> Option<f64> {
    params
        .split(';')
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('=')?.parse().ok())
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
            .filter(|r| r.dataset == *d && agreement_setting(&r.method, &r.params))
        {
            speed
                .entry(family(&r.method, &r.params))
                .or_default()
                .push((r.seconds, r.n_visible));
        }
        no_mesh.push_str(&format!(
            "#### {d}: no mesh, no ground truth\n\nThis dataset has no mesh, so there is nothing \
             to score against: its F1 columns are empty (NaN in results.csv). What can be \
             measured is reported: each method's time and visible count at its automatic \
             setting, and how far the methods agree (Jaccard index of their visible sets, mean \
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

    // F1 against seconds, every setting (mean over views), Pareto front marked, per dataset.
    for d in &datasets {
        let mut series = Vec::new();
        let mut all: Vec<(f64, f64)> = Vec::new();
        for (k, fam) in families.iter().enumerate() {
            let mut by: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
            for r in rows
                .iter()
                .filter(|r| r.dataset == *d && family(&r.method, &r.params) == fam.as_str())
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
            all.extend(&pts);
            let mut s = Series::new(fam.clone(), pts, Mark::Points);
            s.color = Some(k);
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
            x_label: "seconds per view (log)".into(),
            y_label: "F1 against the reference".into(),
            x_log: true,
            series,
            ..Chart::default()
        }
        .save(&dir.join(&file), 1000, 560)?;
        pictures.push_str(&format!("![{d} Pareto]({file})\n\n"));
    }

    // F1 against each family's parameter.
    let param_chart = |fam: &str,
                       key: &str,
                       title: &str,
                       x_label: &str,
                       x_log: bool,
                       negate: bool,
                       by_res: bool|
     -> Result<String> {
        let mut series = Vec::new();
        for d in &datasets {
            let resolutions: Vec<String> = if by_res {
                RESOLUTIONS
                    .iter()
                    .map(|(w, h)| format!("width={w};height={h}"))
                    .collect()
            } else {
                vec![String::new()]
            };
            for res in resolutions {
                let mut by: BTreeMap<i64, Vec<f64>> = BTreeMap::new();
                let mut xs: BTreeMap<i64, f64> = BTreeMap::new();
                for r in rows.iter().filter(|r| {
                    r.dataset == *d
                        && family(&r.method, &r.params) == fam
                        && !is_auto(&r.params)
                        && r.params.contains(&res)
                        && param(&r.params, "perturb").unwrap_or(0.0) == 0.0
                        && (fam != "splat" || param(&r.params, "depth_tolerance") == Some(0.01))
                }) {
                    let Some(x) = param(&r.params, key) else {
                        continue;
                    };
                    let x = if negate { -x } else { x };
                    let key = (x * 1e9) as i64;
                    by.entry(key).or_default().push(r.f1);
                    xs.insert(key, x);
                }
                let pts: Vec<(f64, f64)> = by
                    .iter()
                    .map(|(k, f)| (xs[k], mean(f.iter().copied())))
                    .collect();
                if !pts.is_empty() {
                    let label = if by_res {
                        format!("{d} {}", res.replace("width=", "").replace(";height=", "x"))
                    } else {
                        d.clone()
                    };
                    series.push(Series::new(label, pts, Mark::LinePoints));
                }
            }
        }
        let file = format!("f1_{fam}.png");
        Chart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: "F1 (mean over views)".into(),
            x_log,
            series,
            ..Chart::default()
        }
        .save(&dir.join(&file), 900, 500)?;
        Ok(file)
    };
    for file in [
        param_chart(
            "hpr-linear",
            "gamma",
            "HPR (linear kernel): F1 against gamma",
            "gamma (R = max|p - C| x 10^gamma)",
            false,
            false,
            false,
        )?,
        param_chart(
            "hpr-exp",
            "gamma",
            "HPR (exponential kernel): F1 against -gamma",
            "-gamma (log)",
            true,
            true,
            false,
        )?,
        param_chart(
            "raycast",
            "radius_factor",
            "Ray cast: F1 against the point radius, per resolution",
            "radius (density spacings)",
            false,
            false,
            true,
        )?,
        param_chart(
            "splat",
            "radius_px",
            "Splat baseline (depth tolerance 0.01): F1 against splat radius",
            "splat radius (pixels)",
            false,
            false,
            false,
        )?,
    ] {
        pictures.push_str(&format!("![{file}]({file})\n\n"));
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
                .filter(|r| r.dataset == *d && r.params == p && family(&r.method, &r.params) == fam)
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

    // The automatic rules against the best fixed setting, view by view.
    let mut auto_table = Vec::new();
    let mut worst: BTreeMap<(String, &str), f64> = BTreeMap::new();
    for r in rows.iter().filter(|r| is_auto(&r.params)) {
        let fam = family(&r.method, &r.params);
        let same_res = |p: &str| {
            fam != "raycast"
                || (p.contains(&format!(
                    "width={}",
                    param(&r.params, "width").unwrap_or(0.0)
                )))
        };
        let best = rows
            .iter()
            .filter(|o| {
                o.dataset == r.dataset
                    && o.view == r.view
                    && family(&o.method, &o.params) == fam
                    && !is_auto(&o.params)
                    && same_res(&o.params)
            })
            .filter(|o| fam != "hpr-linear" || param(&o.params, "perturb") == Some(0.0))
            .map(|o| o.f1)
            .fold(f64::NEG_INFINITY, f64::max);
        let gap = best - r.f1;
        let key = (r.dataset.clone(), fam);
        let w = worst.entry(key).or_insert(f64::NEG_INFINITY);
        *w = w.max(gap);
        if fam == "hpr-linear" || r.params.contains("width=1280") {
            auto_table.push(vec![
                r.dataset.clone(),
                r.view.to_string(),
                fam.to_owned(),
                r.params.replace(';', " "),
                format!("{:.4}", r.f1),
                format!("{best:.4}"),
                format!("{gap:+.4}"),
            ]);
        }
    }
    let worst_lines: Vec<String> = worst
        .iter()
        .map(|((d, fam), g)| {
            format!(
                "- {d}, {fam}: worst gap {g:.4} ({})",
                if *g <= 0.02 {
                    "within 0.02"
                } else {
                    "**over 0.02**"
                }
            )
        })
        .collect();

    // Image-space figures (1280 x 720 ray cast and the splats at the view's resolution).
    let mut pixel_table = Vec::new();
    for d in &datasets {
        let mut by: BTreeMap<(String, String), Vec<&PixelRow>> = BTreeMap::new();
        for p in pixels
            .iter()
            .filter(|p| p.dataset == *d && !is_auto(&p.params))
        {
            by.entry((p.method.clone(), p.params.clone()))
                .or_default()
                .push(p);
        }
        for fam in ["raycast", "splat"] {
            let Some((params, _)) = best_setting(rows, d, fam) else {
                continue;
            };
            if let Some(ps) = by.get(&(fam.to_owned(), params.clone())) {
                pixel_table.push(vec![
                    d.clone(),
                    fam.to_owned(),
                    params.replace(';', " "),
                    format!("{:.4}", mean(ps.iter().map(|p| p.pixel_precision))),
                    format!("{:.4}", mean(ps.iter().map(|p| p.mesh_coverage))),
                    format!("{:.0}", mean(ps.iter().map(|p| p.covered_pixels as f64))),
                    format!("{:.0}", mean(ps.iter().map(|p| p.mesh_pixels as f64))),
                ]);
            }
        }
    }

    let renders = if dir.join("renders.png").exists() {
        "![bunny-69451 view 0: every method at its best setting](renders.png)\n\n"
    } else {
        ""
    };
    let summary = format!(
        "Every visibility method against the reference (mesh depth buffer), F1 = harmonic mean of \
         precision and recall of the visible set, mean over the views. `seconds`: the method \
         alone, median of 3 runs (their spread in results.csv).\n\n{renders}### Best setting per method\n\n{}\n\
         ### Choosing the parameter automatically\n\nHPR's γ from the cloud alone: \
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
