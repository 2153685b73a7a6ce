//! The verdict over one condition's cells, the rules every accuracy finding follows (written
//! out in plain words in `docs/verdicts.md`, recomputed by `scripts/audit_findings.py`):
//!
//! 1. **Same cells.** The keys (views, or views at a level or distance) of a condition are the
//!    union of every method's; a method at a setting is compared only when it has every key.
//!    When none has them all, the keys are those of the (method, setting) with the most, and the
//!    methods with all of those are compared. A method without such a setting is left apart
//!    with its count of keys ([`Verdict::apart`]); no mean or median mixes unequal cells.
//! 2. **One statistic decides.** Each method stands at its setting with the highest mean over
//!    the keys (ties: the lower median cost, then the label); methods are ranked by that mean
//!    (ties: the lower cost, then the name).
//! 3. **Identical answers are named, not ranked.** A method whose answers equal the best's on
//!    every key (the same visible-set fingerprint where both rows have one, else the same
//!    score) is listed as identical ([`Verdict::identical`]); the next distinct method is the
//!    runner-up. Speed verdicts (the hulls) do not use this rule: equal answers are their point.
//! 4. **The lead and the margin.** The lead is the mean of the paired differences best −
//!    runner-up over the keys, with its bootstrap 95 % interval ([`crate::stats`]). The word
//!    ([`judge`]): `wins` when the interval lies above the practical margin, `equivalent` when
//!    it lies within ± the margin, else `no clear winner`; `indicative` without an interval
//!    (fewer than [`crate::stats::MIN_VIEWS`] keys), `only method` without a runner-up.
//! 5. **Cheapest near the best.** Of every compared (method, setting), the lowest median cost
//!    whose mean is within the tolerance of the best's.

use std::collections::{BTreeMap, BTreeSet};

use crate::stats::{Estimate, bootstrap_mean};

/// Seed of the findings' bootstrap.
pub const SEED: u64 = 39;

/// The practical margin of F1 and pixel F1: a lead inside ± this is no lead.
pub const F1_MARGIN: f64 = 0.005;
/// The practical margin of PSNR (dB), BD-PSNR included.
pub const PSNR_MARGIN: f64 = 0.1;
/// The practical margin of time, relative: a ratio within 1 ± this is no lead.
pub const TIME_MARGIN: f64 = 0.05;

/// Two scores this close are the same score (identical answers give equal floats).
const SAME: f64 = 1e-12;

/// One measured cell: a method at a setting on one key (a view, or a view at a level or
/// distance), its score (higher is better) and its cost (lower is better).
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Method (or family).
    pub method: String,
    /// Setting.
    pub setting: String,
    /// What pairs cells of different methods (the view, with its level or distance).
    pub key: String,
    /// Score (F1, PSNR), higher is better.
    pub value: f64,
    /// Cost (seconds, points rendered), lower is better.
    pub cost: f64,
    /// A fingerprint of the answer (the visible set's SHA-256), where the results have one.
    pub answer: Option<String>,
}

impl Cell {
    /// A cell without an answer's fingerprint.
    pub fn new(method: &str, setting: &str, key: String, value: f64, cost: f64) -> Self {
        Cell {
            method: method.to_owned(),
            setting: setting.to_owned(),
            key,
            value,
            cost,
            answer: None,
        }
    }
}

/// How a verdict is judged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rules {
    /// The practical margin of the lead, in the score's unit.
    pub margin: f64,
    /// The cheapest (method, setting) is sought within this of the best's mean; `None`: not
    /// sought.
    pub tolerance: Option<f64>,
    /// Whether methods with the best's answers are named identical and skipped as runner-up.
    pub identical: bool,
}

impl Rules {
    /// F1 (per point or per pixel): margin [`F1_MARGIN`], cheapest within 0.01.
    pub const F1: Rules = Rules {
        margin: F1_MARGIN,
        tolerance: Some(0.01),
        identical: true,
    };
}

/// The runner-up: the best distinct other method at its setting, its mean, and the best's
/// paired difference to it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunnerUp {
    /// Method.
    pub method: String,
    /// Its setting.
    pub setting: String,
    /// Its mean over the keys.
    pub value: f64,
    /// The best minus it, paired per key, with its interval.
    pub difference: Option<Estimate>,
}

/// The best method's answer over a set of cells ([`verdict`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// The best method.
    pub method: String,
    /// At its best setting.
    pub setting: String,
    /// Its mean score over the keys, with its interval.
    pub value: Estimate,
    /// Its median cost.
    pub cost: f64,
    /// Methods (at their setting) whose answers equal the best's on every key.
    pub identical: Vec<(String, String)>,
    /// The runner-up.
    pub runner_up: Option<RunnerUp>,
    /// The cheapest method and setting (lowest median cost) whose mean score is within the
    /// tolerance of the best: method, setting, mean score, median cost.
    pub cheapest: Option<(String, String, f64, f64)>,
    /// Methods left apart for lacking keys: name and how many of the keys they have.
    pub apart: Vec<(String, usize)>,
    /// The keys the compared methods share.
    pub keys: usize,
    /// The margin judged against.
    pub margin: f64,
}

impl Verdict {
    /// The word of the verdict ([`judge`]; `only method` without a runner-up).
    pub fn word(&self) -> &'static str {
        match &self.runner_up {
            None => "only method",
            Some(r) => judge(r.difference.as_ref(), self.margin),
        }
    }
}

/// The word for a lead: `wins` when its interval lies above `margin`, `equivalent` when it
/// lies within ± `margin`, `no clear winner` otherwise, `indicative` without an interval.
pub fn judge(difference: Option<&Estimate>, margin: f64) -> &'static str {
    match difference.and_then(|d| d.interval) {
        None => "indicative",
        Some((lo, hi)) => interval_word(lo, hi, 0.0, margin),
    }
}

/// [`judge`]'s rule for an interval `[lo, hi]` around `center` (0 for a difference, 1 for a
/// ratio).
pub fn interval_word(lo: f64, hi: f64, center: f64, margin: f64) -> &'static str {
    if lo > center + margin {
        "wins"
    } else if lo >= center - margin && hi <= center + margin {
        "equivalent"
    } else {
        "no clear winner"
    }
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Per key: the mean score, the mean cost and the first answer fingerprint.
type Keyed<'a> = BTreeMap<&'a str, (f64, f64, Option<&'a str>)>;

/// Of `cells` (name → key → value), the names compared by rule 1 (those with every key any
/// has; when none has, those with every key of the one with the most, the first of equals),
/// and the keys they share.
pub fn compared<N: Ord + Clone, K: Ord + Clone, V>(
    cells: &BTreeMap<N, BTreeMap<K, V>>,
) -> (Vec<N>, BTreeSet<K>) {
    let all: BTreeSet<K> = cells.values().flat_map(|c| c.keys().cloned()).collect();
    let keys: BTreeSet<K> = if cells.values().any(|c| c.len() == all.len()) {
        all
    } else {
        cells
            .values()
            .fold(None::<&BTreeMap<K, V>>, |best, c| match best {
                Some(b) if b.len() >= c.len() => Some(b),
                _ => Some(c),
            })
            .map(|c| c.keys().cloned().collect())
            .unwrap_or_default()
    };
    let names = cells
        .iter()
        .filter(|(_, c)| keys.iter().all(|k| c.contains_key(k)))
        .map(|(n, _)| n.clone())
        .collect();
    (names, keys)
}

/// The verdict over `cells` under `rules` (the module's rules); cells with a non-finite score
/// are left out; `None` when no method is left to compare.
pub fn verdict(cells: &[Cell], rules: Rules) -> Option<Verdict> {
    type Sums<'a> = BTreeMap<&'a str, (f64, f64, usize, Option<&'a str>)>;
    let mut sums: BTreeMap<(&str, &str), Sums<'_>> = BTreeMap::new();
    for c in cells.iter().filter(|c| c.value.is_finite()) {
        let e = sums
            .entry((&c.method, &c.setting))
            .or_default()
            .entry(&c.key)
            .or_insert((0.0, 0.0, 0, c.answer.as_deref()));
        e.0 += c.value;
        e.1 += c.cost;
        e.2 += 1;
    }
    let groups: BTreeMap<(&str, &str), Keyed<'_>> = sums
        .into_iter()
        .map(|(k, v)| {
            let v = v
                .into_iter()
                .map(|(key, (s, c, n, a))| (key, (s / n as f64, c / n as f64, a)))
                .collect();
            (k, v)
        })
        .collect();
    let (ids, keys) = compared(&groups);
    let complete: BTreeMap<(&str, &str), &Keyed<'_>> =
        ids.into_iter().map(|id| (id, &groups[&id])).collect();
    let mut apart: BTreeMap<&str, usize> = BTreeMap::new();
    for ((m, _), k) in &groups {
        if !complete.keys().any(|(cm, _)| cm == m) {
            let n = k.keys().filter(|key| keys.contains(*key)).count();
            let e = apart.entry(m).or_default();
            *e = (*e).max(n);
        }
    }
    let mean = |v: &Keyed<'_>| keys.iter().map(|k| v[k].0).sum::<f64>() / keys.len() as f64;
    let cost = |v: &Keyed<'_>| median(keys.iter().map(|k| v[k].1).collect());
    // Higher mean first, then lower cost (an unknown cost last).
    let order = |a: (f64, f64), b: (f64, f64)| {
        b.0.total_cmp(&a.0)
            .then(a.1.is_nan().cmp(&b.1.is_nan()))
            .then(a.1.total_cmp(&b.1))
    };
    let mut best: BTreeMap<&str, (&str, f64, f64)> = BTreeMap::new();
    for (&(method, setting), views) in &complete {
        let (m, c) = (mean(views), cost(views));
        if best
            .get(method)
            .is_none_or(|b| order((m, c), (b.1, b.2)).is_lt())
        {
            best.insert(method, (setting, m, c));
        }
    }
    let mut ranked: Vec<(&str, &str, f64, f64)> = best
        .into_iter()
        .map(|(m, (s, v, c))| (m, s, v, c))
        .collect();
    ranked.sort_by(|a, b| order((a.2, a.3), (b.2, b.3)).then(a.0.cmp(b.0)));
    let &(wm, ws, wv, _) = ranked.first()?;
    let winner = complete[&(wm, ws)];
    let values: Vec<f64> = keys.iter().map(|k| winner[k].0).collect();
    let value = bootstrap_mean(&values, SEED)?;
    let same = |other: &Keyed<'_>| {
        keys.iter().all(|k| {
            let (a, b) = (winner[k], other[k]);
            match (a.2, b.2) {
                (Some(x), Some(y)) => x == y,
                _ => (a.0 - b.0).abs() <= SAME,
            }
        })
    };
    let mut identical = Vec::new();
    let mut runner_up = None;
    for &(rm, rs, rv, _) in &ranked[1..] {
        let other = complete[&(rm, rs)];
        if rules.identical && same(other) {
            identical.push((rm.to_owned(), rs.to_owned()));
            continue;
        }
        let diffs: Vec<f64> = keys.iter().map(|k| winner[k].0 - other[k].0).collect();
        runner_up = Some(RunnerUp {
            method: rm.to_owned(),
            setting: rs.to_owned(),
            value: rv,
            difference: bootstrap_mean(&diffs, SEED),
        });
        break;
    }
    let cheapest = rules.tolerance.and_then(|tolerance| {
        complete
            .iter()
            .map(|((m, s), v)| (*m, *s, mean(v), cost(v)))
            .filter(|c| c.2 >= wv - tolerance && !c.3.is_nan())
            .min_by(|a, b| a.3.total_cmp(&b.3).then(b.2.total_cmp(&a.2)))
            .map(|(m, s, v, c)| (m.to_owned(), s.to_owned(), v, c))
    });
    Some(Verdict {
        method: wm.to_owned(),
        setting: ws.to_owned(),
        value,
        cost: cost(winner),
        identical,
        runner_up,
        cheapest,
        apart: apart.into_iter().map(|(m, n)| (m.to_owned(), n)).collect(),
        keys: keys.len(),
        margin: rules.margin,
    })
}
