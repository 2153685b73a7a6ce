//! Rate-distortion curves, as the field compares LOD methods: a method's PSNR (or SSIM)
//! against points rendered on one (view, distance), read at a point budget and summarised
//! against an anchor's curve by a Bjøntegaard-style BD-PSNR. The LOD findings and the LOD
//! summary's tables both read them here.
//!
//! - **A curve** ([`Curve`]): a method's settings on one (view, distance), as (ln points,
//!   value) sorted by points; settings drawing the same number of points keep the best value.
//!   An image identical to the reference (PSNR at its [`IDENTICAL_PSNR`] cap) is reported as
//!   identical and is no point of the curve.
//! - **A budget** ([`LOD_BUDGETS`]): a fraction of the dataset's points (its `n_points`, else
//!   the most points any row rendered: [`dataset_points`]); the curve's value there is
//!   interpolated linearly in log(points) between the two settings around it ([`Curve::at`]).
//!   A budget outside the points the method's sweep drew on that (view, distance) is not
//!   reached: never extrapolated.
//! - **BD-PSNR** ([`bd`]; ITU-T VCEG-M33, as point-cloud compression reports it, with
//!   piecewise-linear curves in log points instead of the cubic fit, which a sweep of five or
//!   six settings cannot support): the mean difference between a method's curve and the
//!   anchor's ([`BD_ANCHOR`], the random subsample) over their common range of log points; a
//!   method with fewer than two points of its curve in that range is not comparable there.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::verdict::{Cell, PSNR_MARGIN, Rules};

/// The point budgets of the LOD findings: fractions of the dataset's points.
pub const LOD_BUDGETS: [f64; 6] = [0.01, 0.02, 0.05, 0.1, 0.2, 0.3];

/// The method every BD-PSNR is measured against.
pub const BD_ANCHOR: &str = "random";

/// A PSNR at or above this is the scorer's cap: the image is identical to the reference.
pub const IDENTICAL_PSNR: f64 = 100.0;

/// The rules of the LOD verdicts: the PSNR margin, no cheapest sought.
pub const RULES: Rules = Rules {
    margin: PSNR_MARGIN,
    tolerance: None,
    identical: true,
};

/// The columns of the LOD results the findings read.
#[derive(Deserialize)]
pub struct LodRow {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// Distance factor.
    pub distance: f64,
    /// Method.
    pub method: String,
    /// Setting.
    pub params: String,
    /// Splats drawn.
    pub points_rendered: f64,
    /// PSNR, dB.
    pub psnr: f64,
    /// SSIM (absent from the oldest results).
    #[serde(default = "nan")]
    pub ssim: f64,
    /// `ok` or an error.
    pub status: String,
    /// The dataset's points (absent from older results: 0).
    #[serde(default)]
    pub n_points: f64,
}

fn nan() -> f64 {
    f64::NAN
}

/// One method's curve on one (view, distance): (ln points, value), sorted by points.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Curve(pub Vec<(f64, f64)>);

impl Curve {
    /// The curve of (points, value) pairs: non-finite values left out, one point per points
    /// count (its best value), sorted.
    pub fn new(points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        let mut by: BTreeMap<u64, (f64, f64)> = BTreeMap::new();
        for (n, v) in points {
            if n > 0.0 && v.is_finite() {
                let e = by.entry(n.to_bits()).or_insert((n.ln(), v));
                e.1 = e.1.max(v);
            }
        }
        let mut out: Vec<(f64, f64)> = by.into_values().collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        Curve(out)
    }

    /// The value at `points`, linear in ln(points) between the curve's two points around it;
    /// `None` outside its range (not reached).
    pub fn at(&self, points: f64) -> Option<f64> {
        let x = points.ln();
        let (first, last) = (self.0.first()?, self.0.last()?);
        if x < first.0 || x > last.0 {
            return None;
        }
        let i = self.0.partition_point(|p| p.0 < x);
        let b = self.0[i];
        if b.0 == x || i == 0 {
            return Some(b.1);
        }
        let a = self.0[i - 1];
        Some(a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0))
    }

    /// The integral of the curve over `[lo, hi]` (ln points; within its range).
    fn integral(&self, lo: f64, hi: f64) -> f64 {
        self.0
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let (x0, x1) = (a.0.max(lo), b.0.min(hi));
                if x1 <= x0 {
                    return 0.0;
                }
                let f = |x: f64| a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0);
                (x1 - x0) * 0.5 * (f(x0) + f(x1))
            })
            .sum()
    }
}

/// The BD-PSNR of curve `a` against the anchor's curve `r`: the mean of `a` minus the mean of
/// `r` over their common range of ln points; `None` (not comparable) when the range is empty
/// or fewer than two points of `a` lie in it.
pub fn bd(a: &Curve, r: &Curve) -> Option<f64> {
    let lo = a.0.first()?.0.max(r.0.first()?.0);
    let hi = a.0.last()?.0.min(r.0.last()?.0);
    if hi <= lo {
        return None;
    }
    let inside = a.0.iter().filter(|p| lo <= p.0 && p.0 <= hi).count();
    if inside < 2 {
        return None;
    }
    Some((a.integral(lo, hi) - r.integral(lo, hi)) / (hi - lo))
}

/// A (view, distance) cell's key.
pub fn key(view: usize, distance: f64) -> String {
    format!("{view} {distance}")
}

/// The curves of one dataset: method → (view, distance) key → curve, by `value` (PSNR or
/// SSIM) of the rows whose image is not identical to the reference.
pub type Curves = BTreeMap<String, BTreeMap<String, Curve>>;

/// The curves of `rows` (one dataset's ok rows) by `value`.
pub fn curves(rows: &[&LodRow], value: impl Fn(&LodRow) -> f64) -> Curves {
    let mut pts: BTreeMap<String, BTreeMap<String, Vec<(f64, f64)>>> = BTreeMap::new();
    for r in rows {
        let v = if r.psnr >= IDENTICAL_PSNR {
            f64::NAN
        } else {
            value(r)
        };
        pts.entry(r.method.clone())
            .or_default()
            .entry(key(r.view, r.distance))
            .or_default()
            .push((r.points_rendered, v));
    }
    pts.into_iter()
        .map(|(m, by)| (m, by.into_iter().map(|(k, p)| (k, Curve::new(p))).collect()))
        .collect()
}

/// The dataset's points: its rows' `n_points`, else the most points any row rendered.
pub fn dataset_points(rows: &[&LodRow]) -> f64 {
    let n = rows.iter().map(|r| r.n_points).fold(0.0, f64::max);
    if n > 0.0 {
        n
    } else {
        rows.iter().map(|r| r.points_rendered).fold(0.0, f64::max)
    }
}

/// The value of each method's curve at `points`, per key where it is reached.
pub fn at_budget(curves: &Curves, points: f64) -> Vec<Cell> {
    let mut out = Vec::new();
    for (m, by) in curves {
        for (k, c) in by {
            if let Some(v) = c.at(points) {
                out.push(Cell::new(m, "", k.clone(), v, points));
            }
        }
    }
    out
}

/// Each method's BD-PSNR against the anchor's curve, per key where it is comparable.
pub fn bd_cells(curves: &Curves) -> Vec<Cell> {
    let Some(anchor) = curves.get(BD_ANCHOR) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for (m, by) in curves.iter().filter(|(m, _)| *m != BD_ANCHOR) {
        for (k, c) in by {
            if let Some(v) = anchor.get(k).and_then(|r| bd(c, r)) {
                out.push(Cell::new(m, "", k.clone(), v, f64::NAN));
            }
        }
    }
    out
}

/// `method: WORD` for each method of `curves` (but the anchor, for `skip`) without a cell.
pub fn missing(curves: &Curves, cells: &[Cell], word: &str, skip: Option<&str>) -> Vec<String> {
    curves
        .keys()
        .filter(|m| Some(m.as_str()) != skip && !cells.iter().any(|c| &c.method == *m))
        .map(|m| format!("{m}: {word}"))
        .collect()
}

/// A budget's percentage as the conditions write it (`1`, `10`, `30`).
pub fn percent(fraction: f64) -> String {
    format!("{}", (fraction * 100.0 * 1e6).round() / 1e6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_curve_is_read_in_log_points_and_never_extrapolated() {
        let c = Curve::new([
            (100.0, 10.0),
            (1000.0, 20.0),
            (1000.0, 19.0),
            (10.0, f64::NAN),
        ]);
        assert_eq!(c.0.len(), 2);
        // Half-way in log points between 100 and 1000 is sqrt(100 · 1000).
        let mid = (100.0f64 * 1000.0).sqrt();
        assert!((c.at(mid).unwrap() - 15.0).abs() < 1e-9);
        assert_eq!(c.at(100.0), Some(10.0));
        assert_eq!(c.at(1000.0), Some(20.0));
        // Outside the sweep: not reached, on either side.
        assert_eq!(c.at(99.0), None);
        assert_eq!(c.at(1001.0), None);
        assert_eq!(Curve::default().at(5.0), None);
    }

    #[test]
    fn bd_psnr_is_the_mean_gap_over_the_common_range() {
        // a is 2 dB over r wherever both are drawn; r covers more points.
        let r = Curve::new([(10.0, 10.0), (100.0, 20.0), (1000.0, 30.0)]);
        let a = Curve::new([
            (50.0, 10.0 + 10.0 * 5f64.log10() + 2.0),
            (500.0, 22.0 + 10.0 * 5f64.log10()),
        ]);
        let d = bd(&a, &r).unwrap();
        assert!((d - 2.0).abs() < 1e-9, "{d}");
        // One point of a in the common range: not comparable.
        let one = Curve::new([(50.0, 30.0), (5000.0, 40.0)]);
        assert_eq!(bd(&one, &r), None);
        // No common range.
        let far = Curve::new([(2000.0, 30.0), (5000.0, 40.0)]);
        assert_eq!(bd(&far, &r), None);
    }
}
