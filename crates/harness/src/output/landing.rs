//! The reports' landing page, `reports/index.html`: the site a researcher browses, as
//! ann-benchmarks' is. One self-contained HTML file that opens from disk with no network: the
//! findings table (every row of `findings.csv`, sortable by any column, filtered by a search
//! box, each row linking to the figure that shows it), the experiments (each with its run, its
//! interactive results page and its summary), the 3D viewer pages (`viewer/pages.json`), and one
//! card per method that has results (what it is, its settings with their defaults, the findings
//! it wins or is runner-up in, the figures that draw it).
//!
//! The page is written in HTML by this module; its small script ([`SCRIPT`], beside this file)
//! only sorts and filters, so everything is readable without it. It reads what the assembly
//! already wrote (`findings.csv`, the figures' JSON twins, each experiment's `metadata.json`)
//! and knows nothing of how they were computed; the methods' cards are given by the caller.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

use super::meta::RunMeta;
use super::report::Section;
use super::{escape_html as esc, read_csv, results, write_atomic};

/// The page's file name at the top of a reports folder.
pub const PAGE: &str = "index.html";

/// The page's script: sorting and filtering of the findings table.
const SCRIPT: &str = include_str!("landing.js");

/// What the page says of one method: the caller's view of a registry card.
#[derive(Debug, Clone, Default)]
pub struct MethodInfo {
    /// Name (as the CSVs write it).
    pub name: String,
    /// One line.
    pub summary: String,
    /// `visibility` or `level of detail`.
    pub kind: String,
    /// For a peer: the family of ours it pairs with.
    pub peer_of: Option<String>,
    /// The score it was made for (`points` or `pixels`).
    pub made_for: String,
    /// True when it claims exact answers.
    pub exact: bool,
    /// Its default setting, as a sweep names it.
    pub default_setting: String,
    /// Its parameters: key, default, help.
    pub params: Vec<(String, String, String)>,
}

/// The columns of `findings.csv` the page shows.
#[derive(Debug, Clone, Deserialize)]
struct Row {
    experiment: String,
    condition: String,
    question: String,
    method: String,
    setting: String,
    metric: String,
    value: f64,
    low: Option<f64>,
    high: Option<f64>,
    verdict: String,
    runner_up: String,
    difference: Option<f64>,
    difference_low: Option<f64>,
    difference_high: Option<f64>,
    #[serde(default)]
    not_ranked: String,
    #[serde(default)]
    identical: String,
}

/// A figure of an experiment: its id (the PNG's and the twin's stem), title and the methods its
/// series draw.
#[derive(Debug, Clone)]
struct Fig {
    id: String,
    png: String,
    title: String,
    methods: Vec<String>,
}

/// The figures of `dir` (their JSON twins, in the order its summary shows them).
fn figures_of(dir: &Path) -> Result<Vec<Fig>> {
    Ok(results::figures(dir)?
        .into_iter()
        .filter_map(|twin| {
            let id = twin["id"].as_str()?.to_owned();
            let png = twin["png"]
                .as_str()
                .map_or_else(|| format!("{id}.png"), str::to_owned);
            let mut methods = Vec::new();
            for panel in twin["panels"].as_array().into_iter().flatten() {
                for series in panel["series"].as_array().into_iter().flatten() {
                    if series["draw"] == "front" {
                        continue;
                    }
                    for key in ["method", "family"] {
                        if let Some(m) = series[key].as_str()
                            && !methods.iter().any(|x| x == m)
                        {
                            methods.push(m.to_owned());
                        }
                    }
                }
            }
            Some(Fig {
                id,
                png,
                title: twin["title"].as_str().unwrap_or_default().to_owned(),
                methods,
            })
        })
        .collect())
}

/// The words of `text`, lower case: runs of letters, digits, `-`, `.` and `^` (dataset names
/// such as `bunny-69451` stay whole).
fn words(text: &str) -> Vec<String> {
    text.to_lowercase()
        .split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '.' || c == '^'))
        .filter(|w| !w.is_empty())
        .map(str::to_owned)
        .collect()
}

/// The figure that shows a finding, among its experiment's `figs`: the one whose name (its
/// `_`-separated words) names most of the finding's condition (2 a word: the dataset, the
/// degradation, the kind of build) and of its metric and question (1 a word). `None` when no
/// figure names any of them, or when several share the best score (the finding pools what
/// several figures show): the experiment's results page then stands for it.
fn figure_for<'a>(row: &Row, figs: &'a [Fig]) -> Option<&'a Fig> {
    let condition = words(&row.condition);
    let rest = words(&format!("{} {}", row.metric, row.question));
    let named = |w: &str, list: &[String]| {
        list.iter()
            .any(|x| x == w || (w.ends_with('s') && x == &w[..w.len() - 1]))
    };
    let score = |f: &Fig| -> usize {
        f.id.to_lowercase()
            .split('_')
            .filter(|w| !w.is_empty() && *w != "vs")
            .map(|w| {
                if named(w, &condition) {
                    2
                } else if named(w, &rest) {
                    1
                } else {
                    0
                }
            })
            .sum()
    };
    let best = figs.iter().map(score).max().filter(|&s| s > 0)?;
    let mut at_best = figs.iter().filter(|f| score(f) == best);
    let first = at_best.next()?;
    at_best.next().is_none().then_some(first)
}

/// The card a name of a CSV or figure belongs to: the card of that name; else, with a
/// scale cell's suffix (`-build-ooc`, `-build`, `-select`) removed, that name's; else the
/// longest card name it extends with `-` (a family such as `hpr-linear` is `hpr`'s).
fn card_of<'a>(name: &str, cards: &'a [MethodInfo]) -> Option<&'a MethodInfo> {
    let exact = |n: &str| cards.iter().find(|c| c.name == n);
    if let Some(c) = exact(name) {
        return Some(c);
    }
    for suffix in ["-build-ooc", "-build", "-select"] {
        if let Some(c) = name.strip_suffix(suffix).and_then(exact) {
            return Some(c);
        }
    }
    cards
        .iter()
        .filter(|c| {
            name.strip_prefix(c.name.as_str())
                .is_some_and(|rest| rest.starts_with('-'))
        })
        .max_by_key(|c| c.name.len())
}

/// A value as the table prints it: four significant figures.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let digits = if v == 0.0 {
        4
    } else {
        (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize
    };
    format!("{v:.digits$}")
}

/// `1 figure`, `3 figures`.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// `value [low, high]`, or the value alone without an interval.
fn with_interval(v: Option<f64>, low: Option<f64>, high: Option<f64>) -> String {
    match (v, low, high) {
        (Some(v), Some(l), Some(h)) => format!("{} [{}, {}]", num(v), num(l), num(h)),
        (Some(v), _, _) => num(v),
        _ => String::new(),
    }
}

/// Writes `reports_dir/index.html` over `experiments` (in order) and the methods `cards`.
pub fn write(reports_dir: &Path, experiments: &[Section<'_>], cards: &[MethodInfo]) -> Result<()> {
    let page = html(reports_dir, experiments, cards)?;
    write_atomic(&reports_dir.join(PAGE), page.as_bytes())
}

/// The page (see the module's doc).
pub fn html(
    reports_dir: &Path,
    experiments: &[Section<'_>],
    cards: &[MethodInfo],
) -> Result<String> {
    let csv = reports_dir.join("findings.csv");
    let rows: Vec<Row> = if csv.is_file() {
        read_csv(&csv)?
    } else {
        Vec::new()
    };
    let figs: Vec<(&str, Vec<Fig>)> = experiments
        .iter()
        .map(|e| Ok((e.name, figures_of(&reports_dir.join(e.name))?)))
        .collect::<Result<_>>()?;
    let figs_of = |exp: &str| {
        figs.iter()
            .find(|(n, _)| *n == exp)
            .map_or(&[][..], |(_, f)| f.as_slice())
    };
    let has_page = |exp: &str| reports_dir.join(exp).join(results::PAGE).is_file();
    let quick = experiments
        .iter()
        .any(|e| RunMeta::read(&reports_dir.join(e.name)).is_ok_and(|m| m.quick));

    let mut body = String::new();
    let _ = write!(
        body,
        "<header><h1>pointsight results{}</h1>\n<p>Point-cloud visibility and level-of-detail \
         methods measured side by side against a ground truth. The full report: \
         <a href=\"README.md\">README.md</a>; every time ratio against a peer: \
         <a href=\"ratios.md\">ratios.md</a>; the findings, machine-readable: \
         <a href=\"findings.csv\">findings.csv</a>.</p>\n<nav><a href=\"#findings\">Findings</a> · \
         <a href=\"#experiments\">Experiments</a> · <a href=\"#viewer\">3D pages</a> · \
         <a href=\"#methods\">Methods</a></nav></header>\n",
        if quick {
            " — indicative (quick run)"
        } else {
            ""
        }
    );

    // Findings.
    let _ = write!(
        body,
        "<section id=\"findings\"><h2>Findings</h2>\n<p>{} findings, one a row of \
         <a href=\"findings.csv\">findings.csv</a>; the rules behind each verdict are in the \
         report. Click a column's heading to sort by it (again: the other way); type to keep the \
         rows that contain the text. Each row links to the figure that shows it, or to its \
         experiment's page when several do.</p>\n\
         <p><label>Filter: <input id=\"filter\" type=\"search\" placeholder=\"a method, a \
         dataset, a verdict…\"></label> <span id=\"shown\"></span></p>\n",
        rows.len()
    );
    if rows.is_empty() {
        body.push_str("<p>No findings in this folder.</p>\n");
    } else {
        body.push_str(
            "<table id=\"findings-table\"><thead><tr>\
             <th data-type=\"text\">experiment</th><th data-type=\"text\">condition</th>\
             <th data-type=\"text\">question</th><th data-type=\"text\">verdict</th>\
             <th data-type=\"text\">best</th><th data-type=\"text\">metric</th>\
             <th data-type=\"number\">value [95 % interval]</th>\
             <th data-type=\"text\">runner-up</th>\
             <th data-type=\"number\">difference [95 % interval]</th>\
             <th data-type=\"text\">not ranked</th><th data-type=\"text\">figure</th>\
             </tr></thead>\n<tbody>\n",
        );
        for (i, r) in rows.iter().enumerate() {
            let (href, label) = match figure_for(r, figs_of(&r.experiment)) {
                Some(f) => (format!("{}/{}", r.experiment, f.png), f.id.clone()),
                None if has_page(&r.experiment) => (
                    format!("{}/{}", r.experiment, results::PAGE),
                    format!("{} page", r.experiment),
                ),
                None => (
                    format!("README.md#{}", r.experiment),
                    format!("{} section", r.experiment),
                ),
            };
            let best = if r.setting.is_empty() {
                esc(&r.method)
            } else {
                format!("{} <small>{}</small>", esc(&r.method), esc(&r.setting))
            };
            let runner = if r.identical.is_empty() {
                esc(&r.runner_up)
            } else {
                format!(
                    "{}<br><small>identical to the best: {}</small>",
                    esc(&r.runner_up),
                    esc(&r.identical)
                )
            };
            let _ = writeln!(
                body,
                "<tr id=\"finding-{i}\"><td>{}</td><td>{}</td><td>{}</td><td class=\"verdict\">{}</td>\
                 <td>{best}</td><td>{}</td><td data-sort=\"{}\">{}</td><td>{runner}</td>\
                 <td data-sort=\"{}\">{}</td><td>{}</td>\
                 <td><a class=\"figure\" href=\"{}\">{}</a></td></tr>",
                esc(&r.experiment),
                esc(&r.condition),
                esc(&r.question),
                esc(&r.verdict),
                esc(&r.metric),
                r.value,
                with_interval(Some(r.value), r.low, r.high),
                r.difference.map_or(String::new(), |d| d.to_string()),
                with_interval(r.difference, r.difference_low, r.difference_high),
                esc(&r.not_ranked),
                esc(&href),
                esc(&label),
            );
        }
        body.push_str("</tbody></table>\n");
    }
    body.push_str("</section>\n");

    // Experiments.
    body.push_str("<section id=\"experiments\"><h2>Experiments</h2>\n<ul class=\"experiments\">\n");
    for e in experiments {
        let dir = reports_dir.join(e.name);
        let _ = write!(
            body,
            "<li class=\"experiment\" data-experiment=\"{0}\"><b>{0}</b>: {1}<br>",
            esc(e.name),
            esc(e.summary)
        );
        if !dir.join("summary.md").is_file() {
            let _ = writeln!(
                body,
                "no results in this folder (<code>pointsight run {}</code> writes them).</li>",
                esc(e.name)
            );
            continue;
        }
        if has_page(e.name) {
            let _ = write!(
                body,
                "<a class=\"results\" href=\"{0}/{1}\">interactive figures</a> · ",
                esc(e.name),
                results::PAGE
            );
        }
        let _ = write!(
            body,
            "<a href=\"{0}/summary.md\">tables and figures</a> · <a href=\"README.md#{0}\">its \
             section of the report</a> · {1}, {2}",
            esc(e.name),
            count(
                rows.iter().filter(|r| r.experiment == e.name).count(),
                "finding"
            ),
            count(figs_of(e.name).len(), "figure")
        );
        if let Ok(meta) = RunMeta::read(&dir) {
            let _ = write!(
                body,
                "<br><small>run: {} · {:.0} s · <code>{}</code></small>",
                esc(&meta.describe()),
                meta.seconds,
                esc(&meta.command)
            );
        }
        body.push_str("</li>\n");
    }
    body.push_str("</ul></section>\n");

    // 3D pages.
    body.push_str("<section id=\"viewer\"><h2>3D pages</h2>\n");
    let pages = super::report::viewer_pages(reports_dir);
    if pages.is_empty() {
        body.push_str("<p>No 3D viewer pages in this folder.</p>\n");
    } else {
        body.push_str(
            "<p>Each cloud in a browser, every default method's answer for one view (drag to \
             turn, click a method to show its points).</p>\n<ul class=\"viewer\">\n",
        );
        for (kind, dataset, file) in &pages {
            let _ = writeln!(
                body,
                "<li><a href=\"viewer/{}\">{}</a>{}</li>",
                esc(file),
                esc(dataset),
                if kind == "lod" {
                    " (level of detail)"
                } else {
                    " (visibility)"
                }
            );
        }
        body.push_str("</ul>\n");
    }
    body.push_str("</section>\n");

    // Methods.
    body.push_str(
        "<section id=\"methods\"><h2>Methods</h2>\n<p>Every method with results in this \
         folder: what it is, its parameters, the findings it is best or runner-up in, the \
         figures that draw it.</p>\n<div class=\"cards\">\n",
    );
    let mut without = Vec::new();
    for card in cards {
        let best: Vec<usize> = (0..rows.len())
            .filter(|&i| card_of(&rows[i].method, cards).is_some_and(|c| c.name == card.name))
            .collect();
        let runner: Vec<usize> = (0..rows.len())
            .filter(|&i| {
                let name = rows[i]
                    .runner_up
                    .split_whitespace()
                    .next()
                    .unwrap_or_default();
                card_of(name, cards).is_some_and(|c| c.name == card.name)
            })
            .collect();
        let drawn: Vec<(&str, &Fig)> = figs
            .iter()
            .flat_map(|(exp, fs)| fs.iter().map(move |f| (*exp, f)))
            .filter(|(_, f)| {
                f.methods
                    .iter()
                    .any(|m| card_of(m, cards).is_some_and(|c| c.name == card.name))
            })
            .collect();
        if best.is_empty() && runner.is_empty() && drawn.is_empty() {
            without.push(card.name.as_str());
            continue;
        }
        let what = match &card.peer_of {
            Some(p) => format!("{}, a peer of our {}", card.kind, esc(p)),
            None => format!("{}, ours", card.kind),
        };
        let _ = write!(
            body,
            "<article class=\"card\" id=\"method-{0}\" data-method=\"{0}\"><h3>{0}</h3>\n\
             <p>{1}</p>\n<p><small>{what}; judged per {2}{3}</small></p>\n",
            esc(&card.name),
            esc(&card.summary),
            esc(&card.made_for),
            if card.exact {
                "; claims exact answers (checked against the exact set)"
            } else {
                ""
            }
        );
        if !card.params.is_empty() {
            let _ = writeln!(
                body,
                "<details><summary>settings (default: <code>{}</code>)</summary><table \
                 class=\"params\"><tr><th>key</th><th>default</th><th>meaning</th></tr>",
                esc(if card.default_setting.is_empty() {
                    "none"
                } else {
                    &card.default_setting
                })
            );
            for (key, default, help) in &card.params {
                let _ = writeln!(
                    body,
                    "<tr><td><code>{}</code></td><td><code>{}</code></td><td>{}</td></tr>",
                    esc(key),
                    esc(default),
                    esc(help)
                );
            }
            body.push_str("</table></details>\n");
        }
        let links = |ids: &[usize]| {
            ids.iter()
                .map(|&i| {
                    format!(
                        "<a href=\"#finding-{i}\">{} ({}: {})</a>",
                        esc(&rows[i].condition),
                        esc(&rows[i].experiment),
                        esc(&rows[i].verdict)
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        if !best.is_empty() {
            let _ = writeln!(
                body,
                "<p class=\"best\">Best in {}: {}</p>",
                count(best.len(), "finding"),
                links(&best)
            );
        }
        if !runner.is_empty() {
            let _ = writeln!(
                body,
                "<p class=\"runner\">Runner-up in {}: {}</p>",
                count(runner.len(), "finding"),
                links(&runner)
            );
        }
        if !drawn.is_empty() {
            let _ = writeln!(
                body,
                "<p class=\"figures\">In {}: {}</p>",
                count(drawn.len(), "figure"),
                drawn
                    .iter()
                    .map(|(exp, f)| format!(
                        "<a class=\"figure\" href=\"{0}/{1}\" title=\"{2}\">{0}/{3}</a>",
                        esc(exp),
                        esc(&f.png),
                        esc(&f.title),
                        esc(&f.id)
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        body.push_str("</article>\n");
    }
    body.push_str("</div>\n");
    if !without.is_empty() {
        let _ = writeln!(
            body,
            "<p>Registered, with no results in this folder: {}.</p>",
            esc(&without.join(", "))
        );
    }
    body.push_str("</section>\n");

    body.push_str(&super::script_element(SCRIPT));
    body.push('\n');
    Ok(super::html_document(
        "pointsight report",
        "pointsight results",
        &format!("<style>{STYLE}</style>\n"),
        &body,
    ))
}

/// The page's style sheet.
const STYLE: &str = "body{font:14px/1.45 system-ui,sans-serif;margin:0 auto;max-width:1400px;\
padding:0 16px;color:#222}h1{margin-bottom:4px}nav a{margin:0 4px}table{border-collapse:collapse}\
#findings-table{width:100%;font-size:13px}#findings-table th,#findings-table td{border-bottom:1px \
solid #ddd;padding:3px 6px;vertical-align:top;text-align:left}#findings-table th{cursor:pointer;\
background:#f4f4f4;position:sticky;top:0}#findings-table td{overflow-wrap:anywhere}\
#findings-table td:nth-child(2){min-width:14em}#findings-table td:nth-child(3){min-width:12em}\
#filter{width:24em}#findings-table th[aria-sort=ascending]::after{content:' ▲'}\
#findings-table th[aria-sort=descending]::after{content:' ▼'}td.verdict{white-space:nowrap}\
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(380px,1fr));gap:12px;align-items:start}\
.card{border:1px solid #ccc;border-radius:6px;padding:8px 12px}.card h3{margin:2px 0}\
.params td,.params th{padding:1px 6px;text-align:left;vertical-align:top;font-size:12px}\
small{color:#555}";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::figure::{Axis, Draw, Figure, Point, Series};

    fn row(experiment: &str, condition: &str, metric: &str, method: &str) -> Row {
        Row {
            experiment: experiment.into(),
            condition: condition.into(),
            question: "Which method?".into(),
            method: method.into(),
            setting: String::new(),
            metric: metric.into(),
            value: 1.0,
            low: None,
            high: None,
            verdict: "wins".into(),
            runner_up: String::new(),
            difference: None,
            difference_low: None,
            difference_high: None,
            not_ranked: String::new(),
            identical: String::new(),
        }
    }

    fn fig(id: &str) -> Fig {
        Fig {
            id: id.into(),
            png: format!("{id}.png"),
            title: id.into(),
            methods: Vec::new(),
        }
    }

    #[test]
    fn a_finding_links_the_figure_of_its_condition_or_none_when_several_show_it() {
        let lod = [
            "psnr_vs_points_bunny-69451",
            "psnr_vs_points_dragon-871414",
            "strip_bunny-69451",
            "time_vs_points_bunny-69451",
        ]
        .map(fig);
        let r = row(
            "lod",
            "bunny-69451 at distance ×1, at 10 % of the points (6945)",
            "PSNR (dB)",
            "qsplat",
        );
        assert_eq!(
            figure_for(&r, &lod).unwrap().id,
            "psnr_vs_points_bunny-69451"
        );
        let rob = ["f1_falloff_bunny-69451", "f1_noise_bunny-69451", "f1_scans"].map(fig);
        let noise = row(
            "robustness",
            "noise, harsher 3 of 6 — bunny-69451",
            "F1",
            "x",
        );
        assert_eq!(figure_for(&noise, &rob).unwrap().id, "f1_noise_bunny-69451");
        let scan = row("robustness", "scan — dragon-mobile", "F1", "x");
        assert_eq!(figure_for(&scan, &rob).unwrap().id, "f1_scans");
        // Clean is on every degradation's figure: no single figure shows it.
        let clean = row("robustness", "clean — bunny-69451", "F1", "x");
        assert!(figure_for(&clean, &rob).is_none());
        // `bunny` is not `bunny-69451`.
        let vis = ["f1_raycast", "pareto_bunny", "pareto_bunny-69451"].map(fig);
        let bunny = row(
            "visibility",
            "bunny (tuning data: in-sample)",
            "F1",
            "robust",
        );
        assert_eq!(figure_for(&bunny, &vis).unwrap().id, "pareto_bunny");
        let hull = ["f1_gamma", "perturbation", "seconds"].map(fig);
        let h = row(
            "hull",
            "bunny, 5 of 7 hulls",
            "seconds (geometric mean)",
            "own",
        );
        assert_eq!(figure_for(&h, &hull).unwrap().id, "seconds");
        let none = row("hull", "bunny", "F1", "own");
        assert!(figure_for(&none, &["perturbation"].map(fig)).is_none());
    }

    #[test]
    fn names_find_their_card() {
        let cards: Vec<MethodInfo> = ["hpr", "hpr-confidence", "qsplat", "copc-lod"]
            .iter()
            .map(|n| MethodInfo {
                name: (*n).into(),
                ..MethodInfo::default()
            })
            .collect();
        let of = |n: &str| card_of(n, &cards).map(|c| c.name.as_str());
        assert_eq!(of("hpr"), Some("hpr"));
        assert_eq!(of("hpr-linear"), Some("hpr"));
        assert_eq!(of("hpr-confidence"), Some("hpr-confidence"));
        assert_eq!(of("qsplat-build-ooc"), Some("qsplat"));
        assert_eq!(of("copc-lod-select"), Some("copc-lod"));
        assert_eq!(of("hprx"), None);
        assert_eq!(of("copc_converter-build-ooc"), None);
    }

    #[test]
    fn the_page_lists_every_finding_experiment_and_method_with_results() {
        let dir = tempfile::tempdir().unwrap();
        let exp = dir.path().join("lod");
        std::fs::create_dir_all(&exp).unwrap();
        Figure::new(
            "psnr_vs_points_ds",
            "ds: PSNR <against> points",
            Axis::linear("x"),
            Axis::linear("y"),
        )
        .series(
            vec![Series::new(
                "qsplat",
                "qsplat",
                "",
                Draw::Line,
                vec![Point::new(1.0, 2.0)],
            )],
            Vec::new(),
        )
        .write(&exp)
        .unwrap();
        std::fs::write(exp.join("summary.md"), "![a](psnr_vs_points_ds.png)\n").unwrap();
        let header = "experiment,condition,question,method,setting,metric,value,low,high,n_views,\
                      indicative,verdict,runner_up,runner_up_value,difference,difference_low,\
                      difference_high,cost_metric,cost,cheapest,cheapest_value,cheapest_cost,\
                      tolerance,identical,not_ranked,margin";
        std::fs::write(
            dir.path().join("findings.csv"),
            format!(
                "{header}\nlod,\"ds at distance ×1, at 10 % of the points\",Which <LOD>?,qsplat,\
                 threshold_px=2,PSNR (dB),31.25,30,32,8,false,wins,random fraction=0.1,29,2.25,1,3,\
                 seconds,0.1,,,,,,,0.1\n"
            ),
        )
        .unwrap();
        let cards = vec![
            MethodInfo {
                name: "qsplat".into(),
                summary: "QSplat's bounding-sphere hierarchy".into(),
                kind: "level of detail".into(),
                made_for: "pixels".into(),
                default_setting: "threshold_px=2".into(),
                params: vec![("threshold_px".into(), "2".into(), "splat size".into())],
                ..MethodInfo::default()
            },
            MethodInfo {
                name: "random".into(),
                kind: "level of detail".into(),
                ..MethodInfo::default()
            },
            MethodInfo {
                name: "spt".into(),
                ..MethodInfo::default()
            },
        ];
        let sections = [
            Section {
                name: "lod",
                summary: "LOD error",
            },
            Section {
                name: "hull",
                summary: "hulls",
            },
        ];
        let page = html(dir.path(), &sections, &cards).unwrap();
        assert!(page.contains("<tr id=\"finding-0\">"), "{page}");
        assert!(page.contains("href=\"lod/psnr_vs_points_ds.png\""));
        assert!(page.contains("Which &lt;LOD&gt;?"), "text is escaped");
        assert!(page.contains("31.25 [30.00, 32.00]"));
        assert!(page.contains("data-method=\"qsplat\""));
        assert!(
            page.contains("data-method=\"random\""),
            "runner-up gets its card"
        );
        assert!(!page.contains("data-method=\"spt\""));
        assert!(page.contains("with no results in this folder: spt."));
        assert!(page.contains("no results in this folder (<code>pointsight run hull</code>"));
        assert!(
            !page.contains("http://") && !page.contains("https://"),
            "no network"
        );
        write(dir.path(), &sections, &cards).unwrap();
        assert!(dir.path().join(PAGE).is_file());
    }
}
