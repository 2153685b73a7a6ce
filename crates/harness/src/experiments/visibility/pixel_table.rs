//! The visibility summary's image-space table: every method (its own pixels, or its visible
//! set's projected through `registry::scoring::pixels::projected`) at its best setting by the
//! per-pixel F1 (the harmonic mean of pixel precision and mesh coverage), per dataset, with the
//! score the method was made for (`registry::Card::made_for`).

use std::collections::BTreeMap;

use registry::scoring::pixels::f1;

use super::PixelRow;
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

/// The table (markdown) over `datasets`, methods in the order they appear in pixels.csv.
pub(super) fn table(pixels: &[PixelRow], datasets: &[String]) -> String {
    let families = distinct(pixels.iter().map(|p| p.family.as_str()));
    let mut rows = Vec::new();
    for d in datasets {
        for fam in &families {
            let Some(ps) = best(pixels, d, fam) else {
                continue;
            };
            rows.push(vec![
                d.clone(),
                fam.clone(),
                ps[0].made_for.clone(),
                ps[0].source.clone(),
                ps[0].params.replace(';', " "),
                format!("{:.4}", mean(ps.iter().map(|p| pixel_f1(p)))),
                format!("{:.4}", mean(ps.iter().map(|p| p.pixel_precision))),
                format!("{:.4}", mean(ps.iter().map(|p| p.mesh_coverage))),
                format!("{:.0}", mean(ps.iter().map(|p| p.covered_pixels as f64))),
                format!("{:.0}", mean(ps.iter().map(|p| p.mesh_pixels as f64))),
            ]);
        }
    }
    markdown_table(
        &[
            "dataset",
            "method",
            "made for",
            "pixels",
            "best setting (pixel F1)",
            "pixel F1",
            "pixel precision",
            "mesh coverage",
            "covered pixels",
            "mesh pixels",
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
        }
    }

    #[test]
    fn the_best_setting_is_the_highest_mean_pixel_f1() {
        // a=1: F1 1.0 and 0.5 (mean 0.75); a=2: 0.8 on both views.
        let rows = [
            row("a=1", 0, 1.0, 1.0),
            row("a=1", 1, 0.5, 0.5),
            row("a=2", 0, 0.8, 0.8),
            row("a=2", 1, 0.8, 0.8),
        ];
        let t = table(&rows, &["d".to_owned()]);
        assert!(
            t.contains("| d | m | points | projected | a=2 | 0.8000 | 0.8000 | 0.8000 | 10 | 12 |"),
            "{t}"
        );
    }
}
