//! The robustness report's comparison tables, drawn from `results.csv` alone (so `pointsight
//! tables` redraws them):
//!
//! - [`winners`]: per dataset, degradation and level, the findings' verdict
//!   (`crate::experiments::rules::verdict`: the best mean F1 over the views, either setting,
//!   against the best distinct other method, the F1 difference paired per view with its
//!   bootstrap 95 % interval and the practical margin), and what each costs;
//! - [`mehra`]: the comparison of Mehra et al. 2010 (their project page's figure: HPR against
//!   the robust operator on clouds perturbed uniformly along the normal, noise margins in
//!   bounding-box diagonals, false positives and false negatives against a z-buffer of the
//!   source mesh), as rates: false positives over the truly hidden points, false negatives over
//!   the truly visible ones;
//! - [`biasutti`]: the comparison of Biasutti et al. 2019 (HPR, screen-space operators and
//!   their variable-density operator on mobile-mapping scans), on our simulated mobile and
//!   terrestrial scans, every method beside them;
//! - [`methods_by_datasets`]: per degradation, every method's mean F1 on every dataset, the
//!   best of each dataset in bold (the papers' one-glance table).

use std::collections::BTreeMap;

use registry::Comparison;

use super::{Row, median};
use crate::experiments::markdown_table;
use crate::experiments::rules::verdict::{Cell, Rules, SEED, verdict};
use crate::stats::{Estimate, bootstrap_mean};

/// A cell of the comparison: dataset, degradation, level (×10⁶, rounded).
type Key = (String, String, i64);

/// Per cell (dataset, degradation, level): the findings' verdict ([`verdict`]: each method at
/// the better of `best` and `auto` by its mean F1 over the views, the runner-up the best
/// distinct other method, the paired difference against the F1 margin), and what each costs.
pub fn winners(rows: &[Row]) -> String {
    let mut cells: BTreeMap<Key, Vec<Cell>> = BTreeMap::new();
    let mut seconds: BTreeMap<(Key, String, String), Vec<f64>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.status == "ok") {
        let key = (
            r.dataset.clone(),
            r.degradation.clone(),
            (r.level * 1e6).round() as i64,
        );
        cells.entry(key.clone()).or_default().push(Cell::new(
            &r.method,
            &r.setting,
            r.view.to_string(),
            r.f1,
            r.seconds,
        ));
        seconds
            .entry((key, r.method.clone(), r.setting.clone()))
            .or_default()
            .push(r.seconds);
    }
    let mut table = Vec::new();
    for (key, cells) in cells {
        let Some(v) = verdict(&cells, Rules::F1) else {
            continue;
        };
        let secs = |m: &str, s: &str| {
            seconds
                .get(&(key.clone(), m.to_owned(), s.to_owned()))
                .map_or("-".into(), |x| format!("{:.3}", median(x.clone())))
        };
        let (runner, runner_f1, runner_s, diff) = match &v.runner_up {
            Some(r) => (
                format!("{} {}", r.method, r.setting),
                format!("{:.3}", r.value),
                secs(&r.method, &r.setting),
                r.difference
                    .map_or("-".into(), |e| e.text(|x| format!("{x:+.3}"), "")),
            ),
            None => ("-".into(), "-".into(), "-".into(), "-".into()),
        };
        let identical: Vec<String> = v
            .identical
            .iter()
            .map(|(m, s)| format!("{m} {s}"))
            .collect();
        let apart: Vec<String> = v
            .apart
            .iter()
            .map(|(m, n)| format!("{m}: {n} of {} views", v.keys))
            .collect();
        table.push(vec![
            key.0.clone(),
            key.1.clone(),
            format!("{}", key.2 as f64 / 1e6),
            format!("{} {}", v.method, v.setting),
            format!("{:.3}", v.value.value),
            secs(&v.method, &v.setting),
            runner,
            runner_f1,
            runner_s,
            diff,
            v.word().to_owned(),
            [identical.join(", "), apart.join(", ")]
                .into_iter()
                .filter(|s| !s.is_empty())
                .collect::<Vec<_>>()
                .join("; "),
        ]);
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "Which method is best, per dataset, degradation and level, by the findings' rules \
         (`docs/verdicts.md`): each method at the better of `best` and `auto` by its mean F1 over \
         the views; the runner-up is the best other method whose sets differ (one with the same \
         F1 on every view is named identical); the F1 difference is the mean over the views of \
         the paired differences, with its bootstrap 95 % interval, judged against ±0.005 F1 \
         (*wins* above it, *equivalent* within it, else *no clear winner*). Seconds: median per \
         view.\n\n{}\n",
        markdown_table(
            &[
                "dataset",
                "degradation",
                "level",
                "best",
                "mean F1",
                "s",
                "runner-up",
                "mean F1",
                "s",
                "F1 difference (95 % interval)",
                "verdict",
                "identical; not ranked",
            ],
            &table
        )
    )
}

/// A method's F1 values in one table cell: view -> level -> F1, per setting.
type Views = BTreeMap<usize, BTreeMap<i64, f64>>;

/// One dataset's cells of one degradation: (method, setting) -> its values.
type Settings<'a> = BTreeMap<(&'a str, &'a str), Views>;

/// A method's entry in one column: its estimate, the setting it is at, its cells.
type Entry<'a> = Option<(Estimate, &'a str, usize)>;

/// Per degradation (the clean clouds first, the simulated scans last), methods by datasets:
/// each method's F1 on each view averaged over the degradation's levels run on that dataset,
/// then the mean over the views with its bootstrap 95 % interval; each method at the better of
/// `best` and `auto` there by that mean, the best of each dataset in bold. A method that
/// finished fewer (view, level) cells of a dataset than the most any method did is shown with
/// its count and never bold (its mean is over other cells). Empty without ok rows.
pub fn methods_by_datasets(rows: &[Row]) -> String {
    let mut cells: BTreeMap<&str, BTreeMap<&str, Settings<'_>>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.status == "ok" && r.f1.is_finite()) {
        cells
            .entry(r.degradation.as_str())
            .or_default()
            .entry(r.dataset.as_str())
            .or_default()
            .entry((r.method.as_str(), r.setting.as_str()))
            .or_default()
            .entry(r.view)
            .or_default()
            .insert((r.level * 1e6).round() as i64, r.f1);
    }
    let order = |d: &str| match d {
        "clean" => 0,
        "scan" => 2,
        _ => 1,
    };
    let mut degradations: Vec<&str> = cells.keys().copied().collect();
    degradations.sort_by_key(|d| (order(d), *d));
    let mut out = String::new();
    for degradation in degradations {
        let by_dataset = &cells[degradation];
        let datasets: Vec<&str> = by_dataset.keys().copied().collect();
        let mut methods: Vec<&str> = by_dataset
            .values()
            .flat_map(|m| m.keys().map(|(method, _)| *method))
            .collect();
        methods.sort_unstable();
        methods.dedup();
        // Per dataset, per method: the better setting's estimate, its name and its cells.
        let estimate = |ds: &str, method: &str| -> Entry<'_> {
            by_dataset[ds]
                .iter()
                .filter(|((m, _), _)| *m == method)
                .filter_map(|((_, setting), views)| {
                    let per_view: Vec<f64> = views
                        .values()
                        .map(|f| f.values().sum::<f64>() / f.len() as f64)
                        .collect();
                    let n = views.values().map(BTreeMap::len).sum();
                    bootstrap_mean(&per_view, SEED).map(|e| (e, *setting, n))
                })
                .max_by(|a, b| a.0.value.total_cmp(&b.0.value))
        };
        let columns: Vec<Vec<Entry<'_>>> = datasets
            .iter()
            .map(|ds| methods.iter().map(|m| estimate(ds, m)).collect())
            .collect();
        let table: Vec<Vec<String>> = methods
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let mut row = vec![(*m).to_owned()];
                for column in &columns {
                    let most = column.iter().flatten().map(|c| c.2).max().unwrap_or(0);
                    let best = column
                        .iter()
                        .flatten()
                        .filter(|c| c.2 == most)
                        .map(|c| c.0.value)
                        .max_by(f64::total_cmp);
                    row.push(match &column[i] {
                        Some((e, setting, n)) => {
                            let text = format!("{} ({setting})", e.text(|x| format!("{x:.3}"), ""));
                            if *n < most {
                                format!("{text}, {n} of {most} cells")
                            } else if Some(e.value) == best {
                                format!("**{text}**")
                            } else {
                                text
                            }
                        }
                        None => "-".into(),
                    });
                }
                row
            })
            .collect();
        let header: Vec<&str> = std::iter::once("method")
            .chain(datasets.iter().copied())
            .collect();
        out.push_str(&format!(
            "{degradation}: mean F1 [95 % interval over the views], each view's F1 averaged over \
             the levels run on that dataset, each method at the better of `best` and `auto` (in \
             brackets after the interval); the best of each dataset in bold, among the methods \
             that finished every (view, level) cell any method did (`k of n cells`: fewer, not \
             ranked).\n\n{}\n",
            markdown_table(&header, &table)
        ));
    }
    out
}

/// True when the method called `name` is one `paper` compared (its card says so).
fn compared_in(catalogue: &registry::Catalogue, name: &str, paper: Comparison) -> bool {
    catalogue
        .card_named(name)
        .is_some_and(|c| c.compared_in.contains(&paper))
}

/// False-positive and false-negative rates of HPR and the robust operator on the clean cloud and
/// under the uniform noise along the normal (degradation `jitter`).
pub fn mehra(catalogue: &registry::Catalogue, rows: &[Row]) -> String {
    type Key = (String, i64, String, String);
    /// Per view: false-positive rate, false-negative rate, F1.
    type Rates = (Vec<f64>, Vec<f64>, Vec<f64>);
    let mut rates: BTreeMap<Key, Rates> = BTreeMap::new();
    for r in rows.iter().filter(|r| {
        r.status == "ok"
            && (r.degradation == "jitter" || r.degradation == "clean")
            && compared_in(catalogue, &r.method, Comparison::Mehra2010)
    }) {
        let surface = r.n_points - r.outliers;
        let visible = r.true_positives + r.false_negatives;
        let hidden = surface.saturating_sub(visible);
        let e = rates
            .entry((
                r.dataset.clone(),
                (r.level * 1e6).round() as i64,
                r.method.clone(),
                r.setting.clone(),
            ))
            .or_default();
        e.0.push(if hidden > 0 {
            r.false_positives as f64 / hidden as f64
        } else {
            f64::NAN
        });
        e.1.push(if visible > 0 {
            r.false_negatives as f64 / visible as f64
        } else {
            f64::NAN
        });
        e.2.push(r.f1);
    }
    if !rates.keys().any(|k| k.1 > 0) {
        return String::new();
    }
    let table: Vec<Vec<String>> = rates
        .into_iter()
        .map(|((ds, level, method, setting), (fp, fnr, f1))| {
            vec![
                ds,
                format!("{}", level as f64 / 1e6),
                format!("{method} {setting}"),
                format!("{:.2} %", 100.0 * median(fp)),
                format!("{:.2} %", 100.0 * median(fnr)),
                format!("{:.3}", median(f1)),
            ]
        })
        .collect();
    format!(
        "**Mehra et al. 2010, regenerated.** Their project page compares HPR with the robust \
         operator on clouds perturbed uniformly along the normal (noise margins in bounding-box \
         diagonals) by their false positives and false negatives against a z-buffer of the \
         source mesh; the figure's own numbers could not be read, so this is the same comparison \
         on our clouds, not a check of theirs. False-positive rate: points called visible over \
         the truly hidden ones; false-negative rate: visible points missed over the truly \
         visible ones (medians over the views; margin 0: the clean cloud).\n\n{}\n",
        markdown_table(
            &[
                "dataset",
                "margin (diagonals)",
                "method",
                "false positives",
                "false negatives",
                "F1",
            ],
            &table
        )
    )
}

/// Every method on the simulated scans (mobile first), the methods of Biasutti et al.'s
/// comparison marked.
pub fn biasutti(catalogue: &registry::Catalogue, rows: &[Row]) -> String {
    type Key = (bool, String, String, String);
    let mut cells: BTreeMap<Key, Vec<&Row>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.degradation == "scan") {
        cells
            .entry((
                !r.dataset.contains("mobile"),
                r.dataset.clone(),
                r.method.clone(),
                r.setting.clone(),
            ))
            .or_default()
            .push(r);
    }
    if !cells.keys().any(|k| !k.0) {
        return String::new();
    }
    let table: Vec<Vec<String>> = cells
        .into_iter()
        .map(|((_, ds, method, setting), rs)| {
            let ok: Vec<&&Row> = rs.iter().filter(|r| r.status == "ok").collect();
            let m = |f: fn(&Row) -> f64| median(ok.iter().map(|r| f(r)).collect());
            let theirs = compared_in(catalogue, &method, Comparison::Biasutti2019);
            vec![
                ds,
                if theirs {
                    format!("**{method}**")
                } else {
                    method
                },
                setting,
                format!("{:.3}", m(|r| r.precision)),
                format!("{:.3}", m(|r| r.recall)),
                format!("{:.3}", m(|r| r.f1)),
                format!("{:.3}", m(|r| r.seconds)),
                if ok.len() == rs.len() {
                    "ok".into()
                } else {
                    format!("{} of {} views failed", rs.len() - ok.len(), rs.len())
                },
            ]
        })
        .collect();
    format!(
        "**Biasutti et al. 2019's comparison, regenerated on simulated scans.** They compare HPR, \
         screen-space operators and their variable-density operator on mobile-mapping LiDAR; the \
         methods of that comparison are in bold (`hpr`, `screenspace` after Pintus et al., \
         `vardensity` after Biasutti et al.). `*-mobile`: one pass of a profile scanner beside \
         the mesh, seen from cameras on the vehicle; `*-scan-4`: four terrestrial scanners. The \
         paper's own numbers could not be read; this is the comparison on our scans. Medians \
         over the views.\n\n{}\n",
        markdown_table(
            &[
                "dataset",
                "method",
                "setting",
                "precision",
                "recall",
                "F1",
                "s",
                "status"
            ],
            &table
        )
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of `method` on view `view`: 100 surface points, 40 truly visible, of which `tp`
    /// found, and `fp` hidden ones reported.
    fn row(degradation: &str, level: f64, method: &str, view: usize, tp: usize, fp: usize) -> Row {
        let s = registry::scoring::Score {
            true_positives: tp,
            false_positives: fp,
            false_negatives: 40 - tp,
        };
        Row {
            dataset: "d".into(),
            degradation: degradation.into(),
            level,
            n_points: 100,
            method: method.into(),
            setting: "best".into(),
            params: String::new(),
            view,
            precision: s.precision(),
            recall: s.recall(),
            f1: s.f1(),
            true_positives: tp,
            false_positives: fp,
            false_negatives: 40 - tp,
            outliers: 0,
            outliers_visible: 0,
            seconds: 0.5,
            status: "ok".into(),
        }
    }

    #[test]
    fn mehra_rates_are_over_the_hidden_and_the_visible_points() {
        let rows = vec![
            row("jitter", 0.01, "hpr", 0, 30, 6),
            row("jitter", 0.01, "robust", 0, 40, 12),
            row("jitter", 0.01, "splat", 0, 40, 0),
        ];
        let t = mehra(&registry::Catalogue::builtin(), &rows);
        // hpr: 6 of 60 hidden reported (10 %), 10 of 40 visible missed (25 %).
        assert!(
            t.contains("| d | 0.01 | hpr best | 10.00 % | 25.00 % |"),
            "{t}"
        );
        assert!(
            t.contains("| d | 0.01 | robust best | 20.00 % | 0.00 % |"),
            "{t}"
        );
        assert!(
            !t.contains("splat"),
            "only HPR and the robust operator: {t}"
        );
        assert_eq!(mehra(&registry::Catalogue::builtin(), &rows[..0]), "");
    }

    #[test]
    fn the_winner_is_paired_per_view_against_the_best_other_method() {
        let mut rows = Vec::new();
        for v in 0..6 {
            rows.push(row("noise", 0.5, "a", v, 40, 0)); // F1 1
            rows.push(row("noise", 0.5, "b", v, 30, 0)); // F1 0.857
            rows.push(row("noise", 0.5, "c", v, 20, 0));
        }
        let t = winners(&rows);
        let line = t.lines().find(|l| l.starts_with("| d | noise")).expect(&t);
        assert!(line.contains("| a best | 1.000 |"), "{line}");
        assert!(line.contains("| b best | 0.857 |"), "{line}");
        // Every view differs by the same amount: the interval is that value.
        assert!(line.contains("+0.143 [+0.143, +0.143]"), "{line}");
        // A failed method does not take part.
        for r in rows.iter_mut().filter(|r| r.method == "a") {
            r.status = "error: x".into();
        }
        let t = winners(&rows);
        assert!(
            t.contains("| b best | 0.857 |") && t.contains("| c best |"),
            "{t}"
        );
    }

    #[test]
    fn two_views_print_no_interval() {
        let mut rows = Vec::new();
        for v in 0..2 {
            rows.push(row("noise", 0.5, "a", v, 40, 0));
            rows.push(row("noise", 0.5, "b", v, 30, 0));
        }
        let t = winners(&rows);
        let line = t.lines().find(|l| l.starts_with("| d | noise")).expect(&t);
        assert!(line.contains("+0.143 (indicative: 2 views)"), "{line}");
        assert!(!line.contains('['), "{line}");
    }

    #[test]
    fn biasutti_lists_the_scans_mobile_first_and_marks_the_compared_methods() {
        let mut rows = vec![
            row("scan", 0.0, "vardensity", 0, 40, 0),
            row("scan", 0.0, "raycast", 0, 40, 0),
        ];
        assert_eq!(
            biasutti(&registry::Catalogue::builtin(), &rows),
            "",
            "no mobile scan, no table"
        );
        rows.iter_mut().for_each(|r| r.dataset = "x-mobile".into());
        rows.push(Row {
            dataset: "x-scan-4".into(),
            ..row("scan", 0.0, "hpr", 0, 40, 0)
        });
        let t = biasutti(&registry::Catalogue::builtin(), &rows);
        let mobile = t.find("| x-mobile | **vardensity**").expect(&t);
        let terrestrial = t.find("| x-scan-4 | **hpr**").expect(&t);
        assert!(
            mobile < terrestrial && t.contains("| x-mobile | raycast |"),
            "{t}"
        );
    }

    #[test]
    fn the_methods_by_datasets_table_bolds_each_datasets_best_per_degradation() {
        let mut rows = Vec::new();
        for view in 0..6 {
            // Noise at two levels: `a` averages 30/40 found, `b` 35/40; clean: `a` leads.
            rows.push(row("noise", 0.1, "a", view, 30, 0));
            rows.push(row("noise", 0.2, "a", view, 30, 0));
            rows.push(row("noise", 0.1, "b", view, 36, 0));
            rows.push(row("noise", 0.2, "b", view, 34, 0));
            rows.push(row("clean", 0.0, "a", view, 40, 0));
            rows.push(row("clean", 0.0, "b", view, 38, 0));
            // `b`'s automatic rule is worse on the clean cloud: `best` is shown.
            let mut auto = row("clean", 0.0, "b", view, 20, 0);
            auto.setting = "auto".into();
            rows.push(auto);
        }
        let text = methods_by_datasets(&rows);
        let clean = text.find("clean:").expect("a clean table");
        let noise = text.find("noise:").expect("a noise table");
        assert!(clean < noise, "{text}");
        let (clean_part, noise_part) = text.split_at(noise);
        assert!(
            clean_part.contains("| a | **1.000 [1.000, 1.000] (best)** |"),
            "{text}"
        );
        assert!(
            clean_part.contains("| b | 0.974 [0.974, 0.974] (best) |"),
            "{text}"
        );
        let f1 = |tp: f64| 2.0 * tp / (tp + 40.0);
        let b = format!("{:.3}", (f1(36.0) + f1(34.0)) / 2.0);
        assert!(
            noise_part.contains(&format!("| b | **{b} [{b}, {b}] (best)** |")),
            "{text}"
        );
        assert!(methods_by_datasets(&[]).is_empty());
        // A method that finished fewer cells is shown with its count, never in bold.
        let mut fewer: Vec<Row> = rows
            .iter()
            .filter(|r| !(r.method == "b" && r.degradation == "noise" && r.level > 0.15))
            .cloned()
            .collect();
        fewer.retain(|r| r.degradation == "noise");
        let text = methods_by_datasets(&fewer);
        assert!(text.contains("(best), 6 of 12 cells |"), "{text}");
        assert!(text.contains("| a | **"), "{text}");
    }
}
