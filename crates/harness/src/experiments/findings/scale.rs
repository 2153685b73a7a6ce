//! The scale findings: per group of cells (visibility methods, hulls, LOD builds in core, out of
//! core), the fastest at 10^7 points and at the largest size any of the group finished, with
//! the runner-up and the lightest in peak memory.
//!
//! A cell is one run (no views, no interval): the fastest `wins` when the runner-up took more
//! than 1 + [`super::verdict::TIME_MARGIN`] times its time, else there is `no clear winner`.
//! A method whose exactness claim failed in the sibling experiments' results
//! ([`super::wrong::for_scale`]: a hull of the hull experiment, an HPR peer) is left out and
//! named.

use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

use super::verdict::TIME_MARGIN;
use super::wrong;
use super::{Finding, points_text};
use crate::output::{distinct, read_csv};

/// The columns of the scale results the findings read.
#[derive(Deserialize)]
struct ScaleRow {
    method: String,
    n_points: u64,
    seconds: f64,
    peak_rss_bytes: u64,
    status: String,
}

pub(super) fn scale(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<ScaleRow> = read_csv(&dir.join("results.csv"))?;
    let wrong = wrong::for_scale(dir)?;
    // LOD selections answer another question than builds: the builds only, in core and out of
    // core apart (an out-of-core build is judged against the others within its memory limit).
    let ooc = |m: &str| m.ends_with(super::super::scale::plan::OOC_SUFFIX);
    let in_group = |r: &ScaleRow, g: usize| match g {
        0 | 1 => super::super::scale::render::group(&r.method) == g,
        2 => {
            super::super::scale::render::group(&r.method) == 2
                && !r.method.ends_with("-select")
                && !ooc(&r.method)
        }
        _ => ooc(&r.method),
    };
    let groups = [
        (0, "visibility methods (one view; per-cloud build apart)"),
        (1, "hulls"),
        (2, "LOD builds in core"),
        (3, "LOD builds out of core"),
    ];
    let mut out = Vec::new();
    for (g, name) in groups {
        let ok: Vec<&ScaleRow> = rows
            .iter()
            .filter(|r| {
                r.status == "ok"
                    && r.seconds.is_finite()
                    && in_group(r, g)
                    && wrong.get(&r.method).is_none()
            })
            .collect();
        let Some(largest) = ok.iter().map(|r| r.n_points).max() else {
            continue;
        };
        let tried = distinct(
            rows.iter()
                .filter(|r| in_group(r, g))
                .map(|r| r.method.as_str()),
        )
        .len();
        // At 10^7 points (the default run's largest), then at the largest size any finished.
        let mut sizes = vec![largest];
        if largest > SCALE_SIZE && ok.iter().any(|r| r.n_points == SCALE_SIZE) {
            sizes.insert(0, SCALE_SIZE);
        }
        let notes = wrong.notes(
            rows.iter()
                .filter(|r| in_group(r, g))
                .map(|r| r.method.as_str()),
        );
        for n in sizes {
            let mut f = scale_finding(&ok, n, n == largest, name, tried, quick);
            f.not_ranked = notes.join("; ");
            out.push(f);
        }
    }
    Ok(out)
}

/// The size every scale group is judged at, beside the largest it reached.
const SCALE_SIZE: u64 = 10_000_000;

/// The scale finding of one group at `n` points: the fastest, the runner-up, the lightest.
fn scale_finding(
    ok: &[&ScaleRow],
    n: u64,
    largest: bool,
    name: &str,
    tried: usize,
    quick: bool,
) -> Finding {
    {
        let mut at: Vec<&ScaleRow> = ok.iter().copied().filter(|r| r.n_points == n).collect();
        at.sort_by(|a, b| {
            a.seconds
                .total_cmp(&b.seconds)
                .then(a.method.cmp(&b.method))
        });
        let best = at[0];
        let lightest = at
            .iter()
            .min_by(|a, b| {
                a.peak_rss_bytes
                    .cmp(&b.peak_rss_bytes)
                    .then(a.method.cmp(&b.method))
            })
            .copied()
            .unwrap_or(best);
        let runner = at.get(1);
        let verdict = match runner {
            None => "only method",
            Some(r) if r.seconds > best.seconds * (1.0 + TIME_MARGIN) => "wins",
            Some(_) => "no clear winner",
        };
        Finding {
            experiment: "scale".into(),
            condition: format!(
                "{name} at {} points{} ({} of {tried} finished)",
                points_text(n),
                if largest {
                    ", the largest any finished"
                } else {
                    ""
                },
                at.len()
            ),
            question: "Which method finishes the largest cloud, how fast and in how much memory?"
                .into(),
            method: best.method.clone(),
            setting: String::new(),
            metric: "seconds".into(),
            value: best.seconds,
            low: None,
            high: None,
            n_views: None,
            indicative: quick,
            verdict: verdict.into(),
            runner_up: runner.map_or(String::new(), |r| r.method.clone()),
            runner_up_value: runner.map(|r| r.seconds),
            difference: None,
            difference_low: None,
            difference_high: None,
            cost_metric: "peak memory (MiB)".into(),
            cost: best.peak_rss_bytes as f64 / 1048576.0,
            cheapest: lightest.method.clone(),
            cheapest_value: Some(lightest.seconds),
            cheapest_cost: Some(lightest.peak_rss_bytes as f64 / 1048576.0),
            tolerance: None,
            identical: String::new(),
            not_ranked: String::new(),
            margin: TIME_MARGIN,
        }
    }
}
