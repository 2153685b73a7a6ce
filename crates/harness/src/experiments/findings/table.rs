//! The findings as markdown: the table every experiment's `findings.md` holds, and the
//! README's, which leaves an experiment's in-sample rows to that experiment's page when it has
//! rows measured out of sample.

use std::collections::BTreeSet;

use super::{Finding, with_setting};
use crate::stats::MIN_VIEWS;

/// A number with `digits` decimals, or `-`.
fn num(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "-".into()
    }
}

/// Decimals for a metric's values.
fn digits(metric: &str) -> usize {
    match metric {
        "F1" | "pixel F1" | "seconds (geometric mean)" => 3,
        "seconds" | "PSNR (dB)" | "BD-PSNR (dB)" => 2,
        _ => 1,
    }
}

/// A cost in its unit.
fn cost_text(metric: &str, x: f64) -> String {
    match metric {
        "seconds per view" | "seconds (geometric mean)" => format!("{} s", num(x, 3)),
        "points rendered" | "points (the budget)" => format!("{} pts", num(x, 0)),
        "peak memory (MiB)" => format!("{} MiB", num(x, 0)),
        _ => num(x, 3),
    }
}

/// How a condition on a tuning dataset says that its settings were tuned on it.
pub(super) const IN_SAMPLE: &str = "tuning data: in-sample";

/// How a condition on evaluation data (one dataset or pooled) says where its settings come from.
pub(super) const OUT_OF_SAMPLE: &str = "evaluation: settings tuned on the tuning data";

/// The README's findings table: [`markdown`] of `findings` without an experiment's in-sample
/// rows (a tuning dataset at the settings tuned on it) when that experiment has rows measured
/// out of sample, so that the verdict fits one screen and leads with what no setting was
/// chosen on; a line names the experiment's own findings page, which keeps every row (as does
/// `findings.csv`).
pub fn readme_markdown(findings: &[Finding], quick: bool) -> String {
    let in_sample = |f: &Finding| f.condition.contains(IN_SAMPLE);
    let tuned_out: BTreeSet<&str> = findings
        .iter()
        .filter(|f| f.condition.contains(OUT_OF_SAMPLE))
        .map(|f| f.experiment.as_str())
        .collect();
    let (left, shown): (Vec<&Finding>, Vec<&Finding>) = findings
        .iter()
        .partition(|f| in_sample(f) && tuned_out.contains(f.experiment.as_str()));
    let shown: Vec<Finding> = shown.into_iter().cloned().collect();
    let mut md = markdown(&shown, quick);
    let moved: BTreeSet<&str> = left.iter().map(|f| f.experiment.as_str()).collect();
    for e in moved {
        let n = left.iter().filter(|f| f.experiment == e).count();
        md.push_str(&format!(
            "The {n} in-sample rows of {e} (each tuning dataset at the settings tuned on it) \
             are in [{e}/findings.md]({e}/findings.md).\n\n"
        ));
    }
    md
}

/// The findings table (markdown), for the top of the README: a section `## Findings` with a
/// line saying how to read it, a table, and a link to `findings.csv`; empty without findings.
/// `quick`: the title says the findings are indicative.
pub fn markdown(findings: &[Finding], quick: bool) -> String {
    if findings.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "## Findings{}\n\n",
        if quick {
            " — indicative (quick run)"
        } else {
            ""
        }
    );
    s.push_str(
        "The best method per condition, by the rules of `docs/verdicts.md` (recomputed from the \
         results by `scripts/audit_findings.py`): the same cells for every method compared (a \
         method with fewer is listed under *not ranked* with its count), each view (and LOD \
         distance) on its own before the mean over them, one statistic (the best mean), the \
         lead as the mean paired difference with its 95 % bootstrap interval (none from fewer \
         than 5 views: indicative), judged against a practical margin (±0.005 F1, ±0.1 dB, ±5 % \
         of the time): *wins* beyond it, *equivalent* within it, else *no clear winner*. A \
         method whose answers equal the best's is named identical and the next distinct one is \
         the runner-up; a method that claims exactness and returned other sets (Jaccard below \
         0.999) is never ranked. Visibility: each method at its setting tuned on the tuning \
         datasets (the first rows pool the evaluation datasets: the out-of-sample answer). \
         Robustness: `best` tuned on the clean tuning datasets, and `auto`, the rule, on \
         evaluation data, tuning data (in-sample) and simulated scans. LOD: each method's curve \
         per (view, distance) read at a share of the points, interpolated in log points, never \
         extrapolated, and BD-PSNR against the random subsample. The cheapest choice within \
         0.01 F1 of the best (scale: the lightest in peak memory). Machine-readable: \
         [findings.csv](findings.csv).\n\n\
         | experiment | condition | best | value | runner-up: difference | cost | cheapest near the best | not ranked |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for f in findings {
        let d = digits(&f.metric);
        let value = match (f.low, f.high) {
            (Some(lo), Some(hi)) => {
                format!(
                    "{} {} [{}, {}]",
                    f.metric,
                    num(f.value, d),
                    num(lo, d),
                    num(hi, d)
                )
            }
            _ => format!("{} {}", f.metric, num(f.value, d)),
        };
        let value = match f.n_views {
            Some(n) if n < MIN_VIEWS => format!("{value} ({})", crate::stats::indicative(n)),
            _ if f.indicative => format!("{value} (indicative)"),
            _ => value,
        };
        let runner = if f.runner_up.is_empty() {
            "-".to_owned()
        } else {
            // The hulls' difference is the runner-up's time over the best's.
            let ratio = f.metric.starts_with("seconds (");
            let diff = match (f.difference, f.difference_low, f.difference_high) {
                (Some(x), Some(lo), Some(hi)) if ratio => {
                    format!("{x:.2}× the time [{lo:.2}, {hi:.2}]")
                }
                (Some(x), _, _) if ratio => format!("{x:.2}× the time"),
                (Some(x), Some(lo), Some(hi)) => {
                    format!("{:+.d$} [{:+.d$}, {:+.d$}]", x, lo, hi, d = d)
                }
                (Some(x), _, _) => format!("{x:+.d$}"),
                _ => f
                    .runner_up_value
                    .map_or("-".into(), |v| format!("{} {}", f.metric, num(v, d))),
            };
            format!("{}: {diff} ({})", f.runner_up, f.verdict)
        };
        let runner = match (f.identical.is_empty(), f.runner_up.is_empty()) {
            (true, _) => runner,
            (false, true) => format!("identical answers: {}", f.identical),
            (false, false) => format!("identical answers: {}; next: {runner}", f.identical),
        };
        let lightest = if f.cost_metric == "peak memory (MiB)" {
            "lightest: "
        } else {
            ""
        };
        let cheapest = if f.cheapest.is_empty() {
            "-".to_owned()
        } else if f.cheapest == with_setting(&f.method, &f.setting) {
            format!("{lightest}the best itself")
        } else {
            format!(
                "{lightest}{} ({}, {})",
                f.cheapest,
                f.cheapest_value.map_or("-".into(), |v| num(v, d)),
                f.cheapest_cost
                    .map_or("-".into(), |c| cost_text(&f.cost_metric, c))
            )
        };
        let not_ranked = if f.not_ranked.is_empty() {
            "-"
        } else {
            f.not_ranked.as_str()
        };
        s.push_str(&format!(
            "| [{}](#{}) | {} | {} | {} | {} | {} | {} | {} |\n",
            f.experiment,
            f.experiment,
            f.condition,
            with_setting(&f.method, &f.setting),
            value,
            runner,
            cost_text(&f.cost_metric, f.cost),
            cheapest,
            not_ranked
        ));
    }
    s.push('\n');
    s
}
