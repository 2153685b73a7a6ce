//! The visibility experiment's tables and plots, drawn from its CSVs: Pareto plots and F1
//! charts per family (bars: the spread over views and runs), each family at its tuned setting
//! (best over the tuning datasets, [`super::tuning`]) beside the oracle, each family against
//! exact HPR paired per view with bootstrap intervals, the automatic rules' gaps, image-space
//! figures, the peers, and the renders of one view.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use registry::Setting;
use truth::{Reference, ReferenceParams};

use super::papers::chosen;
use super::tuned_table::{by_dataset, protocol_text, tuned_table};
use super::tuning::{Protocol, observations, roles_of};
use super::{AgreementRow, PeerRow, PixelRow, Row, Run, is_auto};
use crate::datasets;
use crate::experiments::markdown_table;
use crate::experiments::rules::ratio;
use crate::experiments::rules::wrong::{self, Wrong};
use crate::output::figure::{Axis, Draw, Figure, Panel, Point, Series};
use crate::output::render::{classified_panel, compose, footprint};
use crate::output::{distinct, style, write_atomic};
use registry::scoring::Score;

/// Every family of `rows`, in the order they first appear.
fn families_of(rows: &[Row]) -> Vec<String> {
    distinct(rows.iter().map(|r| r.family.as_str()))
}

pub(super) fn render_bunny(
    dir: &Path,
    ds: &datasets::Dataset,
    reference: &Reference,
    rows: &[Row],
    runs: Vec<Run>,
    protocol: &Protocol,
) -> Result<()> {
    let cam = ds.views[0];
    let points = &ds.cloud.positions;
    let truth = reference
        .visibility(ds.truth_points(), &cam, &ReferenceParams::default())?
        .visible;
    // Drawn at the view's resolution, cropped to the object.
    let small = cam;
    let (cx0, cy0, cx1, cy1) = footprint(&small, points, 12);
    let mut panels = vec![classified_panel(
        &format!(
            "reference: {} of {} visible",
            truth.iter().filter(|&&t| t).count(),
            points.len()
        ),
        &small,
        points,
        &truth,
        None,
    )];
    for fam in families_of(rows) {
        let Some((best, _)) = chosen(rows, protocol, ds.name(), &fam) else {
            continue;
        };
        let Some(run) = runs.iter().find(|r| r.family == fam && r.params == best) else {
            continue;
        };
        let mut flags = vec![false; points.len()];
        for &i in &run.visible {
            flags[i as usize] = true;
        }
        let s = Score::of(&run.visible, &truth);
        panels.push(classified_panel(
            &format!("{fam} {} (F1 {:.3})", short(&best), s.f1()),
            &small,
            points,
            &truth,
            Some(&flags),
        ));
    }
    let panels: Vec<_> = panels.iter().map(|p| p.crop(cx0, cy0, cx1, cy1)).collect();
    compose(
        &panels,
        3,
        &format!(
            "{}, view 0, every method at its {} setting. green: visible and found; blue: visible, missed; red: hidden, reported visible; grey: hidden",
            ds.name(),
            match protocol.role(ds.name()) {
                datasets::Role::Tuning => "tuned (in-sample)",
                _ if protocol.tuned.is_empty() => "oracle",
                _ => "tuned",
            }
        ),
        &dir.join("renders.png"),
    )
}

/// A setting in few characters, for captions.
fn short(params: &str) -> String {
    let mut out = Vec::new();
    let (mut w, mut h) = (None, None);
    for kv in params.split(';') {
        match kv.split_once('=') {
            Some(("kernel", _)) | Some(("perturb", "0")) => {}
            Some(("width", v)) => w = Some(v),
            Some(("height", v)) => h = Some(v),
            Some(("radius_factor", v)) => out.push(format!("r={v}s")),
            Some(("depth_tolerance", v)) => out.push(format!("tol={v}")),
            Some(("radius_px", v)) => out.push(format!("r={v}px")),
            Some(("gamma", v)) => out.push(format!("γ={v}")),
            _ => out.push(kv.to_owned()),
        }
    }
    if let (Some(w), Some(h)) = (w, h) {
        out.push(format!("{w}x{h}"));
    }
    out.join(" ")
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Each family at its tuned setting against exact HPR (linear kernel) at its tuned setting,
/// paired per view: the speed ratio (geometric mean of per-view ratios) and the F1 difference
/// (mean of per-view differences), each with its bootstrap 95 % interval.
fn versus_table(
    catalogue: &registry::Catalogue,
    rows: &[Row],
    datasets: &[String],
    families: &[String],
    protocol: &Protocol,
) -> String {
    const BASE: &str = "hpr-linear";
    let mut table = Vec::new();
    for d in datasets {
        let Some((base, _)) = chosen(rows, protocol, d, BASE) else {
            continue;
        };
        let by_view = |fam: &str, params: &str| super::papers::by_view(rows, d, fam, params);
        let ours = by_view(BASE, &base);
        // A peer's time against ours is one number, at the same setting: the peers table
        // (reports/ratios.csv), not here at each one's tuned setting.
        let is_peer = |f: &str| {
            rows.iter()
                .find(|r| r.family == f)
                .and_then(|r| catalogue.card(&r.method).ok())
                .is_some_and(|c| c.peer_of.is_some())
        };
        for fam in families.iter().filter(|f| *f != BASE && !is_peer(f)) {
            let Some((best, _)) = chosen(rows, protocol, d, fam) else {
                continue;
            };
            let theirs = by_view(fam, &best);
            let paired = crate::stats::pair(&theirs, &ours);
            if paired.is_empty() {
                continue;
            }
            let (ts, os): (Vec<f64>, Vec<f64>) = paired.iter().map(|(t, o)| (t.0, o.0)).unzip();
            let df: Vec<f64> = paired.iter().map(|(t, o)| t.1 - o.1).collect();
            let ratio = crate::stats::paired_ratio(&ts, &os, 2007)
                .map_or("-".to_owned(), |e| e.text(|x| format!("{x:.2}"), "×"));
            let diff = crate::stats::bootstrap_mean(&df, 2007)
                .map_or("-".to_owned(), |e| e.text(|x| format!("{x:+.4}"), ""));
            table.push(vec![
                d.clone(),
                fam.clone(),
                best.replace(';', " "),
                paired.len().to_string(),
                ratio,
                diff,
            ]);
        }
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "### Against exact HPR, paired per view

Each method at its tuned setting against \
         `hpr-linear` at its tuned setting (same dataset, same views; see the table above). `time ratio`: the method's \
         seconds over HPR's, geometric mean of the per-view ratios (below 1: faster than HPR); \
         `F1 − HPR`: mean of the per-view differences; both with a bootstrap 95 % interval \
         (views resampled, 10,000 times). Peers are not in this table: their time against \
         ours is measured at the same setting, in the peers table below and in \
         `reports/ratios.csv`.\n\n{}\n",
        markdown_table(
            &[
                "dataset",
                "method",
                "its tuned setting",
                "views",
                "time ratio [95 % CI]",
                "F1 − HPR [95 % CI]",
            ],
            &table
        )
    )
}

/// F1 against a family's main parameter (the numeric key with the most values over its fixed
/// settings), one line per dataset and per combination of the other varying keys; `None` when
/// the family sweeps no number. Negative parameters (the exponential kernel's γ) are negated
/// and spans over two decades get a log axis.
fn param_chart(
    dir: &Path,
    rows: &[Row],
    datasets: &[String],
    fam: &str,
    failed: &Wrong,
) -> Result<Option<String>> {
    let fixed: Vec<(&Row, Setting)> = rows
        .iter()
        .filter(|r| r.family == fam && r.status == "ok" && !r.f1.is_nan() && !is_auto(&r.params))
        .map(|r| (r, Setting::parse(&r.params)))
        .collect();
    // Distinct values per key.
    let mut values: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for (_, s) in &fixed {
        for (k, v) in &s.0 {
            let e = values.entry(k.as_str()).or_default();
            let t = v.to_string();
            if !e.contains(&t) {
                e.push(t);
            }
        }
    }
    let Some(key) = values
        .iter()
        .filter(|(k, vs)| {
            vs.len() > 1
                && fixed
                    .iter()
                    .all(|(_, s)| s.get(k).is_none_or(|v| v.as_f64().is_some()))
        })
        .max_by_key(|(_, vs)| vs.len())
        .map(|(k, _)| (*k).to_owned())
    else {
        return Ok(None);
    };
    let others: Vec<&str> = values
        .iter()
        .filter(|(k, vs)| **k != key && vs.len() > 1)
        .map(|(k, _)| *k)
        .collect();
    let xs: Vec<f64> = fixed.iter().filter_map(|(_, s)| s.number(&key)).collect();
    let negate = xs.iter().all(|&x| x < 0.0);
    let (lo, hi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            let x = if negate { -x } else { x };
            (a.min(x), b.max(x))
        });
    let x_log = lo > 0.0 && hi / lo > 100.0;
    // The lines of a panel: each combination of the other varying keys, ranked over the
    // family's settings (so a combination keeps its style in every panel).
    let line_of = |s: &Setting| {
        others
            .iter()
            .map(|k| format!("{k}={}", s.text(k).unwrap_or_default()))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut lines: Vec<String> = distinct(
        fixed
            .iter()
            .map(|(_, s)| line_of(s))
            .collect::<Vec<_>>()
            .iter()
            .map(String::as_str),
    );
    lines.sort();
    let method = fixed.first().map_or(fam, |(r, _)| r.method.as_str());
    let mut panels = Vec::new();
    for d in datasets {
        let mut by_line: BTreeMap<String, BTreeMap<i64, (f64, Vec<&Row>)>> = BTreeMap::new();
        for (r, s) in fixed.iter().filter(|(r, _)| r.dataset == *d) {
            let Some(x) = s.number(&key) else { continue };
            let x = if negate { -x } else { x };
            by_line
                .entry(line_of(s))
                .or_default()
                .entry((x * 1e9).round() as i64)
                .or_insert((x, Vec::new()))
                .1
                .push(r);
        }
        let mut series = Vec::new();
        for (line, pts) in by_line {
            let points = pts
                .values()
                .map(|(x, rs)| {
                    let (lo, hi) = rs
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
                            (a.min(r.f1), b.max(r.f1))
                        });
                    Point::new(*x, mean(rs.iter().map(|r| r.f1)))
                        .y_interval(lo, hi)
                        .seconds(mean(rs.iter().map(|r| r.seconds)))
                        .setting(rs[0].params.clone())
                })
                .collect();
            let rank = lines.iter().position(|l| *l == line).unwrap_or(0);
            let sr = if let Some(j) = failed.0.get(method) {
                // A failed exactness claim: its own marked style, whatever the line.
                let label = if line.is_empty() { fam } else { line.as_str() };
                Series::new(method, fam, style::WRONG, Draw::Line, points)
                    .label(format!("{label} — {}", wrong::note(*j)))
            } else if line.is_empty() {
                Series::new(method, fam, "settings", Draw::Line, points).label(fam)
            } else {
                Series::new(method, fam, &line, Draw::Line, points)
                    .label(line.clone())
                    .ranked(rank)
            };
            series.push(sr);
        }
        if !series.is_empty() {
            panels.push(Panel {
                title: d.clone(),
                series,
            });
        }
    }
    if panels.is_empty() {
        return Ok(None);
    }
    let shown = if negate {
        format!("-{key}")
    } else {
        key.clone()
    };
    let fig = Figure::new(
        format!("f1_{fam}"),
        format!("{fam}: F1 against {shown}, one panel per dataset"),
        if x_log {
            Axis::log(format!("{shown} (log)"))
        } else {
            Axis::linear(shown.clone())
        },
        Axis::linear("F1 (mean over views; bars: lowest to highest view)"),
    )
    .interval("lowest to highest view")
    .panels(panels);
    Ok(Some(fig.write(dir)?))
}

/// The peers' section: per dataset, peer and peer setting, the method of ours it is paired
/// with (its `peer_of`, at the matching setting) and, over the views: the Jaccard index of the
/// two visible sets (median and lowest view), the time ratio (the peer's seconds over ours:
/// geometric mean of the paired per-view ratios with its bootstrap 95 % interval, and the
/// lowest and highest view's), the F1 difference (mean, bootstrap 95 % interval); then the
/// peers that were not run, and why.
pub(super) fn peers_summary(peers: &[PeerRow], not_run: &[String]) -> String {
    let mut s = String::from("### Peers, measured in the same run\n\n");
    let mut groups: BTreeMap<(&str, &str, &str), Vec<&PeerRow>> = BTreeMap::new();
    for p in peers {
        groups
            .entry((&p.dataset, &p.peer, &p.peer_params))
            .or_default()
            .push(p);
    }
    if groups.is_empty() && not_run.is_empty() {
        s.push_str(
            "No peer (a method.toml with `peer_of`) has a grid in methods/: none was run.\n\n",
        );
        return s;
    }
    if !groups.is_empty() {
        s.push_str(
            "Each peer at each of its settings against the method of ours its `peer_of` names, \
             at the matching setting, paired per view. `Jaccard`: of the two visible sets, the \
             median over the views and the lowest view's (on clouds without a mesh, the only \
             measure of agreement). `time ratio`: the peer's seconds (its own reported compute \
             time) over ours, geometric mean over the views with its bootstrap 95 % interval \
             (views resampled, 10,000 times), then the lowest and highest view's; above 1 means \
             ours is faster (these ratios are `reports/ratios.csv`'s, the one table of ratios \
             against peers). A peer claiming exactness whose sets missed ours (Jaccard below \
             0.999) is marked `wrong answers`. `ΔF1`: the peer's F1 minus ours, mean over the views [95 % \
             interval]. `build s`: the per-cloud structure's build, once per setting, apart \
             from the per-view times (median over the views' cells): the peer's as its own \
             `built` line reports it (Embree's BVH, VTK's render window and first draw; `-`: it \
             builds nothing per cloud, or does not say), ours as our method accounts for it \
             (the ray caster's point hierarchy; else its whole preparation). A peer whose `peer_of` \
             names no visibility method of ours has its own figures only.\n\n",
        );
        let pairs: Vec<ratio::PeerPair> = peers.iter().map(PeerRow::pair).collect();
        let ratios: BTreeMap<(String, String, String), ratio::Ratio> = ratio::visibility(&pairs)
            .into_iter()
            .map(|r| {
                (
                    (r.dataset.clone(), r.peer.clone(), r.peer_setting.clone()),
                    r,
                )
            })
            .collect();
        let rows: Vec<Vec<String>> = groups
            .iter()
            .map(|((d, peer, setting), ps)| {
                let first = ps[0];
                let ratio =
                    ratios.get(&((*d).to_owned(), (*peer).to_owned(), (*setting).to_owned()));
                let partner = if first.partner.is_empty() {
                    format!("none (no method `{}` of ours)", first.peer_of)
                } else {
                    format!("{} {}", first.partner, first.partner_params)
                };
                let partner = match ratio.filter(|r| !r.note.is_empty()) {
                    Some(r) => format!("{partner} — {}", r.note),
                    None => partner,
                };
                let peer_s: Vec<f64> = ps.iter().map(|p| p.peer_seconds).collect();
                let ours_s: Vec<f64> = ps.iter().map(|p| p.partner_seconds).collect();
                let spread = ratio.map_or("-".into(), |r| format!("{:.2}–{:.2}", r.min, r.max));
                let ratio = ratio.map_or("-".to_owned(), |r| r.text());
                let mut jaccard: Vec<f64> = ps
                    .iter()
                    .map(|p| p.jaccard)
                    .filter(|j| !j.is_nan())
                    .collect();
                jaccard.sort_by(f64::total_cmp);
                let (j_median, j_min) = if jaccard.is_empty() {
                    ("-".to_owned(), "-".to_owned())
                } else {
                    let n = jaccard.len();
                    let median = if n % 2 == 1 {
                        jaccard[n / 2]
                    } else {
                        0.5 * (jaccard[n / 2 - 1] + jaccard[n / 2])
                    };
                    (format!("{median:.4}"), format!("{:.4}", jaccard[0]))
                };
                let df1: Vec<f64> = ps
                    .iter()
                    .map(|p| p.peer_f1 - p.partner_f1)
                    .filter(|d| !d.is_nan())
                    .collect();
                let build = |f: fn(&PeerRow) -> f64| {
                    let mut b: Vec<f64> = ps.iter().map(|p| f(p)).filter(|x| !x.is_nan()).collect();
                    b.sort_by(f64::total_cmp);
                    b.get(b.len() / 2)
                        .map_or("-".to_owned(), |x| format!("{x:.4}"))
                };
                let df1 = crate::stats::bootstrap_mean(&df1, 2007)
                    .map_or("-".to_owned(), |e| e.text(|x| format!("{x:+.4}"), ""));
                vec![
                    (*d).to_owned(),
                    (*peer).to_owned(),
                    (*setting).to_owned(),
                    partner,
                    ps.len().to_string(),
                    j_median,
                    j_min,
                    if first.partner.is_empty() {
                        "-".to_owned()
                    } else {
                        format!("{:.4}", mean(ours_s.iter().copied()))
                    },
                    format!("{:.4}", mean(peer_s.iter().copied())),
                    ratio,
                    spread,
                    df1,
                    build(|p| p.partner_build_seconds),
                    build(|p| p.peer_build_seconds),
                ]
            })
            .collect();
        s.push_str(&markdown_table(
            &[
                "dataset",
                "peer",
                "peer setting",
                "paired with (ours, setting)",
                "views",
                "Jaccard median",
                "Jaccard min",
                "ours s",
                "peer s",
                "time ratio [95 % CI]",
                "ratio min–max",
                "ΔF1 [95 % CI]",
                "ours build s",
                "peer build s",
            ],
            &rows,
        ));
        s.push('\n');
    }
    for n in not_run {
        s.push_str(&format!("- not run: {n}\n"));
    }
    if !not_run.is_empty() {
        s.push('\n');
    }
    s
}

#[allow(clippy::too_many_arguments)]
pub(super) fn render(
    catalogue: &registry::Catalogue,
    dir: &Path,
    rows: &[Row],
    pixels: &[PixelRow],
    agreement: &[AgreementRow],
    peers_md: &str,
    defaults: &BTreeMap<String, String>,
    render_ds: Option<&str>,
) -> Result<()> {
    let all_datasets = distinct(rows.iter().map(|r| r.dataset.as_str()));
    // Datasets without a ground truth (no mesh) have NaN F1: they get the agreement table.
    let (datasets, unscored): (Vec<String>, Vec<String>) = all_datasets
        .into_iter()
        .partition(|d| rows.iter().any(|r| r.dataset == *d && !r.f1.is_nan()));
    let mut no_mesh = String::new();
    for d in &unscored {
        let mut by: BTreeMap<(&str, &str), Vec<f64>> = BTreeMap::new();
        for a in agreement.iter().filter(|a| a.dataset == *d) {
            by.entry((&a.a, &a.b)).or_default().push(a.jaccard);
        }
        let mut speed: BTreeMap<&str, Vec<(f64, usize)>> = BTreeMap::new();
        for r in rows
            .iter()
            .filter(|r| r.dataset == *d && defaults.get(&r.method) == Some(&r.params))
        {
            speed
                .entry(r.family.as_str())
                .or_default()
                .push((r.seconds, r.n_visible));
        }
        no_mesh.push_str(&format!(
            "#### {d}: no mesh, no ground truth\n\nThis dataset has no mesh, so there is nothing \
             to score against: its F1 columns are empty (NaN in results.csv). What can be \
             measured is reported: each method's time and visible count at its default \
             setting (its automatic rule where it has one), and how far the methods agree (Jaccard index of their visible sets, mean \
             over views).\n\n{}\n{}\n",
            markdown_table(
                &["method", "seconds", "visible points"],
                &speed
                    .iter()
                    .map(|(m, v)| {
                        vec![
                            (*m).to_owned(),
                            format!("{:.4}", mean(v.iter().map(|x| x.0))),
                            format!("{:.0}", mean(v.iter().map(|x| x.1 as f64))),
                        ]
                    })
                    .collect::<Vec<_>>()
            ),
            markdown_table(
                &["method A", "method B", "Jaccard (mean over views)"],
                &by.iter()
                    .map(|((a, b), j)| {
                        vec![
                            (*a).to_owned(),
                            (*b).to_owned(),
                            format!("{:.4}", mean(j.iter().copied())),
                        ]
                    })
                    .collect::<Vec<_>>()
            )
        ));
    }
    let mut off_surface = String::new();
    let mut mesh_warning = String::new();
    for d in &datasets {
        if rows
            .iter()
            .any(|r| r.dataset == *d && r.mesh_fit == "off-surface")
        {
            mesh_warning.push_str(&format!(
                "- **{d}: scored against a mesh that does not fit its points** \
                 (`--allow-off-surface`; the share far from it, the median distance and the \
                 likely cause are in metadata.json's `off_surface`): its rows are marked \
                 `mesh_fit=off-surface`, and their scores are not a ground truth's.\n\n"
            ));
        }
        let flagged: usize = rows
            .iter()
            .filter(|r| r.dataset == *d)
            .map(|r| r.off_surface_visible)
            .max()
            .unwrap_or(0);
        if flagged > 0 {
            off_surface.push_str(&format!(
                "- {d}: up to {flagged} points called visible lie farther from the mesh than the \
                 surface tolerance (see metadata.json); they are left out of precision and \
                 recall.\n"
            ));
        }
    }
    let families = families_of(rows);
    let meta = crate::output::meta::RunMeta::read(dir)
        .map(|m| m.parameters)
        .unwrap_or_default();
    let protocol = Protocol::new(observations(rows), roles_of(&datasets, &meta));
    let mut pictures = String::new();
    // A method whose exactness claim failed, in every figure below.
    let failed = wrong::peers(dir)?;

    // F1 against seconds, every setting (mean over views; bars: the views' fastest and slowest
    // timed runs and the lowest and highest F1), Pareto front marked, per dataset.
    for d in &datasets {
        let mut series = Vec::new();
        // Every setting's point, with its family and setting, for the front.
        let mut all: Vec<(f64, f64, String)> = Vec::new();
        for fam in &families {
            let mut by: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
            for r in rows
                .iter()
                .filter(|r| r.dataset == *d && r.family == *fam && r.status == "ok")
            {
                by.entry(&r.params).or_default().push(r);
            }
            let Some(first) = by.values().next().and_then(|rs| rs.first()) else {
                continue;
            };
            let method = first.method.clone();
            let points: Vec<Point> = by
                .iter()
                .map(|(params, rs)| {
                    let fold = |f: &dyn Fn(&Row) -> (f64, f64)| {
                        rs.iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                                let (a, b) = f(r);
                                (lo.min(a), hi.max(b))
                            })
                    };
                    let seconds = mean(rs.iter().map(|r| r.seconds));
                    let (xl, xh) = fold(&|r| (r.seconds_min, r.seconds_max));
                    let (yl, yh) = fold(&|r| (r.f1, r.f1));
                    Point::new(seconds, mean(rs.iter().map(|r| r.f1)))
                        .x_interval(xl, xh)
                        .y_interval(yl, yh)
                        .seconds(seconds)
                        .setting(params.to_string())
                })
                .collect();
            // A method with wrong answers is drawn apart and is never on the front.
            if let Some(j) = failed.0.get(&method) {
                series.push(
                    Series::new(&method, fam, style::WRONG, Draw::Points, points)
                        .label(format!("{fam} — {}", wrong::note(*j))),
                );
                continue;
            }
            all.extend(points.iter().map(|p| {
                (
                    p.x,
                    p.y,
                    format!("{fam} {}", short(p.setting.as_deref().unwrap_or(""))),
                )
            }));
            series.push(
                Series::new(&method, fam, "settings", Draw::Points, points).label(fam.clone()),
            );
        }
        all.retain(|p| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0);
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut front: Vec<Point> = Vec::new();
        for (x, y, name) in all {
            if front.last().is_none_or(|l| y > l.y) {
                front.push(Point {
                    name: Some(name),
                    ..Point::new(x, y).seconds(x)
                });
            }
        }
        let front = Series::new("Pareto front", "pareto-front", "", Draw::Front, front)
            .label("Pareto front (numbered: see below)");
        let fig = Figure::new(
            format!("pareto_{d}"),
            format!("{d}: F1 against time, every method and setting (mean over views)"),
            Axis::log("seconds per view (log; bars: fastest to slowest run over the views)"),
            Axis::linear("F1 against the reference (bars: lowest to highest view)"),
        )
        .interval("lowest to highest view")
        .series(series, vec![front]);
        pictures.push_str(&fig.write(dir)?);
    }

    // F1 against each family's main parameter.
    for fam in &families {
        if let Some(md) = param_chart(dir, rows, &datasets, fam, &failed)? {
            pictures.push_str(&md);
        }
    }

    // Each family at its tuned setting per dataset, the oracle beside it.
    let best_table = tuned_table(rows, &datasets, &families, &protocol);
    let never_best: Vec<&str> = failed.0.keys().map(String::as_str).collect();
    let protocol_md = format!(
        "{}{}",
        protocol_text(&protocol),
        by_dataset(&best_table, &datasets, &families, &never_best)
    );

    let versus = format!(
        "{}{}{}",
        versus_table(catalogue, rows, &datasets, &families, &protocol),
        super::papers::machado(rows, &datasets),
        super::papers::katz_tal(rows, &datasets, &protocol)
    );

    let (auto_table, worst_lines) = super::auto_rules::gaps(rows);

    // Image-space figures of every method at its setting tuned by the per-pixel F1.
    let pixel_table = super::pixel_table::table(pixels, &datasets, protocol.roles.clone());

    let renders = match (dir.join("renders.png").exists(), render_ds) {
        (true, Some(d)) => {
            format!("![{d}, view 0: every method at its tuned setting](renders.png)\n\n")
        }
        _ => String::new(),
    };
    // How many timed runs the calls had (fewer past the time budget).
    let samples = rows.iter().filter(|r| r.status == "ok").map(|r| r.samples);
    let runs = match (samples.clone().min(), samples.max()) {
        (Some(lo), Some(hi)) if lo == hi => format!("median of {hi} runs"),
        (Some(lo), Some(hi)) => format!(
            "median of {lo} to {hi} runs (a call slower than the time budget is timed fewer \
             times)"
        ),
        _ => "median of the timed runs".to_owned(),
    };
    let summary = format!(
        "Every visibility method against the reference (mesh depth buffer), F1 = harmonic mean of \
         precision and recall of the visible set, mean over the views. `seconds`: the method \
         alone, {runs} (their spread and number, `samples`, in results.csv).\n\n{mesh_warning}{renders}### Tuned setting per method\n\n{protocol_md}{}\n\
         {versus}### Choosing the parameter automatically\n\nHPR's γ from the cloud alone: \
         γ = log10(κ·D·d²/(s²·m)) (`hpr::auto`, κ = {} fitted on the synthetic scenes); the ray \
         cast's radius: {} density spacings (`raycast::auto`, fitted on these datasets). The gap is the oracle's F1, the best fixed \
         setting on that very view (same resolution for the ray cast), minus the rule's; the \
         goal is at most 0.02.\n\n{}\n\n<details><summary>View by view</summary>\n\n{}\n</details>\n\n\
         ### Image space (every method)\n\nEach pixel shows at most one point: `pixel \
         precision` is the share of covered pixels whose point is truly visible, `mesh coverage` \
         the share of the mesh's pixels (the mesh rasterised at the same camera) that got a \
         point, `pixel F1` their harmonic mean, by which each method's setting is tuned here: the \
         setting with the best mean pixel F1 over the tuning datasets (the protocol above, with \
         this score; in-sample on a tuning dataset), the oracle beside it. \
         `pixels`: `method`, the method's own choice (ray cast, splat, screen-space operators, \
         at their setting's resolution); `projected`, its visible set drawn at the view's \
         resolution as spheres of the ray cast's automatic radius (`registry::scoring::pixels`; \
         one pixel per point would bound coverage by the cloud's density, as it does for \
         `screenspace` and `vardensity`). `made for`: the score the method was made for \
         (`registry::Card::made_for`), the one the findings judge it by.\n\n{}\n\
         ### Figures\n\nF1 against time per dataset, past ten families one panel per family (the \
         others' settings in grey; the Pareto front's points numbered and named under the \
         legend), then each family's F1 against its main parameter, one panel per dataset. A \
         family has one colour and a variant one marker in every figure; a peer's marker is \
         hollow. Each figure's data (series, styles, points with their setting and seconds) \
         is the JSON file of its name.\n\n{pictures}\
         {peers_md}{off_surface}{no_mesh}Raw rows: [results.csv](results.csv), [pixels.csv](pixels.csv){}.\n",
        markdown_table(
            &[
                "dataset",
                "role",
                "method",
                "setting",
                "F1 [95 % CI]",
                "precision",
                "recall",
                "seconds",
                "oracle setting (best on this dataset)",
                "oracle F1",
            ],
            &best_table
        ),
        hpr::auto::KAPPA,
        raycast::auto::RADIUS_FACTOR,
        worst_lines.join("\n"),
        markdown_table(
            &[
                "dataset",
                "view",
                "method",
                "rule",
                "F1",
                "oracle fixed F1 (this view)",
                "gap"
            ],
            &auto_table
        ),
        pixel_table,
        if agreement.is_empty() {
            ""
        } else {
            ", [agreement.csv](agreement.csv)"
        },
    );
    // A method whose exactness claim failed: said first, as every table below lists it.
    let mut summary = match failed.0.is_empty() {
        true => summary,
        false => format!(
            "**Wrong answers** (a method that claims exactness and returned sets that differ from \
             our hpr's at the same γ, Jaccard below 0.999 on an unperturbed cell; never ranked in \
             the findings): {}.\n\n{summary}",
            failed.notes(failed.0.keys().map(String::as_str)).join("; ")
        ),
    };
    for extra in ["builds.csv", "peers.csv"] {
        if dir.join(extra).exists() {
            summary = summary.replace(
                "[pixels.csv](pixels.csv)",
                &format!("[pixels.csv](pixels.csv), [{extra}]({extra})"),
            );
        }
    }
    write_atomic(&dir.join("summary.md"), summary.as_bytes())
}

#[cfg(test)]
mod tests;
