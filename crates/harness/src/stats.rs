//! Statistics for the comparisons the report states: paired per view, with a bootstrap 95 %
//! confidence interval (percentile method, seeded, so the same CSVs give the same interval).

use cloud::rng::{RngExt, seeded};

/// Resamples of the bootstrap.
pub const RESAMPLES: usize = 10_000;

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
/// (views resampled with replacement); `None` without a finite positive pair.
pub fn paired_ratio(a: &[f64], b: &[f64], seed: u64) -> Option<(f64, f64, f64)> {
    let logs: Vec<f64> = a
        .iter()
        .zip(b)
        .filter(|&(&x, &y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(&x, &y)| (x / y).ln())
        .collect();
    let (mean, lo, hi) = bootstrap_mean(&logs, seed)?;
    Some((mean.exp(), lo.exp(), hi.exp()))
}

/// The mean of `values` and its bootstrap 95 % interval; `None` when empty.
pub fn bootstrap_mean(values: &[f64], seed: u64) -> Option<(f64, f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let mut rng = seeded(seed, "bootstrap");
    let mut means: Vec<f64> = (0..RESAMPLES)
        .map(|_| (0..n).map(|_| values[rng.random_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let at = |q: f64| means[((q * (RESAMPLES - 1) as f64).round() as usize).min(RESAMPLES - 1)];
    Some((mean, at(0.025), at(0.975)))
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
        let (g, lo, hi) = paired_ratio(&[2.0, 4.0, 8.0], &[1.0, 2.0, 4.0], 1).unwrap();
        assert!((g - 2.0).abs() < 1e-12 && (lo - 2.0).abs() < 1e-12 && (hi - 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_interval_holds_the_mean_and_is_reproducible() {
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        let (m, lo, hi) = bootstrap_mean(&v, 7).unwrap();
        assert!((m - 4.0).abs() < 1e-12);
        assert!(lo < m && m < hi && lo >= 1.0 && hi <= 10.0, "{lo} {hi}");
        assert_eq!(bootstrap_mean(&v, 7), bootstrap_mean(&v, 7));
        assert!(bootstrap_mean(&[], 1).is_none());
        assert!(paired_ratio(&[1.0], &[f64::NAN], 1).is_none());
    }
}
