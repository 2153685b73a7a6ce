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
    let long = "copc_converter-build-ooc (slope 0.94, 2 sizes)";
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
