//! The hull experiment's comparisons with ours: every hull's time over our own hull's, paired
//! per (view, γ) cell (the one table of ratios, [`crate::experiments::ratios`]), and the
//! seconds figure's series, each a median over the cells every compared hull ran (a hull with
//! fewer cells, or whose sets missed the exact one, drawn apart and labelled so).

use std::collections::{BTreeMap, BTreeSet};

use super::{CGAL, Row, cells as hull_cells, fmt_s, median_of};
use crate::experiments::markdown_table;
use crate::experiments::rules::ratio;
use crate::experiments::rules::verdict::compared;
use crate::experiments::rules::wrong::{self, Wrong};
use crate::output::figure::{Draw, Point, Series};
use crate::output::style;

/// Every hull against ours (`own`, k = 0), from the ratios table: time ratio with its interval,
/// identical sets, wrong answers; then the hulls not run and why.
pub(super) fn table(rows: &[Row], not_run: &[String], repeats: u64) -> String {
    let mut table = Vec::new();
    for r in ratio::hull(&hull_cells(rows)) {
        let d = r.dataset.as_str();
        let cells: Vec<&Row> = rows
            .iter()
            .filter(|x| x.dataset == d && x.hull == r.peer && x.perturb == 0.0 && x.status == "ok")
            .collect();
        let identical = cells.iter().filter(|x| x.jaccard_vs_exact == 1.0).count();
        table.push(vec![
            d.to_owned(),
            r.peer.clone(),
            r.pairs.to_string(),
            fmt_s(median_of(
                rows,
                |x| x.dataset == d && x.hull == r.peer && x.perturb == 0.0,
                |x| x.seconds,
            )),
            fmt_s(median_of(
                rows,
                |x| x.dataset == d && x.hull == ratio::OWN_HULL && x.perturb == 0.0,
                |x| x.seconds,
            )),
            r.text(),
            format!("{identical} of {}", cells.len()),
            if r.note.is_empty() {
                "-".into()
            } else {
                r.note.clone()
            },
        ]);
    }
    let mut out = String::new();
    if !table.is_empty() {
        out.push_str(&format!(
            "**Every hull in the same HPR against ours (`own`, k = 0)**, paired per (view, γ) \
             cell: its seconds of flip + hull + mapping (median of up to {repeats} runs, fewer \
             under the time budget; CGAL's (`{CGAL}`), its own reported seconds) over ours, \
             geometric mean with its bootstrap 95 % interval (from 5 views), as \
             `reports/ratios.csv` has it; identical: the visible sets equal; a hull whose sets \
             missed the exact one (Jaccard below 0.999) is marked `wrong answers`: its time is \
             no comparison.\n\n{}\n",
            markdown_table(
                &[
                    "dataset",
                    "hull",
                    "pairs",
                    "its median s",
                    "own median s",
                    "its time ÷ own [95 % CI]",
                    "identical sets",
                    "wrong answers",
                ],
                &table
            )
        ));
    }
    for n in not_run {
        out.push_str(&format!("- not run: {n}\n"));
    }
    if !not_run.is_empty() {
        out.push('\n');
    }
    out
}

/// The seconds figure's series: per hull, its median and quartiles over the (view, γ) cells
/// every compared hull ran on each dataset; a hull that ran fewer cells there, or whose sets
/// missed the exact one, in a series apart labelled with its count or its worst Jaccard.
pub(super) fn seconds_series(
    rows: &[Row],
    datasets: &[String],
    hulls: &[&str],
    wrong: &Wrong,
) -> Vec<Series> {
    type Times = BTreeMap<(usize, u64), f64>;
    let ok = |r: &&Row| r.status == "ok" && r.perturb == 0.0;
    type Compared<'a> = (
        BTreeMap<&'a str, Times>,
        Vec<&'a str>,
        BTreeSet<(usize, u64)>,
    );
    let mut per: BTreeMap<&str, Compared<'_>> = BTreeMap::new();
    for d in datasets {
        let mut cells: BTreeMap<&str, Times> = BTreeMap::new();
        for r in rows.iter().filter(ok).filter(|r| r.dataset == *d) {
            cells
                .entry(r.hull.as_str())
                .or_default()
                .insert((r.view, r.gamma.to_bits()), r.seconds);
        }
        let fair: BTreeMap<&str, Times> = cells
            .iter()
            .filter(|(h, _)| wrong.get(h).is_none())
            .map(|(h, c)| (*h, c.clone()))
            .collect();
        let (complete, keys) = compared(&fair);
        per.insert(d.as_str(), (cells, complete, keys));
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        let m = super::median(v.clone());
        (m, at(0.25), at(0.75))
    };
    let mut out = Vec::new();
    for h in hulls {
        let (mut main, mut apart) = (Vec::new(), Vec::new());
        let mut counts = Vec::new();
        for (k, d) in datasets.iter().enumerate() {
            let (cells, complete, keys) = &per[d.as_str()];
            let Some(c) = cells.get(h) else { continue };
            let comparable = complete.iter().any(|x| x == h);
            let mut v: Vec<f64> = if comparable {
                keys.iter().map(|key| c[key]).collect()
            } else {
                c.values().copied().collect()
            };
            let (m, lo, hi) = stats(&mut v);
            let p = Point::new(k as f64, m).y_interval(lo, hi).seconds(m);
            if comparable {
                main.push(p);
            } else {
                counts.push(format!("{d}: {} of {} cells", c.len(), keys.len()));
                apart.push(p);
            }
        }
        let family = format!("hull-{h}");
        if let Some(j) = wrong.get(h) {
            let mut all = main;
            all.extend(apart);
            out.push(
                Series::new(h, &family, style::WRONG, Draw::Points, all)
                    .label(format!("{h} — {}", wrong::note(j))),
            );
            continue;
        }
        if !main.is_empty() {
            out.push(Series::new(h, &family, "", Draw::Points, main));
        }
        if !apart.is_empty() {
            out.push(
                Series::new(h, &family, "fewer cells", Draw::Points, apart)
                    .label(format!("{h}, apart: {}", counts.join(", "))),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(hull: &str, view: usize, gamma: f64, seconds: f64, jaccard: f64) -> Row {
        Row {
            dataset: "d".into(),
            n_points: 10,
            view,
            gamma,
            hull: hull.into(),
            perturb: 0.0,
            seconds,
            samples: 3,
            n_visible: 5,
            jaccard_vs_exact: jaccard,
            f1_vs_reference: 0.9,
            status: "ok".into(),
            visible_sha256: String::new(),
        }
    }

    #[test]
    fn every_hull_is_paired_with_own_per_view_and_gamma_and_a_wrong_one_is_marked() {
        let mut rows = Vec::new();
        for view in 0..3 {
            for gamma in [2.0, 3.0] {
                rows.push(row("own", view, gamma, 0.1, 1.0));
                let j = if view == 2 { 0.99 } else { 1.0 };
                rows.push(row(CGAL, view, gamma, 0.5, j));
            }
        }
        let t = table(&rows, &[], 3);
        let line = t.lines().find(|l| l.starts_with("| d | cgal |")).expect(&t);
        // 6 cells but 3 views: no interval; 4 of 6 sets identical; below 0.999: wrong answers.
        assert!(
            line.contains("| 6 |") && line.contains("5.00× (indicative: 3 views)"),
            "{line}"
        );
        assert!(line.contains("4 of 6"), "{line}");
        assert!(
            line.contains("wrong answers (worst Jaccard 0.990)"),
            "{line}"
        );
        // From 5 views, its interval.
        let five: Vec<Row> = (0..5)
            .flat_map(|view| {
                [2.0, 3.0].into_iter().flat_map(move |gamma| {
                    [
                        row("own", view, gamma, 0.1, 1.0),
                        row(CGAL, view, gamma, 0.5, 1.0),
                    ]
                })
            })
            .collect();
        let t5 = table(&five, &[], 3);
        let line5 = t5
            .lines()
            .find(|l| l.starts_with("| d | cgal |"))
            .expect(&t5);
        assert!(
            line5.contains("| 10 |") && line5.contains("5.00× [5.00, 5.00]"),
            "{line5}"
        );
        assert_eq!(
            table(&rows[..0], &["cgal-hpr: not installed".into()], 3),
            "- not run: cgal-hpr: not installed\n\n"
        );
    }

    #[test]
    fn the_seconds_figure_draws_a_hull_with_fewer_cells_apart() {
        let mut rows = Vec::new();
        for view in 0..3 {
            for gamma in [2.0, 3.0] {
                rows.push(row("own", view, gamma, 0.1, 1.0));
                rows.push(row("qhull", view, gamma, 1.0, 1.0));
            }
        }
        // chull ran one cell, and a fast one: no median beside the others'.
        rows.push(row("chull", 0, 3.0, 0.001, 1.0));
        rows.push(row("quick", 0, 3.0, 0.001, 0.2));
        let wrong = Wrong(BTreeMap::from([("quick".to_owned(), 0.2)]));
        let series = seconds_series(
            &rows,
            &["d".into()],
            &["own", "qhull", "chull", "quick"],
            &wrong,
        );
        let labels: Vec<String> = series.iter().map(|s| s.label.clone()).collect();
        assert_eq!(
            labels,
            [
                "own",
                "qhull",
                "chull, apart: d: 1 of 6 cells",
                "quick — wrong answers (worst Jaccard 0.200)"
            ]
        );
        // The wrong hull in the wrong answers' own grey; the others in their families' colours.
        assert_eq!(series[3].style.color, style::WRONG_COLOR);
        assert!(
            series[..3]
                .iter()
                .all(|s| s.style.color != style::WRONG_COLOR)
        );
    }
}
