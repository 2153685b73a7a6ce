//! The robustness findings: which method keeps the best F1 on degraded input, per degradation
//! and level group, per pool of datasets.
//!
//! The pools, in this order: the evaluation datasets pooled (out of sample: `best` was tuned on
//! the clean tuning datasets, which these are not), each tuning dataset alone (in-sample: its
//! clean cloud tuned `best`), a user's own datasets each alone, and the simulated scans pooled
//! (captures of the tuning meshes; `best` tuned on the clean tuning datasets, not on the
//! scans). A run whose results do not say what `best` was tuned on (`tuned_on` in the run's
//! metadata; older runs tuned it on each dataset's own clean cloud, and on a scan itself) labels
//! every pool an oracle. Within a pool, each degradation measured at one level is one condition
//! and one measured at several is two, its milder and its harsher half ([`level_groups`]).
//! A condition's keys are (dataset, level, view); each method stands at the better of `best`
//! and `auto` on the condition; the verdict's rules are [`super::verdict`]'s.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

use super::verdict::{Cell, Rules, verdict};
use super::{Ask, Finding, IN_SAMPLE, OUT_OF_SAMPLE, POOLED, finding};
use crate::datasets::Role;
use crate::experiments::visibility::tuning::roles_of;
use crate::output::meta::RunMeta;
use crate::output::{distinct, read_csv};

/// The columns of the robustness results the findings read.
#[derive(Deserialize)]
struct RobustnessRow {
    dataset: String,
    degradation: String,
    level: f64,
    method: String,
    setting: String,
    view: usize,
    f1: f64,
    seconds: f64,
    status: String,
}

/// A pool's label after its dataset names, by kind.
const SCANS: &str = "simulated scans of the tuning meshes: settings tuned on the clean tuning \
                     data, not on the scans";
const OWN: &str = "own data: settings tuned on the clean tuning data";
const ORACLE: &str = "oracle: `best` tuned on each dataset's own clean cloud, a scan's on itself";

/// The pool of each dataset of a run: (its order, its label).
fn pools(rows: &[RobustnessRow], meta: &serde_json::Value) -> BTreeMap<String, (usize, String)> {
    let names = distinct(rows.iter().map(|r| r.dataset.as_str()));
    let roles = roles_of(&names, meta);
    let tuned_on: Option<Vec<String>> = serde_json::from_value(meta["tuned_on"].clone()).ok();
    let scans: Vec<&str> = names
        .iter()
        .map(String::as_str)
        .filter(|d| {
            rows.iter()
                .any(|r| r.dataset == *d && r.degradation == "scan")
        })
        .collect();
    let tuned = tuned_on.filter(|t| !t.is_empty());
    let evaluation: Vec<&str> = names
        .iter()
        .map(String::as_str)
        .filter(|d| roles[*d] == Role::Evaluation && !scans.contains(d))
        .collect();
    let mut out = BTreeMap::new();
    for d in &names {
        let pool = match &tuned {
            None => (2, format!("{d} ({ORACLE})")),
            Some(_) if scans.contains(&d.as_str()) => {
                (3, format!("{} ({SCANS})", scans.join(", ")))
            }
            Some(_) if evaluation.contains(&d.as_str()) => match evaluation.len() {
                1 => (0, format!("{d} ({OUT_OF_SAMPLE})")),
                _ => (
                    0,
                    format!("{POOLED}: {} ({OUT_OF_SAMPLE})", evaluation.join(", ")),
                ),
            },
            Some(t) if t.contains(d) => (1, format!("{d} ({IN_SAMPLE})")),
            Some(_) => (2, format!("{d} ({OWN})")),
        };
        out.insert(d.clone(), pool);
    }
    out
}

pub(super) fn robustness(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<RobustnessRow> = read_csv(&dir.join("results.csv"))?;
    let meta = RunMeta::read(dir).map(|m| m.parameters).unwrap_or_default();
    let pools = pools(&rows, &meta);
    // The level groups of each pool, from the levels measured in it.
    let mut groups: BTreeMap<&str, BTreeMap<(String, u64), String>> = BTreeMap::new();
    for pool in pools.values().map(|p| p.1.as_str()) {
        groups.entry(pool).or_insert_with(|| {
            level_groups(
                rows.iter()
                    .filter(|r| pools[&r.dataset].1 == pool)
                    .map(|r| (r.degradation.as_str(), r.level)),
            )
        });
    }
    // (pool order, pool, group) in the order of first appearance within each pool.
    let mut conditions: Vec<((usize, String, String), Vec<Cell>)> = Vec::new();
    for r in rows.iter().filter(|r| r.status == "ok") {
        let (order, pool) = &pools[&r.dataset];
        let group = groups[pool.as_str()]
            .get(&(r.degradation.clone(), r.level.to_bits()))
            .cloned()
            .unwrap_or_else(|| r.degradation.clone());
        let id = (*order, pool.clone(), group);
        let cell = Cell::new(
            &r.method,
            &r.setting,
            format!("{} {} {}", r.dataset, r.level, r.view),
            r.f1,
            r.seconds,
        );
        match conditions.iter_mut().find(|(k, _)| *k == id) {
            Some((_, cells)) => cells.push(cell),
            None => conditions.push((id, vec![cell])),
        }
    }
    conditions.sort_by_key(|((order, _, _), _)| *order);
    Ok(conditions
        .into_iter()
        .filter_map(|((_, pool, group), cells)| {
            let v = verdict(&cells, Rules::F1)?;
            Some(finding(
                Ask {
                    experiment: "robustness",
                    condition: format!("{group} — {pool}"),
                    question: "Which method keeps the best F1 on degraded input?",
                    metric: "F1",
                    cost_metric: "seconds per view",
                    rules: Rules::F1,
                    quick,
                },
                v,
                Vec::new(),
            ))
        })
        .collect())
}

/// The condition of each (degradation, level): a degradation measured at one level is one
/// condition; one at several is two, its milder half of the levels and its harsher half (the
/// middle level of an odd count goes with the milder), named by their level ranges, so a
/// winner that changes as the degradation grows shows as two rows.
pub fn level_groups<'a>(
    rows: impl Iterator<Item = (&'a str, f64)>,
) -> BTreeMap<(String, u64), String> {
    let mut levels: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (d, l) in rows {
        levels.entry(d).or_default().push(l);
    }
    let mut out = BTreeMap::new();
    for (d, mut l) in levels {
        l.sort_by(f64::total_cmp);
        l.dedup();
        if l.len() < 2 {
            continue;
        }
        let split = l.len().div_ceil(2);
        for (part, word) in [(&l[..split], "milder"), (&l[split..], "harsher")] {
            let range = match part {
                [one] => format!("level {one}"),
                [first, .., last] => format!("levels {first} to {last}"),
                [] => continue,
            };
            let name = format!("{d}, {word} {} of {}: {range}", part.len(), l.len());
            for x in part {
                out.insert((d.to_owned(), x.to_bits()), name.clone());
            }
        }
    }
    out
}
