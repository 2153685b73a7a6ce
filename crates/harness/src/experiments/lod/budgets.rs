//! The LOD summary's rate-distortion tables, from the findings' curves
//! ([`crate::experiments::rules::curve`]): each method's PSNR and SSIM read at the fixed point
//! budgets, per view on its own curve, and its BD-PSNR against the random subsample, one pair
//! of tables per distance (as the findings judge each distance on its own). The verdicts over
//! them are the findings'; these tables show every method's numbers, with how many views each
//! one's mean is over.

use crate::experiments::markdown_table;
use crate::experiments::rules::curve::{
    self as lod, BD_ANCHOR, Curves, IDENTICAL_PSNR, LOD_BUDGETS, LodRow, percent,
};
use crate::experiments::rules::verdict::SEED;
use crate::output::figure::Rule;
use crate::stats::bootstrap_mean;

use super::Row;

/// The findings' view of a results row.
fn as_findings_row(r: &Row) -> LodRow {
    LodRow {
        dataset: r.dataset.clone(),
        view: r.view,
        distance: r.distance,
        method: r.method.clone(),
        params: r.params.clone(),
        points_rendered: r.points_rendered as f64,
        psnr: r.psnr,
        ssim: r.ssim,
        status: r.status.clone(),
        n_points: r.n_points as f64,
    }
}

/// Mean of `cells`' values per method (with how many cells), `None` for a method without any.
fn means(curves: &Curves, points: f64) -> Vec<(String, Option<(f64, usize)>)> {
    let cells = lod::at_budget(curves, points);
    curves
        .keys()
        .map(|m| {
            let v: Vec<f64> = cells
                .iter()
                .filter(|c| &c.method == m)
                .map(|c| c.value)
                .collect();
            let mean = (!v.is_empty()).then(|| (v.iter().sum::<f64>() / v.len() as f64, v.len()));
            (m.clone(), mean)
        })
        .collect()
}

/// The ok rows of dataset `ds`, in the findings' form.
fn ok_rows(rows: &[Row], ds: &str) -> Vec<LodRow> {
    rows.iter()
        .filter(|r| r.dataset == ds && r.status == "ok")
        .map(as_findings_row)
        .collect()
}

/// The budgets of dataset `ds` as the figures' vertical rules, each labelled with its share
/// ("10 %"), at the points the tables read them at.
pub(super) fn rules(rows: &[Row], ds: &str) -> Vec<Rule> {
    let own = ok_rows(rows, ds);
    let refs: Vec<&LodRow> = own.iter().collect();
    let n = lod::dataset_points(&refs);
    if n <= 0.0 {
        return Vec::new();
    }
    LOD_BUDGETS
        .iter()
        .map(|b| Rule {
            x: (b * n).round(),
            label: format!("{} %", percent(*b)),
        })
        .collect()
}

/// The tables of dataset `ds` (markdown), per distance; empty without ok rows.
pub(super) fn tables(rows: &[Row], ds: &str) -> String {
    let own = ok_rows(rows, ds);
    let refs: Vec<&LodRow> = own.iter().collect();
    let n = lod::dataset_points(&refs);
    let mut distances: Vec<f64> = refs.iter().map(|r| r.distance).collect();
    distances.sort_by(f64::total_cmp);
    distances.dedup();
    distances
        .into_iter()
        .map(|d| {
            let at: Vec<&LodRow> = refs.iter().copied().filter(|r| r.distance == d).collect();
            format!("At distance ×{d}: {}", at_distance(&at, n))
        })
        .collect()
}

/// The tables of one dataset's ok rows at one distance, `n` its points.
fn at_distance(refs: &[&LodRow], n: f64) -> String {
    let cells_total = {
        let mut views: Vec<usize> = refs.iter().map(|r| r.view).collect();
        views.sort_unstable();
        views.dedup();
        views.len()
    };
    let psnr = lod::curves(refs, |r| r.psnr);
    let ssim = lod::curves(refs, |r| r.ssim);
    let mut header = vec!["method".to_owned()];
    let mut table: Vec<Vec<String>> = psnr.keys().map(|m| vec![m.clone()]).collect();
    for b in LOD_BUDGETS {
        let points = (b * n).round();
        header.push(format!("{} % ({points:.0} pts)", percent(b)));
        let (p, s) = (means(&psnr, points), means(&ssim, points));
        for (row, ((_, p), (_, s))) in table.iter_mut().zip(p.iter().zip(&s)) {
            row.push(match (p, s) {
                (Some((pv, k)), Some((sv, _))) => format!("{pv:.2} / {sv:.3} ({k})"),
                (Some((pv, k)), None) => format!("{pv:.2} / - ({k})"),
                _ => "not reached".into(),
            });
        }
    }
    let identical: Vec<String> = psnr
        .keys()
        .filter_map(|m| {
            let k = refs
                .iter()
                .filter(|r| &r.method == m && r.psnr >= IDENTICAL_PSNR)
                .count();
            (k > 0).then(|| format!("{m} ({k} rows)"))
        })
        .collect();
    let head: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut out = format!(
        "PSNR (dB) / SSIM at fixed shares of the {n:.0} points, each method's curve read per \
         view by interpolation in log points, never extrapolated; the mean over the views \
         where the budget lies within the method's sweep, their count of {cells_total} in \
         brackets (`not reached`: none). The verdicts, over the views every \
         compared method reached, are in [findings.md](findings.md).{}\n\n{}\n",
        if identical.is_empty() {
            String::new()
        } else {
            format!(
                " Images identical to the reference (PSNR at its {IDENTICAL_PSNR:.0} dB cap) \
                 are no point of a curve or figure: {}.",
                identical.join(", ")
            )
        },
        markdown_table(&head, &table)
    );
    let bd = lod::bd_cells(&psnr);
    if !bd.is_empty() {
        let table: Vec<Vec<String>> = psnr
            .keys()
            .filter(|m| *m != BD_ANCHOR)
            .map(|m| {
                let v: Vec<f64> = bd
                    .iter()
                    .filter(|c| &c.method == m)
                    .map(|c| c.value)
                    .collect();
                let text = bootstrap_mean(&v, SEED).map_or("not comparable".into(), |e| {
                    e.text(|x| format!("{x:+.2}"), " dB")
                });
                vec![m.clone(), text, format!("{} of {cells_total}", v.len())]
            })
            .collect();
        out.push_str(&format!(
            "BD-PSNR against `{BD_ANCHOR}` (ITU-T VCEG-M33's mean PSNR difference over the \
             common range of log points, with piecewise-linear curves), per view, then the \
             mean over the views where the method has at least two points of its \
             curve in the common range, with its bootstrap 95 % interval:\n\n{}\n",
            markdown_table(&["method", "BD-PSNR", "comparable views"], &table)
        ));
    }
    out
}
