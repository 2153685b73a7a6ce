//! The LOD findings ([`crate::experiments::rules::curve`]'s curves): per dataset and per
//! distance (a budget draws a different density on screen at each distance, so the distances
//! are never averaged together), the methods' PSNR at each fixed point budget
//! ([`LOD_BUDGETS`]), each view read on its own curve, never extrapolated; the verdict
//! ([`super::verdict`], margin [`super::verdict::PSNR_MARGIN`]) compares the methods that reach
//! the budget on every view the others do, the rest listed apart with their count, or as not
//! reached. Then per dataset and distance the methods ranked by their mean BD-PSNR against the
//! random subsample over the views where they are comparable.

use std::path::Path;

use anyhow::Result;

use super::{Ask, Finding, finding};
use crate::experiments::rules::curve::{
    BD_ANCHOR, LOD_BUDGETS, LodRow, RULES, at_budget, bd_cells, curves, dataset_points, missing,
    percent,
};
use crate::experiments::rules::verdict::verdict;
use crate::output::{distinct, read_csv};

pub(super) fn lod(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<LodRow> = read_csv(&dir.join("results.csv"))?;
    let mut out = Vec::new();
    for dataset in distinct(rows.iter().map(|r| r.dataset.as_str())) {
        let ok: Vec<&LodRow> = rows
            .iter()
            .filter(|r| r.dataset == dataset && r.status == "ok")
            .collect();
        if ok.is_empty() {
            continue;
        }
        let n = dataset_points(&ok);
        let mut distances: Vec<f64> = ok.iter().map(|r| r.distance).collect();
        distances.sort_by(f64::total_cmp);
        distances.dedup();
        for d in distances {
            let at_d: Vec<&LodRow> = ok.iter().copied().filter(|r| r.distance == d).collect();
            out.extend(at_distance(&dataset, &d.to_string(), &at_d, n, quick));
        }
    }
    Ok(out)
}

/// The findings of one dataset at one distance (`rows`, its ok rows there) whose dataset has
/// `n` points: a row per budget a method reaches, then the BD-PSNR row.
fn at_distance(dataset: &str, d: &str, rows: &[&LodRow], n: f64, quick: bool) -> Vec<Finding> {
    let mut out = Vec::new();
    let psnr = curves(rows, |r| r.psnr);
    for b in LOD_BUDGETS {
        let points = (b * n).round();
        let cells = at_budget(&psnr, points);
        let Some(v) = verdict(&cells, RULES) else {
            continue;
        };
        out.push(finding(
            Ask {
                experiment: "lod",
                condition: format!(
                    "{dataset} at distance ×{d}, at {} % of the points ({points:.0})",
                    percent(b)
                ),
                question: "Which LOD method renders closest to the full cloud (PSNR) at a \
                           fixed point budget?",
                metric: "PSNR (dB)",
                cost_metric: "points (the budget)",
                rules: RULES,
                quick,
            },
            v,
            missing(&psnr, &cells, "not reached", None),
        ));
    }
    let cells = bd_cells(&psnr);
    if let Some(v) = verdict(&cells, RULES) {
        out.push(finding(
            Ask {
                experiment: "lod",
                condition: format!(
                    "{dataset} at distance ×{d}, BD-PSNR against {BD_ANCHOR} over each view's \
                     common range of log points"
                ),
                question: "Which LOD method gains most PSNR over the random subsample at \
                           equal points (BD-PSNR)?",
                metric: "BD-PSNR (dB)",
                cost_metric: "-",
                rules: RULES,
                quick,
            },
            v,
            missing(&psnr, &cells, "not comparable", Some(BD_ANCHOR)),
        ));
    }
    out
}
