//! The robustness experiment's measurement: the cases of each dataset, `best` tuned once on the
//! clean tuning datasets, and every method at `best` and `auto` on every case.
//!
//! **The protocol.** `best` is tuned on the clean clouds of the run's tuning datasets (those
//! with a clean cloud: not the simulated scans): each grid setting's mean F1 over the views of
//! each such dataset, then the mean over the datasets (each weighs the same); the setting with
//! the highest (the first in the grid of equals) is held fixed for every dataset and case,
//! evaluation datasets and scans included, so their rows are out of sample. A run without such
//! a dataset (evaluation datasets or a user's own data alone, scans alone) tunes `best` on each
//! dataset's own clean cloud, a scan's on the scan itself: an oracle, which the findings say.
//!
//! **The cost.** An evaluation dataset is degraded at [`EVALUATION_LEVELS`] only, one level in
//! each half of every degradation's levels (the findings' milder and harsher groups), and gets
//! no LOD noise rows: this keeps the full benchmark within its hour.

use std::collections::BTreeMap;

use anyhow::{Context as _, Result};
use cloud::degrade::{Degradation, Unit};
use cloud::glam::DVec3;
use registry::{Setting, kernel};
use truth::{Reference, ReferenceParams};

use super::{Case, FALLOFF, JITTER, JITTER_QUICK, NOISE, OUTLIERS, Row, SEED, degraded, run_views};
use crate::datasets::{self, Degraded, Role};
use crate::experiments::Context;
use crate::experiments::lod::noise::{self, LodRow};
use crate::progress;

/// The levels an evaluation dataset is degraded at: noise σ, outlier fractions, fall-off
/// ratios, jitter margins; one in each half of the full list.
pub const EVALUATION_LEVELS: [&[f64]; 4] =
    [&[0.25, 1.0], &[0.02, 0.1], &[4.0, 16.0], &[0.005, 0.01]];

/// What the measurement hands back: rows, LOD rows, the datasets `best` was tuned on (empty: each
/// on itself) and each method's `best` there.
pub struct Measured {
    /// Every row.
    pub rows: Vec<Row>,
    /// The LOD methods under noise.
    pub lod: Vec<LodRow>,
    /// The clean tuning datasets `best` was tuned on.
    pub tuned_on: Vec<String>,
    /// Each method's `best` (with a tuning pool).
    pub best: BTreeMap<String, String>,
}

/// One method with its sweep.
type Method<'a> = (&'a registry::Card, registry::MethodSweep);

/// The clean (or scanned) case of `ds`.
fn clean_case(ds: &datasets::Dataset) -> Case {
    let scanned = is_scan(ds);
    Case {
        degradation: if scanned { "scan" } else { "clean" },
        level: 0.0,
        d: Degraded {
            cloud: ds.cloud.clone(),
            truth_positions: ds.truth_points().to_vec(),
            outliers: ds
                .outliers
                .clone()
                .unwrap_or_else(|| vec![false; ds.cloud.len()]),
        },
    }
}

/// A scan: truth positions given and no outliers flagged (scored as it is, no clean cloud).
fn is_scan(ds: &datasets::Dataset) -> bool {
    ds.truth_positions.is_some() && ds.outliers.is_none()
}

/// The truth of every point of `case` per view.
fn truths(reference: &Reference, case: &Case, views: &[cloud::Camera]) -> Result<Vec<Vec<bool>>> {
    views
        .iter()
        .map(|cam| {
            Ok(reference
                .visibility(&case.d.truth_positions, cam, &ReferenceParams::default())?
                .visible)
        })
        .collect()
}

/// The grid value of `rows` (a method's grid on one dataset, labelled by params) with the
/// highest mean F1 over the views, per dataset, then over `datasets`; the first of equals in
/// `grid`'s order. Settings missing (or without a finite F1) on a dataset are no candidates.
fn tune(
    grid: &[Setting],
    rows: &BTreeMap<String, Vec<Row>>,
    datasets: &[String],
) -> Option<Setting> {
    let mut best: Option<(f64, &Setting)> = None;
    for s in grid {
        let label = s.label();
        let per: Option<Vec<f64>> = datasets
            .iter()
            .map(|d| {
                let f1: Vec<f64> = rows
                    .get(d)?
                    .iter()
                    .filter(|r| r.params == label && r.status == "ok" && r.f1.is_finite())
                    .map(|r| r.f1)
                    .collect();
                (!f1.is_empty()).then(|| f1.iter().sum::<f64>() / f1.len() as f64)
            })
            .collect();
        let Some(per) = per else { continue };
        let t = per.iter().sum::<f64>() / per.len() as f64;
        if best.is_none_or(|b| t > b.0) {
            best = Some((t, s));
        }
    }
    best.map(|(_, s)| s.clone())
}

/// Rows relabelled `kind`.
fn labelled(rows: Vec<Row>, kind: &str) -> impl Iterator<Item = Row> + '_ {
    rows.into_iter().map(move |mut r| {
        r.setting = kind.into();
        r
    })
}

/// The experiment's rows (the module's protocol).
pub fn measure(
    ctx: &Context,
    methods: &[Method<'_>],
    n_views: usize,
    repeats: usize,
) -> Result<Measured> {
    let role = |d: &str| match ctx.on_user_files() {
        true => Role::Own,
        false => datasets::role(d),
    };
    // 1. The grid on the clean cloud of every tuning dataset.
    let mut grid_rows: BTreeMap<String, BTreeMap<&str, Vec<Row>>> = BTreeMap::new();
    let mut tuned_on: Vec<String> = Vec::new();
    for name in ctx.datasets.iter().filter(|d| role(d) == Role::Tuning) {
        let ds = ctx.dataset(name)?;
        if is_scan(&ds) {
            continue;
        }
        let reference = Reference::new(ds.mesh("robustness")?)?;
        let views: Vec<cloud::Camera> = ds.views.iter().take(n_views).copied().collect();
        let kviews = kernel::View::all(&views);
        let case = clean_case(&ds);
        let truths = truths(&reference, &case, &views)?;
        let bar = progress::bar(methods.len() as u64, format!("robustness {name}: tuning"));
        for (method, sweep) in methods {
            progress::at(name, method.name);
            let mut rows = Vec::new();
            for setting in sweep.tuning(ctx.quick) {
                rows.extend(run_views(
                    name, &case, &truths, &kviews, method, "grid", setting, repeats,
                ));
            }
            grid_rows
                .entry(name.clone())
                .or_default()
                .insert(method.name, rows);
            bar.inc(1);
        }
        bar.finish_and_clear();
        tuned_on.push(name.clone());
    }
    let mut best: BTreeMap<&str, Setting> = BTreeMap::new();
    for (method, sweep) in methods {
        let per: BTreeMap<String, Vec<Row>> = grid_rows
            .iter()
            .filter_map(|(d, m)| Some((d.clone(), m.get(method.name)?.clone())))
            .collect();
        if let Some(s) = tune(sweep.tuning(ctx.quick), &per, &tuned_on) {
            best.insert(method.name, s);
        }
    }
    // 2. Every dataset's cases, each method at `best` and `auto`.
    let mut rows: Vec<Row> = Vec::new();
    let mut lod: Vec<LodRow> = Vec::new();
    for name in &ctx.datasets {
        let ds = ctx.dataset(name)?;
        let mesh = ds.mesh("robustness")?;
        let reference = Reference::new(mesh)?;
        let views: Vec<cloud::Camera> = ds.views.iter().take(n_views).copied().collect();
        let kviews = kernel::View::all(&views);
        let evaluation = role(name) == Role::Evaluation && !tuned_on.is_empty();
        let mut cases = vec![clean_case(&ds)];
        if !is_scan(&ds) {
            if !evaluation {
                let pinhole: Vec<cloud::Camera> = views
                    .iter()
                    .filter(|c| matches!(c.model(), cloud::Model::Pinhole { .. }))
                    .copied()
                    .collect();
                lod.extend(noise::rows(ctx, name, &ds.cloud, &pinhole, SEED)?);
            }
            let bbox = mesh.bbox().context("the mesh has no vertices")?;
            let from = bbox.center() + DVec3::new(1.5, 0.0, 0.5) * bbox.diagonal();
            // Noise along the normal needs normals: a user's cloud without them (and no mesh
            // sampled for it) leaves this degradation out, and says so.
            if ds.cloud.normals.is_none() {
                eprintln!(
                    "robustness: {name} has no normals: the jitter degradation (noise along the \
                     normal) is left out"
                );
            }
            let [noise_l, outliers_l, falloff_l, jitter_l] = if evaluation {
                EVALUATION_LEVELS
            } else {
                [
                    NOISE,
                    OUTLIERS,
                    FALLOFF,
                    if ctx.quick { JITTER_QUICK } else { JITTER },
                ]
            };
            for &sigma in noise_l {
                let step = Degradation::Noise {
                    sigma,
                    unit: Unit::Spacing,
                    along_normal: false,
                };
                cases.push(degraded(&ds.cloud, "noise", sigma, step)?);
            }
            for &fraction in outliers_l {
                let step = Degradation::Outliers {
                    fraction,
                    near_surface: None,
                    unit: Unit::Spacing,
                };
                cases.push(degraded(&ds.cloud, "outliers", fraction, step)?);
            }
            for &ratio in falloff_l {
                let step = Degradation::FallOff { from, ratio };
                cases.push(degraded(&ds.cloud, "falloff", ratio, step)?);
            }
            for &margin in jitter_l.iter().filter(|_| ds.cloud.normals.is_some()) {
                let step = Degradation::Jitter {
                    margin,
                    unit: Unit::Diagonal,
                };
                cases.push(degraded(&ds.cloud, "jitter", margin, step)?);
            }
        }
        let bar = progress::bar(
            (views.len() * cases.len()) as u64,
            format!("robustness {name}"),
        );
        // Without a tuning pool: `best` tuned on this dataset's own clean cloud (or scan).
        let mut own_best: BTreeMap<&str, Setting> = BTreeMap::new();
        let grids = grid_rows.get(name);
        for case in &cases {
            let truths = truths(&reference, case, &views)?;
            let first = case.degradation == "clean" || case.degradation == "scan";
            for (method, sweep) in methods {
                progress::at(name, method.name);
                let run = |kind: &str, setting: &Setting| {
                    run_views(name, case, &truths, &kviews, method, kind, setting, repeats)
                };
                let automatic = sweep.automatic().unwrap_or_default();
                // Rows already measured at the automatic setting on this case (the grid's, or
                // `best`'s when it is the automatic one): reported under both names, not run
                // twice (the same deterministic calls).
                let mut at_automatic: Option<Vec<Row>> = None;
                if let (true, Some(grid)) = (first, grids.and_then(|g| g.get(method.name))) {
                    let of = |s: &Setting| -> Vec<Row> {
                        let label = s.label();
                        grid.iter().filter(|r| r.params == label).cloned().collect()
                    };
                    let b = best.get(method.name).cloned().unwrap_or_default();
                    rows.extend(labelled(of(&b), "best"));
                    let a = of(&automatic);
                    at_automatic = (!a.is_empty()).then_some(a);
                } else if tuned_on.is_empty() && first {
                    // Oracle: tune on this case itself (the grid value with the best mean F1).
                    let mut by: BTreeMap<String, Vec<Row>> = BTreeMap::new();
                    let mut all = Vec::new();
                    for setting in sweep.tuning(ctx.quick) {
                        let r = run("grid", setting);
                        if *setting == automatic {
                            at_automatic = Some(r.clone());
                        }
                        all.extend(r);
                    }
                    by.insert(name.clone(), all);
                    if let Some(s) = tune(sweep.tuning(ctx.quick), &by, std::slice::from_ref(name))
                    {
                        let label = s.label();
                        rows.extend(labelled(
                            by[name]
                                .iter()
                                .filter(|r| r.params == label)
                                .cloned()
                                .collect(),
                            "best",
                        ));
                        own_best.insert(method.name, s);
                    }
                } else {
                    let setting = best
                        .get(method.name)
                        .or_else(|| own_best.get(method.name))
                        .cloned()
                        .unwrap_or_default();
                    let r = run("best", &setting);
                    if setting == automatic {
                        at_automatic = Some(r.clone());
                    }
                    rows.extend(r);
                }
                let auto_rows = at_automatic.unwrap_or_else(|| run("auto", &automatic));
                rows.extend(labelled(auto_rows, "auto"));
            }
            bar.inc(views.len() as u64);
        }
        bar.finish_and_clear();
    }
    Ok(Measured {
        rows,
        lod,
        best: best
            .iter()
            .map(|(m, s)| ((*m).to_owned(), s.label()))
            .collect(),
        tuned_on,
    })
}
