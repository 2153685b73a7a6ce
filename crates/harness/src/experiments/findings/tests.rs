//! Tests of the findings on small synthetic result rows.

use super::*;

fn cell(method: &str, setting: &str, view: usize, value: f64, cost: f64) -> Cell {
    Cell::new(method, setting, view.to_string(), value, cost)
}

/// The F1 rules with the cheapest sought within `tolerance`.
fn within(tolerance: f64) -> Rules {
    Rules {
        tolerance: Some(tolerance),
        ..Rules::F1
    }
}

/// Method `a` at two settings (the second better), `b` a little worse and faster, `c` much
/// worse and fastest, over `views` views.
fn three_methods(views: usize) -> Vec<Cell> {
    let mut cells = Vec::new();
    for v in 0..views {
        let wobble = 0.001 * (v % 3) as f64;
        cells.push(cell("a", "k=1", v, 0.80 + wobble, 1.0));
        cells.push(cell("a", "k=2", v, 0.95 + wobble, 2.0));
        cells.push(cell("b", "", v, 0.947 + wobble, 0.5));
        cells.push(cell("c", "", v, 0.50 + wobble, 0.1));
    }
    cells
}

#[test]
fn the_winner_is_the_best_method_at_its_best_setting() {
    let v = verdict(&three_methods(8), within(0.01)).unwrap();
    assert_eq!((v.method.as_str(), v.setting.as_str()), ("a", "k=2"));
    let mean = (0..8).map(|k| 0.95 + 0.001 * (k % 3) as f64).sum::<f64>() / 8.0;
    assert!((v.value.value - mean).abs() < 1e-12);
    assert_eq!(v.value.n, 8);
    let (lo, hi) = v.value.interval.expect("8 views give an interval");
    assert!(lo <= mean && mean <= hi);
    assert_eq!(v.cost, 2.0);
    let r = v.runner_up.clone().unwrap();
    assert_eq!((r.method.as_str(), r.setting.as_str()), ("b", ""));
    assert!((v.value.value - r.value - 0.003).abs() < 1e-12);
    let diff = r.difference.unwrap();
    assert!((diff.value - 0.003).abs() < 1e-12);
    // A lead of 0.003 on every view does not clear the margin: inside ± 0.005.
    assert_eq!(v.word(), "equivalent");
    // b is within 0.01 F1 of the best and cheaper; c is cheaper still but not within 0.01.
    let (cm, _, _, cc) = v.cheapest.clone().unwrap();
    assert_eq!((cm.as_str(), cc), ("b", 0.5));
    // With a tolerance wide enough, c is the cheapest.
    let wide = verdict(&three_methods(8), within(0.5)).unwrap();
    assert_eq!(wide.cheapest.unwrap().0, "c");
}

#[test]
fn equal_answers_are_named_identical_and_the_next_distinct_method_is_the_runner_up() {
    let mut cells = Vec::new();
    for v in 0..6 {
        cells.push(cell("zeta", "", v, 0.9, 1.0));
        cells.push(cell("alpha", "", v, 0.9, 2.0));
        cells.push(cell("beta", "", v, 0.8 + 0.001 * v as f64, 0.5));
    }
    // The same answers at half the cost: the cheaper is named best, the other identical, and
    // the runner-up is the next distinct method, far behind: it wins.
    let v = verdict(&cells, within(0.01)).unwrap();
    assert_eq!(v.method, "zeta");
    assert_eq!(v.identical, [("alpha".to_owned(), String::new())]);
    assert_eq!(v.runner_up.as_ref().unwrap().method, "beta");
    assert_eq!(v.word(), "wins");
    assert_eq!(v.cheapest.clone().unwrap().0, "zeta");
    let f = finding(
        Ask {
            experiment: "visibility",
            condition: "c".into(),
            question: "q",
            metric: "F1",
            cost_metric: "seconds per view",
            rules: Rules::F1,
            quick: false,
        },
        v,
        Vec::new(),
    );
    assert_eq!(f.identical, "alpha");
    assert!(
        markdown(&[f], false).contains("| identical answers: alpha; next: beta: +0.09"),
        "identical named before the runner-up"
    );
    // Equal scores but different answers (their fingerprints differ): not identical.
    let mut fp = Vec::new();
    for v in 0..6 {
        for (m, a) in [("zeta", "x"), ("alpha", "y")] {
            fp.push(Cell {
                answer: Some(format!("{a}{v}")),
                ..cell(m, "", v, 0.9, 1.0)
            });
        }
    }
    let v = verdict(&fp, Rules::F1).unwrap();
    assert!(v.identical.is_empty());
    assert_eq!(v.runner_up.as_ref().unwrap().method, "zeta");
    assert_eq!(v.word(), "equivalent");
    // Speed rules name nobody identical.
    let v = verdict(
        &cells,
        Rules {
            identical: false,
            ..Rules::F1
        },
    )
    .unwrap();
    assert_eq!(v.runner_up.as_ref().unwrap().method, "alpha");
    // Within a method, the cheaper of two equal settings.
    let mut cells = Vec::new();
    for v in 0..6 {
        cells.push(cell("zeta", "", v, 0.9, 1.0));
        cells.push(cell("alpha", "slow", v, 0.9, 3.0));
        cells.push(cell("alpha", "fast", v, 0.9, 1.0));
    }
    let v = verdict(&cells, Rules::F1).unwrap();
    assert_eq!((v.method.as_str(), v.setting.as_str()), ("alpha", "fast"));
}

#[test]
fn a_lead_wins_only_beyond_the_margin_and_is_equivalent_within_it() {
    // Paired differences around `lead` (± 0.001): above 0.005 wins; around 0.001 equivalent;
    // a noisy difference straddling the margin: no clear winner.
    let run = |lead: f64, noise: f64| {
        let mut cells = Vec::new();
        for v in 0..8 {
            let sign = if v % 2 == 0 { 1.0 } else { -1.0 };
            cells.push(cell("p", "", v, 0.9 + lead + noise * sign, 1.0));
            cells.push(cell("q", "", v, 0.9, 1.0));
        }
        verdict(&cells, Rules::F1).unwrap().word()
    };
    assert_eq!(run(0.02, 0.001), "wins");
    assert_eq!(run(0.001, 0.001), "equivalent");
    assert_eq!(run(0.006, 0.001), "wins");
    assert_eq!(run(0.004, 0.001), "equivalent");
    assert_eq!(run(0.005, 0.002), "no clear winner");
    assert_eq!(run(0.001, 0.05), "no clear winner");
    assert_eq!(verdict::interval_word(1.06, 1.2, 1.0, 0.05), "wins");
    assert_eq!(verdict::interval_word(0.97, 1.04, 1.0, 0.05), "equivalent");
    assert_eq!(
        verdict::interval_word(0.97, 1.2, 1.0, 0.05),
        "no clear winner"
    );
}

#[test]
fn only_the_cells_every_compared_method_has_are_averaged_and_the_rest_stand_apart() {
    let mut cells = Vec::new();
    for v in 0..6 {
        cells.push(cell("full", "", v, 0.8, 1.0));
        cells.push(cell("other", "", v, 0.7, 1.0));
    }
    // `lucky` ran two views, both perfect: it is no winner, it stands apart with its count.
    cells.push(cell("lucky", "", 0, 1.0, 0.1));
    cells.push(cell("lucky", "", 1, 1.0, 0.1));
    let v = verdict(&cells, Rules::F1).unwrap();
    assert_eq!(v.method, "full");
    assert_eq!(v.apart, [("lucky".to_owned(), 2)]);
    assert_eq!(v.keys, 6);
    let f = finding(
        Ask {
            experiment: "e",
            condition: "c".into(),
            question: "q",
            metric: "F1",
            cost_metric: "seconds per view",
            rules: Rules::F1,
            quick: false,
        },
        v,
        vec!["bad: wrong answers (worst Jaccard 0.500)".into()],
    );
    assert_eq!(
        f.not_ranked,
        "bad: wrong answers (worst Jaccard 0.500); lucky: 2 of 6 cells"
    );
    // Nobody ran every view: the keys of the one that ran most.
    let mut cells = Vec::new();
    for v in 0..5 {
        cells.push(cell("a", "", v, 0.5, 1.0));
        cells.push(cell("b", "", v + 1, 0.6, 1.0));
    }
    let v = verdict(&cells, Rules::F1).unwrap();
    assert_eq!((v.keys, v.apart.len()), (5, 1));
}

#[test]
fn fewer_than_five_views_give_no_interval_and_are_indicative() {
    let v = verdict(&three_methods(3), within(0.01)).unwrap();
    assert_eq!(v.value.interval, None);
    assert_eq!(v.value.n, 3);
    assert_eq!(
        v.runner_up.as_ref().unwrap().difference.unwrap().interval,
        None
    );
    assert_eq!(v.word(), "indicative");
    let f = finding(
        Ask {
            experiment: "visibility",
            condition: "toy".into(),
            question: "q",
            metric: "F1",
            cost_metric: "seconds per view",
            rules: Rules::F1,
            quick: false,
        },
        v,
        Vec::new(),
    );
    assert!(f.indicative);
    assert_eq!((f.low, f.high, f.difference_low), (None, None, None));
    let md = markdown(&[f], false);
    let row = md.lines().find(|l| l.contains("toy")).unwrap();
    assert!(row.contains("indicative: 3 views"), "{row}");
    // The only brackets of the row are the section link's.
    assert_eq!(row.matches('[').count(), 1, "{row}");
    assert!(md.starts_with("## Findings\n"));
    assert!(markdown(&[], true).is_empty());
}

#[test]
fn single_and_missing_methods() {
    assert!(verdict(&[], Rules::F1).is_none());
    let nan = [cell("a", "", 0, f64::NAN, 1.0)];
    assert!(verdict(&nan, Rules::F1).is_none());
    let one: Vec<Cell> = (0..5).map(|v| cell("a", "", v, 0.5, 1.0)).collect();
    let v = verdict(&one, Rules::F1).unwrap();
    assert_eq!(v.word(), "only method");
    assert_eq!(v.cheapest.unwrap().0, "a");
}

const VIS_HEADER: &str = "dataset,view,method,family,params,seconds,f1,status,extra\n";

/// A visibility results file: on `ds`, `hi` beats `lo` by 0.02 F1 on each of `views` views.
fn visibility_csv(ds: &str, views: usize) -> String {
    let mut s = String::new();
    for v in 0..views {
        let f = 0.9 + 0.01 * (v % 2) as f64;
        s.push_str(&format!("{ds},{v},hi,hi,g=1,0.2,{f},ok,x\n"));
        s.push_str(&format!("{ds},{v},hi,hi,g=2,0.1,{},ok,x\n", f - 0.5));
        s.push_str(&format!("{ds},{v},lo,lo,,0.01,{},ok,x\n", f - 0.02));
        s.push_str(&format!("{ds},{v},lo,lo,,0.01,0.99,error: it failed,x\n"));
    }
    s
}

#[test]
fn findings_come_from_the_csvs_of_the_experiments_present() {
    let dir = tempfile::tempdir().unwrap();
    // No experiment: no findings, no table.
    assert!(
        findings(dir.path(), &["visibility", "lod"])
            .unwrap()
            .is_empty()
    );
    std::fs::create_dir_all(dir.path().join("visibility")).unwrap();
    std::fs::write(
        dir.path().join("visibility/results.csv"),
        format!(
            "{VIS_HEADER}{}{}",
            visibility_csv("d1", 6),
            visibility_csv("d2", 2)
        ),
    )
    .unwrap();
    let found = findings(dir.path(), &["visibility", "robustness", "lod", "scale"]).unwrap();
    assert_eq!(found.len(), 2, "{found:?}");
    let (d1, d2) = (&found[0], &found[1]);
    // Neither is a built-in dataset: no tuning data, so the settings are the oracle's.
    let oracle = "(oracle: best setting on these data, no tuning data in the run)";
    assert_eq!(d1.condition, format!("d1 {oracle}"));
    assert_eq!(d2.condition, format!("d2 {oracle}"));
    assert_eq!((d1.method.as_str(), d1.setting.as_str()), ("hi", "g=1"));
    assert!((d1.value - 0.905).abs() < 1e-12, "{}", d1.value);
    assert!((d1.difference.unwrap() - 0.02).abs() < 1e-12);
    assert_eq!(d1.verdict, "wins");
    assert_eq!(d1.n_views, Some(6));
    assert!(!d1.indicative && d1.low.is_some());
    // The failed rows (F1 0.99) are not counted.
    assert!((d1.runner_up_value.unwrap() - 0.885).abs() < 1e-12);
    // lo is not within 0.01 of the best: the cheapest near the best is the best itself.
    assert_eq!(d1.cheapest, "hi g=1");
    assert!(d2.indicative && d2.low.is_none() && d2.n_views == Some(2));

    write(dir.path(), &found).unwrap();
    let back: Vec<Finding> = read_csv(&dir.path().join(CSV)).unwrap();
    assert_eq!(back.len(), 2);
    assert_eq!(back[0].method, "hi");
    assert_eq!(back[1].low, None);
    let text = std::fs::read_to_string(dir.path().join(CSV)).unwrap();
    assert!(text.starts_with(
        "experiment,condition,question,method,setting,metric,value,low,high,n_views,indicative,"
    ));
}

#[test]
fn the_report_page_opens_with_the_findings() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("visibility")).unwrap();
    std::fs::write(
        dir.path().join("visibility/results.csv"),
        format!("{VIS_HEADER}{}", visibility_csv("d1", 6)),
    )
    .unwrap();
    let long: String = (0..60).map(|k| format!("line {k}\n")).collect();
    std::fs::write(dir.path().join("visibility/summary.md"), &long).unwrap();
    let found = findings(dir.path(), &["visibility"]).unwrap();
    let sections = [crate::output::report::Section {
        name: "visibility",
        summary: "which points are visible",
    }];
    crate::output::report::assemble(dir.path(), &sections, &markdown(&found, true), true, "")
        .unwrap();
    let page = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
    assert!(page.starts_with("# pointsight results — indicative (quick run)\n"));
    let first = page.lines().find(|l| l.starts_with("## ")).unwrap();
    assert_eq!(first, "## Findings — indicative (quick run)");
    assert!(page.contains(
        "| [visibility](#visibility) | d1 (oracle: best setting on these data, no tuning data \
         in the run) | hi g=1 | F1 0.905 ["
    ));
    // A long summary is linked, not inlined.
    assert!(page.contains("[visibility/summary.md](visibility/summary.md)"));
    assert!(!page.contains("line 59"));
}

#[test]
fn the_fastest_hull_is_paired_per_cell_partial_hulls_stand_apart_and_wrong_ones_are_not_ranked() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("dataset,view,gamma,hull,perturb,seconds,jaccard_vs_exact,status\n");
    for view in 0..5 {
        for gamma in [2.0, 3.0] {
            let base = 0.01 * (1 + view) as f64;
            csv.push_str(&format!("d,{view},{gamma},own,0,{base},1,ok\n"));
            csv.push_str(&format!("d,{view},{gamma},qhull,0,{},1,ok\n", 2.0 * base));
            // The fastest of all, but its sets miss the exact one on one cell: never ranked.
            let j = if view == 3 { 0.5 } else { 1.0 };
            csv.push_str(&format!("d,{view},{gamma},quick,0,{},{j},ok\n", 0.1 * base));
            // Perturbed and failed rows do not count.
            csv.push_str(&format!("d,{view},{gamma},qhull,0.01,0.000001,0.1,ok\n"));
            csv.push_str(&format!("d,{view},{gamma},own,0,0.000001,1,error: x\n"));
        }
    }
    csv.push_str("d,0,3,chull,0,0.000001,1,ok\n");
    std::fs::create_dir_all(dir.path().join("hull")).unwrap();
    std::fs::write(dir.path().join("hull/results.csv"), csv).unwrap();
    let found = findings(dir.path(), &["hull"]).unwrap();
    assert_eq!(found.len(), 1, "{found:?}");
    let f = &found[0];
    assert_eq!(f.method, "own");
    assert_eq!(f.condition, "d, 2 of 4 hulls on all 10 (view, γ) cells");
    assert_eq!(f.runner_up, "qhull");
    assert!((f.difference.unwrap() - 2.0).abs() < 1e-9);
    let (lo, hi) = (f.difference_low.unwrap(), f.difference_high.unwrap());
    assert!((lo - 2.0).abs() < 1e-9 && (hi - 2.0).abs() < 1e-9);
    assert_eq!(f.verdict, "wins");
    assert_eq!(
        f.not_ranked,
        "quick: wrong answers (worst Jaccard 0.500); chull: 1 of 10 cells"
    );
    let geomean = ((1..=5).map(|k| (0.01 * k as f64).ln()).sum::<f64>() / 5.0).exp();
    assert!((f.value - geomean).abs() < 1e-12, "{}", f.value);
    assert!(markdown(&found, false).contains("qhull: 2.00× the time [2.00, 2.00] (wins)"));
}

/// The LOD findings of dataset `d` (1000 points) over 5 views, each view's rows
/// (distance, method, setting, points rendered, PSNR) given by `rows`.
fn lod_findings(
    rows: impl Fn(usize) -> Vec<(u32, &'static str, &'static str, f64, f64)>,
) -> Vec<Finding> {
    let dir = tempfile::tempdir().unwrap();
    let mut lod =
        String::from("dataset,view,distance,method,params,points_rendered,psnr,status,n_points\n");
    for view in 0..5 {
        for (d, m, p, pts, psnr) in rows(view) {
            lod.push_str(&format!("d,{view},{d},{m},{p},{pts},{psnr},ok,1000\n"));
        }
    }
    std::fs::create_dir_all(dir.path().join("lod")).unwrap();
    std::fs::write(dir.path().join("lod/results.csv"), lod).unwrap();
    findings(dir.path(), &["lod"]).unwrap()
}

#[test]
fn lod_reads_each_curve_at_the_budgets_never_beyond_its_sweep() {
    // Of 1000 points: `a` drew 50 and 200 (its sweep ends exactly at the 20 % budget), `b` 20
    // and 100, the random subsample 10 to 300; `full` only images identical to the reference.
    let found = lod_findings(|_| {
        [
            (1, "full", "", 1000.0, 100.0),
            (1, "a", "k=1", 50.0, 10.0),
            (1, "a", "k=2", 200.0, 16.0),
            (1, "b", "e=1", 20.0, 9.0),
            (1, "b", "e=2", 100.0, 14.0),
            (1, "random", "f=1", 10.0, 6.0),
            (1, "random", "f=2", 50.0, 10.0),
            (1, "random", "f=3", 100.0, 12.0),
            (1, "random", "f=4", 300.0, 15.0),
        ]
        .to_vec()
    });
    let rows: Vec<(&str, &str, &str)> = found
        .iter()
        .map(|f| {
            (
                f.condition.as_str(),
                f.method.as_str(),
                f.runner_up.as_str(),
            )
        })
        .collect();
    let bd = "d at distance ×1, BD-PSNR against random over each view's common range of log \
              points";
    assert_eq!(
        rows,
        [
            ("d at distance ×1, at 1 % of the points (10)", "random", ""),
            ("d at distance ×1, at 2 % of the points (20)", "b", "random"),
            ("d at distance ×1, at 5 % of the points (50)", "b", "a"),
            ("d at distance ×1, at 10 % of the points (100)", "b", "a"),
            (
                "d at distance ×1, at 20 % of the points (200)",
                "a",
                "random"
            ),
            (
                "d at distance ×1, at 30 % of the points (300)",
                "random",
                ""
            ),
            (bd, "b", "a"),
        ]
    );
    // Interpolated in log points: b at 50 points lies 0.569 of the way (ln 2.5 / ln 5) from 9
    // to 14 dB; a at 100, half-way from 10 to 16.
    let at = |x0: f64, y0: f64, x1: f64, y1: f64, x: f64| {
        y0 + (y1 - y0) * (x / x0).ln() / (x1 / x0).ln()
    };
    assert!((found[2].value - at(20.0, 9.0, 100.0, 14.0, 50.0)).abs() < 1e-9);
    assert!((found[3].runner_up_value.unwrap() - 13.0).abs() < 1e-9);
    assert_eq!(found[3].verdict, "wins");
    // The budget edge: a's sweep ends at 200 points, so a reaches 20 % and not 30 %; b's at
    // 100; identical images are no curve: `full` reaches nothing.
    assert_eq!(found[4].value, 16.0);
    assert_eq!(found[4].not_ranked, "b: not reached; full: not reached");
    assert_eq!(found[5].verdict, "only method");
    assert!(found[5].not_ranked.contains("a: not reached"));
    // BD-PSNR against random over the common range: a's gap, averaged per segment (a runs
    // second to b, whose curve lies further above random's).
    let r200 = at(100.0, 12.0, 300.0, 15.0, 200.0);
    let random_mean = (11.0 + 0.5 * (12.0 + r200)) / 2.0;
    let a_bd = found[6].runner_up_value.unwrap();
    assert!((a_bd - (13.0 - random_mean)).abs() < 1e-9, "{a_bd}");
    assert_eq!(found[6].not_ranked, "full: not comparable");
    assert_eq!(found[6].metric, "BD-PSNR (dB)");
}

#[test]
fn each_lod_distance_is_judged_on_its_own_at_equal_points() {
    // Of 1000 points, at the 10 % budget: at distance 1 `a` leads `b` by 3 dB on every view, at
    // distance 2 `b` leads `a` by 1 dB. Averaged over the distances `a` would lead by 1 dB;
    // judged per distance each distance has its own winner.
    let found = lod_findings(|view| {
        let v = view as f64 * 0.1;
        [
            (1, "a", "k=1", 50.0, 20.0 + v),
            (1, "a", "k=2", 200.0, 26.0 + v),
            (1, "b", "e=1", 50.0, 17.0 + v),
            (1, "b", "e=2", 200.0, 23.0 + v),
            (2, "a", "k=1", 50.0, 30.0 + v),
            (2, "a", "k=2", 200.0, 34.0 + v),
            (2, "b", "e=1", 50.0, 31.0 + v),
            (2, "b", "e=2", 200.0, 35.0 + v),
        ]
        .to_vec()
    });
    let at = |c: &str| found.iter().find(|f| f.condition == c).unwrap();
    let (near, far) = (
        at("d at distance ×1, at 10 % of the points (100)"),
        at("d at distance ×2, at 10 % of the points (100)"),
    );
    assert_eq!((near.method.as_str(), near.runner_up.as_str()), ("a", "b"));
    assert!((near.difference.unwrap() - 3.0).abs() < 1e-9);
    assert_eq!((far.method.as_str(), far.runner_up.as_str()), ("b", "a"));
    assert!((far.difference.unwrap() - 1.0).abs() < 1e-9);
    assert_eq!((near.n_views, far.n_views), (Some(5), Some(5)));
    // Distance ×1's rows (5, 10 and 20 %) come first, then ×2's.
    assert_eq!(found.len(), 6);
    let conditions: Vec<&str> = found.iter().map(|f| f.condition.as_str()).collect();
    assert!(
        conditions[..found.len() / 2]
            .iter()
            .all(|c| c.starts_with("d at distance ×1,"))
    );
}

#[test]
fn scale_is_judged_at_the_largest_size_finished_against_the_time_margin() {
    let dir = tempfile::tempdir().unwrap();
    let scale = "method,n_points,seconds,peak_rss_bytes,status\n\
                 a,1000,0.5,1048576,ok\n\
                 a,10000000,5,2097152,ok\n\
                 a,100000000,60,4194304,ok\n\
                 b,1000,0.1,4194304,ok\n\
                 b,10000000,4,8388608,ok\n\
                 b,100000000,NaN,0,timeout after 40 s\n\
                 hull-x,1000,0.2,1048576,ok\n\
                 q-build,100000,3,1048576,ok\n\
                 q-select,100000,0.01,1048576,ok\n\
                 r-build,100000,9,524288,ok\n\
                 q-build-ooc,1000000,4,1048576,ok\n\
                 peer-build-ooc,1000000,2,2097152,ok\n\
                 hull-own,1000,0.21,1048576,ok\n";
    std::fs::create_dir_all(dir.path().join("scale")).unwrap();
    std::fs::write(dir.path().join("scale/results.csv"), scale).unwrap();
    // The hull experiment beside it found hull `x` wrong: scale leaves `hull-x` out.
    std::fs::create_dir_all(dir.path().join("hull")).unwrap();
    std::fs::write(
        dir.path().join("hull/results.csv"),
        "hull,perturb,jaccard_vs_exact,status\nx,0,0.4,ok\nown,0,1,ok\n",
    )
    .unwrap();
    let found = findings(dir.path(), &["lod", "scale"]).unwrap();
    let names: Vec<(&str, &str)> = found
        .iter()
        .map(|f| (f.condition.as_str(), f.method.as_str()))
        .collect();
    assert_eq!(
        names,
        [
            (
                "visibility methods (one view; per-cloud build apart) at 10^7 points (2 of 2 finished)",
                "b"
            ),
            (
                "visibility methods (one view; per-cloud build apart) at 10^8 points, the largest any finished (1 of 2 finished)",
                "a"
            ),
            (
                "hulls at 10^3 points, the largest any finished (1 of 2 finished)",
                "hull-own"
            ),
            (
                "LOD builds in core at 10^5 points, the largest any finished (2 of 2 finished)",
                "q-build"
            ),
            (
                "LOD builds out of core at 10^6 points, the largest any finished (2 of 2 finished)",
                "peer-build-ooc"
            ),
        ]
    );
    // The LOD builds: q fastest (r takes 3 times its time: wins), r the lightest.
    let builds = &found[3];
    assert_eq!((builds.value, builds.runner_up.as_str()), (3.0, "r-build"));
    assert_eq!(builds.verdict, "wins");
    assert_eq!(
        (builds.cheapest.as_str(), builds.cheapest_cost),
        ("r-build", Some(0.5))
    );
    assert_eq!(found[1].verdict, "only method");
    // b at 4 s against a at 5 s: 1.25 times, beyond the 5 % margin.
    assert_eq!((found[0].value, found[0].runner_up.as_str()), (4.0, "a"));
    assert_eq!(found[0].verdict, "wins");
    assert_eq!(found[4].runner_up_value, Some(4.0));
    // The wrong hull is named, not ranked: hull-own is the only method left.
    assert_eq!(found[2].verdict, "only method");
    assert_eq!(
        found[2].not_ranked,
        "hull-x: wrong answers (worst Jaccard 0.400)"
    );
}

#[test]
fn robustness_has_a_row_per_half_of_the_levels_and_the_winner_may_change() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("dataset,degradation,level,method,setting,view,f1,seconds,status\n");
    // "calm" wins at the three mild noise levels, "tough" at the three harsh ones; one level of
    // outliers is one row; a failed row is not counted.
    for (level, calm, tough) in [
        (0.1, 0.95, 0.90),
        (0.2, 0.94, 0.90),
        (0.5, 0.93, 0.90),
        (1.0, 0.70, 0.88),
        (2.0, 0.60, 0.86),
        (4.0, 0.50, 0.84),
    ] {
        for view in 0..6 {
            let wobble = view as f64 * 1e-4;
            csv += &format!(
                "b,noise,{level},calm,auto,{view},{},0.01,ok\n",
                calm + wobble
            );
            csv += &format!(
                "b,noise,{level},tough,auto,{view},{},0.02,ok\n",
                tough - wobble
            );
        }
    }
    for view in 0..6 {
        csv += &format!("b,outliers,0.05,calm,auto,{view},0.9,0.01,ok\n");
        csv += &format!("b,outliers,0.05,tough,auto,{view},0.99,0.01,error: lost\n");
    }
    std::fs::create_dir_all(dir.path().join("robustness")).unwrap();
    std::fs::write(dir.path().join("robustness/results.csv"), csv).unwrap();
    let found = findings(dir.path(), &["robustness"]).unwrap();
    let rows: Vec<(&str, &str)> = found
        .iter()
        .map(|f| (f.condition.as_str(), f.method.as_str()))
        .collect();
    // No record of where `best` was tuned (an older run): an oracle, and the condition says so.
    let pool = "b (oracle: `best` tuned on each dataset's own clean cloud, a scan's on itself)";
    assert_eq!(
        rows,
        [
            (
                format!("noise, milder 3 of 6: levels 0.1 to 0.5 — {pool}").as_str(),
                "calm"
            ),
            (
                format!("noise, harsher 3 of 6: levels 1 to 4 — {pool}").as_str(),
                "tough"
            ),
            (format!("outliers — {pool}").as_str(), "calm"),
        ]
    );
    // The milder half's mean over its 3 levels and 6 views: (0.95 + 0.94 + 0.93) / 3 + the
    // mean wobble 2.5e-4.
    assert!(
        (found[0].value - (0.94 + 2.5e-4)).abs() < 1e-12,
        "{}",
        found[0].value
    );
    assert_eq!(
        found[2].runner_up_value, None,
        "the failed rows are not a runner-up"
    );
}

/// A run's `metadata.json` with `parameters`.
fn metadata(dir: &Path, parameters: serde_json::Value) {
    let meta = serde_json::json!({
        "experiment": "robustness", "date_utc": "2026-01-01T00:00:00Z", "git_revision": "abc",
        "git_dirty": false, "rustc": "rustc", "cpu": "cpu", "cores": 2, "os": "linux",
        "command": "test", "quick": false, "datasets": [], "parameters": parameters,
        "seconds": 1.0
    });
    std::fs::write(dir.join("metadata.json"), meta.to_string()).unwrap();
}

#[test]
fn robustness_pools_the_evaluation_datasets_out_of_sample_and_names_every_pool() {
    let dir = tempfile::tempdir().unwrap();
    let rob = dir.path().join("robustness");
    std::fs::create_dir_all(&rob).unwrap();
    let mut csv = String::from("dataset,degradation,level,method,setting,view,f1,seconds,status\n");
    for view in 0..5 {
        let w = view as f64 * 1e-3;
        for (d, deg, level) in [
            ("bunny-69451", "clean", 0.0),
            ("bunny-69451", "noise", 0.25),
            ("bunny-69451", "noise", 1.0),
            ("elephant-50000", "clean", 0.0),
            ("elephant-50000", "noise", 1.0),
            ("camel-50000", "noise", 1.0),
            ("bunny-scan-4", "scan", 0.0),
        ] {
            csv += &format!("{d},{deg},{level},m,best,{view},{},0.01,ok\n", 0.9 + w);
            csv += &format!("{d},{deg},{level},n,auto,{view},{},0.01,ok\n", 0.8 + w);
        }
    }
    std::fs::write(rob.join("results.csv"), csv).unwrap();
    metadata(&rob, serde_json::json!({"tuned_on": ["bunny-69451"]}));
    let found = findings(dir.path(), &["robustness"]).unwrap();
    let conditions: Vec<&str> = found.iter().map(|f| f.condition.as_str()).collect();
    let eval = "evaluation datasets pooled: elephant-50000, camel-50000 (evaluation: settings \
                tuned on the tuning data)";
    assert_eq!(
        conditions,
        [
            format!("clean — {eval}").as_str(),
            format!("noise — {eval}").as_str(),
            "clean — bunny-69451 (tuning data: in-sample)",
            "noise, milder 1 of 2: level 0.25 — bunny-69451 (tuning data: in-sample)",
            "noise, harsher 1 of 2: level 1 — bunny-69451 (tuning data: in-sample)",
            "scan — bunny-scan-4 (simulated scans of the tuning meshes: settings tuned on the \
             clean tuning data, not on the scans)",
        ]
    );
    // The evaluation pool's noise row is over both datasets' views: 10 keys.
    assert_eq!(found[1].n_views, Some(10));
    assert_eq!(found[1].verdict, "wins");
    // The README leads with the out-of-sample rows and leaves the in-sample ones to the page.
    let md = readme_markdown(&found, false);
    assert!(md.contains("| clean — evaluation datasets pooled"), "{md}");
    assert!(!md.contains("bunny-69451 (tuning data: in-sample)"), "{md}");
    assert!(md.contains("| scan — bunny-scan-4"), "{md}");
}

/// A visibility results file over a tuning dataset (`bunny`) and an evaluation dataset
/// (`elephant-50000`): on bunny `hi` is best at g=1; on the elephant g=2 is better (the oracle),
/// `lo` in between. `eval_shift` moves every elephant F1 of `hi` g=2.
fn tuning_and_evaluation_csv(eval_shift: f64) -> String {
    let mut s = String::from(VIS_HEADER);
    for v in 0..6 {
        let w = 0.002 * (v % 3) as f64;
        s.push_str(&format!("bunny,{v},hi,hi,g=1,0.2,{},ok,x\n", 0.95 + w));
        s.push_str(&format!("bunny,{v},hi,hi,g=2,0.4,{},ok,x\n", 0.90 + w));
        s.push_str(&format!("bunny,{v},lo,lo,,0.01,{},ok,x\n", 0.80 + w));
        s.push_str(&format!(
            "elephant-50000,{v},hi,hi,g=1,0.2,{},ok,x\n",
            0.70 + w
        ));
        s.push_str(&format!(
            "elephant-50000,{v},hi,hi,g=2,0.4,{},ok,x\n",
            0.93 + w + eval_shift
        ));
        s.push_str(&format!(
            "elephant-50000,{v},lo,lo,,0.01,{},ok,x\n",
            0.75 + w
        ));
    }
    s
}

#[test]
fn an_evaluation_dataset_is_judged_at_the_settings_tuned_on_the_tuning_data() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("visibility")).unwrap();
    let run = |shift: f64| {
        std::fs::write(
            dir.path().join("visibility/results.csv"),
            tuning_and_evaluation_csv(shift),
        )
        .unwrap();
        findings(dir.path(), &["visibility"]).unwrap()
    };
    let found = run(0.0);
    assert_eq!(found.len(), 2, "{found:?}");
    let (bunny, elephant) = (&found[0], &found[1]);
    assert_eq!(bunny.condition, "bunny (tuning data: in-sample)");
    assert_eq!(
        elephant.condition,
        "elephant-50000 (evaluation: settings tuned on the tuning data)"
    );
    // On the elephant, hi stands at g=1 (tuned on bunny), not at its oracle g=2 (0.93 + w).
    assert_eq!(
        (elephant.method.as_str(), elephant.setting.as_str()),
        ("lo", "")
    );
    let mean_w = (0..6).map(|v| 0.002 * (v % 3) as f64).sum::<f64>() / 6.0;
    assert!((elephant.value - (0.75 + mean_w)).abs() < 1e-12);
    assert_eq!(elephant.runner_up, "hi g=1");
    assert!((elephant.runner_up_value.unwrap() - (0.70 + mean_w)).abs() < 1e-12);
    assert!((elephant.difference.unwrap() - 0.05).abs() < 1e-12);
    assert_eq!(elephant.verdict, "wins");
    assert!(elephant.low.is_some() && elephant.n_views == Some(6));
    // The evaluation rows cannot move the tuned setting: however good g=2 gets there, hi
    // still stands at g=1 on both datasets.
    for shift in [-0.5, 0.06] {
        let again = run(shift);
        assert_eq!(again[0].setting, "g=1");
        assert_eq!(again[1].runner_up, "hi g=1", "shift {shift}");
    }
    // The markdown row says which protocol gave it.
    let md = markdown(&found, false);
    assert!(
        md.contains("| elephant-50000 (evaluation: settings tuned on the tuning data) | lo |"),
        "{md}"
    );
}

#[test]
fn the_evaluation_datasets_pooled_come_first_over_every_dataset_and_view() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("visibility")).unwrap();
    // A second evaluation dataset where hi at its tuned g=1 beats lo by 0.1 on every view.
    let mut csv = tuning_and_evaluation_csv(0.0);
    for v in 0..6 {
        csv.push_str(&format!("camel-50000,{v},hi,hi,g=1,0.2,0.9,ok,x\n"));
        csv.push_str(&format!("camel-50000,{v},hi,hi,g=2,0.4,0.5,ok,x\n"));
        csv.push_str(&format!("camel-50000,{v},lo,lo,,0.01,0.8,ok,x\n"));
    }
    std::fs::write(dir.path().join("visibility/results.csv"), csv).unwrap();
    let found = findings(dir.path(), &["visibility"]).unwrap();
    assert_eq!(found.len(), 4, "{found:?}");
    let pooled = &found[0];
    assert_eq!(
        pooled.condition,
        "evaluation datasets pooled: elephant-50000, camel-50000 \
         (evaluation: settings tuned on the tuning data)"
    );
    // hi g=1: elephant 0.70 + w, camel 0.9, over 12 (dataset, view) cells; lo: 0.75 + w and
    // 0.8. hi's mean is higher by (−0.05 + 0.1) / 2 = 0.025.
    let mean_w = (0..6).map(|v| 0.002 * (v % 3) as f64).sum::<f64>() / 6.0;
    assert_eq!(
        (pooled.method.as_str(), pooled.setting.as_str()),
        ("hi", "g=1")
    );
    assert!(
        (pooled.value - (0.80 + mean_w / 2.0)).abs() < 1e-12,
        "{}",
        pooled.value
    );
    assert_eq!(pooled.n_views, Some(12));
    assert!((pooled.difference.unwrap() - 0.025).abs() < 1e-12);
    // The per-dataset rows follow, unchanged.
    assert_eq!(found[1].condition, "bunny (tuning data: in-sample)");
    assert_eq!(found[2].method, "lo");
    assert_eq!(found[3].method, "hi");
    // One evaluation dataset alone is not pooled.
    std::fs::write(
        dir.path().join("visibility/results.csv"),
        tuning_and_evaluation_csv(0.0),
    )
    .unwrap();
    let one = findings(dir.path(), &["visibility"]).unwrap();
    assert!(one.iter().all(|f| !f.condition.starts_with(POOLED)));
}

#[test]
fn the_readme_leaves_in_sample_rows_to_the_experiments_page_only_beside_out_of_sample_ones() {
    let row = |experiment: &str, condition: String| {
        finding(
            Ask {
                experiment,
                condition,
                question: "q",
                metric: "F1",
                cost_metric: "seconds per view",
                rules: Rules::F1,
                quick: false,
            },
            verdict(&three_methods(8), within(0.01)).unwrap(),
            Vec::new(),
        )
    };
    let tuning = row("visibility", format!("bunny ({IN_SAMPLE})"));
    let evaluation = row("visibility", format!("camel ({OUT_OF_SAMPLE})"));
    let other = row("robustness", "noise".into());
    let all = [tuning.clone(), evaluation.clone(), other.clone()];
    let md = readme_markdown(&all, false);
    assert!(!md.contains("| bunny ("), "{md}");
    assert!(md.contains("| camel (") && md.contains("| noise |"), "{md}");
    assert!(
        md.contains("The 1 in-sample rows of visibility (each tuning dataset at the settings tuned on it) are in [visibility/findings.md](visibility/findings.md)."),
        "{md}"
    );
    // The experiment's own page keeps every row.
    assert!(markdown(&all, false).contains("| bunny ("));
    // A run with tuning data only (a quick one) keeps its in-sample rows: they are all it has.
    let md = readme_markdown(&[tuning, other], false);
    assert!(
        md.contains("| bunny (") && !md.contains("in-sample rows of"),
        "{md}"
    );
}
