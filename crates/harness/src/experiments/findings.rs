//! The findings: the answer of each experiment present, computed from its results CSVs, for the
//! top of `reports/README.md` and for `reports/findings.csv` (issue 39, "verdicts first").
//!
//! One row per condition: visibility per dataset, twice: F1 among the methods made for the
//! visible set and per-pixel F1 among those made for the image ([`pixels`];
//! `registry::Card::made_for`), robustness per degradation and level group (its milder and its
//! harsher half of the levels; F1 over its datasets, those levels and views), LOD per dataset
//! (PSNR over views and distances), scale per group (visibility, hulls, LOD builds in core, out
//! of core: seconds and peak memory at 10^7 points and at the largest size a method of the
//! group finished), hull per dataset (the
//! fastest hull, the runner-up's time over its, paired per cell). A row names the best
//! method at its best setting on these data, its value with its bootstrap 95 % interval over
//! the views ([`crate::stats`]: none from fewer than [`crate::stats::MIN_VIEWS`]), the runner-up
//! and the paired difference (no winner when its interval holds 0), the winner's cost and the
//! cheapest method and setting within a tolerance of the best. A quick run's findings, and any
//! from fewer than [`crate::stats::MIN_VIEWS`] views, are flagged indicative.
//!
//! Which setting stands for a method. Visibility: each family at its **tuned** setting, the one
//! with the highest mean F1 over the run's tuning datasets (the definition, the mean over the
//! tuning datasets of each one's mean over its views, is
//! [`super::visibility::tuning`]'s); the condition says whether the dataset is an evaluation
//! dataset (out-of-sample), a tuning one (in-sample) or, in a run without tuning data (a user's
//! own data alone), that the setting is the **oracle**, best on the very data reported. The
//! other experiments still take each method's best setting on the condition itself (the
//! robustness `best` setting is itself tuned on the clean cloud; the choice between it and
//! `auto` is made on the condition).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use serde::{Deserialize, Serialize};

use super::visibility::tuning::{Obs, Protocol, roles_of};
use crate::datasets::Role;
use crate::output::meta::RunMeta;
use crate::output::{distinct, read_csv, write_csv};
use crate::stats::{Estimate, MIN_VIEWS, bootstrap_mean};

/// Seed of the findings' bootstrap.
const SEED: u64 = 39;

/// The file the findings are written to, in the reports folder.
pub const CSV: &str = "findings.csv";

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
}

/// The best method's answer over a set of cells ([`verdict`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// The best method.
    pub method: String,
    /// At its best setting.
    pub setting: String,
    /// Its mean score over its keys, with its interval (from at least [`MIN_VIEWS`] keys).
    pub value: Estimate,
    /// Its median cost.
    pub cost: f64,
    /// The best other method at its best setting, its mean score and the winner's paired
    /// difference to it (over the keys both have).
    pub runner_up: Option<(String, String, f64, Option<Estimate>)>,
    /// The cheapest method and setting (lowest median cost) whose mean score is within the
    /// tolerance of the best: method, setting, mean score, median cost.
    pub cheapest: Option<(String, String, f64, f64)>,
}

impl Verdict {
    /// `wins`, `no clear winner` (the difference's interval holds 0), `tie` (equal means),
    /// `indicative` (no interval: fewer than [`MIN_VIEWS`] paired views), `only method`.
    pub fn word(&self) -> &'static str {
        match &self.runner_up {
            None => "only method",
            Some((_, _, v, _)) if (self.value.value - v).abs() < 1e-12 => "tie",
            Some((_, _, _, None)) => "indicative",
            Some((_, _, _, Some(d))) => match d.holds(0.0) {
                None => "indicative",
                Some(true) => "no clear winner",
                Some(false) => "wins",
            },
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
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

/// The best method over `cells`: each method at the setting with its highest mean score (ties:
/// the cheaper setting by median cost, then the first by name), methods ranked by that mean
/// (ties: the cheaper, then by name: of two methods that choose the same points, the one that
/// costs less is named); the cheapest
/// (method, setting) within `tolerance` of the best mean. Cells with a non-finite score are
/// left out; `None` when none is left.
pub fn verdict(cells: &[Cell], tolerance: f64) -> Option<Verdict> {
    // (method, setting) -> key -> (score, cost); a repeated key keeps its mean.
    type Sums<'a> = BTreeMap<&'a str, (f64, f64, usize)>;
    let mut groups: BTreeMap<(&str, &str), Sums<'_>> = BTreeMap::new();
    for c in cells.iter().filter(|c| c.value.is_finite()) {
        let e = groups
            .entry((&c.method, &c.setting))
            .or_default()
            .entry(&c.key)
            .or_insert((0.0, 0.0, 0));
        e.0 += c.value;
        e.1 += c.cost;
        e.2 += 1;
    }
    type Views<'a> = BTreeMap<&'a str, (f64, f64)>;
    let groups: BTreeMap<(&str, &str), Views<'_>> = groups
        .into_iter()
        .map(|(k, v)| {
            let v = v
                .into_iter()
                .map(|(key, (s, c, n))| (key, (s / n as f64, c / n as f64)))
                .collect();
            (k, v)
        })
        .collect();
    let mean = |v: &Views<'_>| v.values().map(|x| x.0).sum::<f64>() / v.len() as f64;
    let cost = |v: &Views<'_>| median(v.values().map(|x| x.1).collect());
    // Higher mean first, then lower cost (an unknown cost last), then name.
    let order = |a: (f64, f64), b: (f64, f64)| {
        b.0.total_cmp(&a.0)
            .then(a.1.is_nan().cmp(&b.1.is_nan()))
            .then(a.1.total_cmp(&b.1))
    };
    let mut best: BTreeMap<&str, (&str, f64, f64)> = BTreeMap::new();
    for ((method, setting), views) in &groups {
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
    let winner = &groups[&(wm, ws)];
    let values: Vec<f64> = winner.values().map(|x| x.0).collect();
    let value = bootstrap_mean(&values, SEED)?;
    debug_assert!((value.value - wv).abs() < 1e-9);
    let runner_up = ranked.get(1).map(|&(rm, rs, rv, _)| {
        let other = &groups[&(rm, rs)];
        let diffs: Vec<f64> = winner
            .iter()
            .filter_map(|(k, a)| Some(a.0 - other.get(k)?.0))
            .collect();
        (
            rm.to_owned(),
            rs.to_owned(),
            rv,
            bootstrap_mean(&diffs, SEED),
        )
    });
    let cheapest = groups
        .iter()
        .map(|((m, s), v)| (*m, *s, mean(v), cost(v)))
        .filter(|c| c.2 >= wv - tolerance && !c.3.is_nan())
        .min_by(|a, b| a.3.total_cmp(&b.3).then(b.2.total_cmp(&a.2)))
        .map(|(m, s, v, c)| (m.to_owned(), s.to_owned(), v, c));
    Some(Verdict {
        method: wm.to_owned(),
        setting: ws.to_owned(),
        value,
        cost: cost(winner),
        runner_up,
        cheapest,
    })
}

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
    /// `wins`, `no clear winner`, `tie`, `indicative`, `only method` ([`Verdict::word`]).
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
    /// The tolerance `cheapest` is chosen within, in `metric`'s unit.
    pub tolerance: f64,
}

/// What a question asks, for [`finding`].
struct Ask<'a> {
    experiment: &'a str,
    condition: String,
    question: &'a str,
    metric: &'a str,
    cost_metric: &'a str,
    tolerance: f64,
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

fn finding(ask: Ask<'_>, v: Verdict) -> Finding {
    let (lo, hi) = v.value.interval.unzip();
    let diff = v.runner_up.as_ref().and_then(|r| r.3);
    let (dlo, dhi) = diff.and_then(|d| d.interval).unzip();
    Finding {
        experiment: ask.experiment.to_owned(),
        condition: ask.condition,
        question: ask.question.to_owned(),
        metric: ask.metric.to_owned(),
        indicative: ask.quick || v.value.n < MIN_VIEWS,
        verdict: v.word().to_owned(),
        method: v.method,
        setting: v.setting,
        value: v.value.value,
        low: lo,
        high: hi,
        n_views: Some(v.value.n),
        runner_up: v
            .runner_up
            .as_ref()
            .map_or(String::new(), |r| with_setting(&r.0, &r.1)),
        runner_up_value: v.runner_up.as_ref().map(|r| r.2),
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
        tolerance: ask.tolerance,
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
}

fn points() -> String {
    "points".into()
}

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

/// The columns of the LOD results the findings read.
#[derive(Deserialize)]
struct LodRow {
    dataset: String,
    view: usize,
    distance: f64,
    method: String,
    params: String,
    points_rendered: f64,
    psnr: f64,
    status: String,
}

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
            method: r.family.clone(),
            setting: r.params.clone(),
            key: r.view.to_string(),
            value: r.f1,
            cost: r.seconds,
        },
    );
    pool_evaluation(&mut conditions, &protocol);
    Ok(conditions
        .into_iter()
        .filter_map(|(dataset, cells)| {
            let v = verdict(&cells, 0.01)?;
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
                    tolerance: 0.01,
                    quick,
                },
                v,
            ))
        })
        .collect())
}

fn robustness(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<RobustnessRow> = read_csv(&dir.join("results.csv"))?;
    let groups = level_groups(rows.iter().map(|r| (r.degradation.as_str(), r.level)));
    let conditions = by_condition(
        &rows,
        |r| {
            (r.status == "ok").then(|| {
                groups
                    .get(&(r.degradation.clone(), r.level.to_bits()))
                    .cloned()
                    .unwrap_or_else(|| r.degradation.clone())
            })
        },
        |r| Cell {
            method: r.method.clone(),
            setting: r.setting.clone(),
            key: format!("{} {} {}", r.dataset, r.level, r.view),
            value: r.f1,
            cost: r.seconds,
        },
    );
    Ok(conditions
        .into_iter()
        .filter_map(|(condition, cells)| {
            let v = verdict(&cells, 0.01)?;
            Some(finding(
                Ask {
                    experiment: "robustness",
                    condition,
                    question: "Which method keeps the best F1 on degraded input?",
                    metric: "F1",
                    cost_metric: "seconds per view",
                    tolerance: 0.01,
                    quick,
                },
                v,
            ))
        })
        .collect())
}

/// The condition of each (degradation, level): a degradation measured at one level is one
/// condition; one at several is two, its milder half of the levels and its harsher half (the
/// middle level of an odd count goes with the milder), named by their level ranges, so a
/// winner that changes as the degradation grows shows as two rows.
fn level_groups<'a>(rows: impl Iterator<Item = (&'a str, f64)>) -> BTreeMap<(String, u64), String> {
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

/// The point budgets of the LOD findings: fractions of the most points any setting renders on
/// the dataset (about the whole cloud). Without a budget the finest setting, which renders
/// the whole cloud, wins trivially.
pub const LOD_BUDGETS: [f64; 2] = [0.1, 0.3];

fn lod(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<LodRow> = read_csv(&dir.join("results.csv"))?;
    let conditions = by_condition(
        &rows,
        |r| (r.status == "ok").then(|| r.dataset.clone()),
        |r| Cell {
            method: r.method.clone(),
            setting: r.params.clone(),
            key: format!("{} {}", r.view, r.distance),
            value: r.psnr,
            cost: r.points_rendered,
        },
    );
    let mut out = Vec::new();
    for (dataset, cells) in conditions {
        // Each setting's mean points rendered.
        let mut points: BTreeMap<(&str, &str), (f64, usize)> = BTreeMap::new();
        for c in &cells {
            let e = points.entry((&c.method, &c.setting)).or_insert((0.0, 0));
            e.0 += c.cost;
            e.1 += 1;
        }
        let mean_points = |c: &Cell| {
            let (sum, n) = points[&(c.method.as_str(), c.setting.as_str())];
            sum / n as f64
        };
        let most = cells.iter().map(mean_points).fold(0.0, f64::max);
        for budget in LOD_BUDGETS {
            let within: Vec<Cell> = cells
                .iter()
                .filter(|c| mean_points(c) <= budget * most)
                .cloned()
                .collect();
            let Some(v) = verdict(&within, 1.0) else {
                continue;
            };
            out.push(finding(
                Ask {
                    experiment: "lod",
                    condition: format!("{dataset}, ≤ {:.0} % of the points", budget * 100.0),
                    question: "Which LOD method renders closest to the full cloud (PSNR) within \
                               a point budget?",
                    metric: "PSNR (dB)",
                    cost_metric: "points rendered",
                    tolerance: 1.0,
                    quick,
                },
                v,
            ));
        }
    }
    Ok(out)
}

/// A hull's seconds per (view, γ bits) cell.
type Times = BTreeMap<(usize, u64), f64>;

/// The fastest hull per dataset on unperturbed input: among the hulls that ran every (view,
/// γ) the most complete hull ran (others, run on a few cells only, are counted out), the
/// lowest geometric mean of seconds; the runner-up's time over the winner's, paired per cell,
/// with its interval.
fn hull(dir: &Path, quick: bool) -> Result<Vec<Finding>> {
    let rows: Vec<HullRow> = read_csv(&dir.join("results.csv"))?;
    let mut out = Vec::new();
    let ok: Vec<&HullRow> = rows
        .iter()
        .filter(|r| r.status == "ok" && r.perturb == 0.0 && r.seconds > 0.0)
        .collect();
    for dataset in distinct(ok.iter().map(|r| r.dataset.as_str())) {
        let mut cells: BTreeMap<&str, Times> = BTreeMap::new();
        for r in ok.iter().filter(|r| r.dataset == dataset) {
            cells
                .entry(&r.hull)
                .or_default()
                .insert((r.view, r.gamma.to_bits()), r.seconds);
        }
        let Some(most) = cells.values().max_by_key(|c| c.len()).cloned() else {
            continue;
        };
        let complete: Vec<(&str, &Times)> = cells
            .iter()
            .filter(|(_, c)| most.keys().all(|k| c.contains_key(k)))
            .map(|(h, c)| (*h, c))
            .collect();
        let geomean =
            |c: &Times| (most.keys().map(|k| c[k].ln()).sum::<f64>() / most.len() as f64).exp();
        let mut ranked: Vec<(&str, f64)> = complete.iter().map(|(h, c)| (*h, geomean(c))).collect();
        ranked.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
        let Some(&(best, seconds)) = ranked.first() else {
            continue;
        };
        let ratio = ranked.get(1).and_then(|&(runner, _)| {
            let (r, w): (Vec<f64>, Vec<f64>) = most
                .keys()
                .map(|k| (cells[runner][k], cells[best][k]))
                .unzip();
            crate::stats::paired_ratio(&r, &w, SEED)
        });
        let verdict = match (ranked.len(), ratio.and_then(|e| e.holds(1.0))) {
            (1, _) => "only method",
            (_, None) => "indicative",
            (_, Some(true)) => "no clear winner",
            (_, Some(false)) => "fastest",
        };
        let (dlo, dhi) = ratio.and_then(|e| e.interval).unzip();
        out.push(Finding {
            experiment: "hull".into(),
            condition: format!(
                "{dataset}, {} of {} hulls on all {} (view, γ) cells",
                complete.len(),
                cells.len(),
                most.len()
            ),
            question: "Which convex hull makes HPR fastest?".into(),
            method: best.to_owned(),
            setting: String::new(),
            metric: "seconds (geometric mean)".into(),
            value: seconds,
            low: None,
            high: None,
            n_views: Some(most.len()),
            indicative: quick || most.len() < MIN_VIEWS,
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
            tolerance: 0.0,
        });
    }
    Ok(out)
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
        "robustness" => robustness(dir, quick)?,
        "lod" => lod(dir, quick)?,
        "scale" => scale::scale(dir, quick)?,
        "hull" => hull(dir, quick)?,
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
            b"experiment,condition,question,method,setting,metric,value,low,high,n_views,indicative,verdict,runner_up,runner_up_value,difference,difference_low,difference_high,cost_metric,cost,cheapest,cheapest_value,cheapest_cost,tolerance\n",
        );
    }
    write_csv(&reports_dir.join(CSV), findings)
}

mod pixels;
mod scale;
mod table;

use table::{IN_SAMPLE, OUT_OF_SAMPLE};
pub use table::{markdown, readme_markdown};
#[cfg(test)]
mod tests;
