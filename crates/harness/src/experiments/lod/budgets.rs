//! The LOD summary's rate-distortion tables, from the findings' curves
//! ([`crate::experiments::rules::curve`]): each method's PSNR and SSIM read at the fixed point
//! budgets, per view on its own curve, and its BD-PSNR against the random subsample, one pair
//! of tables per distance (as the findings judge each distance on its own). The verdicts over
//! them are the findings'; these tables show every method's numbers, with how many views each
//! one's mean is over; and [`methods_by_datasets`], the papers' one-glance table of every
//! method's BD-PSNR on every dataset and distance.

use crate::experiments::markdown_table;
use crate::experiments::rules::curve::{
    self as lod, BD_ANCHOR, Curves, IDENTICAL_PSNR, LOD_BUDGETS, LodRow, percent,
};
use crate::experiments::rules::verdict::{Cell, SEED};
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

/// The values of `method`'s cells.
fn values_of(cells: &[Cell], method: &str) -> Vec<f64> {
    cells
        .iter()
        .filter(|c| c.method == method)
        .map(|c| c.value)
        .collect()
}

/// Mean of `cells`' values per method (with how many cells), `None` for a method without any.
fn means(curves: &Curves, points: f64) -> Vec<(String, Option<(f64, usize)>)> {
    let cells = lod::at_budget(curves, points);
    curves
        .keys()
        .map(|m| {
            let v = values_of(&cells, m);
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

/// Every method's BD-PSNR against the random subsample ([`at_distance`]'s, with its bootstrap
/// interval over the comparable views), methods by (dataset, distance), the best of each
/// column in bold: the papers' table at a glance. Empty without a comparable method.
pub(super) fn methods_by_datasets(rows: &[Row], quick: bool) -> String {
    let mut columns: Vec<(String, f64)> = rows
        .iter()
        .filter(|r| r.status == "ok")
        .map(|r| (r.dataset.clone(), r.distance))
        .collect();
    columns.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    columns.dedup();
    let mut methods: Vec<String> = rows
        .iter()
        .filter(|r| r.status == "ok" && r.method != BD_ANCHOR)
        .map(|r| r.method.clone())
        .collect();
    methods.sort();
    methods.dedup();
    // Per column: each method's estimate, `Err(true)` when it ran there but is not
    // comparable, `Err(false)` when it did not run there.
    let estimates: Vec<Vec<Result<crate::stats::Estimate, bool>>> = columns
        .iter()
        .map(|(ds, d)| {
            let own = ok_rows(rows, ds);
            let at: Vec<&LodRow> = own.iter().filter(|r| r.distance == *d).collect();
            let bd = lod::bd_cells(&lod::curves(&at, |r| r.psnr));
            methods
                .iter()
                .map(|m| {
                    let v = values_of(&bd, m);
                    bootstrap_mean(&v, SEED).ok_or_else(|| at.iter().any(|r| &r.method == m))
                })
                .collect()
        })
        .collect();
    if estimates.iter().flatten().all(Result::is_err) {
        return String::new();
    }
    let table: Vec<Vec<String>> = methods
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mut row = vec![m.clone()];
            for column in &estimates {
                let best = column
                    .iter()
                    .flatten()
                    .map(|e| e.value)
                    .max_by(f64::total_cmp);
                row.push(match &column[i] {
                    Ok(e) => {
                        let text = bd_text(e, "", quick);
                        if Some(e.value) == best {
                            format!("**{text}**")
                        } else {
                            text
                        }
                    }
                    Err(true) => "not comparable".into(),
                    Err(false) => "-".into(),
                });
            }
            row
        })
        .collect();
    let header: Vec<String> = std::iter::once("method".to_owned())
        .chain(columns.iter().map(|(ds, d)| format!("{ds} ×{d}")))
        .collect();
    let head: Vec<&str> = header.iter().map(String::as_str).collect();
    format!(
        "BD-PSNR (dB) against `{BD_ANCHOR}` [95 % interval over the comparable views], methods \
         by dataset and distance; the best of each column in bold (`not comparable`: fewer than \
         two points of the method's curve in the common range on every view; `-`: not run \
         there). Per dataset \
         below: the curves, PSNR at each budget and the views each figure is over.\n\n{}\n",
        markdown_table(&head, &table)
    )
}

/// A BD-PSNR estimate as a table prints it: with its interval, or, from a quick run (whose
/// figures are indicative), the mean alone, saying so.
fn bd_text(e: &crate::stats::Estimate, unit: &str, quick: bool) -> String {
    if quick {
        format!("{:+.2}{unit} (indicative: quick run)", e.value)
    } else {
        e.text(|x| format!("{x:+.2}"), unit)
    }
}

/// The tables of dataset `ds` (markdown), per distance; empty without ok rows. `quick`: a
/// quick run's, whose BD-PSNR is printed without its interval.
pub(super) fn tables(rows: &[Row], ds: &str, quick: bool) -> String {
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
            format!("At distance ×{d}: {}", at_distance(&at, n, quick))
        })
        .collect()
}

/// The tables of one dataset's ok rows at one distance, `n` its points.
fn at_distance(refs: &[&LodRow], n: f64, quick: bool) -> String {
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
                let v = values_of(&bd, m);
                let text = bootstrap_mean(&v, SEED)
                    .map_or("not comparable".into(), |e| bd_text(&e, " dB", quick));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of `method` on `ds` at distance 1 on 6 views: PSNR `offset + log10(points)` at
    /// each of `points`.
    fn curve(ds: &str, method: &str, offset: f64, points: &[usize]) -> Vec<Row> {
        let mut rows = Vec::new();
        for view in 0..6 {
            for &p in points {
                let mut r = Row::new(
                    ds.into(),
                    view,
                    1.0,
                    method.into(),
                    format!("p={p}"),
                    "ok".into(),
                );
                r.points_rendered = p;
                r.psnr = offset + (p as f64).log10() + 0.01 * view as f64;
                r.ssim = 0.5;
                r.n_points = 10_000;
                rows.push(r);
            }
        }
        rows
    }

    #[test]
    fn the_methods_by_datasets_table_bolds_each_columns_best_bd_psnr() {
        let sweep = [100, 300, 1_000, 3_000];
        let mut rows = Vec::new();
        for ds in ["a", "b"] {
            rows.extend(curve(ds, BD_ANCHOR, 10.0, &sweep));
        }
        // `qsplat` leads on `a`, `spt` on `b`; `one` has a single point of its curve.
        rows.extend(curve("a", "qsplat", 12.0, &sweep));
        rows.extend(curve("b", "qsplat", 10.5, &sweep));
        rows.extend(curve("a", "spt", 11.0, &sweep));
        rows.extend(curve("b", "spt", 11.5, &sweep));
        rows.extend(curve("a", "one", 15.0, &[1_000]));
        let table = methods_by_datasets(&rows, false);
        let line = |m: &str| {
            table
                .lines()
                .find(|l| l.starts_with(&format!("| {m} |")))
                .unwrap_or_else(|| panic!("no row for {m} in {table}"))
                .to_owned()
        };
        assert!(table.contains("| method | a ×1 | b ×1 |"), "{table}");
        assert!(
            line("qsplat").contains("| **+2.00 [+2.00, +2.00]** | +0.50"),
            "{table}"
        );
        assert!(
            line("spt").contains("| +1.00 [+1.00, +1.00] | **+1.50"),
            "{table}"
        );
        assert!(line("one").contains("| not comparable | - |"), "{table}");
        assert!(!table.contains(&format!("| {BD_ANCHOR} |")), "{table}");
        let quick = methods_by_datasets(&rows, true);
        assert!(
            quick.contains("| **+2.00 (indicative: quick run)** |") && !quick.contains("[+"),
            "{quick}"
        );
    }

    #[test]
    fn the_methods_by_datasets_table_is_empty_without_a_comparable_method() {
        assert!(methods_by_datasets(&curve("a", BD_ANCHOR, 10.0, &[100, 1_000]), false).is_empty());
    }
}
