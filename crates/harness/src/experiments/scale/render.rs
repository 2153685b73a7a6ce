//! The scale experiment's report: time and memory against size on log–log axes, a chart per
//! family (visibility methods, hulls, LOD), the fitted slopes ([`fit`]) and what did not
//! finish, and the out-of-core builds' details.

use std::path::Path;

use anyhow::Result;

use super::plan::OOC_SUFFIX;
use super::row::Row;
use crate::experiments::markdown_table;
use crate::output::plot::{Chart, Mark, Series};
use crate::output::{read_csv, write_atomic};

/// Per size where copc_converter's cell finished: each of our out-of-core builds' rate over
/// its rate (points per second), from the same run.
fn rates_against_the_peer(rows: &[Row]) -> String {
    let peer = format!("{}{OOC_SUFFIX}", super::copc::COPC_CONVERTER);
    let mut out = String::new();
    for p in rows.iter().filter(|r| r.method == peer && r.status == "ok") {
        let ours: Vec<String> = rows
            .iter()
            .filter(|r| {
                r.method.ends_with(OOC_SUFFIX)
                    && r.method != peer
                    && r.n_points == p.n_points
                    && r.status == "ok"
            })
            .map(|r| {
                format!(
                    "`{}` {:.2}×",
                    r.method,
                    (r.n_points as f64 / r.seconds) / (p.n_points as f64 / p.seconds)
                )
            })
            .collect();
        if !ours.is_empty() {
            out.push_str(&format!(
                "\nAt {} points, our rate over copc_converter's ({:.2} M points/s): {}.\n",
                p.n_points,
                p.n_points as f64 / p.seconds / 1e6,
                ours.join(", ")
            ));
        }
    }
    out
}

/// Draws the plots and writes `summary.md` of the results in `dir`.
pub fn render(dir: &Path) -> Result<()> {
    let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
    let mut methods: Vec<String> = rows.iter().map(|r| r.method.clone()).collect();
    methods.dedup();
    let mut table = Vec::new();
    // Three families, a chart each (time and memory), so colours stay distinct.
    let family = |m: &str| {
        if m.starts_with("hull-") {
            1
        } else if m.ends_with("-build") || m.ends_with("-select") || m.ends_with(OOC_SUFFIX) {
            2
        } else {
            0
        }
    };
    let mut time_series: [Vec<Series>; 3] = Default::default();
    let mut memory_series: [Vec<Series>; 3] = Default::default();
    for m in &methods {
        let f = family(m);
        let color = time_series[f].len();
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
        time_series[f].push(Series {
            color: Some(color),
            ..Series::new(
                format!("{m} (slope {}, {} sizes)", slope(t_fit), times.len()),
                times,
                Mark::LinePoints,
            )
        });
        memory_series[f].push(Series {
            color: Some(color),
            ..Series::new(
                format!("{m} (slope {}, {} sizes)", slope(m_fit), mems.len()),
                mems,
                Mark::LinePoints,
            )
        });
        let largest = ok.iter().map(|r| r.n_points).max().unwrap_or(0);
        let not_ok: Vec<String> = rows
            .iter()
            .filter(|r| &r.method == m && r.status != "ok")
            .map(|r| format!("{}: {}", r.n_points, r.status))
            .collect();
        table.push(vec![
            m.clone(),
            slope(t_fit),
            slope(m_fit),
            ok.len().to_string(),
            largest.to_string(),
            ok.iter()
                .find(|r| r.n_points == largest)
                .map_or("-".into(), |r| format!("{:.3}", r.seconds)),
            ok.iter()
                .find(|r| r.n_points == largest)
                .filter(|r| r.prepare_seconds.is_finite())
                .map_or("-".into(), |r| format!("{:.2}", r.prepare_seconds)),
            ok.iter()
                .find(|r| r.n_points == largest)
                .map_or("-".into(), |r| {
                    format!("{:.0}", r.peak_rss_bytes as f64 / 1048576.0)
                }),
            if not_ok.is_empty() {
                "-".into()
            } else {
                not_ok.join("; ")
            },
        ]);
    }
    let names = ["visibility", "hulls", "lod"];
    let captions = [
        "visibility methods",
        "hull implementations on HPR's flipped set",
        "LOD builds and selections",
    ];
    let mut images = String::new();
    for (k, (times, mems)) in time_series.into_iter().zip(memory_series).enumerate() {
        if times.is_empty() {
            continue;
        }
        Chart {
            title: format!("Time against cloud size: {}", captions[k]),
            x_label: "points".into(),
            y_label: "seconds".into(),
            x_log: true,
            y_log: true,
            series: times,
            ..Chart::default()
        }
        .save(&dir.join(format!("seconds_{}.png", names[k])), 1000, 600)?;
        Chart {
            title: format!("Peak memory (the cell process's RSS): {}", captions[k]),
            x_label: "points".into(),
            y_label: "bytes".into(),
            x_log: true,
            y_log: true,
            series: mems,
            ..Chart::default()
        }
        .save(&dir.join(format!("memory_{}.png", names[k])), 1000, 600)?;
        images.push_str(&format!(
            "![time, {c}](seconds_{n}.png)\n\n![memory, {c}](memory_{n}.png)\n\n",
            c = captions[k],
            n = names[k]
        ));
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
            rates_against_the_peer(&rows)
        )
    };
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
         process's fixed overhead at the small sizes). `seconds` is the operation alone; \
         `prepare s` the cell's input before it (sampling the cloud; a hull's flip; an LOD \
         method's normals), under a cap of its own ({} s on the operation, {} s on the \
         preparation). Cells not run or stopped say why.\n\n\
         {images}{}{ooc}{opted_out}\nRaw rows: [results.csv](results.csv).\n",
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
                "prepare s there",
                "peak MiB there",
                "not finished",
            ],
            &table
        )
    );
    write_atomic(&dir.join("summary.md"), text.as_bytes())
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

    #[test]
    fn our_rates_are_given_over_the_peers_at_each_size() {
        let row = |method: &str, n: u64, seconds: f64, status: &str| Row {
            method: method.into(),
            n_points: n,
            seconds,
            peak_rss_bytes: 0,
            status: status.into(),
            prepare_seconds: 0.0,
            detail: String::new(),
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
            "\nAt 1000000 points, our rate over copc_converter's (0.50 M points/s): \
             `qsplat-build-ooc` 0.40×, `spt-build-ooc` 0.25×.\n"
        );
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
