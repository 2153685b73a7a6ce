//! The hull findings: per dataset, the fastest convex hull for HPR on unperturbed input.
//!
//! A hull whose unperturbed sets missed the exact one ([`super::wrong`]) is left out. Of the
//! others, those that ran every (view, γ) cell any hull ran are compared (when none did, the
//! cells of the hull that ran the most); the rest are listed apart with their count. The
//! fastest has the lowest geometric mean of seconds over those cells; the runner-up's time over
//! the winner's is paired per cell by the ratios table's rule (`rules::ratio::paired`:
//! geometric mean of the ratios, bootstrap 95 % interval from 5 views), and
//! judged against the time margin ([`super::verdict::TIME_MARGIN`]): `wins` when the interval
//! lies above 1 + margin, `equivalent` within 1 ± margin, else `no clear winner`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

use super::verdict::{TIME_MARGIN, compared, interval_word};
use super::{Finding, wrong};
use crate::output::{distinct, read_csv};
use crate::stats::MIN_VIEWS;

/// The columns of the hull results the findings read.
#[derive(Deserialize)]
struct HullRow {
    dataset: String,
    view: usize,
    gamma: f64,
    hull: String,
    perturb: f64,
    seconds: f64,
    status: String,
}

/// A hull's seconds per (view, γ bits) cell.
type Times = BTreeMap<(usize, u64), f64>;

pub(super) fn hull(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<HullRow> = read_csv(&dir.join("results.csv"))?;
    let wrong = wrong::hulls(dir)?;
    let mut out = Vec::new();
    let ok: Vec<&HullRow> = rows
        .iter()
        .filter(|r| r.status == "ok" && r.perturb == 0.0 && r.seconds > 0.0)
        .collect();
    for dataset in distinct(ok.iter().map(|r| r.dataset.as_str())) {
        let mut cells: BTreeMap<&str, Times> = BTreeMap::new();
        let mut tried: BTreeSet<&str> = BTreeSet::new();
        for r in ok.iter().filter(|r| r.dataset == dataset) {
            tried.insert(&r.hull);
            if wrong.get(&r.hull).is_none() {
                cells
                    .entry(&r.hull)
                    .or_default()
                    .insert((r.view, r.gamma.to_bits()), r.seconds);
            }
        }
        let (complete, keys) = compared(&cells);
        if complete.is_empty() {
            continue;
        }
        let geomean =
            |c: &Times| (keys.iter().map(|k| c[k].ln()).sum::<f64>() / keys.len() as f64).exp();
        let mut ranked: Vec<(&str, f64)> =
            complete.iter().map(|h| (*h, geomean(&cells[h]))).collect();
        ranked.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
        let (best, seconds) = ranked[0];
        // The ratios table's rule (`rules::ratio::paired`), over the compared cells.
        let ratio = ranked.get(1).and_then(|&(runner, _)| {
            let pairs: Vec<(usize, f64, f64)> = keys
                .iter()
                .map(|k| (k.0, cells[runner][k], cells[best][k]))
                .collect();
            crate::experiments::rules::ratio::paired(&pairs).map(|(e, _, _)| e)
        });
        let verdict = match (ranked.len(), ratio.and_then(|e| e.interval)) {
            (1, _) => "only method",
            (_, None) => "indicative",
            (_, Some((lo, hi))) => interval_word(lo, hi, 1.0, TIME_MARGIN),
        };
        let mut not_ranked = wrong.notes(tried.iter().copied());
        for (h, c) in &cells {
            if !complete.iter().any(|x| x == h) {
                let n = c.keys().filter(|k| keys.contains(k)).count();
                not_ranked.push(format!("{h}: {n} of {} cells", keys.len()));
            }
        }
        let (dlo, dhi) = ratio.and_then(|e| e.interval).unzip();
        out.push(Finding {
            experiment: "hull".into(),
            condition: format!(
                "{dataset}, {} of {} hulls on all {} (view, γ) cells",
                complete.len(),
                tried.len(),
                keys.len()
            ),
            question: "Which convex hull makes HPR fastest?".into(),
            method: best.to_owned(),
            setting: String::new(),
            metric: "seconds (geometric mean)".into(),
            value: seconds,
            low: None,
            high: None,
            n_views: Some(keys.len()),
            indicative: quick || keys.len() < MIN_VIEWS,
            verdict: verdict.into(),
            runner_up: ranked.get(1).map_or(String::new(), |r| r.0.to_owned()),
            runner_up_value: ranked.get(1).map(|r| r.1),
            difference: ratio.map(|e| e.value),
            difference_low: dlo,
            difference_high: dhi,
            cost_metric: "seconds (geometric mean)".into(),
            cost: seconds,
            cheapest: String::new(),
            cheapest_value: None,
            cheapest_cost: None,
            tolerance: None,
            identical: String::new(),
            not_ranked: not_ranked.join("; "),
            margin: TIME_MARGIN,
        });
    }
    Ok(out)
}
