//! The findings: the answer of each experiment present, computed from its results CSVs, for the
//! top of `reports/README.md` and for `reports/findings.csv`.
//!
//! One row per condition: visibility per dataset, twice: F1 among the methods made for the
//! visible set and per-pixel F1 among those made for the image ([`pixels`];
//! `registry::Card::made_for`); robustness per degradation and level group, per pool of
//! datasets ([`robustness`]); LOD per dataset at fixed point budgets and by BD-PSNR against the
//! random subsample ([`lod`]); scale per group ([`scale`]); hull per dataset ([`hull`]). Every
//! accuracy row follows the rules of [`verdict`] (same cells, one statistic, identical answers
//! named, a practical margin); a method whose exactness claim failed is never ranked
//! ([`wrong`]). The rules in plain words: `docs/verdicts.md`; `scripts/audit_findings.py`
//! recomputes every row from the results CSVs by a second path (Python and pandas).
//!
//! Which setting stands for a method. Visibility: each family at its **tuned** setting, the one
//! with the highest mean F1 over the run's tuning datasets ([`super::visibility::tuning`]); the
//! condition says whether the dataset is an evaluation dataset (out-of-sample), a tuning one
//! (in-sample) or, in a run without tuning data, that the setting is the **oracle**.
//! Robustness: `best`, tuned on the clean tuning datasets, and `auto`, the better of the two on
//! the condition. LOD: each method's whole curve over its sweep, read at the budget.

use std::path::Path;

use anyhow::Result;
use serde::{Deserialize, Serialize};

use super::visibility::tuning::{Obs, Protocol, roles_of};
use crate::datasets::Role;
use crate::output::meta::RunMeta;
use crate::output::{distinct, read_csv, write_csv};
use crate::stats::MIN_VIEWS;

/// The file the findings are written to, in the reports folder.
pub const CSV: &str = "findings.csv";

/// One finding: a row of `findings.csv` and of the README's findings table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Finding {
    /// Experiment (its section in the README).
    pub experiment: String,
    /// The condition (a dataset, a degradation, a group).
    pub condition: String,
    /// The question answered.
    pub question: String,
    /// The answer: the best method.
    pub method: String,
    /// Its setting.
    pub setting: String,
    /// What `value` measures.
    pub metric: String,
    /// The best method's value.
    pub value: f64,
    /// Its 95 % interval (empty: none, from fewer than 5 views or no views).
    pub low: Option<f64>,
    /// See `low`.
    pub high: Option<f64>,
    /// Views (keys) the value comes from (empty: no views, as in scale).
    pub n_views: Option<usize>,
    /// A quick run's, or from fewer than 5 views: not a result to quote.
    pub indicative: bool,
    /// `wins`, `equivalent`, `no clear winner`, `indicative`, `only method`
    /// ([`verdict::judge`]).
    pub verdict: String,
    /// The runner-up, with its setting.
    pub runner_up: String,
    /// The runner-up's value.
    pub runner_up_value: Option<f64>,
    /// The best's paired difference to the runner-up (empty for scale).
    pub difference: Option<f64>,
    /// Its 95 % interval.
    pub difference_low: Option<f64>,
    /// See `difference_low`.
    pub difference_high: Option<f64>,
    /// What `cost` measures.
    pub cost_metric: String,
    /// The best method's cost.
    pub cost: f64,
    /// The cheapest method (with its setting) within the tolerance of the best.
    pub cheapest: String,
    /// Its value.
    pub cheapest_value: Option<f64>,
    /// Its cost.
    pub cheapest_cost: Option<f64>,
    /// The tolerance `cheapest` is chosen within, in `metric`'s unit (empty: none sought).
    pub tolerance: Option<f64>,
    /// Methods (with their setting) whose answers equal the best's on every key: named, not
    /// ranked (`; `-separated).
    #[serde(default)]
    pub identical: String,
    /// Methods left out of the ranking and why: wrong answers (a failed exactness claim, with
    /// the worst Jaccard), or fewer cells than the compared ones (with their count); `; `-
    /// separated.
    #[serde(default)]
    pub not_ranked: String,
    /// The practical margin the verdict is judged against, in `metric`'s unit (a ratio's: its
    /// relative margin).
    #[serde(default)]
    pub margin: f64,
}

/// What a question asks, for [`finding`].
struct Ask<'a> {
    experiment: &'a str,
    condition: String,
    question: &'a str,
    metric: &'a str,
    cost_metric: &'a str,
    rules: Rules,
    quick: bool,
}

/// `method setting` for the table, the setting's pairs space-separated and its `seed=` left
/// out (a seed is not a tuned setting; the `setting` column of `findings.csv` keeps it whole).
fn with_setting(method: &str, setting: &str) -> String {
    let pairs: Vec<&str> = setting
        .split(';')
        .filter(|p| !p.is_empty() && !p.starts_with("seed="))
        .collect();
    if pairs.is_empty() {
        method.to_owned()
    } else {
        format!("{method} {}", pairs.join(" "))
    }
}

/// The finding of verdict `v` for `ask`; `wrong`: the notes of the methods left out for wrong
/// answers (before those left apart for fewer cells).
fn finding(ask: Ask<'_>, v: Verdict, wrong: Vec<String>) -> Finding {
    let (lo, hi) = v.value.interval.unzip();
    let diff = v.runner_up.as_ref().and_then(|r| r.difference);
    let (dlo, dhi) = diff.and_then(|d| d.interval).unzip();
    let mut not_ranked = wrong;
    not_ranked.extend(
        v.apart
            .iter()
            .map(|(m, n)| format!("{m}: {n} of {} cells", v.keys)),
    );
    Finding {
        experiment: ask.experiment.to_owned(),
        condition: ask.condition,
        question: ask.question.to_owned(),
        metric: ask.metric.to_owned(),
        indicative: ask.quick || v.value.n < MIN_VIEWS,
        verdict: v.word().to_owned(),
        value: v.value.value,
        low: lo,
        high: hi,
        n_views: Some(v.value.n),
        runner_up: v
            .runner_up
            .as_ref()
            .map_or(String::new(), |r| with_setting(&r.method, &r.setting)),
        runner_up_value: v.runner_up.as_ref().map(|r| r.value),
        difference: diff.map(|d| d.value),
        difference_low: dlo,
        difference_high: dhi,
        cost_metric: ask.cost_metric.to_owned(),
        cost: v.cost,
        cheapest: v
            .cheapest
            .as_ref()
            .map_or(String::new(), |c| with_setting(&c.0, &c.1)),
        cheapest_value: v.cheapest.as_ref().map(|c| c.2),
        cheapest_cost: v.cheapest.as_ref().map(|c| c.3),
        tolerance: ask.rules.tolerance,
        identical: v
            .identical
            .iter()
            .map(|(m, s)| with_setting(m, s))
            .collect::<Vec<_>>()
            .join("; "),
        not_ranked: not_ranked.join("; "),
        margin: ask.rules.margin,
        method: v.method,
        setting: v.setting,
    }
}

/// The columns of the visibility results the findings read.
#[derive(Deserialize)]
struct VisibilityRow {
    dataset: String,
    view: usize,
    family: String,
    params: String,
    seconds: f64,
    f1: f64,
    status: String,
    /// `points` or `pixels` (absent from older results: points); the per-point row judges
    /// the methods made for points, [`pixels`] the others.
    #[serde(default = "points")]
    made_for: String,
    /// The visible set's fingerprint (absent from older results: scores compare instead).
    #[serde(default)]
    visible_sha256: String,
}

fn points() -> String {
    "points".into()
}

/// The conditions of `rows` in the order they first appear, each with its cells.
fn by_condition<R>(
    rows: &[R],
    condition: impl Fn(&R) -> Option<String>,
    cell: impl Fn(&R) -> Cell,
) -> Vec<(String, Vec<Cell>)> {
    let mut out: Vec<(String, Vec<Cell>)> = Vec::new();
    for r in rows {
        let Some(c) = condition(r) else { continue };
        match out.iter_mut().find(|(k, _)| *k == c) {
            Some((_, cells)) => cells.push(cell(r)),
            None => out.push((c, vec![cell(r)])),
        }
    }
    out
}

/// How the condition pooling a run's evaluation datasets starts ([`pool_evaluation`]).
const POOLED: &str = "evaluation datasets pooled";

/// Puts first in `conditions` (dataset → cells) a condition pooling the cells of the run's
/// evaluation datasets, when it has at least two and tuned settings: the out-of-sample answer
/// in one row. Each cell is keyed by its dataset and view, so the mean is over every (dataset,
/// view) and the bootstrap resamples those (views of one mesh are not independent draws of
/// meshes: the interval is the views', not the meshes', as in every row).
fn pool_evaluation(conditions: &mut Vec<(String, Vec<Cell>)>, protocol: &Protocol) {
    let eval: Vec<&(String, Vec<Cell>)> = conditions
        .iter()
        .filter(|(d, _)| protocol.role(d) == Role::Evaluation)
        .collect();
    if eval.len() < 2 || protocol.tuned.is_empty() {
        return;
    }
    let names: Vec<&str> = eval.iter().map(|(d, _)| d.as_str()).collect();
    let cells: Vec<Cell> = eval
        .iter()
        .flat_map(|(d, cells)| {
            cells.iter().map(move |c| Cell {
                key: format!("{d} {}", c.key),
                ..c.clone()
            })
        })
        .collect();
    conditions.insert(0, (format!("{POOLED}: {}", names.join(", ")), cells));
}

/// The role of a visibility condition's dataset (the pooled condition's is evaluation).
fn role_of(protocol: &Protocol, condition: &str) -> Role {
    match condition.starts_with(POOLED) {
        true => Role::Evaluation,
        false => protocol.role(condition),
    }
}

/// A visibility condition's label: `dataset` with how its settings were chosen (`untuned`
/// when the run has no tuned setting), after `scope` (e.g. `per pixel; `), and the families of
/// `cells` without a tuned setting, at their best on these data (oracle).
fn tuned_condition(
    protocol: &Protocol,
    dataset: &str,
    cells: &[Cell],
    scope: &str,
    untuned: &str,
) -> String {
    let oracle: Vec<String> = distinct(cells.iter().map(|c| c.method.as_str()))
        .into_iter()
        .filter(|f| !protocol.tuned.contains_key(f))
        .collect();
    let how = match (role_of(protocol, dataset), protocol.tuned.is_empty()) {
        (_, true) => untuned,
        (Role::Tuning, false) => IN_SAMPLE,
        (Role::Evaluation, false) => OUT_OF_SAMPLE,
        (Role::Own, false) => "own data: settings tuned on the tuning data",
    };
    if oracle.is_empty() || protocol.tuned.is_empty() {
        format!("{dataset} ({scope}{how})")
    } else {
        format!("{dataset} ({scope}{how}; oracle for {})", oracle.join(", "))
    }
}

fn visibility(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<VisibilityRow> = read_csv(&dir.join("results.csv"))?;
    let wrong = wrong::peers(dir)?;
    // Each family at its tuned setting (tuned on the run's tuning datasets alone), else every
    // setting (the verdict then takes the best on the condition itself: an oracle).
    let meta = RunMeta::read(dir).map(|m| m.parameters).unwrap_or_default();
    let names = distinct(rows.iter().map(|r| r.dataset.as_str()));
    let protocol = Protocol::new(
        rows.iter().map(|r| Obs {
            dataset: &r.dataset,
            family: &r.family,
            params: &r.params,
            f1: r.f1,
            ok: r.status == "ok",
        }),
        roles_of(&names, &meta),
    );
    let stands = |r: &VisibilityRow| {
        protocol
            .tuned
            .get(&r.family)
            .is_none_or(|(p, _)| *p == r.params)
    };
    let mut conditions = by_condition(
        &rows,
        |r| (r.status == "ok" && r.made_for == "points" && stands(r)).then(|| r.dataset.clone()),
        |r| Cell {
            answer: (!r.visible_sha256.is_empty()).then(|| r.visible_sha256.clone()),
            ..Cell::new(&r.family, &r.params, r.view.to_string(), r.f1, r.seconds)
        },
    );
    pool_evaluation(&mut conditions, &protocol);
    Ok(conditions
        .into_iter()
        .filter_map(|(dataset, cells)| {
            let (cells, notes) = without_wrong(cells, &wrong);
            let v = verdict(&cells, Rules::F1)?;
            let condition = tuned_condition(
                &protocol,
                &dataset,
                &cells,
                "",
                "oracle: best setting on these data, no tuning data in the run",
            );
            Some(finding(
                Ask {
                    experiment: "visibility",
                    condition,
                    question: "Which method made for the visible set finds the visible \
                               points best (F1)?",
                    metric: "F1",
                    cost_metric: "seconds per view",
                    rules: Rules::F1,
                    quick,
                },
                v,
                notes,
            ))
        })
        .collect())
}

/// `cells` without those of the methods in `wrong`, and a note for each method left out.
fn without_wrong(cells: Vec<Cell>, wrong: &Wrong) -> (Vec<Cell>, Vec<String>) {
    let notes = wrong.notes(cells.iter().map(|c| c.method.as_str()));
    let kept = cells
        .into_iter()
        .filter(|c| wrong.get(&c.method).is_none())
        .collect();
    (kept, notes)
}

/// `10^k` for a power of ten, else the number.
fn points_text(n: u64) -> String {
    let k = (n as f64).log10().round() as u32;
    if k > 0 && 10u64.checked_pow(k) == Some(n) {
        format!("10^{k}")
    } else {
        n.to_string()
    }
}

/// The findings of the experiments under `reports_dir` whose results are there, in the order
/// of `experiments` (names); an experiment without results, or without findings of its own
/// kind, gives none.
pub fn findings(reports_dir: &Path, experiments: &[&str]) -> Result<Vec<Finding>> {
    let mut out = Vec::new();
    for &name in experiments {
        out.extend(findings_in(&reports_dir.join(name), name)?);
    }
    Ok(out)
}

/// The findings of one experiment `name` whose results are in `dir` (any folder: `run --out
/// DIR` on a user's own data included); none without results or findings of its kind.
pub fn findings_in(dir: &Path, name: &str) -> Result<Vec<Finding>> {
    if !dir.join("results.csv").is_file() {
        return Ok(Vec::new());
    }
    let quick = RunMeta::read(dir).is_ok_and(|m| m.quick);
    Ok(match name {
        "visibility" => pixels::beside(visibility(dir, quick)?, pixels::visibility(dir, quick)?),
        "robustness" => robustness::robustness(dir, quick)?,
        "lod" => lod::lod(dir, quick)?,
        "scale" => scale::scale(dir, quick)?,
        "hull" => hull::hull(dir, quick)?,
        _ => Vec::new(),
    })
}

/// Writes experiment `name`'s findings beside its results in `dir` (any folder: a run's own,
/// a staging or a merged one): `findings.csv` (a header alone without findings) and
/// `findings.md`.
pub fn write_in(dir: &Path, name: &str) -> Result<()> {
    let found = findings_in(dir, name)?;
    write(dir, &found)?;
    let quick = RunMeta::read(dir).is_ok_and(|m| m.quick);
    crate::output::write_atomic(&dir.join("findings.md"), markdown(&found, quick).as_bytes())
}

/// Writes `findings.csv` into `reports_dir` (a header alone without findings).
pub fn write(reports_dir: &Path, findings: &[Finding]) -> Result<()> {
    if findings.is_empty() {
        return crate::output::write_atomic(
            &reports_dir.join(CSV),
            b"experiment,condition,question,method,setting,metric,value,low,high,n_views,indicative,verdict,runner_up,runner_up_value,difference,difference_low,difference_high,cost_metric,cost,cheapest,cheapest_value,cheapest_cost,tolerance,identical,not_ranked,margin\n",
        );
    }
    write_csv(&reports_dir.join(CSV), findings)
}

mod hull;
mod lod;
mod pixels;
mod robustness;
mod scale;
mod table;

use super::rules::{verdict, wrong};
use table::{IN_SAMPLE, OUT_OF_SAMPLE};
pub use table::{markdown, readme_markdown};
pub use verdict::{Cell, Rules, Verdict, verdict};
use wrong::Wrong;
#[cfg(test)]
mod tests;
