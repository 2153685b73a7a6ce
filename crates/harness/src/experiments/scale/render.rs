//! The scale experiment's report: time and memory against size on log–log axes, a figure per
//! group (visibility methods, hulls, LOD; small multiples by family past ten series), the
//! fitted slopes ([`fit`]) and what did not finish (each reason once, [`not_finished`]), and
//! the out-of-core builds' details.

use std::path::Path;

use anyhow::Result;

use super::plan::OOC_SUFFIX;
use super::row::Row;
use crate::experiments::markdown_table;
use crate::experiments::rules::ratio;
use crate::output::figure::{Axis, Draw, Figure, Point, Series};
use crate::output::style;
use crate::output::{read_csv, write_atomic};

/// Per size where copc_converter's cell finished: its time over each of our out-of-core
/// builds' (our rate over its rate), from the ratios table (`rules::ratio::scale`).
fn rates_against_the_peer(rows: &[Row]) -> String {
    let mut out = String::new();
    let cells: Vec<ratio::ScaleCell> = rows
        .iter()
        .map(|r| ratio::ScaleCell {
            method: r.method.clone(),
            n_points: r.n_points,
            seconds: r.seconds,
            status: r.status.clone(),
        })
        .collect();
    let peer = format!("{}{OOC_SUFFIX}", super::copc::COPC_CONVERTER);
    let ratios = ratio::scale(&cells, &peer, OOC_SUFFIX);
    for size in crate::output::distinct(ratios.iter().map(|r| r.dataset.as_str())) {
        let ours: Vec<String> = ratios
            .iter()
            .filter(|r| r.dataset == size)
            .map(|r| format!("`{}` {}", r.ours, r.text()))
            .collect();
        out.push_str(&format!(
            "\nAt {size}, copc_converter's time over ours (our rate over its rate; \
             `reports/ratios.csv`): {}.\n",
            ours.join(", ")
        ));
    }
    out
}

/// Our out-of-core builds with the normals estimated and given ([`super::plan::GIVEN`]) beside
/// copc_converter's build of the same points without normals, one table: a size and method a
/// row, each time and the converter's over it (above 1: ours is faster). One run each.
fn structure_table(rows: &[Row]) -> String {
    let secs = |m: &str, n: u64| {
        rows.iter()
            .find(|r| r.method == m && r.n_points == n && r.status == "ok")
            .map(|r| r.seconds)
    };
    let peer = format!("{}{OOC_SUFFIX}", super::copc::COPC_CONVERTER);
    let mut sizes: Vec<u64> = rows
        .iter()
        .filter(|r| r.method.ends_with(OOC_SUFFIX))
        .map(|r| r.n_points)
        .collect();
    sizes.sort_unstable();
    sizes.dedup();
    let text = |t: Option<f64>| t.map_or("-".to_owned(), |t| format!("{t:.2}"));
    let over = |p: Option<f64>, t: Option<f64>| match (p, t) {
        (Some(p), Some(t)) if t > 0.0 => format!("{:.2}×", p / t),
        _ => "-".to_owned(),
    };
    let mut table = Vec::new();
    for n in sizes {
        let copc = secs(&peer, n);
        for m in crate::lod_build::OUT_OF_CORE {
            let estimated = secs(&format!("{m}{OOC_SUFFIX}"), n);
            let given = secs(&format!("{m}{}{OOC_SUFFIX}", super::plan::GIVEN), n);
            if estimated.is_none() && given.is_none() {
                continue;
            }
            table.push(vec![
                n.to_string(),
                (*m).to_owned(),
                text(estimated),
                text(given),
                text(copc),
                over(copc, estimated),
                over(copc, given),
            ]);
        }
    }
    if table.is_empty() {
        return String::new();
    }
    format!(
        "\nOut-of-core builds from the same LAZ points: ours with the normals estimated, ours \
         with the normals given by the file (the structure alone), copc_converter (structure, \
         no normals), one run each:\n\n{}",
        markdown_table(
            &[
                "points",
                "ours",
                "normals estimated s",
                "normals given s",
                "copc_converter s",
                "copc ÷ estimated",
                "copc ÷ given",
            ],
            &table
        )
    )
}

/// The peak memory of an out-of-core cell's build alone, MiB: the first `peak N MiB` of its
/// detail (our build's own measure, the converter's own), else the cell process's (which adds
/// the LAZ written before and, for the peer, the harness beside the converter).
fn build_peak_mib(r: &Row) -> f64 {
    r.detail
        .split_once("peak ")
        .and_then(|(_, rest)| rest.split_once(" MiB"))
        .and_then(|(v, _)| v.parse().ok())
        .unwrap_or(r.peak_rss_bytes as f64 / 1048576.0)
}

/// A warning for each out-of-core cell whose build's peak memory ([`build_peak_mib`]) went
/// over its `limit` (bytes), or nothing: a limit the build does not keep is a result, not a
/// footnote.
fn over_the_limit(rows: &[Row], limit: u64) -> String {
    let limit_mib = limit as f64 / 1048576.0;
    let over: Vec<String> = rows
        .iter()
        .filter(|r| r.method.ends_with(OOC_SUFFIX) && r.status == "ok")
        .filter(|r| build_peak_mib(r) > limit_mib)
        .map(|r| {
            format!(
                "`{}` at {} points peaked at {:.0} MiB",
                r.method,
                r.n_points,
                build_peak_mib(r)
            )
        })
        .collect();
    if over.is_empty() {
        return String::new();
    }
    format!(
        "**Over the memory limit** of the out-of-core builds ({limit_mib:.0} MiB, the build's \
         own peak): {}.\n\n",
        over.join("; ")
    )
}

/// The group of a scale cell's method, by the cell names' convention: 0 a visibility method,
/// 1 a hull (`hull-NAME`), 2 an LOD build or selection (`NAME-build`, `NAME-select`,
/// `NAME-build-ooc`), 3 a normal estimation (`normals-NAME`, [`super::normals`]).
pub fn group(m: &str) -> usize {
    if super::normals::Kind::named(m).is_some() {
        3
    } else if m.starts_with("hull-") {
        1
    } else if m.ends_with("-build") || m.ends_with("-select") || m.ends_with(OOC_SUFFIX) {
        2
    } else {
        0
    }
}

/// Draws the plots and writes `summary.md` of the results in `dir`.
pub fn render(catalogue: &registry::Catalogue, dir: &Path) -> Result<()> {
    let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
    let wrong = crate::experiments::rules::wrong::for_scale(dir)?;
    let mut methods: Vec<String> = rows.iter().map(|r| r.method.clone()).collect();
    methods.dedup();
    let mut table = Vec::new();
    // Three groups, a figure each (time and memory): visibility methods, hulls, LOD builds and
    // selections. A series is its method's family (an LOD cell `NAME-build`, `NAME-select`,
    // `NAME-build-ooc`: family NAME, the operation its variant; a visibility method at its
    // default setting: variant `default`).
    let identity = |m: &str| -> (String, String) {
        for op in ["-build-ooc", "-build", "-select"] {
            if let Some(base) = m.strip_suffix(op) {
                return (base.to_owned(), op[1..].to_owned());
            }
        }
        if m.starts_with("hull-") {
            (m.to_owned(), String::new())
        } else {
            (style::family(catalogue, m, ""), "default".to_owned())
        }
    };
    let mut time_series: [Vec<Series>; 4] = Default::default();
    let mut memory_series: [Vec<Series>; 4] = Default::default();
    for m in &methods {
        let g = group(m);
        let (family, variant) = identity(m);
        let ok: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.method == m && r.status == "ok")
            .collect();
        let times: Vec<(f64, f64)> = ok.iter().map(|r| (r.n_points as f64, r.seconds)).collect();
        let mems: Vec<(f64, f64)> = ok
            .iter()
            .map(|r| (r.n_points as f64, r.peak_rss_bytes as f64))
            .collect();
        let t_fit = fit(&times);
        let m_fit = fit(&mems);
        let slope = |f: Option<(f64, f64)>| f.map_or("-".into(), |(s, _)| format!("{s:.2}"));
        let points = |y: &dyn Fn(&Row) -> f64| -> Vec<Point> {
            ok.iter()
                .map(|r| Point::new(r.n_points as f64, y(r)).seconds(r.seconds))
                .collect()
        };
        // A method whose exactness claim failed elsewhere in the reports: said in its label
        // and drawn in the wrong answers' own style.
        let mark = wrong.note(m).map_or(String::new(), |n| format!(" — {n}"));
        let variant = if mark.is_empty() {
            variant
        } else {
            style::WRONG.to_owned()
        };
        time_series[g].push(
            Series::new(m, &family, &variant, Draw::Line, points(&|r| r.seconds)).label(format!(
                "{m} (slope {}, {} sizes){mark}",
                slope(t_fit),
                times.len()
            )),
        );
        memory_series[g].push(
            Series::new(
                m,
                &family,
                &variant,
                Draw::Line,
                points(&|r| r.peak_rss_bytes as f64),
            )
            .label(format!(
                "{m} (slope {}, {} sizes){mark}",
                slope(m_fit),
                mems.len()
            )),
        );
        let largest = ok.iter().map(|r| r.n_points).max().unwrap_or(0);
        let not_ok = not_finished(
            rows.iter()
                .filter(|r| &r.method == m && r.status != "ok")
                .map(|r| (r.n_points, r.status.as_str())),
        );
        table.push(vec![
            format!("{m}{mark}"),
            slope(t_fit),
            slope(m_fit),
            ok.len().to_string(),
            largest.to_string(),
            ok.iter()
                .find(|r| r.n_points == largest)
                .map_or("-".into(), |r| format!("{:.3}", r.seconds)),
            ok.iter()
                .find(|r| r.n_points == largest)
                .filter(|r| r.build_seconds.is_finite())
                .map_or("-".into(), |r| format!("{:.3}", r.build_seconds)),
            ok.iter()
                .find(|r| r.n_points == largest)
                .filter(|r| r.prepare_seconds.is_finite())
                .map_or("-".into(), |r| format!("{:.2}", r.prepare_seconds)),
            ok.iter()
                .find(|r| r.n_points == largest)
                .map_or("-".into(), |r| {
                    format!("{:.0}", r.peak_rss_bytes as f64 / 1048576.0)
                }),
            not_ok,
        ]);
    }
    let names = ["visibility", "hulls", "lod", "normals"];
    let captions = [
        "visibility methods",
        "hull implementations on HPR's flipped set",
        "LOD builds and selections",
        "normal estimation (16 neighbours)",
    ];
    let mut images = String::new();
    for (k, (times, mems)) in time_series.into_iter().zip(memory_series).enumerate() {
        if times.is_empty() {
            continue;
        }
        // A log axis draws only positive finite values: a group none of whose cells finished
        // (every one refused or timed out, as on a loaded machine) is said, not drawn.
        let drawable = |series: &[Series]| {
            series
                .iter()
                .flat_map(|s| &s.points)
                .any(|p| p.x.is_finite() && p.y.is_finite() && p.x > 0.0 && p.y > 0.0)
        };
        if !drawable(&times) || !drawable(&mems) {
            images.push_str(&format!(
                "No cell of the {} finished at any size: no figure (their reasons are in the \
                 table).\n\n",
                captions[k]
            ));
            continue;
        }
        images.push_str(
            &Figure::new(
                format!("seconds_{}", names[k]),
                format!("Time against cloud size: {}", captions[k]),
                Axis::log("points"),
                Axis::log("seconds"),
            )
            .series(times, Vec::new())
            .write(dir)?,
        );
        images.push_str(
            &Figure::new(
                format!("memory_{}", names[k]),
                format!("Peak memory (the cell process's RSS): {}", captions[k]),
                Axis::log("points"),
                Axis::log("bytes"),
            )
            .series(mems, Vec::new())
            .write(dir)?,
        );
    }
    let meta = crate::output::meta::RunMeta::read(dir).ok();
    let parameter = |key: &str| {
        meta.as_ref()
            .and_then(|m| m.parameters[key].as_u64())
            .map_or("?".to_owned(), |v| v.to_string())
    };
    let (cap, prepare_cap) = (parameter("cap_seconds"), parameter("prepare_cap_seconds"));
    let opted_out: Vec<String> = meta
        .as_ref()
        .and_then(|m| m.parameters["opted_out"].as_array().cloned())
        .unwrap_or_default()
        .iter()
        .map(|o| {
            format!(
                "- `{}` takes no part: {}\n",
                o["method"].as_str().unwrap_or("?"),
                o["reason"].as_str().unwrap_or("?")
            )
        })
        .collect();
    let limit = meta
        .as_ref()
        .and_then(|m| m.parameters["out_of_core"]["memory_limit_bytes"].as_u64())
        .unwrap_or(super::plan::OOC_LIMIT);
    let over = over_the_limit(&rows, limit);
    let ooc: Vec<String> = rows
        .iter()
        .filter(|r| r.method.ends_with(OOC_SUFFIX) && !r.detail.is_empty())
        .map(|r| format!("- `{}`, {} points: {}\n", r.method, r.n_points, r.detail))
        .collect();
    let ooc = if ooc.is_empty() {
        String::new()
    } else {
        format!(
            "\nOut-of-core builds (`pointsight lod-build` of a LAZ file the cell wrote from \
             the same samples, and the peer copc_converter's build of that file with the same \
             thread count and memory limit; `seconds` includes reading and decoding it):\n\n{}{}",
            ooc.concat(),
            rates_against_the_peer(&rows),
        ) + &structure_table(&rows)
    };
    let normals = super::normals::summary(&rows);
    let opted_out = if opted_out.is_empty() {
        String::new()
    } else {
        format!("\nMethods that opted out:\n\n{}", opted_out.concat())
    };
    let text = format!(
        "How each method's time and peak memory grow with the cloud size: clouds sampled \
         from the dragon mesh, view 0, one process per cell (peak RSS is the cell's own: \
         the sampled cloud plus the method, and the largest program it waited for). Slopes are least-squares fits of log10 against \
         log10 over the sizes that finished (1: linear; memory slopes are lowered by the \
         process's fixed overhead at the small sizes). `seconds` is the operation alone (a \
         visibility method's: one view's answer); `build s` a visibility method's per-cloud \
         preparation, which every view reuses and `seconds` leaves out (a tree, a learned \
         method's feature pass; `-` where the method builds nothing it accounts for), inside \
         the operation's cap; `prepare s` the cell's input before it (sampling the cloud; a \
         hull's flip; an LOD method's normals), under a cap of its own ({} s on the \
         operation, {} s on the preparation). Cells not run or stopped say why.\n\n\
         {over}{images}{}{ooc}{normals}{opted_out}\nRaw rows: [results.csv](results.csv).\n",
        cap,
        prepare_cap,
        markdown_table(
            &[
                "method",
                "time slope",
                "memory slope",
                "sizes fitted",
                "largest finished",
                "seconds there",
                "build s there",
                "prepare s there",
                "peak MiB there",
                "not finished",
            ],
            &table
        )
    );
    write_atomic(&dir.join("summary.md"), text.as_bytes())
}

/// The sizes that did not finish, grouped by why: `"10000000, 100000000: refused: ..."`, each
/// reason once (`-` when every size finished).
pub fn not_finished<'a>(cells: impl Iterator<Item = (u64, &'a str)>) -> String {
    let mut groups: Vec<(Vec<u64>, &str)> = Vec::new();
    for (n, status) in cells {
        match groups.iter_mut().find(|(_, s)| *s == status) {
            Some((sizes, _)) => sizes.push(n),
            None => groups.push((vec![n], status)),
        }
    }
    if groups.is_empty() {
        return "-".into();
    }
    groups
        .iter()
        .map(|(sizes, status)| {
            let sizes: Vec<String> = sizes.iter().map(ToString::to_string).collect();
            format!("{}: {status}", sizes.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Least-squares slope and intercept of log10 y against log10 x.
pub fn fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && y.is_finite())
        .map(|(x, y)| (x.log10(), y.log10()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reason shared by several sizes is said once in a row, not once a size ("10000000:
    /// refused: its memory per point is not declared (...); 100000000: refused: its memory per
    /// point is not declared (...)").
    #[test]
    fn a_reason_is_given_once_for_all_its_sizes() {
        let why = "refused: its memory per point is not declared (memory_bytes_per_point in an \
                   external method's method.toml, Method::scale for a built-in one), so it is not \
                   run above 1000000 points";
        let text = not_finished(
            [
                (10_000_000, why),
                (100_000_000, why),
                (1_000_000_000, "skipped: the previous size did not finish"),
            ]
            .into_iter(),
        );
        assert_eq!(
            text.matches("memory per point is not declared").count(),
            1,
            "{text}"
        );
        assert!(
            text.starts_with(&format!("10000000, 100000000: {why}; ")),
            "{text}"
        );
        assert!(text.ends_with("1000000000: skipped: the previous size did not finish"));
        assert_eq!(not_finished(std::iter::empty()), "-");
    }

    #[test]
    fn a_group_where_nothing_finished_is_said_not_drawn() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("results.csv"),
            "method,n_points,seconds,peak_rss_bytes,status,prepare_seconds,detail\n\
             splat,10000,NaN,0,timeout after 40 s,NaN,\n\
             raycast,10000,NaN,0,timeout after 40 s,NaN,\n\
             hull-own,10000,0.5,1048576,ok,0.1,\n",
        )
        .unwrap();
        render(&registry::Catalogue::builtin(), dir.path()).unwrap();
        let summary = std::fs::read_to_string(dir.path().join("summary.md")).unwrap();
        assert!(
            summary.contains("No cell of the visibility methods finished at any size"),
            "{summary}"
        );
        assert!(!dir.path().join("seconds_visibility.png").exists());
        assert!(dir.path().join("seconds_hulls.png").exists());
        // A hull cell builds nothing per cloud: `-` under `build s`, its flip under `prepare s`.
        assert!(summary.contains("| 0.500 | - | 0.10 |"), "{summary}");
    }

    #[test]
    fn a_visibility_cells_build_is_its_own_column() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("results.csv"),
            "method,n_points,seconds,peak_rss_bytes,status,prepare_seconds,detail,runs_seconds,\
             angle_median_deg,angle_p95_deg,sign_agreement,build_seconds\n\
             raycast,10000,0.25,1048576,ok,0.5,,,NaN,NaN,NaN,1.75\n\
             raycast,100000,0.5,2097152,ok,0.75,,,NaN,NaN,NaN,3.5\n",
        )
        .unwrap();
        render(&registry::Catalogue::builtin(), dir.path()).unwrap();
        let summary = std::fs::read_to_string(dir.path().join("summary.md")).unwrap();
        let header = summary
            .lines()
            .find(|l| l.starts_with("| method |"))
            .unwrap();
        assert!(
            header.contains("| seconds there | build s there | prepare s there |"),
            "{header}"
        );
        assert!(summary.contains("| 0.500 | 3.500 | 0.75 |"), "{summary}");
    }

    /// A row of an out-of-core cell: `seconds`, peak MiB, status.
    fn ooc_row(method: &str, n: u64, seconds: f64, peak_mib: u64, status: &str) -> Row {
        Row {
            seconds,
            peak_rss_bytes: peak_mib << 20,
            prepare_seconds: 0.0,
            ..Row::not_run(method, n, status.into())
        }
    }

    #[test]
    fn our_rates_are_given_over_the_peers_at_each_size() {
        let row = |method: &str, n: u64, seconds: f64, status: &str| {
            ooc_row(method, n, seconds, 0, status)
        };
        let rows = [
            row("qsplat-build-ooc", 1_000_000, 5.0, "ok"),
            row("spt-build-ooc", 1_000_000, 8.0, "ok"),
            row("copc_converter-build-ooc", 1_000_000, 2.0, "ok"),
            row("qsplat-build-ooc", 10_000_000, 50.0, "ok"),
            row(
                "copc_converter-build-ooc",
                10_000_000,
                f64::NAN,
                "timeout after 3600 s",
            ),
        ];
        let text = rates_against_the_peer(&rows);
        assert_eq!(
            text,
            "\nAt 1000000 points, copc_converter's time over ours (our rate over its rate; \
             `reports/ratios.csv`): `qsplat-build-ooc` 0.40× (one run), `spt-build-ooc` 0.25× (one run).\n"
        );
    }

    #[test]
    fn the_structure_table_sets_given_and_estimated_normals_beside_the_converter() {
        let rows = [
            ooc_row("qsplat-build-ooc", 2_000_000, 4.0, 500, "ok"),
            ooc_row("qsplat-given-build-ooc", 2_000_000, 2.0, 500, "ok"),
            ooc_row("copc_converter-build-ooc", 2_000_000, 3.0, 500, "ok"),
            ooc_row(
                "spt-given-build-ooc",
                2_000_000,
                1.0,
                500,
                "timeout after 9 s",
            ),
        ];
        let t = structure_table(&rows);
        assert!(
            t.contains("| 2000000 | qsplat | 4.00 | 2.00 | 3.00 | 0.75× | 1.50× |"),
            "{t}"
        );
        assert!(!t.contains("| spt |"), "{t}");
        assert_eq!(structure_table(&rows[2..3]), "");
    }

    #[test]
    fn a_build_over_its_memory_limit_is_flagged() {
        let row = |method: &str, n: u64, peak_mib: u64, status: &str| {
            ooc_row(method, n, 1.0, peak_mib, status)
        };
        let with = |mut r: Row, detail: &str| {
            r.detail = detail.into();
            r
        };
        let rows = [
            row("qsplat-build-ooc", 1_000_000_000, 2186, "ok"),
            row("spt-build-ooc", 100_000_000, 965, "ok"),
            row("spt-build-ooc", 1_000_000_000, 0, "skipped: disk"),
            row("qsplat-build", 10_000_000, 4297, "ok"),
            // The cell process holds more than the build: the build's own peak counts.
            with(
                row("qsplat-build-ooc", 10_000_000, 1100, "ok"),
                "limit 1024 MiB, peak 577 MiB, 0.25 M points/s; peak after 1100 MiB",
            ),
            with(
                row("copc_converter-build-ooc", 10_000_000, 1100, "ok"),
                "copc_converter --threads 2 --memory-limit 1024 MiB: peak 1030 MiB (the \
                 converter's own)",
            ),
        ];
        assert_eq!(
            over_the_limit(&rows, 1 << 30),
            "**Over the memory limit** of the out-of-core builds (1024 MiB, the build's own \
             peak): `qsplat-build-ooc` at 1000000000 points peaked at 2186 MiB; \
             `copc_converter-build-ooc` at 10000000 points peaked at 1030 MiB.\n\n"
        );
        assert_eq!(over_the_limit(&rows[1..5], 1 << 30), "");
    }

    #[test]
    fn the_fit_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 1e5, 1e6]
            .iter()
            .map(|&n: &f64| (n, 3e-8 * n.powf(1.2)))
            .collect();
        let (slope, intercept) = fit(&pts).unwrap();
        assert!((slope - 1.2).abs() < 1e-9);
        assert!((intercept - 3e-8f64.log10()).abs() < 1e-9);
        assert!(fit(&pts[..1]).is_none());
        assert!(fit(&[(1e4, f64::NAN), (1e5, 1.0)]).is_none());
    }
}
