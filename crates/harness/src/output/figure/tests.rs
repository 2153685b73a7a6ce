//! Tests of the figure descriptions, their JSON twins and their drawing.

use plotters::prelude::*;

use super::*;

fn series(method: &str, family: &str, variant: &str, draw: Draw) -> Series {
    Series::new(
        method,
        family,
        variant,
        draw,
        vec![
            Point::new(10.0, 0.91).y_interval(0.9, 0.93),
            Point::new(100.0, 0.95).seconds(0.1),
            Point::new(1000.0, 0.97),
        ],
    )
}

#[test]
fn a_figure_writes_its_twin_and_a_png_drawn_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let fig = Figure::new("f", "test", Axis::log("points"), Axis::linear("F1"))
        .interval("lowest to highest view")
        .series(
            vec![
                series("hpr", "hpr-linear", "best", Draw::Line),
                series("hpr", "hpr-linear", "auto", Draw::Line),
                series("cgal-hpr", "cgal-hpr", "", Draw::Points),
            ],
            vec![],
        );
    let md = fig.write(dir.path()).unwrap();
    assert_eq!(md, "![test](f.png)\n\n");
    let img = image::open(dir.path().join("f.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), fig.size());
    // Each series' colour is in the picture.
    for s in fig.legend() {
        let c = s.style.color;
        assert!(img.pixels().any(|p| p.0 == c), "{}", s.label);
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(json["format"], FORMAT);
    let s0 = &json["panels"][0]["series"][0];
    assert_eq!(s0["method"], "hpr");
    assert_eq!(s0["family"], "hpr-linear");
    assert_eq!(s0["variant"], "best");
    assert_eq!(s0["style"]["marker"], "square");
    assert_eq!(s0["points"][0]["y_lo"], 0.9);
    assert_eq!(json["panels"][0]["series"][2]["peer"], true);
    assert!(fig.style_clash().is_none());
}

#[test]
fn more_than_ten_series_become_small_multiples_with_grey_context() {
    let families = [
        "hpr-linear",
        "hpr-exp",
        "hpr-log",
        "robust",
        "raycast",
        "splat",
    ];
    let mut all = Vec::new();
    for f in families {
        all.push(series(f, f, "best", Draw::Line));
        all.push(series(f, f, "auto", Draw::Line));
    }
    let fig = Figure::new("g", "many", Axis::linear("x"), Axis::linear("y")).series(all, vec![]);
    assert_eq!(fig.panels.len(), families.len());
    for (p, f) in fig.panels.iter().zip(families) {
        assert_eq!(p.title, f);
        let own: Vec<&Series> = p.series.iter().filter(|s| !s.context).collect();
        assert_eq!(own.len(), 2);
        assert!(own.iter().all(|s| s.family == f));
        let context: Vec<&Series> = p.series.iter().filter(|s| s.context).collect();
        // The other families' best, in grey.
        assert_eq!(context.len(), families.len() - 1);
        assert!(
            context
                .iter()
                .all(|s| s.variant == "best" && s.style == CONTEXT)
        );
    }
    assert!(fig.style_clash().is_none());
    let dir = tempfile::tempdir().unwrap();
    fig.write(dir.path()).unwrap();
}

#[test]
fn series_without_points_are_left_out() {
    let fig = Figure::new("d", "d", Axis::log("x"), Axis::linear("y")).series(
        vec![
            series("hpr", "hpr-linear", "best", Draw::Line),
            Series::new(
                "chull",
                "hull-chull",
                "",
                Draw::Points,
                vec![Point::new(f64::NAN, 1.0)],
            ),
        ],
        vec![],
    );
    assert_eq!(fig.legend().len(), 1);
    assert_eq!(fig.legend()[0].method, "hpr");
}

#[test]
fn axes_are_zoomed_to_the_data() {
    let (lo, hi) = padded([0.97, 0.99].into_iter(), false).unwrap();
    assert!(lo > 0.96 && hi < 1.0, "{lo} {hi}");
    let (lo, hi) = padded([1.0, 1000.0].into_iter().map(f64::log10), true).unwrap();
    assert!(lo > -0.2 && hi < 3.2);
}

#[test]
fn dashes_follow_the_pattern_across_vertices() {
    let seg = dash_segments(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], &[8.0, 4.0]);
    // On 0..8, off 8..12 (crossing the corner), on 12..20.
    assert_eq!(seg.len(), 2);
    assert_eq!(seg[0], [(0.0, 0.0), (8.0, 0.0)]);
    assert_eq!(seg[1], [(10.0, 2.0), (10.0, 10.0)]);
    assert_eq!(dash_segments(&[(0.0, 0.0), (3.0, 4.0)], &[]).len(), 1);
}

#[test]
fn an_empty_figure_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let fig = Figure::new("e", "e", Axis::log("x"), Axis::linear("y")).series(
        vec![Series::new(
            "a",
            "a",
            "",
            Draw::Line,
            vec![Point::new(0.0, 1.0)],
        )],
        vec![],
    );
    assert!(fig.write(dir.path()).is_err());
}

#[test]
fn long_text_is_wrapped_within_the_width() {
    ensure_font().unwrap();
    let mut buf = vec![255u8; 400 * 100 * 3];
    let root = BitMapBackend::with_buffer(&mut buf, (400, 100)).into_drawing_area();
    let font: TextStyle = (FONT, 18).into_font().into();
    let text = "screenspace tol=0.01 half_width=2 levels=3 sectors=8 threshold=0.25 (F1 0.972)";
    let lines = wrap_text(&root, text, &font, 250);
    assert!(lines.len() >= 2, "{lines:?}");
    for l in &lines {
        assert!(root.estimate_text_size(l, &font).unwrap().0 <= 250, "{l}");
    }
    assert_eq!(lines.join(" "), text);
}

#[test]
fn the_legend_widens_so_that_no_series_label_is_cut() {
    ensure_font().unwrap();
    let long = "copc_converter-build-ooc (slope 0.94, 2 sizes, out of core, every level)";
    let mut s = series("copc_converter", "copc_converter", "", Draw::Line);
    s.label = long.to_owned();
    let short = Figure::new("f", "t", Axis::log("points"), Axis::log("s"))
        .series(vec![series("hpr", "hpr-linear", "", Draw::Line)], vec![]);
    let fig = Figure::new("f", "t", Axis::log("points"), Axis::log("s"))
        .series(vec![series("hpr", "hpr-linear", "", Draw::Line), s], vec![]);
    assert_eq!(short.legend_width(), LEGEND_W);
    let w = fig.legend_width();
    assert!(w > LEGEND_W, "{w}");
    assert_eq!(fig.size().0, short.size().0 + w - LEGEND_W);
    // The label at the legend's text width is not cut.
    let mut buf = vec![255u8; 3];
    let area = BitMapBackend::with_buffer(&mut buf, (1, 1)).into_drawing_area();
    let font: TextStyle = (FONT, LEGEND_FONT).into_font().into();
    assert_eq!(fit_text(&area, long, &font, w - LEGEND_TEXT_X - 8), long);
}

/// The rows of `img` holding a pixel darker than mid grey between columns `x0` and `x1`.
fn dark_rows(img: &image::RgbImage, x0: u32, x1: u32) -> Vec<u32> {
    (0..img.height())
        .filter(|&y| (x0..x1).any(|x| img.get_pixel(x, y).0.iter().all(|&c| c < 128)))
        .collect()
}

#[test]
fn the_decimal_point_sits_on_the_digits_baseline_at_every_text_size() {
    ensure_font().unwrap();
    for size in TEXT_SIZES {
        assert_eq!(size % 2, 0, "{size}");
        let (w, h) = (120u32, 60u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let font: TextStyle = (FONT, size).into_font().color(&BLACK);
            root.draw_text("0.", &font, (10, 10)).unwrap();
            root.present().unwrap();
        }
        let img = image::RgbImage::from_raw(w, h, buf).unwrap();
        let zero_w = text_width("0", size);
        let digit = dark_rows(&img, 10, 10 + zero_w);
        let point = dark_rows(&img, 10 + zero_w, w);
        assert!(!digit.is_empty() && !point.is_empty(), "{size}");
        assert_eq!(
            digit.last(),
            point.last(),
            "at {size} px the point's lowest row is not the digit's"
        );
    }
}

#[test]
fn a_figure_draws_its_vertical_rules_and_notes_and_lists_them_in_its_twin() {
    let dir = tempfile::tempdir().unwrap();
    let fig = Figure::new("r", "rules", Axis::log("points"), Axis::linear("PSNR"))
        .rules(vec![
            Rule {
                x: 30.0,
                label: "1 %".into(),
            },
            Rule {
                x: 5000.0,
                label: "outside".into(),
            },
        ])
        .notes(vec![
            "Not drawn, identical to the reference: m ×1: a=1 (8 of 8 views).".into(),
        ])
        .series(vec![series("qsplat", "qsplat", "×1", Draw::Line)], vec![]);
    fig.write(dir.path()).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(json["rules"][0]["x"], 30.0);
    assert_eq!(json["rules"][0]["label"], "1 %");
    assert!(json["notes"][0].as_str().unwrap().contains("identical"));
    // The rule inside the x range is drawn: a column of the rules' grey.
    let img = image::open(dir.path().join("r.png")).unwrap().to_rgb8();
    let grey = [RULE_LINE.0, RULE_LINE.1, RULE_LINE.2];
    let columns: std::collections::BTreeMap<u32, usize> = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 == grey)
        .fold(Default::default(), |mut m, (x, _, _)| {
            *m.entry(x).or_default() += 1;
            m
        });
    assert!(
        columns.values().any(|&n| n > 100),
        "no vertical rule: {columns:?}"
    );
    // The note is in the legend's lines.
    assert!(
        fig.legend_lines()
            .iter()
            .any(|l| matches!(l, LegendLine::Note(t) if t.contains("identical")))
    );
}

#[test]
fn two_series_of_one_colour_in_a_figure_take_distinct_shades() {
    let fig = Figure::new("c", "colours", Axis::log("points"), Axis::linear("F1")).series(
        vec![
            series("hpr", "hpr-linear", "synchronous", Draw::Line),
            series("hpr", "hpr-linear", "background", Draw::Line),
            series("cgal-hpr", "cgal-hpr", "", Draw::Points),
            series("quick", "hull-quickhull", style::WRONG, Draw::Points),
            series("own", "hull-own", style::WRONG, Draw::Points),
        ],
        vec![],
    );
    let colours: Vec<[u8; 3]> = fig.legend().iter().map(|s| s.style.color).collect();
    assert_eq!(colours[0], style::style("hpr-linear", "synchronous").color);
    assert_ne!(colours[0], colours[1]);
    assert!(!colours[..3].contains(&style::WRONG_COLOR));
    let firsts: std::collections::BTreeSet<_> = colours[..3].iter().collect();
    assert_eq!(firsts.len(), 3);
    // Wrong answers keep their grey (told apart by marker and label).
    assert_eq!(colours[3], style::WRONG_COLOR);
    assert_eq!(colours[4], style::WRONG_COLOR);
}

/// Every figure twin under the committed `reports/`.
fn committed_figures() -> Vec<(std::path::PathBuf, serde_json::Value)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../reports");
    let mut out = Vec::new();
    for dir in std::fs::read_dir(&root).unwrap().flatten() {
        let Ok(files) = std::fs::read_dir(dir.path()) else {
            continue;
        };
        for f in files.flatten() {
            let path = f.path();
            if path.extension().is_none_or(|e| e != "json") {
                continue;
            }
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            if let Ok(v) = serde_json::from_str::<serde_json::Value>(&text)
                && v["format"] == FORMAT
            {
                out.push((path, v));
            }
        }
    }
    out
}

#[test]
fn no_two_series_of_a_committed_panel_share_a_colour() {
    let figures = committed_figures();
    assert!(figures.len() > 20, "{} figure twins", figures.len());
    let mut clashes = Vec::new();
    for (path, fig) in &figures {
        for panel in fig["panels"].as_array().unwrap() {
            let mut seen: Vec<(String, String)> = Vec::new();
            for s in panel["series"].as_array().unwrap() {
                let colour = s["style"]["color"].as_str().unwrap().to_owned();
                let label = s["label"].as_str().unwrap().to_owned();
                if s["context"] == true || s["variant"] == style::WRONG {
                    continue;
                }
                if let Some((_, other)) = seen.iter().find(|(c, l)| *c == colour && *l != label) {
                    clashes.push(format!("{}: {other} / {label}", path.display()));
                }
                seen.push((colour, label));
            }
        }
    }
    assert!(
        clashes.is_empty(),
        "{} clashes: {clashes:#?}",
        clashes.len()
    );
}

#[test]
fn the_committed_lod_curves_mark_every_budget_and_draw_no_identical_image() {
    let lod: Vec<_> = committed_figures()
        .into_iter()
        .filter(|(p, _)| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("psnr_vs_points_"))
        })
        .collect();
    assert!(!lod.is_empty());
    for (path, fig) in &lod {
        let labels: Vec<&str> = fig["rules"]
            .as_array()
            .unwrap_or_else(|| panic!("{}: no rules", path.display()))
            .iter()
            .map(|r| r["label"].as_str().unwrap())
            .collect();
        assert_eq!(
            labels,
            ["1 %", "2 %", "5 %", "10 %", "20 %", "30 %"],
            "{}",
            path.display()
        );
        let ys = fig["panels"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| p["series"].as_array().unwrap())
            .flat_map(|s| s["points"].as_array().unwrap())
            .map(|p| p["y"].as_f64().unwrap());
        assert!(ys.into_iter().all(|y| y < 60.0), "{}", path.display());
    }
}

#[test]
fn a_fronts_numbers_never_overlap_each_other_or_a_ring() {
    // Rings as close as the dragon's front at 0.3 s: 6, 8 and 10 within a few pixels.
    let rings = [
        (40.0, 200.0),
        (44.0, 204.0),
        (120.0, 190.0),
        (150.0, 188.0),
        (160.0, 186.0),
        (300.0, 150.0),
        (302.0, 152.0),
        (305.0, 149.0),
        (303.0, 140.0),
        (306.0, 151.0),
    ];
    let (ring, size) = (5.6, 12);
    let places = front_labels(&rings, ring, size);
    assert_eq!(places.len(), rings.len());
    let boxes: Vec<(f64, f64, f64, f64)> = places
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let w = f64::from(text_width(&(k + 1).to_string(), size)) / 2.0;
            let h = f64::from(size) / 2.0;
            (
                p.centre.0 - w,
                p.centre.1 - h,
                p.centre.0 + w,
                p.centre.1 + h,
            )
        })
        .collect();
    let overlap = |a: &(f64, f64, f64, f64), b: &(f64, f64, f64, f64)| {
        a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
    };
    for (i, a) in boxes.iter().enumerate() {
        for b in &boxes[i + 1..] {
            assert!(!overlap(a, b), "{a:?} {b:?}");
        }
        for &(x, y) in &rings {
            assert!(
                !overlap(a, &(x - ring, y - ring, x + ring, y + ring)),
                "{a:?}"
            );
        }
    }
    // Crowded rings send some numbers apart, with a leader line.
    assert!(places.iter().any(|p| p.leader));
}
