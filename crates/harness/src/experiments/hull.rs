//! Experiment `hull`: HPR's convex hull, every implementation, with and without seed 000's
//! perturbation; seed 000 Table 1 regenerated.
//!
//! For each dataset, view, γ (R = max‖p − C‖·10^γ, linear kernel), hull implementation and
//! perturbation k, `seconds` is the median of `--repeats` runs of flip + hull + mapping
//! (`hpr::visible`; fewer once the runs so far took `--time-budget` seconds, as in the
//! measurement kernel), `jaccard_vs_exact` compares the visible set with the exact unperturbed
//! answer (`own`, k = 0, same dataset, view and γ) and `f1_vs_reference` scores it against the
//! mesh reference. A failure is a row with status `error: …` or `panic: …`.
//!
//! The grid ([`plan`]) is the full one (5 views, [`crate::stats::MIN_VIEWS`], so CGAL's ratio has
//! its interval; × 3 γ × k ∈ {0, 1e-4, 1e-3, 1e-2}) for `own`
//! and `qhull` on every dataset; the other implementations run the full grid on the bunnies and
//! view 0 with γ = 3 on the dragon (one Qhull-class run there takes 1 to 12 s, and the whole
//! benchmark has 30 minutes); `chull` (exact big-integer QuickHull, about 100 times slower
//! than Qhull) runs view 0, γ = 3, k = 0 on the bunnies only. `own` and `qhull` also run
//! k ∈ {1e-7, 1e-6, 1e-5} (view 0, γ = 3 only on the dragon), to show where the perturbation
//! starts to erode the visible set. Every configuration left out is a row with status
//! `error: skipped (…)`, so the gaps are visible. Quick mode: the bunnies, views 0 and 1,
//! k ∈ {0, 1e-6, 1e-2}, `chull` on `bunny` only.
//!
//! CGAL (`hull = cgal`): the peer `cgal-hpr` (CGAL's exact `convex_hull_3` in the same
//! flip, hull and mapping, a C++ program behind the external-method protocol) on every view and γ
//! at k = 0 (it has no perturbation), through the measurement kernel (`registry::kernel`:
//! its own reported seconds, the median of `--repeats`, so the process's start and the cloud's
//! transfer are not counted). Not installed: the metadata's `not_run` says so and the report
//! prints it.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use hpr::{HprError, HprParams, Kernel, Radius};
use hull::HullError;
use serde::{Deserialize, Serialize};
use truth::{Reference, ReferenceParams};

use super::{Context, Experiment, markdown_table};

mod peers;
use crate::output::figure::{Axis, Draw, Figure, Panel, Point, Series};
use crate::output::{read_csv, write_atomic, write_csv};
use crate::progress;
use registry::scoring::Score;

/// Hull implementations compared, in report order.
pub const HULLS: &[&str] = &["own", "qhull", "qhull-qj", "parry", "quickhull", "chull"];
/// The peer beside them: CGAL's `convex_hull_3` in HPR (the external method `cgal-hpr`,
/// through the measurement kernel; its rows' `hull` is [`CGAL`]).
pub const CGAL_METHOD: &str = "cgal-hpr";
/// The `hull` of its rows.
pub const CGAL: &str = "cgal";
/// Katz's γ values.
pub const GAMMAS: &[f64] = &[2.0, 3.0, 4.0];
/// Perturbation amplitudes k (relative to R): the required grid and, for `own` and `qhull`,
/// three smaller values that show where the visible set starts to erode.
pub const PERTURBS: &[f64] = &[0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2];
/// The smaller perturbations, run for `own` and `qhull` only.
pub const EXTRA_PERTURBS: &[f64] = &[1e-7, 1e-6, 1e-5];
/// Seed of the perturbation.
pub const SEED: u64 = 2007;

/// The experiment.
pub struct HullExperiment;

/// One CSV row (the column order is the output contract).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// Dataset name.
    pub dataset: String,
    /// Points in the dataset.
    pub n_points: usize,
    /// View index.
    pub view: usize,
    /// Katz's γ.
    pub gamma: f64,
    /// Hull implementation.
    pub hull: String,
    /// Perturbation k.
    pub perturb: f64,
    /// Median seconds of flip + hull + mapping.
    pub seconds: f64,
    /// Timed runs behind `seconds` (`--repeats`, fewer under `--time-budget`; 0 in reports
    /// written before the column existed).
    #[serde(default)]
    pub samples: usize,
    /// Visible points found.
    pub n_visible: usize,
    /// Jaccard index against the exact unperturbed visible set.
    pub jaccard_vs_exact: f64,
    /// F1 against the reference.
    pub f1_vs_reference: f64,
    /// `ok`, `error: …` or `panic: …`.
    pub status: String,
    /// SHA-256 of the visible set ([`visible_sha256`]); empty where the row has no answer (and
    /// in reports written before the column existed).
    #[serde(default)]
    pub visible_sha256: String,
}

/// The SHA-256 (lowercase hex) of a visible set: its indices sorted ascending, each written in
/// decimal and followed by `\n`. Equal sets give equal digests on every machine, so two runs'
/// answers can be compared by their `results.csv` alone (`tests/hull_goldens.rs` compares them
/// with digests from revision 5c38c1a).
pub fn visible_sha256(visible: &[u32]) -> String {
    let mut sorted = visible.to_vec();
    sorted.sort_unstable();
    let text: String = sorted.iter().map(|i| format!("{i}\n")).collect();
    crate::fetch::sha256_hex(text.as_bytes())
}

/// Whether a configuration runs, or why not.
pub fn plan(
    dataset: &str,
    hull: &str,
    view: usize,
    gamma: f64,
    perturb: f64,
    quick: bool,
) -> Result<(), String> {
    let dragon = dataset.starts_with("dragon");
    let extra = EXTRA_PERTURBS.contains(&perturb);
    match hull {
        "own" | "qhull" if extra && dragon && (view != 0 || gamma != 3.0) => {
            Err("skipped (the extra small k run on view 0, gamma 3 only on the dragon)".into())
        }
        "own" | "qhull" => Ok(()),
        _ if extra => Err("skipped (the extra small k run for own and qhull only)".into()),
        "chull" if dragon || (quick && dataset != "bunny") => {
            Err("skipped (chull takes seconds to minutes per run at this size)".into())
        }
        "chull" if view == 0 && gamma == 3.0 && perturb == 0.0 => Ok(()),
        "chull" => Err("skipped (chull runs view 0, gamma 3, k 0 only: seconds per run)".into()),
        _ if dragon && (view != 0 || gamma != 3.0) => {
            Err("skipped (on the dragon, view 0 and gamma 3 only for this implementation)".into())
        }
        _ => Ok(()),
    }
}

fn status_of(e: &HprError) -> String {
    match e {
        HprError::Hull(HullError::Panic { message, .. }) => format!("panic: {message}"),
        other => format!("error: {other}"),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

impl Experiment for HullExperiment {
    fn name(&self) -> &'static str {
        "hull"
    }

    fn summary(&self) -> &'static str {
        "HPR's convex hull: six implementations, seed 000's perturbation, seed 000 Table 1"
    }

    fn default_datasets(&self, quick: bool) -> &'static [&'static str] {
        if quick {
            &["bunny", "bunny-69451"]
        } else {
            &["bunny", "bunny-69451", "dragon-871414"]
        }
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let views = if ctx.quick {
            2
        } else {
            crate::stats::MIN_VIEWS
        };
        let perturbs: &[f64] = if ctx.quick {
            &[0.0, 1e-6, 1e-2]
        } else {
            PERTURBS
        };
        let mut rows = Vec::new();
        let cgal = ctx
            .run
            .catalogue
            .card(CGAL_METHOD)
            .map_err(|e| e.to_string())
            .and_then(|m| m.availability().map(|()| m));
        let mut not_run = Vec::new();
        if let Err(why) = &cgal {
            not_run.push(format!("{CGAL_METHOD}: {why}"));
        }
        for name in &ctx.datasets {
            let ds = ctx.dataset(name)?;
            // A dataset with fewer views (one camera from `run hull --eye`) is measured on those.
            let views = views.min(ds.views.len());
            // Without a mesh the F1 column stays NaN; the rest is measured.
            let reference = ds.mesh.as_ref().map(Reference::new).transpose()?;
            let hulls: Vec<(&str, Box<dyn hull::ConvexHull>)> = HULLS
                .iter()
                .map(|&h| Ok((h, hull::by_name(h)?)))
                .collect::<Result<_>>()?;
            let total = (views * GAMMAS.len() * HULLS.len() * perturbs.len()) as u64;
            let bar = progress::bar(total, format!("hull {name}"));
            // The exact answers (own, k = 0) and the truths, per (view, γ) and view, for CGAL's rows.
            let mut exacts: BTreeMap<(usize, u64), Vec<u32>> = BTreeMap::new();
            let mut truths: Vec<Option<Vec<bool>>> = Vec::new();
            for view in 0..views {
                let cam = ds.view(view)?;
                let truth = match &reference {
                    Some(r) => Some(
                        r.visibility(ds.truth_points(), cam, &ReferenceParams::default())?
                            .visible,
                    ),
                    None => None,
                };
                for &gamma in GAMMAS {
                    let mut exact: Option<Vec<u32>> = None;
                    for (hull_name, hull) in &hulls {
                        progress::at(name, hull_name);
                        for &perturb in perturbs {
                            bar.inc(1);
                            let mut row = Row {
                                dataset: name.clone(),
                                n_points: ds.cloud.len(),
                                view,
                                gamma,
                                hull: hull_name.to_string(),
                                perturb,
                                seconds: f64::NAN,
                                samples: 0,
                                n_visible: 0,
                                jaccard_vs_exact: f64::NAN,
                                f1_vs_reference: f64::NAN,
                                status: "ok".into(),
                                visible_sha256: String::new(),
                            };
                            if let Err(why) = plan(name, hull_name, view, gamma, perturb, ctx.quick)
                            {
                                row.status = format!("error: {why}");
                                rows.push(row);
                                continue;
                            }
                            let params = HprParams {
                                kernel: Kernel::Linear(Radius::Gamma(gamma)),
                                perturb,
                                seed: SEED,
                            };
                            // Timed by HPR's own seconds (flip + hull + mapping), under the
                            // time budget as the kernel's calls are.
                            let measured = registry::timing::measure_reported(
                                ctx.repeats,
                                ctx.time_budget,
                                || {
                                    hpr::visible(
                                        &ds.cloud.positions,
                                        cam.eye,
                                        &params,
                                        hull.as_ref(),
                                    )
                                    .map(|v| {
                                        let seconds = v.timings.total();
                                        (v.visible, seconds)
                                    })
                                },
                            );
                            match measured {
                                Ok((visible, timing)) => {
                                    if *hull_name == "own" && perturb == 0.0 {
                                        exact = Some(visible.clone());
                                        exacts.insert((view, gamma.to_bits()), visible.clone());
                                    }
                                    row.seconds = timing.median;
                                    row.samples = timing.samples;
                                    row.n_visible = visible.len();
                                    row.visible_sha256 = visible_sha256(&visible);
                                    row.f1_vs_reference = truth
                                        .as_ref()
                                        .map_or(f64::NAN, |t| Score::of(&visible, t).f1());
                                    if let Some(exact) = &exact {
                                        row.jaccard_vs_exact =
                                            Score::of_sets(&visible, exact).jaccard();
                                    }
                                }
                                Err(e) => row.status = status_of(&e),
                            }
                            rows.push(row);
                        }
                    }
                }
                truths.push(truth);
            }
            bar.finish_and_clear();
            if let Ok(method) = cgal {
                let cams: Vec<cloud::Camera> = (0..views)
                    .map(|v| ds.view(v).copied())
                    .collect::<Result<_>>()?;
                let kviews = registry::kernel::View::all(&cams);
                let input = registry::Input {
                    cloud: &ds.cloud,
                    mesh: None,
                };
                for &gamma in GAMMAS {
                    let setting = registry::Setting::parse(&format!("gamma={gamma}"));
                    let cell = registry::kernel::Cell {
                        budget: ctx.time_budget,
                        ..registry::kernel::Cell::new(method, &setting, &kviews, ctx.repeats)
                    };
                    let (_, answers) = registry::kernel::collect(&cell, input);
                    for (v, answer) in answers {
                        let mut row = Row {
                            dataset: name.clone(),
                            n_points: ds.cloud.len(),
                            view: v.index,
                            gamma,
                            hull: CGAL.into(),
                            perturb: 0.0,
                            seconds: f64::NAN,
                            samples: 0,
                            n_visible: 0,
                            jaccard_vs_exact: f64::NAN,
                            f1_vs_reference: f64::NAN,
                            status: "ok".into(),
                            visible_sha256: String::new(),
                        };
                        match answer {
                            Ok(a) => {
                                let visible = &a.output.visible;
                                row.seconds = a.timing.median;
                                row.samples = a.timing.samples;
                                row.n_visible = visible.len();
                                row.visible_sha256 = visible_sha256(visible);
                                row.f1_vs_reference = truths[v.index]
                                    .as_ref()
                                    .map_or(f64::NAN, |t| Score::of(visible, t).f1());
                                if let Some(exact) = exacts.get(&(v.index, gamma.to_bits())) {
                                    row.jaccard_vs_exact = Score::of_sets(visible, exact).jaccard();
                                }
                            }
                            Err(e) => row.status = format!("error: {e}"),
                        }
                        rows.push(row);
                    }
                }
            }
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        Ok(serde_json::json!({
            "views": views,
            "gammas": GAMMAS,
            "perturbs": perturbs,
            "hulls": HULLS,
            "peer": CGAL_METHOD,
            "not_run": not_run,
            "repeats": ctx.repeats,
            "time_budget_s": ctx.time_budget,
            "perturbation_seed": SEED,
            "kernel": "linear (spherical flipping), R = max|p - C| * 10^gamma",
            "extra_perturbs_own_qhull": EXTRA_PERTURBS,
            "grid": "own and qhull: every configuration (extra small k: view 0, gamma 3 only on the dragon); qhull-qj, parry, quickhull: view 0, gamma 3 only on the dragon; chull: view 0, gamma 3, k 0 on the bunnies (quick: bunny only)",
        }))
    }

    fn render(&self, _: &registry::Catalogue, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let meta = crate::output::meta::RunMeta::read(dir)?;
        let repeats = meta.parameters["repeats"]
            .as_u64()
            .unwrap_or(super::REPEATS as u64);
        let not_run: Vec<String> =
            serde_json::from_value(meta.parameters["not_run"].clone()).unwrap_or_default();
        render(dir, &rows, repeats, &not_run)
    }
}

fn ok(r: &&Row) -> bool {
    r.status == "ok"
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Median over the rows selected by `pick` of `value`.
fn median_of(
    rows: &[Row],
    pick: impl Fn(&Row) -> bool,
    value: impl Fn(&Row) -> f64,
) -> Option<f64> {
    let v: Vec<f64> = rows
        .iter()
        .filter(|r| r.status == "ok" && pick(r))
        .map(value)
        .collect();
    (!v.is_empty()).then(|| median(v))
}

/// The rows as the ratios read them (`rules::ratio`).
fn cells(rows: &[Row]) -> Vec<super::rules::ratio::HullCell> {
    rows.iter()
        .map(|r| super::rules::ratio::HullCell {
            dataset: r.dataset.clone(),
            view: r.view,
            gamma: r.gamma,
            hull: r.hull.clone(),
            perturb: r.perturb,
            seconds: r.seconds,
            jaccard_vs_exact: r.jaccard_vs_exact,
            status: r.status.clone(),
        })
        .collect()
}

fn fmt_s(v: Option<f64>) -> String {
    v.map_or("—".into(), |s| {
        if s < 1.0 {
            format!("{s:.3}")
        } else {
            format!("{s:.2}")
        }
    })
}

fn render(dir: &Path, rows: &[Row], repeats: u64, not_run: &[String]) -> Result<()> {
    let datasets = crate::output::distinct(rows.iter().map(|r| r.dataset.as_str()));
    let hulls: Vec<&str> = HULLS
        .iter()
        .copied()
        .chain([CGAL])
        .filter(|h| rows.iter().any(|r| r.hull == *h))
        .collect();
    let perturbs: Vec<f64> = PERTURBS
        .iter()
        .copied()
        .filter(|k| rows.iter().any(|r| r.perturb == *k))
        .collect();

    // Plot 1: seconds per implementation per dataset (k = 0), the median over the (view, γ)
    // cells every compared hull ran (quartiles as bars); apart: fewer cells, wrong answers.
    let wrong = super::rules::wrong::hulls(dir)?;
    let seconds = Figure::new(
        "seconds",
        "HPR time per hull implementation (k = 0; median over the (view, γ) cells every compared hull ran)",
        Axis::categories("dataset", datasets.clone()),
        Axis::log("seconds (flip + hull + mapping; bars: quartiles)"),
    )
    .interval("first to third quartile over the cells")
    .series(
        peers::seconds_series(rows, &datasets, &hulls, &wrong),
        Vec::new(),
    )
    .write(dir)?;

    // Plot 2: speed-up against visibility lost, one point per k, for own and qhull; a panel
    // per dataset.
    let mut panels = Vec::new();
    for d in &datasets {
        let mut series = Vec::new();
        for h in ["qhull", "own"] {
            let base = median_of(
                rows,
                |r| r.dataset == *d && r.hull == h && r.perturb == 0.0,
                |r| r.seconds,
            );
            let pts: Vec<Point> = perturbs
                .iter()
                .filter_map(|&k| {
                    let t = median_of(
                        rows,
                        |r| r.dataset == *d && r.hull == h && r.perturb == k,
                        |r| r.seconds,
                    )?;
                    let j = median_of(
                        rows,
                        |r| r.dataset == *d && r.hull == h && r.perturb == k,
                        |r| r.jaccard_vs_exact,
                    )?;
                    Some(
                        Point::new(100.0 * (1.0 - j), base? / t)
                            .seconds(t)
                            .setting(format!("perturb={k}")),
                    )
                })
                .collect();
            if !pts.is_empty() {
                series.push(Series::new(h, &format!("hull-{h}"), "", Draw::Line, pts));
            }
        }
        if !series.is_empty() {
            panels.push(Panel {
                title: d.clone(),
                series,
            });
        }
    }
    let perturbation = Figure::new(
        "perturbation",
        format!(
            "Perturbation: speed-up vs visible set lost (k = {})",
            perturbs
                .iter()
                .map(|k| format!("{k}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Axis::linear("visible set lost: 100 x (1 - Jaccard vs exact)"),
        Axis::log("speed-up over k = 0"),
    )
    .panels(panels);
    let perturbation = if perturbation.is_empty() {
        String::new()
    } else {
        perturbation.write(dir)?
    };

    // Plot 3: F1 against γ (own, k = 0, mean over views), a panel per dataset.
    let f1_gamma = Figure::new(
        "f1_gamma",
        "HPR F1 against the reference as gamma grows (exact hull, k = 0)",
        Axis::linear("gamma (R = max|p - C| x 10^gamma)"),
        Axis::linear("F1 (mean over views)"),
    )
    .panels(
        datasets
            .iter()
            .map(|d| Panel {
                title: d.clone(),
                series: vec![
                    Series::new(
                        "hpr",
                        "hpr-linear",
                        "settings",
                        Draw::Line,
                        GAMMAS
                            .iter()
                            .map(|&g| {
                                let rs: Vec<&Row> = rows
                                    .iter()
                                    .filter(ok)
                                    .filter(|r| {
                                        r.dataset == *d
                                            && r.hull == "own"
                                            && r.perturb == 0.0
                                            && r.gamma == g
                                    })
                                    .collect();
                                Point::new(g, mean(rs.iter().map(|r| r.f1_vs_reference)))
                                    .seconds(mean(rs.iter().map(|r| r.seconds)))
                                    .setting(format!("gamma={g}"))
                            })
                            .collect(),
                    )
                    .label("hpr (own hull)"),
                ],
            })
            .collect(),
    )
    .write(dir)?;

    // The comparison table: per dataset and implementation, at k = 0.
    let mut table = Vec::new();
    for d in &datasets {
        for h in &hulls {
            let all: Vec<&Row> = rows
                .iter()
                .filter(|r| r.dataset == *d && r.hull == *h && r.perturb == 0.0)
                .collect();
            let good: Vec<&&Row> = all.iter().filter(|r| r.status == "ok").collect();
            let failures: BTreeMap<String, usize> =
                all.iter()
                    .filter(|r| r.status != "ok")
                    .fold(BTreeMap::new(), |mut m, r| {
                        *m.entry(r.status.clone()).or_default() += 1;
                        m
                    });
            table.push(vec![
                d.clone(),
                h.to_string(),
                format!("{}/{}", good.len(), all.len()),
                fmt_s(median_of(
                    rows,
                    |r| r.dataset == *d && r.hull == *h && r.perturb == 0.0,
                    |r| r.seconds,
                )),
                if good.is_empty() {
                    "—".into()
                } else {
                    let j = good
                        .iter()
                        .map(|r| r.jaccard_vs_exact)
                        .fold(f64::INFINITY, f64::min);
                    match wrong.get(h) {
                        Some(_) if j < super::rules::wrong::JACCARD => {
                            format!("{j:.4} (wrong answers)")
                        }
                        _ => format!("{j:.4}"),
                    }
                },
                if good.is_empty() {
                    "—".into()
                } else {
                    format!("{:.3}", mean(good.iter().map(|r| r.f1_vs_reference)))
                },
                failures
                    .iter()
                    .map(|(s, n)| format!("{n}× {s}"))
                    .collect::<Vec<_>>()
                    .join("; "),
            ]);
        }
    }
    // Exactness of own against Qhull, where both ran.
    let pairs: Vec<(f64, bool)> = rows
        .iter()
        .filter(|r| r.hull == "qhull" && r.perturb == 0.0 && r.status == "ok")
        .map(|r| (r.jaccard_vs_exact, r.jaccard_vs_exact == 1.0))
        .collect();
    let identical = pairs.iter().filter(|p| p.1).count();
    let min_j = pairs.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);

    let table1 = table1(rows, &datasets);
    write_atomic(&dir.join("table1.md"), table1.as_bytes())?;
    let cgal = peers::table(rows, not_run, repeats);

    let summary = format!(
        "HPR (linear kernel, R = max‖p − C‖·10^γ) with six convex hull implementations. \
         `seconds`: median of up to {repeats} runs of flip + hull + mapping (`samples`: how many; a call stops repeating once its runs took the time budget). `min Jaccard vs exact`: \
         the worst agreement with the exact visible set (`own`, k = 0) over the configurations. \
         Grid and skips: see the rows with status `error: skipped`.\n\n\
         **own vs Qhull (Qt), k = 0:** identical visible sets in {identical} of {} configurations; \
         lowest Jaccard {}.\n\n{cgal}{}\n\
         {seconds}{perturbation}{f1_gamma}\
         ### Seed 000 Table 1, regenerated\n\n{}\nRaw rows: [results.csv](results.csv); the table alone: [table1.md](table1.md).\n",
        pairs.len(),
        if pairs.is_empty() {
            "—".into()
        } else {
            format!("{min_j:.6}")
        },
        markdown_table(
            &[
                "dataset",
                "hull",
                "ran (k = 0)",
                "median s",
                "min Jaccard vs exact",
                "mean F1",
                "failures"
            ],
            &table
        ),
        table1,
    );
    write_atomic(&dir.join("summary.md"), summary.as_bytes())
}

/// Seed 000 Table 1 beside ours.
fn table1(rows: &[Row], datasets: &[String]) -> String {
    let paper = [
        ("bunny-69451", "Bunny (69,451 points)", 4.5, 0.9),
        ("dragon-871414", "Dragon (871,414 points)", 150.0, 70.0),
    ];
    let mut out = String::from(
        "| model | paper: without perturbation (s) | paper: with (s) | paper speed-up | γ | Qhull k = 0 (s) | Qhull k = 0.01 (s) | our speed-up [95 % CI] | own (exact) k = 0 (s) | Jaccard k = 0.01 vs exact | F1 k = 0 | F1 k = 0.01 |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut notes = Vec::new();
    for (d, label, p0, p1) in paper {
        if !datasets.iter().any(|x| x == d) {
            out.push_str(&format!(
                "| {label} | {p0} | {p1} | {:.1}× | — | not run | | | | | | |\n",
                p0 / p1
            ));
            continue;
        }
        for &g in GAMMAS {
            let sel = |h: &'static str, k: f64| {
                move |r: &Row| r.dataset == d && r.hull == h && r.perturb == k && r.gamma == g
            };
            let q0 = median_of(rows, sel("qhull", 0.0), |r| r.seconds);
            let q1 = median_of(rows, sel("qhull", 1e-2), |r| r.seconds);
            let o0 = median_of(rows, sel("own", 0.0), |r| r.seconds);
            let j1 = median_of(rows, sel("qhull", 1e-2), |r| r.jaccard_vs_exact);
            let f0 = median_of(rows, sel("qhull", 0.0), |r| r.f1_vs_reference);
            let f1 = median_of(rows, sel("qhull", 1e-2), |r| r.f1_vs_reference);
            // Paired per view: geometric mean of the per-view ratios, bootstrap 95 % interval.
            let paired = |a: (&'static str, f64), b: (&'static str, f64)| {
                let by_view = |h: &'static str, k: f64| -> BTreeMap<usize, f64> {
                    rows.iter()
                        .filter(|r| sel(h, k)(r) && r.status == "ok")
                        .map(|r| (r.view, r.seconds))
                        .collect()
                };
                let (xs, ys): (Vec<f64>, Vec<f64>) =
                    crate::stats::pair(&by_view(a.0, a.1), &by_view(b.0, b.1))
                        .into_iter()
                        .unzip();
                crate::stats::paired_ratio(&xs, &ys, 2007)
            };
            let speed = paired(("qhull", 0.0), ("qhull", 1e-2));
            // Ours against Qhull is the ratios table's (every view and γ), one number.
            let versus_own = super::rules::ratio::hull(&cells(rows))
                .into_iter()
                .find(|r| r.dataset == d && r.peer == "qhull")
                .map_or("—".into(), |r| r.text());
            let ci = |r: Option<crate::stats::Estimate>| {
                r.map_or("—".into(), |e| e.text(|x| format!("{x:.1}"), "×"))
            };
            out.push_str(&format!(
                "| {label} | {p0} | {p1} | {:.1}× | {g} | {} | {} | {} | {} | {} | {} | {} |\n",
                p0 / p1,
                fmt_s(q0),
                fmt_s(q1),
                ci(speed),
                fmt_s(o0),
                j1.map_or("—".into(), |j| format!("{j:.4}")),
                f0.map_or("—".into(), |f| format!("{f:.3}")),
                f1.map_or("—".into(), |f| format!("{f:.3}")),
            ));
            if g == 3.0
                && let (Some(q0), Some(q1), Some(o0), Some(j1)) = (q0, q1, o0, j1)
            {
                notes.push(format!(
                    "- {label}, γ = 3: Qhull takes {q0:.2} s where the paper's QuickHull took {p0} s, and {q1:.2} s \
                     with the perturbation ({} faster; the paper: {:.1}×). The perturbed hull keeps a \
                     Jaccard of {j1:.4} of the exact visible set: ±0.01·R on each coordinate, with R at 10^γ \
                     times the object's distance, is far larger than the object itself, so the speed-up \
                     comes from discarding the visible set, not from a better-conditioned hull. Our exact \
                     hull needs {o0:.3} s with nothing discarded (Qhull's time over ours at k = 0, \
                     over every view and γ: {versus_own}).",
                    ci(speed),
                    p0 / p1,
                ));
            }
        }
    }
    out.push_str(
        "\nTimes are medians over the views, seconds of flip + hull + mapping on this machine; speed-ups \
         are paired per view (geometric mean of the per-view ratios, bootstrap 95 % interval over \
         the views); the \
         paper's are QuickHull alone on an Intel Core i7 920 (2009). The paper does not give R; we \
         show γ = 2, 3, 4. Where ours differ:\n\n",
    );
    for n in notes {
        out.push_str(&n);
        out.push('\n');
    }
    out
}
