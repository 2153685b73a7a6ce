//! The visibility experiment's per-pixel findings: per dataset, which method made for the image
//! (`made_for = pixels` in `pixels.csv`: `registry::Card::made_for`) shows the visible surface
//! best, by the per-pixel F1 (the harmonic mean of pixel precision and mesh coverage,
//! `registry::scoring::pixels::f1`), each method at its setting with the best mean over the
//! views. The rules are the per-point row's ([`super::verdict`]: bootstrap interval over the
//! views, none from fewer than [`crate::stats::MIN_VIEWS`], a quick run indicative; the
//! cheapest within 0.01 by seconds per view from `results.csv`; identical answers by equal
//! scores, pixels having no fingerprint). Each dataset's row stands
//! right after its per-point row ([`beside`]), which judges the methods made for points.
//!
//! The settings follow the per-point row's protocol (`visibility::tuning`), with the per-pixel
//! F1 as the score: each family at the setting with the best mean per-pixel F1 over the run's
//! tuning datasets (each weighing the same), so an evaluation dataset's row is out-of-sample;
//! a family with no tuning rows in the run (a user's own data alone) is at its best setting on
//! the reported data, and the condition says so (oracle).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use registry::scoring::pixels::f1;
use serde::Deserialize;

use super::{
    Ask, Cell, Finding, Rules, VisibilityRow, by_condition, finding, pool_evaluation,
    tuned_condition, verdict,
};
use crate::experiments::visibility::tuning::{Obs, Protocol, roles_of};
use crate::output::meta::RunMeta;
use crate::output::{distinct, read_csv};

/// The columns of `pixels.csv` the findings read.
#[derive(Deserialize)]
struct PixelCsvRow {
    dataset: String,
    view: usize,
    family: String,
    params: String,
    pixel_precision: f64,
    mesh_coverage: f64,
    /// Absent from an older pixels.csv, which held the per-pixel methods only.
    #[serde(default = "pixels")]
    made_for: String,
}

fn pixels() -> String {
    "pixels".into()
}

/// The per-pixel findings of the visibility results in `dir` (none without `pixels.csv`).
pub(super) fn visibility(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    if !dir.join("pixels.csv").is_file() {
        return Ok(Vec::new());
    }
    let rows: Vec<PixelCsvRow> = read_csv(&dir.join("pixels.csv"))?;
    let wrong = super::wrong::peers(dir)?;
    let results: Vec<VisibilityRow> = read_csv(&dir.join("results.csv"))?;
    let seconds: BTreeMap<(&str, usize, &str, &str), f64> = results
        .iter()
        .filter(|r| r.status == "ok")
        .map(|r| {
            (
                (
                    r.dataset.as_str(),
                    r.view,
                    r.family.as_str(),
                    r.params.as_str(),
                ),
                r.seconds,
            )
        })
        .collect();
    // Tuned on the run's tuning datasets by the per-pixel F1 (the module's protocol).
    let made: Vec<&PixelCsvRow> = rows.iter().filter(|r| r.made_for == "pixels").collect();
    let meta = RunMeta::read(dir).map(|m| m.parameters).unwrap_or_default();
    let names = distinct(made.iter().map(|r| r.dataset.as_str()));
    let protocol = Protocol::new(
        made.iter().map(|r| Obs {
            dataset: &r.dataset,
            family: &r.family,
            params: &r.params,
            f1: f1(r.pixel_precision, r.mesh_coverage),
            ok: true,
        }),
        roles_of(&names, &meta),
    );
    let stands = |r: &PixelCsvRow| {
        protocol
            .tuned
            .get(&r.family)
            .is_none_or(|(p, _)| *p == r.params)
    };
    let mut conditions = by_condition(
        &rows,
        |r| (r.made_for == "pixels" && stands(r)).then(|| r.dataset.clone()),
        |r| {
            Cell::new(
                &r.family,
                &r.params,
                r.view.to_string(),
                f1(r.pixel_precision, r.mesh_coverage),
                seconds
                    .get(&(
                        r.dataset.as_str(),
                        r.view,
                        r.family.as_str(),
                        r.params.as_str(),
                    ))
                    .copied()
                    .unwrap_or(f64::NAN),
            )
        },
    );
    pool_evaluation(&mut conditions, &protocol);
    Ok(conditions
        .into_iter()
        .filter_map(|(dataset, cells)| {
            let (cells, notes) = super::without_wrong(cells, &wrong);
            let v = verdict(&cells, Rules::F1)?;
            let condition = tuned_condition(
                &protocol,
                &dataset,
                &cells,
                "per pixel; ",
                "oracle: best setting on these data",
            );
            Some(finding(
                Ask {
                    experiment: "visibility",
                    condition,
                    question: "Which method made for the image shows the visible surface best \
                               (pixel F1)?",
                    metric: "pixel F1",
                    cost_metric: "seconds per view",
                    rules: Rules::F1,
                    quick,
                },
                v,
                notes,
            ))
        })
        .collect())
}

/// The per-point findings with each dataset's per-pixel finding right after its per-point one;
/// a per-pixel finding without a per-point one comes after them all.
pub(super) fn beside(points: Vec<Finding>, pixels: Vec<Finding>) -> Vec<Finding> {
    let mut pixels: Vec<Option<Finding>> = pixels.into_iter().map(Some).collect();
    let mut out = Vec::new();
    for p in points {
        let paired = pixels
            .iter_mut()
            .find(|x| {
                x.as_ref()
                    .is_some_and(|x| dataset_of(&x.condition) == dataset_of(&p.condition))
            })
            .and_then(Option::take);
        out.push(p);
        out.extend(paired);
    }
    out.extend(pixels.into_iter().flatten());
    out
}

/// The dataset a visibility condition names (its text before the protocol's parenthesis).
fn dataset_of(condition: &str) -> &str {
    condition.split(" (").next().unwrap_or(condition)
}

#[cfg(test)]
mod tests {
    use super::super::findings;
    use super::*;

    const RESULTS: &str = "dataset,view,method,family,params,seconds,f1,status,made_for\n";
    const PIXELS: &str = "dataset,view,method,family,params,width,height,covered_pixels,\
                          true_pixels,mesh_pixels,mesh_pixels_covered,pixel_precision,\
                          mesh_coverage,pixel_f1,source,made_for\n";

    /// On `ds` over `views` views: `pts` (made for points) has the best F1 and `img` (made for
    /// pixels, two settings) the best per-pixel F1 among the methods made for pixels; `pts`'s
    /// per-pixel F1 is higher still but it is judged by points. Returns (results, pixels).
    fn csvs(ds: &str, views: usize) -> (String, String) {
        let (mut r, mut p) = (String::new(), String::new());
        for v in 0..views {
            let e = 0.01 * (v % 2) as f64;
            r.push_str(&format!("{ds},{v},pts,pts,,0.5,{},ok,points\n", 0.95 + e));
            r.push_str(&format!("{ds},{v},img,img,k=1,0.1,{},ok,pixels\n", 0.6 + e));
            r.push_str(&format!("{ds},{v},img,img,k=2,0.3,{},ok,pixels\n", 0.7 + e));
            r.push_str(&format!("{ds},{v},ray,ray,,0.2,{},ok,pixels\n", 0.99));
            // Per-pixel F1: pts 1.0; img k=1: 0.9 + e (precision = coverage); k=2: 0.8 + e;
            // ray 0.85 + e.
            let row = |m: &str, s: &str, x: f64, made: &str, src: &str| {
                format!("{ds},{v},{m},{m},{s},4,4,1,1,1,1,{x},{x},{x},{src},{made}\n")
            };
            p.push_str(&row("pts", "", 1.0, "points", "projected"));
            p.push_str(&row("img", "k=1", 0.9 + e, "pixels", "projected"));
            p.push_str(&row("img", "k=2", 0.8 + e, "pixels", "projected"));
            p.push_str(&row("ray", "", 0.85 + e, "pixels", "method"));
        }
        (r, p)
    }

    #[test]
    fn each_dataset_has_a_per_point_row_and_a_per_pixel_row_each_judging_its_own_methods() {
        let dir = tempfile::tempdir().unwrap();
        let vis = dir.path().join("visibility");
        std::fs::create_dir_all(&vis).unwrap();
        let (r1, p1) = csvs("d1", 6);
        let (r2, p2) = csvs("d2", 3);
        std::fs::write(vis.join("results.csv"), format!("{RESULTS}{r1}{r2}")).unwrap();
        std::fs::write(vis.join("pixels.csv"), format!("{PIXELS}{p1}{p2}")).unwrap();
        let found = findings(dir.path(), &["visibility"]).unwrap();
        let summary: Vec<(&str, &str, &str)> = found
            .iter()
            .map(|f| {
                (
                    dataset_of(&f.condition),
                    f.metric.as_str(),
                    f.method.as_str(),
                )
            })
            .collect();
        // The per-point row judges pts alone (ray and img are made for pixels, whatever their
        // F1); the per-pixel row judges img and ray, not pts.
        assert_eq!(
            summary,
            [
                ("d1", "F1", "pts"),
                ("d1", "pixel F1", "img"),
                ("d2", "F1", "pts"),
                ("d2", "pixel F1", "img")
            ]
        );
        let px = &found[1];
        // img at k=1: mean of 0.90 and 0.91 over 6 views; interval from 6 views.
        assert_eq!(px.setting, "k=1");
        assert!((px.value - 0.905).abs() < 1e-12, "{}", px.value);
        assert!(px.low.is_some() && !px.indicative && px.n_views == Some(6));
        assert_eq!(px.runner_up, "ray");
        assert!((px.difference.unwrap() - 0.05).abs() < 1e-12);
        assert_eq!(px.verdict, "wins");
        // Its cost is results.csv's seconds for that setting; nothing within 0.01 is cheaper.
        assert_eq!(px.cost, 0.1);
        assert_eq!(px.cheapest, "img k=1");
        // Three views: no interval, indicative.
        let px2 = &found[3];
        assert!(px2.low.is_none() && px2.indicative && px2.n_views == Some(3));
        // The table prints the metric with three decimals.
        let md = super::super::markdown(&found, false);
        assert!(
            md.contains(
                "| d1 (per pixel; oracle: best setting on these data) | img k=1 | pixel F1 0.905 ["
            ),
            "{md}"
        );
    }

    #[test]
    fn an_evaluation_dataset_is_judged_per_pixel_at_the_setting_tuned_on_the_tuning_data() {
        let dir = tempfile::tempdir().unwrap();
        let vis = dir.path().join("visibility");
        std::fs::create_dir_all(&vis).unwrap();
        // On the tuning dataset `bunny`, img's k=1 has the better per-pixel F1 (0.90..0.91
        // against 0.80..0.81); on the evaluation dataset k=2 is far better (0.99 against 0.5).
        let (r1, p1) = csvs("bunny", 6);
        let (r2, _) = csvs("elephant-50000", 6);
        let mut p2 = String::new();
        for v in 0..6 {
            for (m, s, x) in [("img", "k=1", 0.5), ("img", "k=2", 0.99), ("ray", "", 0.85)] {
                p2.push_str(&format!(
                    "elephant-50000,{v},{m},{m},{s},4,4,1,1,1,1,{x},{x},{x},projected,pixels\n"
                ));
            }
        }
        std::fs::write(vis.join("results.csv"), format!("{RESULTS}{r1}{r2}")).unwrap();
        std::fs::write(vis.join("pixels.csv"), format!("{PIXELS}{p1}{p2}")).unwrap();
        let found = visibility(&vis, false).unwrap();
        let eval = found
            .iter()
            .find(|f| dataset_of(&f.condition) == "elephant-50000")
            .unwrap();
        // img stands at k=1, its tuned setting, not at k=2, the best on these data: at 0.5 it
        // loses to ray (0.85, no setting to tune).
        assert_eq!(eval.method, "ray", "{eval:?}");
        assert_eq!(eval.runner_up, "img k=1");
        assert!(
            eval.condition
                .contains("per pixel; evaluation: settings tuned on the tuning data"),
            "{}",
            eval.condition
        );
        let tuning = found
            .iter()
            .find(|f| dataset_of(&f.condition) == "bunny")
            .unwrap();
        assert_eq!(
            (tuning.method.as_str(), tuning.setting.as_str()),
            ("img", "k=1")
        );
        assert!(tuning.condition.contains("tuning data: in-sample"));
    }

    #[test]
    fn a_quick_run_marks_the_per_pixel_row_indicative_and_an_older_folder_has_none() {
        let dir = tempfile::tempdir().unwrap();
        let vis = dir.path().join("visibility");
        std::fs::create_dir_all(&vis).unwrap();
        let (r, p) = csvs("d1", 6);
        std::fs::write(vis.join("results.csv"), format!("{RESULTS}{r}")).unwrap();
        // Without pixels.csv: the per-point row alone.
        assert_eq!(findings(dir.path(), &["visibility"]).unwrap().len(), 1);
        std::fs::write(vis.join("pixels.csv"), format!("{PIXELS}{p}")).unwrap();
        let quick = visibility(&vis, true).unwrap();
        assert_eq!(quick.len(), 1);
        assert!(quick[0].indicative && quick[0].low.is_some());
    }
}
