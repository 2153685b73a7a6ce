//! Every time ratio against a peer, by one pairing rule ([`paired`]): the visibility
//! experiment's peers against their partners ([`visibility`]), every hull against ours
//! ([`hull`]), the scale experiment's out-of-core peer build against ours ([`scale`]). The one
//! table of them is `reports/ratios.csv` (`experiments::ratios`); the summaries that print a
//! ratio print these rows.
//!
//! **The pairing rule**: the peer and ours on the same input at the same setting (a peer's
//! setting translated into ours through its `peer_keys`; in the hull experiment the hull is the
//! only difference), paired per view (the hull experiment: per (view, γ) cell). The ratio is
//! the geometric mean of the per-pair ratios of the peer's seconds over ours (above 1: ours is
//! faster), with its bootstrap 95 % interval (pairs resampled, seed [`SEED`]), stated from at
//! least [`crate::stats::MIN_VIEWS`] distinct views. A scale cell is one run of one view: its
//! ratio has no interval.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use super::wrong;
use crate::stats::{Estimate, MIN_VIEWS, paired_ratio};

/// Seed of the ratios' bootstrap.
pub const SEED: u64 = 2007;

/// The hull of ours every other hull is paired with.
pub const OWN_HULL: &str = "own";

/// One ratio against a peer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ratio {
    /// Experiment the pairs come from.
    pub experiment: String,
    /// Dataset (scale: the cloud's size in points).
    pub dataset: String,
    /// The peer.
    pub peer: String,
    /// Its setting.
    pub peer_setting: String,
    /// The method of ours.
    pub ours: String,
    /// Its setting.
    pub ours_setting: String,
    /// Pairs (views, or (view, γ) cells).
    pub pairs: usize,
    /// Distinct views among them.
    pub views: usize,
    /// The peer's seconds over ours, geometric mean over the pairs.
    pub ratio: f64,
    /// Its 95 % interval (empty below 5 views).
    pub low: Option<f64>,
    /// See `low`.
    pub high: Option<f64>,
    /// The lowest pair's ratio.
    pub min: f64,
    /// The highest pair's.
    pub max: f64,
    /// The lowest Jaccard index of the two visible sets over the pairs (empty: not known).
    pub jaccard_min: Option<f64>,
    /// `wrong answers (…)` when the peer claims exactness and its sets missed ours.
    pub note: String,
    /// The run: its start (UTC).
    pub run: String,
    /// Its machine (CPU, cores).
    pub machine: String,
    /// Its revision.
    pub revision: String,
}

impl Ratio {
    /// `13.65× [12.76, 14.51]`, or without an interval `13.65× (indicative: 3 views)` (a scale
    /// cell's: `0.53× (one run)`; the scale experiment's normal estimation, alternated rounds:
    /// `3.10× (median of 3 alternated pairs)`).
    pub fn text(&self) -> String {
        match (self.low, self.high) {
            (Some(lo), Some(hi)) => format!("{:.2}× [{lo:.2}, {hi:.2}]", self.ratio),
            _ if self.experiment == "scale" && self.pairs > 1 => format!(
                "{:.2}× (median of {} alternated pairs)",
                self.ratio, self.pairs
            ),
            _ if self.experiment == "scale" => format!("{:.2}× (one run)", self.ratio),
            _ => format!(
                "{:.2}× ({})",
                self.ratio,
                crate::stats::indicative(self.views)
            ),
        }
    }
}

/// The ratio of `peer` seconds over `ours` (the module's rule) over `pairs` (views, seconds
/// of the peer, seconds of ours): the estimate (its interval from at least
/// [`MIN_VIEWS`] distinct views), the lowest and highest pair's ratio; `None` without a
/// finite positive pair.
pub fn paired(pairs: &[(usize, f64, f64)]) -> Option<(Estimate, f64, f64)> {
    let ok: Vec<&(usize, f64, f64)> = pairs
        .iter()
        .filter(|(_, p, o)| *p > 0.0 && *o > 0.0 && p.is_finite() && o.is_finite())
        .collect();
    let (peer, ours): (Vec<f64>, Vec<f64>) = ok.iter().map(|(_, p, o)| (*p, *o)).unzip();
    let views: BTreeSet<usize> = ok.iter().map(|(v, _, _)| *v).collect();
    let e = paired_ratio(&peer, &ours, SEED)?;
    let e = Estimate {
        interval: e.interval.filter(|_| views.len() >= MIN_VIEWS),
        n: views.len(),
        ..e
    };
    let per: Vec<f64> = peer.iter().zip(&ours).map(|(p, o)| p / o).collect();
    let min = per.iter().copied().fold(f64::INFINITY, f64::min);
    let max = per.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some((e, min, max))
}

/// A ratio row without its run (filled by [`all`]).
#[allow(clippy::too_many_arguments)]
fn ratio(
    experiment: &str,
    dataset: &str,
    (peer, peer_setting): (&str, &str),
    (ours, ours_setting): (&str, &str),
    pairs: &[(usize, f64, f64)],
    jaccard: &[f64],
    note: String,
) -> Option<Ratio> {
    let (e, min, max) = paired(pairs)?;
    let (low, high) = e.interval.unzip();
    let jaccard_min = jaccard
        .iter()
        .copied()
        .filter(|j| j.is_finite())
        .reduce(f64::min);
    Some(Ratio {
        experiment: experiment.into(),
        dataset: dataset.into(),
        peer: peer.into(),
        peer_setting: peer_setting.into(),
        ours: ours.into(),
        ours_setting: ours_setting.into(),
        pairs: pairs.len(),
        views: e.n,
        ratio: e.value,
        low,
        high,
        min,
        max,
        jaccard_min,
        note,
        run: String::new(),
        machine: String::new(),
        revision: String::new(),
    })
}

/// A row of the visibility experiment's `peers.csv`: a peer and its partner on one view.
#[derive(Debug, Clone, Deserialize)]
pub struct PeerPair {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// The peer.
    pub peer: String,
    /// Its setting.
    pub peer_params: String,
    /// Our partner (empty: none).
    pub partner: String,
    /// Its setting.
    pub partner_params: String,
    /// The peer's seconds.
    pub peer_seconds: f64,
    /// Ours.
    pub partner_seconds: f64,
    /// Jaccard index of the two sets.
    pub jaccard: f64,
    /// The peer claims exactness (absent from older results: no claim).
    #[serde(default)]
    pub claims_exact: bool,
}

/// A row of the hull experiment's results: one hull on one (view, γ) cell.
#[derive(Debug, Clone, Deserialize)]
pub struct HullCell {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// γ.
    pub gamma: f64,
    /// Hull.
    pub hull: String,
    /// Perturbation.
    pub perturb: f64,
    /// Seconds.
    pub seconds: f64,
    /// Jaccard index against the exact set.
    pub jaccard_vs_exact: f64,
    /// Status.
    pub status: String,
}

/// A row of the scale experiment's results: one method at one size.
#[derive(Debug, Clone, Deserialize)]
pub struct ScaleCell {
    /// Method (cell kind).
    pub method: String,
    /// Points.
    pub n_points: u64,
    /// Seconds.
    pub seconds: f64,
    /// Status.
    pub status: String,
}

/// The visibility experiment's peers (`peers.csv` rows) against their partners: one ratio per
/// dataset, peer and setting, in the rows' order.
pub fn visibility(rows: &[PeerPair]) -> Vec<Ratio> {
    let mut order: Vec<(&str, &str, &str)> = Vec::new();
    let mut groups: BTreeMap<(&str, &str, &str), Vec<&PeerPair>> = BTreeMap::new();
    for r in rows.iter().filter(|r| !r.partner.is_empty()) {
        let key = (r.dataset.as_str(), r.peer.as_str(), r.peer_params.as_str());
        if !groups.contains_key(&key) {
            order.push(key);
        }
        groups.entry(key).or_default().push(r);
    }
    let claims: BTreeMap<&str, f64> = rows
        .iter()
        .filter(|r| r.claims_exact && r.jaccard.is_finite())
        .fold(BTreeMap::new(), |mut m, r| {
            let e = m.entry(r.peer.as_str()).or_insert(r.jaccard);
            *e = e.min(r.jaccard);
            m
        });
    order
        .into_iter()
        .filter_map(|key| {
            let ps = &groups[&key];
            let first = ps[0];
            let pairs: Vec<(usize, f64, f64)> = ps
                .iter()
                .map(|p| (p.view, p.peer_seconds, p.partner_seconds))
                .collect();
            let jaccard: Vec<f64> = ps.iter().map(|p| p.jaccard).collect();
            let note = claims
                .get(key.1)
                .filter(|j| **j < wrong::JACCARD)
                .map_or(String::new(), |j| wrong::note(*j));
            ratio(
                "visibility",
                key.0,
                (key.1, key.2),
                (&first.partner, &first.partner_params),
                &pairs,
                &jaccard,
                note,
            )
        })
        .collect()
}

/// The hull experiment's hulls against ours ([`OWN_HULL`]) at perturbation 0, paired per
/// (view, γ) cell: one ratio per dataset and hull.
pub fn hull(rows: &[HullCell]) -> Vec<Ratio> {
    let ok = |r: &&HullCell| r.status == "ok" && r.perturb == 0.0;
    let worst: BTreeMap<&str, f64> = rows.iter().filter(ok).fold(BTreeMap::new(), |mut m, r| {
        if r.jaccard_vs_exact.is_finite() {
            let e = m.entry(r.hull.as_str()).or_insert(r.jaccard_vs_exact);
            *e = e.min(r.jaccard_vs_exact);
        }
        m
    });
    let mut out = Vec::new();
    for d in crate::output::distinct(rows.iter().map(|r| r.dataset.as_str())) {
        let at = |h: &str| -> BTreeMap<(usize, u64), (f64, f64)> {
            rows.iter()
                .filter(ok)
                .filter(|r| r.dataset == d && r.hull == h)
                .map(|r| ((r.view, r.gamma.to_bits()), (r.seconds, r.jaccard_vs_exact)))
                .collect()
        };
        let own = at(OWN_HULL);
        for h in crate::output::distinct(rows.iter().map(|r| r.hull.as_str())) {
            if h == OWN_HULL {
                continue;
            }
            let theirs = at(&h);
            let pairs: Vec<(usize, f64, f64)> = theirs
                .iter()
                .filter_map(|(k, t)| Some((k.0, t.0, own.get(k)?.0)))
                .collect();
            let jaccard: Vec<f64> = theirs
                .iter()
                .filter(|(k, _)| own.contains_key(k))
                .map(|(_, t)| t.1)
                .collect();
            let note = worst
                .get(h.as_str())
                .filter(|j| **j < wrong::JACCARD)
                .map_or(String::new(), |j| wrong::note(*j));
            out.extend(ratio(
                "hull",
                &d,
                (&h, ""),
                (OWN_HULL, ""),
                &pairs,
                &jaccard,
                note,
            ));
        }
    }
    out
}

/// The scale experiment's out-of-core peer build (`peer`, copc_converter's) against each of
/// our out-of-core builds (the methods ending in `suffix`) at the same size: one run each, no
/// interval.
pub fn scale(rows: &[ScaleCell], peer: &str, suffix: &str) -> Vec<Ratio> {
    let mut out = Vec::new();
    for p in rows.iter().filter(|r| r.method == peer && r.status == "ok") {
        for r in rows.iter().filter(|r| {
            r.method.ends_with(suffix)
                && r.method != peer
                && r.n_points == p.n_points
                && r.status == "ok"
        }) {
            out.extend(ratio(
                "scale",
                &format!("{} points", p.n_points),
                (peer, ""),
                (&r.method, ""),
                &[(0, p.seconds, r.seconds)],
                &[],
                String::new(),
            ));
        }
    }
    out
}

/// The ratios as markdown: the rule, then one table (empty without ratios).
pub fn markdown(ratios: &[Ratio]) -> String {
    if ratios.is_empty() {
        return String::new();
    }
    let rows: Vec<Vec<String>> = ratios
        .iter()
        .map(|r| {
            let with = |m: &str, s: &str| match s {
                "" => m.to_owned(),
                s => format!("{m} {}", s.replace(';', " ")),
            };
            vec![
                r.experiment.clone(),
                r.dataset.clone(),
                with(&r.peer, &r.peer_setting),
                with(&r.ours, &r.ours_setting),
                r.pairs.to_string(),
                r.text(),
                format!("{:.2}–{:.2}", r.min, r.max),
                r.jaccard_min.map_or("-".into(), |j| format!("{j:.4}")),
                if r.note.is_empty() {
                    "-".into()
                } else {
                    r.note.clone()
                },
                format!(
                    "{} · `{}` · {}",
                    r.run,
                    &r.revision[..r.revision.len().min(10)],
                    r.machine
                ),
            ]
        })
        .collect();
    format!(
        "# Time ratios against the peers\n\nEvery ratio of a peer's time over ours in these \
         reports, computed once (`experiments::ratios`): the peer and ours on the same input at \
         the same setting, paired per view (the hull experiment: per (view, γ) cell); the \
         geometric mean of the per-pair ratios (above 1: ours is faster) with its bootstrap 95 % \
         interval, stated from 5 views; a scale cell is one run (no interval). A peer that \
         claims exactness and returned sets other than ours is marked: its time is no \
         comparison. Machine-readable: [ratios.csv](ratios.csv).\n\n{}",
        crate::experiments::markdown_table(
            &[
                "experiment",
                "dataset",
                "peer",
                "ours",
                "pairs",
                "peer time ÷ ours [95 % CI]",
                "pair min–max",
                "Jaccard min",
                "note",
                "run · revision · machine",
            ],
            &rows
        )
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ratio_is_the_geometric_mean_over_the_pairs_with_an_interval_from_five_views() {
        let pairs: Vec<(usize, f64, f64)> = (0..5)
            .map(|v| (v, 2.0 * (v + 1) as f64, (v + 1) as f64))
            .collect();
        let (e, min, max) = paired(&pairs).unwrap();
        assert!((e.value - 2.0).abs() < 1e-12 && min == 2.0 && max == 2.0);
        assert!(e.interval.is_some());
        // Fifteen cells over three views: no interval.
        let cells: Vec<(usize, f64, f64)> = (0..15).map(|k| (k % 3, 3.0, 1.0)).collect();
        let (e, _, _) = paired(&cells).unwrap();
        assert_eq!((e.interval, e.n), (None, 3));
        assert!(paired(&[(0, f64::NAN, 1.0)]).is_none());
    }
}
