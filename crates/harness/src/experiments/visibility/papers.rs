//! Two comparisons of the literature redrawn from the visibility sweep's rows:
//!
//! - Machado e Silva et al., SIBGRAPI 2012 / CGF 2014 (approximate HPR): the speed bought by
//!   the approximate hull against what it costs in accuracy, per number of sectors k: each
//!   `hpr-approx` setting against exact HPR at the same γ (the rule `gamma = auto`, which both
//!   use), so the difference is the approximation's alone;
//! - Katz and Tal, ICCV 2015: the members of the transformation family (`hpr-linear`,
//!   `hpr-exp`, `hpr-log`, `hpr-expdecay`) at their best parameter, and the visibility-confidence
//!   score thresholded (`hpr-confidence`), each against the linear kernel at its best.
//!
//! Every comparison is paired per view: time ratio (geometric mean of the per-view ratios) and
//! F1 difference (mean of the per-view differences), each with its bootstrap 95 % interval
//! (`crate::stats`). Neither paper's tables could be read (see the crates' docs), so these are
//! their comparisons on our data, not checks of their numbers.

use std::collections::BTreeMap;

use super::tuning::{Chosen, Protocol};
use super::{Row, is_auto};
use crate::experiments::markdown_table;

/// The setting that stands for `fam` on `dataset` under `protocol`: the tuned one, else (no
/// tuning rows for it) the oracle, [`best_setting`] on the dataset itself.
pub(super) fn chosen(
    rows: &[Row],
    protocol: &Protocol,
    dataset: &str,
    fam: &str,
) -> Option<(String, Chosen)> {
    protocol.choose(dataset, fam, best_setting(rows, dataset, fam).map(|b| b.0))
}

/// The setting of `family` with the best mean F1 on `dataset`: automatic settings excluded,
/// unless every setting of the family is one (`robust`'s noise and `hpr-approx`'s γ always
/// come from their rules; the best of those is then the family's).
pub(super) fn best_setting(rows: &[Row], dataset: &str, fam: &str) -> Option<(String, f64)> {
    let best = |fixed_only: bool| {
        let mut by: BTreeMap<&str, (f64, usize)> = BTreeMap::new();
        for r in rows.iter().filter(|r| {
            r.dataset == dataset
                && r.family == fam
                && (!fixed_only || !is_auto(&r.params))
                && r.status == "ok"
        }) {
            let e = by.entry(&r.params).or_default();
            e.0 += r.f1;
            e.1 += 1;
        }
        by.into_iter()
            .map(|(p, (s, n))| (p.to_owned(), s / n as f64))
            .max_by(|a, b| a.1.total_cmp(&b.1))
    };
    best(true).or_else(|| best(false))
}

/// Per view: (seconds, F1) of `family` at `params` on `dataset`.
pub(super) fn by_view(
    rows: &[Row],
    dataset: &str,
    family: &str,
    params: &str,
) -> BTreeMap<usize, (f64, f64)> {
    rows.iter()
        .filter(|r| {
            r.dataset == dataset && r.family == family && r.params == params && r.status == "ok"
        })
        .map(|r| (r.view, (r.seconds, r.f1)))
        .collect()
}

/// The settings of `family` on `dataset`, in the order they first appear.
fn settings(rows: &[Row], dataset: &str, family: &str) -> Vec<String> {
    crate::output::distinct(
        rows.iter()
            .filter(|r| r.dataset == dataset && r.family == family)
            .map(|r| r.params.as_str()),
    )
}

/// One table row: `theirs` against `base`, paired per view.
fn paired(
    dataset: &str,
    label: String,
    theirs: &BTreeMap<usize, (f64, f64)>,
    base: &BTreeMap<usize, (f64, f64)>,
) -> Option<Vec<String>> {
    let pairs = crate::stats::pair(theirs, base);
    if pairs.is_empty() {
        return None;
    }
    let (ts, bs): (Vec<f64>, Vec<f64>) = pairs.iter().map(|(t, b)| (t.0, b.0)).unzip();
    let df: Vec<f64> = pairs.iter().map(|(t, b)| t.1 - b.1).collect();
    let n = pairs.len() as f64;
    let ratio = crate::stats::paired_ratio(&ts, &bs, 2012)
        .map_or("-".to_owned(), |e| e.text(|x| format!("{x:.3}"), "×"));
    let diff = crate::stats::bootstrap_mean(&df, 2012)
        .map_or("-".to_owned(), |e| e.text(|x| format!("{x:+.4}"), ""));
    Some(vec![
        dataset.to_owned(),
        label,
        pairs.len().to_string(),
        format!("{:.4}", ts.iter().sum::<f64>() / n),
        ratio,
        format!("{:.4}", pairs.iter().map(|(t, _)| t.1).sum::<f64>() / n),
        diff,
    ])
}

const HEADER: [&str; 7] = [
    "dataset",
    "setting",
    "views",
    "mean s",
    "time ratio [95 % CI]",
    "mean F1",
    "F1 difference [95 % CI]",
];

/// Machado e Silva et al.'s trade-off: `hpr-approx` per k against exact HPR at γ = auto.
pub fn machado(rows: &[Row], datasets: &[String]) -> String {
    let mut table = Vec::new();
    for d in datasets {
        let Some(exact) = settings(rows, d, "hpr-linear")
            .into_iter()
            .find(|p| p.split(';').any(|kv| kv == "gamma=auto"))
        else {
            continue;
        };
        let base = by_view(rows, d, "hpr-linear", &exact);
        for p in settings(rows, d, "hpr-approx") {
            let label = p
                .split(';')
                .find_map(|kv| kv.strip_prefix("sectors="))
                .map_or(p.clone(), |k| format!("k = {k}"));
            table.extend(paired(d, label, &by_view(rows, d, "hpr-approx", &p), &base));
        }
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "### Machado e Silva et al. 2012: approximate HPR's speed against its accuracy\n\n\
         `hpr-approx` at each number of sectors k (a cube map of directions around the eye; \
         `auto`: one sector per pixel) against exact HPR (`hpr-linear`) at the same γ \
         (`gamma = auto` in both), paired per view: time ratio below 1 is faster than exact HPR; \
         the F1 difference is what the approximate hull costs. It returns a sample of the \
         visible points, at most one per sector (the SIBGRAPI paper's Fig. 1 shows such \
         subsets): its precision stays near 1 (the summary's table) and the F1 difference is \
         mostly its recall, bounded by the sectors the object covers. The papers' own tables \
         (GPU timings) could not be read; this is their trade-off on our CPU and data.\n\n{}\n",
        markdown_table(&HEADER, &table)
    )
}

/// Katz and Tal's family and confidence score against the linear kernel, each at its tuned
/// setting ([`chosen`]).
pub fn katz_tal(rows: &[Row], datasets: &[String], protocol: &Protocol) -> String {
    let mut table = Vec::new();
    for d in datasets {
        let Some(linear) = chosen(rows, protocol, d, "hpr-linear").map(|b| b.0) else {
            continue;
        };
        let base = by_view(rows, d, "hpr-linear", &linear);
        for fam in ["hpr-exp", "hpr-log", "hpr-expdecay"] {
            if let Some((p, how)) = chosen(rows, protocol, d, fam) {
                let label = format!("{fam} {}: {}", how.word(), p.replace(';', " "));
                table.extend(paired(d, label, &by_view(rows, d, fam, &p), &base));
            }
        }
        for p in settings(rows, d, "hpr-confidence") {
            let label = format!("hpr-confidence {}", p.replace(';', " "));
            table.extend(paired(
                d,
                label,
                &by_view(rows, d, "hpr-confidence", &p),
                &base,
            ));
        }
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "### Katz and Tal 2015: the transformation family and the confidence score\n\n\
         Members of the family at their tuned parameter (`hpr-exp`, `hpr-log`, `hpr-expdecay`; \
         `tuned`: best mean F1 over the tuning datasets, `in-sample` on a tuning dataset, \
         `oracle` where the run has no tuning data) and the visibility-confidence score \
         thresholded (`hpr-confidence`, each setting), against the linear kernel at its tuned \
         γ, paired per view. The paper's figures could not be read; this is its comparison on \
         our data.\n\n{}\n",
        markdown_table(&HEADER, &table)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(family: &str, params: &str, view: usize, seconds: f64, f1: f64) -> Row {
        Row {
            dataset: "d".into(),
            n_points: 10,
            view,
            method: family.split('-').next().unwrap_or(family).into(),
            family: family.into(),
            params: params.into(),
            detail: String::new(),
            seconds,
            rays: 0,
            n_visible: 0,
            precision: f1,
            recall: f1,
            f1,
            off_surface_visible: 0,
            seconds_min: seconds,
            seconds_max: seconds,
            samples: 1,
            status: "ok".into(),
            made_for: "points".into(),
            visible_sha256: String::new(),
            mesh_fit: String::new(),
            wall_seconds: f64::NAN,
        }
    }

    #[test]
    fn approximate_hpr_is_paired_with_exact_hpr_at_the_same_gamma_rule() {
        let mut rows = Vec::new();
        for v in 0..5 {
            rows.push(row("hpr-linear", "gamma=3;kernel=linear", v, 1.0, 0.99));
            rows.push(row("hpr-linear", "gamma=auto;kernel=linear", v, 2.0, 0.95));
            rows.push(row(
                "hpr-approx",
                "gamma=auto;kernel=linear;sectors=6144",
                v,
                0.5,
                0.90,
            ));
        }
        let t = machado(&rows, &["d".into()]);
        let line = t.lines().find(|l| l.contains("k = 6144")).expect(&t);
        // Against gamma=auto (2 s, F1 0.95), not the better gamma=3.
        assert!(line.contains("0.250× [0.250, 0.250]"), "{line}");
        assert!(line.contains("-0.0500 [-0.0500, -0.0500]"), "{line}");
        assert_eq!(
            machado(&rows[..2], &["d".into()]),
            "",
            "no approximate rows, no table"
        );
    }

    #[test]
    fn the_family_members_meet_the_linear_kernel_at_its_best() {
        let mut rows = Vec::new();
        for v in 0..5 {
            rows.push(row("hpr-linear", "gamma=2;kernel=linear", v, 1.0, 0.90));
            rows.push(row("hpr-linear", "gamma=3;kernel=linear", v, 1.0, 0.98));
            rows.push(row("hpr-exp", "gamma=-0.001;kernel=exp", v, 1.5, 0.97));
            rows.push(row("hpr-exp", "gamma=-0.01;kernel=exp", v, 1.5, 0.50));
            rows.push(row("hpr-confidence", "steps=5;threshold=0.6", v, 5.0, 0.99));
        }
        let tuning = BTreeMap::from([("d".to_owned(), crate::datasets::Role::Tuning)]);
        let protocol = Protocol::new(super::super::tuning::observations(&rows), tuning);
        let t = katz_tal(&rows, &["d".into()], &protocol);
        let exp = t
            .lines()
            .find(|l| l.starts_with("| d | hpr-exp in-sample"))
            .expect(&t);
        assert!(
            exp.contains("gamma=-0.001") && exp.contains("-0.0100 ["),
            "{exp}"
        );
        let conf = t
            .lines()
            .find(|l| l.starts_with("| d | hpr-confidence"))
            .expect(&t);
        assert!(
            conf.contains("5.000× [") && conf.contains("+0.0100 ["),
            "{conf}"
        );
    }

    #[test]
    fn the_best_setting_prefers_fixed_settings_and_falls_back_to_rules() {
        let mut rows = Vec::new();
        for v in 0..2 {
            rows.push(row("hpr-linear", "gamma=3", v, 1.0, 0.90));
            rows.push(row("hpr-linear", "gamma=auto", v, 1.0, 0.99));
            rows.push(row("robust", "band=2;noise=auto", v, 1.0, 0.80));
            rows.push(row("robust", "band=3;noise=auto", v, 1.0, 0.85));
        }
        // A family with fixed settings: the best fixed one, though a rule scored higher.
        assert_eq!(best_setting(&rows, "d", "hpr-linear").unwrap().0, "gamma=3");
        // Every setting automatic: the best of them.
        let (p, f1) = best_setting(&rows, "d", "robust").unwrap();
        assert_eq!((p.as_str(), f1), ("band=3;noise=auto", 0.85));
        assert!(best_setting(&rows, "d", "nosuch").is_none());
    }
}
