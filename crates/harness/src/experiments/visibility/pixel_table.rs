//! The visibility summary's image-space table: every method (its own pixels, or its visible
//! set's projected through `registry::scoring::pixels::projected`) per dataset at its setting
//! tuned by the per-pixel F1 (the harmonic mean of pixel precision and mesh coverage) on the
//! run's tuning datasets, the per-point protocol's rule ([`super::tuning`]) with that score
//! (in-sample on a tuning dataset; the best on the dataset itself, labelled oracle, for a
//! family without tuning rows), the oracle setting's score beside it, and the score the method
//! was made for (`registry::Card::made_for`).

use std::collections::BTreeMap;

use registry::scoring::pixels::f1;

use super::PixelRow;
use super::tuning::{Obs, Protocol};
use crate::datasets::Role;
use crate::experiments::markdown_table;
use crate::output::distinct;

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// A row's per-pixel F1, from its two figures (pixels.csv of an older run has no column).
pub(super) fn pixel_f1(p: &PixelRow) -> f64 {
    f1(p.pixel_precision, p.mesh_coverage)
}

/// The setting of `family` with the highest mean per-pixel F1 over the views on `dataset`
/// (ties: the first by label), with its rows.
fn best<'a>(pixels: &'a [PixelRow], dataset: &str, family: &str) -> Option<Vec<&'a PixelRow>> {
    let mut by: BTreeMap<&str, Vec<&PixelRow>> = BTreeMap::new();
    for p in pixels
        .iter()
        .filter(|p| p.dataset == dataset && p.family == family)
    {
        by.entry(&p.params).or_default().push(p);
    }
    by.into_values()
        .map(|ps| (mean(ps.iter().map(|p| pixel_f1(p))), ps))
        .filter(|(m, _)| !m.is_nan())
        .fold(None, |b: Option<(f64, Vec<&PixelRow>)>, (m, ps)| match b {
            Some((bm, _)) if bm >= m => b,
            _ => Some((m, ps)),
        })
        .map(|(_, ps)| ps)
}

/// The rows of `family` at `params` on `dataset`.
fn at<'a>(pixels: &'a [PixelRow], dataset: &str, family: &str, params: &str) -> Vec<&'a PixelRow> {
    pixels
        .iter()
        .filter(|p| p.dataset == dataset && p.family == family && p.params == params)
        .collect()
}

/// The table (markdown) over `datasets` (roles as `roles` gives them), methods in the order
/// they appear in pixels.csv.
pub(super) fn table(
    pixels: &[PixelRow],
    datasets: &[String],
    roles: BTreeMap<String, Role>,
) -> String {
    let protocol = Protocol::new(
        pixels.iter().map(|p| Obs {
            dataset: &p.dataset,
            family: &p.family,
            params: &p.params,
            f1: pixel_f1(p),
            ok: true,
        }),
        roles,
    );
    let families = distinct(pixels.iter().map(|p| p.family.as_str()));
    let mut rows = Vec::new();
    for d in datasets {
        for fam in &families {
            let Some(oracle) = best(pixels, d, fam) else {
                continue;
            };
            let Some((setting, how)) = protocol.choose(d, fam, Some(oracle[0].params.clone()))
            else {
                continue;
            };
            let ps = at(pixels, d, fam, &setting);
            if ps.is_empty() {
                continue;
            }
            rows.push(vec![
                d.clone(),
                fam.clone(),
                ps[0].made_for.clone(),
                ps[0].source.clone(),
                format!("{} ({})", setting.replace(';', " "), how.word()),
                format!("{:.4}", mean(ps.iter().map(|p| pixel_f1(p)))),
                format!("{:.4}", mean(ps.iter().map(|p| p.pixel_precision))),
                format!("{:.4}", mean(ps.iter().map(|p| p.mesh_coverage))),
                format!("{:.0}", mean(ps.iter().map(|p| p.covered_pixels as f64))),
                format!("{:.0}", mean(ps.iter().map(|p| p.mesh_pixels as f64))),
                oracle[0].params.replace(';', " "),
                format!("{:.4}", mean(oracle.iter().map(|p| pixel_f1(p)))),
            ]);
        }
    }
    markdown_table(
        &[
            "dataset",
            "method",
            "made for",
            "pixels",
            "setting (tuned by pixel F1)",
            "pixel F1",
            "pixel precision",
            "mesh coverage",
            "covered pixels",
            "mesh pixels",
            "oracle setting (best on this dataset)",
            "oracle pixel F1",
        ],
        &rows,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(params: &str, view: usize, precision: f64, coverage: f64) -> PixelRow {
        PixelRow {
            dataset: "d".into(),
            view,
            method: "m".into(),
            family: "m".into(),
            params: params.into(),
            width: 4,
            height: 4,
            covered_pixels: 10,
            true_pixels: 9,
            mesh_pixels: 12,
            mesh_pixels_covered: 8,
            pixel_precision: precision,
            mesh_coverage: coverage,
            pixel_f1: f64::NAN,
            source: "projected".into(),
            made_for: "points".into(),
            mesh_fit: String::new(),
        }
    }

    #[test]
    fn without_tuning_data_the_setting_is_the_oracle_the_highest_mean_pixel_f1() {
        // a=1: F1 1.0 and 0.5 (mean 0.75); a=2: 0.8 on both views.
        let rows = [
            row("a=1", 0, 1.0, 1.0),
            row("a=1", 1, 0.5, 0.5),
            row("a=2", 0, 0.8, 0.8),
            row("a=2", 1, 0.8, 0.8),
        ];
        let t = table(&rows, &["d".to_owned()], BTreeMap::new());
        assert!(
            t.contains(
                "| d | m | points | projected | a=2 (oracle) | 0.8000 | 0.8000 | 0.8000 | 10 | 12 \
                 | a=2 | 0.8000 |"
            ),
            "{t}"
        );
    }

    #[test]
    fn an_evaluation_dataset_stands_at_the_setting_tuned_on_the_tuning_data() {
        // Tuning dataset t: a=1 best (0.9 against 0.6). Evaluation dataset e: a=2 best (0.9
        // against 0.4); e is reported at a=1, with a=2 as its oracle beside it.
        let on = |d: &str, params: &str, x: f64| PixelRow {
            dataset: d.into(),
            ..row(params, 0, x, x)
        };
        let rows = [
            on("t", "a=1", 0.9),
            on("t", "a=2", 0.6),
            on("e", "a=1", 0.4),
            on("e", "a=2", 0.9),
        ];
        let roles = BTreeMap::from([
            ("t".to_owned(), Role::Tuning),
            ("e".to_owned(), Role::Evaluation),
        ]);
        let t = table(&rows, &["t".to_owned(), "e".to_owned()], roles);
        assert!(
            t.contains("| t | m | points | projected | a=1 (in-sample) | 0.9000 |"),
            "{t}"
        );
        assert!(
            t.contains("| e | m | points | projected | a=1 (tuned) | 0.4000 |")
                && t.contains("| a=2 | 0.9000 |"),
            "{t}"
        );
    }
}
