//! Statistics for the comparisons the report states: paired per view, with a bootstrap 95 %
//! confidence interval (percentile method, seeded, so the same CSVs give the same interval).
//! No interval is stated from fewer than [`MIN_VIEWS`] views: such an estimate is the value
//! alone, marked indicative ([`Estimate::text`]).

use cloud::rng::{RngExt, seeded};

/// Resamples of the bootstrap.
pub const RESAMPLES: usize = 10_000;

/// The fewest views (paired values) an interval is stated from; below, an estimate is
/// indicative (an interval over 2 views looks like a result and is not one).
pub const MIN_VIEWS: usize = 5;

/// A value estimated from `n` views, with its bootstrap 95 % interval when `n` is at least
/// [`MIN_VIEWS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The estimate (a mean, or a geometric mean of ratios).
    pub value: f64,
    /// Its 95 % interval; `None` below [`MIN_VIEWS`] views.
    pub interval: Option<(f64, f64)>,
    /// The views (values) it comes from.
    pub n: usize,
}

impl Estimate {
    /// `value` with `unit`, then `[low, high]`, each formatted by `f`; without an interval,
    /// `(indicative: N views)`.
    pub fn text(&self, f: impl Fn(f64) -> String, unit: &str) -> String {
        match self.interval {
            Some((lo, hi)) => format!("{}{unit} [{}, {}]", f(self.value), f(lo), f(hi)),
            None => format!("{}{unit} ({})", f(self.value), indicative(self.n)),
        }
    }

    /// Whether the interval holds `x`; `None` without an interval.
    pub fn holds(&self, x: f64) -> Option<bool> {
        self.interval.map(|(lo, hi)| lo <= x && x <= hi)
    }
}

/// `indicative: N views` (or `1 view`).
pub fn indicative(n: usize) -> String {
    format!("indicative: {n} view{}", if n == 1 { "" } else { "s" })
}

/// The values of `a` and `b` at the keys both have (views), in key order: the pairs a paired
/// comparison is made of.
pub fn pair<K: Ord, V: Copy>(
    a: &std::collections::BTreeMap<K, V>,
    b: &std::collections::BTreeMap<K, V>,
) -> Vec<(V, V)> {
    a.iter()
        .filter_map(|(k, x)| Some((*x, *b.get(k)?)))
        .collect()
}

/// The geometric mean of the per-view ratios `a[k] / b[k]` and its bootstrap 95 % interval
/// (views resampled with replacement; none below [`MIN_VIEWS`]); `None` without a finite
/// positive pair.
pub fn paired_ratio(a: &[f64], b: &[f64], seed: u64) -> Option<Estimate> {
    let logs: Vec<f64> = a
        .iter()
        .zip(b)
        .filter(|&(&x, &y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(&x, &y)| (x / y).ln())
        .collect();
    let e = bootstrap_mean(&logs, seed)?;
    Some(Estimate {
        value: e.value.exp(),
        interval: e.interval.map(|(lo, hi)| (lo.exp(), hi.exp())),
        n: e.n,
    })
}

/// The mean of `values` and its bootstrap 95 % interval (none below [`MIN_VIEWS`] values);
/// `None` when empty.
pub fn bootstrap_mean(values: &[f64], seed: u64) -> Option<Estimate> {
    if values.is_empty() {
        return None;
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < MIN_VIEWS {
        return Some(Estimate {
            value: mean,
            interval: None,
            n,
        });
    }
    let mut rng = seeded(seed, "bootstrap");
    let mut means: Vec<f64> = (0..RESAMPLES)
        .map(|_| (0..n).map(|_| values[rng.random_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let at = |q: f64| means[((q * (RESAMPLES - 1) as f64).round() as usize).min(RESAMPLES - 1)];
    Some(Estimate {
        value: mean,
        interval: Some((at(0.025), at(0.975))),
        n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_are_the_common_views_in_order() {
        let a = std::collections::BTreeMap::from([(3, 30.0), (0, 0.5), (1, 10.0)]);
        let b = std::collections::BTreeMap::from([(1, 1.0), (3, 3.0), (7, 7.0)]);
        assert_eq!(pair(&a, &b), [(10.0, 1.0), (30.0, 3.0)]);
        assert!(pair(&a, &std::collections::BTreeMap::new()).is_empty());
    }

    #[test]
    fn a_constant_ratio_has_a_point_interval() {
        let e = paired_ratio(&[2.0, 4.0, 8.0, 16.0, 32.0], &[1.0, 2.0, 4.0, 8.0, 16.0], 1).unwrap();
        let (lo, hi) = e.interval.unwrap();
        assert!(
            (e.value - 2.0).abs() < 1e-12 && (lo - 2.0).abs() < 1e-12 && (hi - 2.0).abs() < 1e-12
        );
    }

    #[test]
    fn the_interval_holds_the_mean_and_is_reproducible() {
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        let e = bootstrap_mean(&v, 7).unwrap();
        let (m, (lo, hi)) = (e.value, e.interval.unwrap());
        assert!((m - 4.0).abs() < 1e-12);
        assert!(lo < m && m < hi && lo >= 1.0 && hi <= 10.0, "{lo} {hi}");
        assert_eq!(bootstrap_mean(&v, 7), bootstrap_mean(&v, 7));
        assert!(bootstrap_mean(&[], 1).is_none());
        assert!(paired_ratio(&[1.0], &[f64::NAN], 1).is_none());
    }

    #[test]
    fn fewer_than_five_views_give_no_interval() {
        let e = bootstrap_mean(&[0.9, 0.95], 7).unwrap();
        assert_eq!(e.interval, None);
        assert_eq!(e.n, 2);
        assert!((e.value - 0.925).abs() < 1e-12);
        assert_eq!(e.holds(0.0), None);
        let text = e.text(|x| format!("{x:.3}"), "");
        assert_eq!(text, "0.925 (indicative: 2 views)");
        assert!(!text.contains('['));
        let r = paired_ratio(&[2.0, 4.0, 8.0, 16.0], &[1.0, 2.0, 4.0, 8.0], 1).unwrap();
        assert_eq!((r.interval, r.n), (None, 4));
        assert_eq!(
            r.text(|x| format!("{x:.2}"), "×"),
            "2.00× (indicative: 4 views)"
        );
        let five = bootstrap_mean(&[1.0, 2.0, 3.0, 4.0, 5.0], 7).unwrap();
        assert!(five.interval.is_some() && five.holds(3.0) == Some(true));
        assert!(five.text(|x| format!("{x:.1}"), "").starts_with("3.0 ["));
    }
}
