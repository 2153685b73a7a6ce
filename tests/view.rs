//! `pointsight view`: the page's data (what the browser tests in web/test/ read), and bad
//! input refused with the errors `visible` gives and no page. The viewer's script is a stand-in
//! here (POINTSIGHT_VIEWER_JS): these tests need no npm; web/test/ drives the real one.

use std::path::Path;
use std::process::{Command, Output};

fn pointsight(args: &[&str], script: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .env("POINTSIGHT_VIEWER_JS", script)
        .output()
        .expect("the pointsight binary runs")
}

fn data_of(html: &str) -> serde_json::Value {
    let start = html
        .find("<script id=\"pointsight-data\" type=\"application/json\">")
        .expect("the data element")
        + "<script id=\"pointsight-data\" type=\"application/json\">".len();
    let end = start + html[start..].find("</script>").expect("its end");
    serde_json::from_str(&html[start..end]).expect("the data is JSON")
}

fn bits(b64: &str) -> Vec<u8> {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD
        .decode(b64)
        .expect("base64")
}

#[test]
fn sphere_page_holds_every_point_and_the_classes() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "window.stub = '</script>';").unwrap();
    let page = dir.path().join("sphere.html");
    let png = dir.path().join("sphere.png");
    let out = pointsight(
        &[
            "view",
            "--dataset",
            "sphere-20000",
            "--methods",
            "hpr,splat",
            "--set",
            "gamma=3",
            "--out",
            page.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
        ],
        &script,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = String::from_utf8(out.stdout).unwrap();
    assert!(
        line.contains("points=20000 shown=20000 methods=2"),
        "{line}"
    );
    let html = std::fs::read_to_string(&page).unwrap();
    // The script's "</script>" cannot end its element early.
    assert!(html.contains("window.stub = '<\\/script>';"));
    let data = data_of(&html);
    assert_eq!(data["n"], 20000);
    assert_eq!(data["truth_kind"], "reference");
    assert_eq!(bits(data["positions"].as_str().unwrap()).len(), 6 * 20000);
    let truth = bits(data["truth"].as_str().unwrap());
    assert_eq!(truth.len(), 2500);
    let visible_truth: u32 = truth.iter().map(|b| b.count_ones()).sum();
    let methods = data["methods"].as_array().unwrap();
    assert_eq!(methods[0]["name"], "hpr");
    assert!(methods[0]["setting"].as_str().unwrap().contains("gamma=3"));
    for m in methods {
        let c = &m["counts"];
        let n = |k: &str| c[k].as_u64().unwrap();
        assert_eq!(n("tp") + n("fn") + n("fp") + n("hidden") + n("off"), 20000);
        if n("off") == 0 {
            assert_eq!(n("tp") + n("fn"), u64::from(visible_truth));
        }
        let v: u32 = bits(m["visible"].as_str().unwrap())
            .iter()
            .map(|b| b.count_ones())
            .sum();
        assert_eq!(u64::from(v), n("tp") + n("fp"));
        assert_eq!(m["n_visible_total"].as_u64().unwrap(), u64::from(v));
        // Every point is on the page: its scores are the counts'.
        let (tp, fnn, fp) = (n("tp") as f64, n("fn") as f64, n("fp") as f64);
        let p = m["scores"][0].as_f64().unwrap();
        let r = m["scores"][1].as_f64().unwrap();
        assert!((p - tp / (tp + fp)).abs() < 1e-9, "{p}");
        assert!((r - tp / (tp + fnn)).abs() < 1e-9, "{r}");
        assert!(r > 0.5, "{r}");
    }
    let img = image::open(&png).unwrap();
    assert_eq!(
        (img.width(), img.height()),
        (
            data["camera"]["width"].as_u64().unwrap() as u32,
            data["camera"]["height"].as_u64().unwrap() as u32
        )
    );
}

#[test]
fn max_points_keeps_a_prefix_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "").unwrap();
    let page = dir.path().join("small.html");
    let out = pointsight(
        &[
            "view",
            "--dataset",
            "sphere-20000",
            "--methods",
            "splat",
            "--max-points",
            "5000",
            "--out",
            page.to_str().unwrap(),
        ],
        &script,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let data = data_of(&std::fs::read_to_string(&page).unwrap());
    assert_eq!(data["n"], 5000);
    assert_eq!(data["n_total"], 20000);
    assert!(
        data["note"]
            .as_str()
            .unwrap()
            .contains("uniform subsample of 5000")
    );
    assert_eq!(bits(data["positions"].as_str().unwrap()).len(), 6 * 5000);
}

#[test]
fn bad_input_gets_an_error_and_no_page() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "").unwrap();
    let page = dir.path().join("p.html");
    let p = page.to_str().unwrap();
    let missing = dir.path().join("nope.ply");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--dataset", "nosuch"], "nosuch"),
        (vec!["--dataset", "sphere-20000", "--view", "99"], "view 99"),
        (
            vec!["--dataset", "sphere-20000", "--methods", "nosuch"],
            "nosuch",
        ),
        (
            vec!["--dataset", "sphere-20000", "--set", "nokey=1"],
            "no chosen method",
        ),
        (
            vec!["--cloud", missing.to_str().unwrap(), "--eye", "1,2,3"],
            "nope.ply",
        ),
        (
            vec!["--dataset", "sphere-20000", "--max-points", "0"],
            "at least 1",
        ),
        (
            vec!["--dataset", "sphere-20000", "--lod", "--methods", "hpr"],
            "no level-of-detail method \"hpr\"",
        ),
        (
            vec!["--dataset", "sphere-20000", "--lod", "--distance", "0"],
            "--distance must be",
        ),
        (
            vec!["--dataset", "sphere-20000", "--distance", "3"],
            "--distance is for level-of-detail pages",
        ),
        (
            vec!["--dataset", "sphere-20000", "--lod", "--set", "gamma=2"],
            "no chosen method",
        ),
    ];
    for (args, message) in cases {
        let mut all = vec!["view"];
        all.extend(&args);
        all.extend(["--out", p]);
        let out = pointsight(&all, &script);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(message), "{args:?}: {err} lacks {message:?}");
        assert!(!page.exists(), "{args:?} left a page");
    }
    // With --cloud and no camera: the error `visible` gives.
    let ply = dir.path().join("c.xyz");
    std::fs::write(&ply, "0 0 0\n1 0 0\n0 1 0\n0 0 1\n").unwrap();
    let out = pointsight(
        &["view", "--cloud", ply.to_str().unwrap(), "--out", p],
        &script,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("give a camera"));
    assert!(!page.exists());
}

#[test]
fn a_missing_script_says_how_to_build_it() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("p.html");
    let out = pointsight(
        &[
            "view",
            "--dataset",
            "sphere-20000",
            "--out",
            page.to_str().unwrap(),
        ],
        &dir.path().join("absent.js"),
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("just web"), "{err}");
    assert!(!page.exists());
}

/// `view --lod` on a cloud no registry knows (a user's XYZ file, no normals, a camera from the
/// command line): the full detail and each named method, every splat on the page.
#[test]
fn a_lod_page_of_a_users_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "/* stand-in */").unwrap();
    // A bumpy sphere of 4,000 points on a golden-angle spiral.
    let mut text = String::new();
    let n = 4000;
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let a = i as f64 * 2.399_963_229_728_653;
        let bump = 1.0 + 0.05 * (5.0 * a).sin();
        text.push_str(&format!(
            "{} {} {}\n",
            bump * r * a.cos(),
            bump * r * a.sin(),
            bump * z
        ));
    }
    let cloud = dir.path().join("ball.xyz");
    std::fs::write(&cloud, text).unwrap();
    let page = dir.path().join("lod.html");
    let png = dir.path().join("full.png");
    let out = pointsight(
        &[
            "view",
            "--lod",
            "--cloud",
            cloud.to_str().unwrap(),
            "--eye",
            "0,0,4",
            "--target",
            "0,0,0",
            "--methods",
            "qsplat,spt",
            "--distance",
            "1.5",
            "--out",
            page.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
        ],
        &script,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = String::from_utf8_lossy(&out.stdout);
    assert!(
        line.contains("points=4000") && line.contains("methods=3"),
        "{line}"
    );
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("/* stand-in */"));
    let data = data_of(&html);
    assert_eq!(data["kind"], "lod");
    assert_eq!(data["distance"], 1.5);
    let names: Vec<&str> = data["methods"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["full detail", "qsplat", "spt"]);
    let full = &data["methods"][0];
    assert_eq!(full["n"], n);
    assert!(full["psnr"].is_null() && full["seconds"].is_null());
    for m in data["methods"].as_array().unwrap() {
        let k = m["n"].as_u64().unwrap() as usize;
        assert!(k > 0 && m["covered_px"].as_u64().unwrap() > 0, "{m}");
        assert_eq!(bits(m["centers"].as_str().unwrap()).len(), 6 * k);
        assert_eq!(bits(m["radii"].as_str().unwrap()).len(), 2 * k);
        assert_eq!(bits(m["colors"].as_str().unwrap()).len(), 3 * k);
    }
    assert!(data["methods"][1]["psnr"].as_f64().unwrap() > 5.0);
    // The eye 1.5 times as far from the target.
    let eye = data["camera"]["eye"].as_array().unwrap();
    assert!((eye[2].as_f64().unwrap() - 6.0).abs() < 1e-9, "{eye:?}");
    assert!(png.exists());
}
