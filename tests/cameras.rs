//! Camera models end to end: every method on spherical and orthographic cameras against the
//! analytic visibility of the synthetic scenes; COLMAP views through `pointsight visible`.

use std::path::Path;
use std::process::Command;

use cloud::glam::DVec3;
use cloud::synth::{SpherePlane, sphere_point_visible};
use cloud::{Camera, Model};
use harness::datasets::{self, Dataset};
use registry::scoring::Score;
use registry::{Output, Params, kernel};

fn load(name: &str) -> Dataset {
    datasets::Datasets::default()
        .load(name, Path::new("/nonexistent"))
        .expect("a synthetic dataset")
}

/// F1 of `method` (with `set`) from `camera` against the flags `truth`.
fn f1(ds: &Dataset, method: &str, set: &[&str], camera: &Camera, truth: &[bool]) -> f64 {
    let out = answer(ds, method, set, camera).expect("a visible set");
    Score::of(&out.visible, truth).f1()
}

/// `method` (with `set`) from `camera`, through the measurement kernel.
fn answer(ds: &Dataset, method: &str, set: &[&str], camera: &Camera) -> Result<Output, String> {
    let views = [kernel::View {
        index: 0,
        camera: *camera,
    }];
    let cell = kernel::Cell {
        method: registry::builtin_card(method).expect("a built-in method"),
        params: Params::parse(set).expect("valid parameters"),
        views: &views,
        repeats: 1,
        budget: None,
        parallel: false,
    };
    let (prepared, answers) = kernel::collect(&cell, ds.input());
    prepared.expect("prepared");
    answers
        .into_iter()
        .next()
        .expect("one view")
        .1
        .map(|a| a.output)
}

#[test]
fn a_spherical_scanner_above_the_ball_and_square() {
    let ds = load("sphere-plane-24000");
    let g = SpherePlane::default();
    // A 360° scanner above the square, beside and above the ball: it sees the square around
    // it, the top of the ball and the ball's shadow on the square.
    let eye = DVec3::new(0.9, -0.6, 2.2);
    let camera = Camera::look_at(eye, DVec3::ZERO, DVec3::Z, Model::Spherical, 2048, 1024).unwrap();
    let truth: Vec<bool> = ds
        .cloud
        .positions
        .iter()
        .map(|&p| g.visible(p, eye))
        .collect();
    let n_true = truth.iter().filter(|&&t| t).count();
    assert!(n_true > 5_000 && n_true < 20_000, "{n_true}");
    let reference = f1(&ds, "reference", &[], &camera, &truth);
    let hpr = f1(&ds, "hpr", &["gamma=2.5"], &camera, &truth);
    let raycast = f1(&ds, "raycast", &[], &camera, &truth);
    let splat = f1(
        &ds,
        "splat",
        &["radius_px=5", "depth_tolerance=0.03"],
        &camera,
        &truth,
    );
    eprintln!(
        "spherical: reference {reference:.4} hpr {hpr:.4} raycast {raycast:.4} splat {splat:.4}"
    );
    assert!(reference >= 0.98, "reference F1 {reference}");
    // Stated figures for the methods (docs/commands.md, "Cameras"): these bounds catch a broken
    // model.
    // Measured: hpr 0.977 (γ = 2.5; 0.921 at γ = 3), raycast 0.980 (1.5 density spacings),
    // splat 0.932 (5 px, tolerance 0.03).
    assert!(hpr >= 0.95, "hpr F1 {hpr}");
    assert!(raycast >= 0.95, "raycast F1 {raycast}");
    assert!(splat >= 0.9, "splat F1 {splat}");
    // The HPR family beyond seed 000 takes the spherical camera too (it needs only the eye):
    // approximate HPR at one sector per pixel is within a little of exact HPR, and the
    // confidence score thresholded over γ 1.5..3.5 is an HPR-like answer.
    let approx = f1(&ds, "hpr-approx", &["gamma=2.5"], &camera, &truth);
    let confidence = f1(
        &ds,
        "hpr-confidence",
        &["from=1.5", "to=3.5", "steps=5", "threshold=0.6"],
        &camera,
        &truth,
    );
    eprintln!("spherical: hpr-approx {approx:.4} hpr-confidence {confidence:.4}");
    assert!(approx >= hpr - 0.02, "hpr-approx F1 {approx}");
    assert!(confidence >= 0.9, "hpr-confidence F1 {confidence}");
}

#[test]
fn an_orthographic_view_of_the_sphere() {
    let ds = load("sphere-20000");
    let dir = DVec3::new(0.3, -0.5, 1.0).normalize();
    let camera = Camera::look_at(
        dir * 5.0,
        DVec3::ZERO,
        DVec3::Y,
        Model::Orthographic {
            view_width: 2.4,
            view_height: 2.4,
        },
        600,
        600,
    )
    .unwrap();
    // Seen from infinity along −dir, a sphere point is visible when its normal faces dir.
    let truth: Vec<bool> = ds
        .cloud
        .positions
        .iter()
        .map(|&p| p.dot(dir) > 0.0)
        .collect();
    let reference = f1(&ds, "reference", &[], &camera, &truth);
    let raycast = f1(&ds, "raycast", &[], &camera, &truth);
    let exact = f1(&ds, "exact", &[], &camera, &truth);
    eprintln!("orthographic: reference {reference:.4} raycast {raycast:.4} exact {exact:.4}");
    assert!(reference >= 0.98 && exact >= 0.98, "{reference} {exact}");
    assert!(raycast >= 0.9, "{raycast}");
    // HPR needs a centre of projection.
    let err = answer(&ds, "hpr", &[], &camera).unwrap_err();
    assert!(err.contains("orthographic"), "{err}");
    for name in ["hpr-approx", "hpr-confidence"] {
        let err = answer(&ds, name, &[], &camera).unwrap_err();
        assert!(err.contains("orthographic") && err.contains(name), "{err}");
    }
}

#[test]
fn colmap_views_through_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let colmap = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/colmap");
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args([
            "visible",
            "--dataset",
            "sphere-20000",
            // A views file without --view: every camera in it.
            "--views",
            colmap.to_str().unwrap(),
            "--method",
            "reference",
            "--out",
            dir.path().to_str().unwrap(),
        ])
        .env("POINTSIGHT_DATA", "/nonexistent")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = stdout.lines().collect();
    let summary = lines.last().unwrap();
    assert!(
        summary.starts_with("views=3 points=20000 seconds=")
            && summary.contains("views_per_second="),
        "{summary}"
    );
    let ds = load("sphere-20000");
    for (k, eye) in [
        DVec3::new(0.0, 0.0, -5.0),
        DVec3::new(5.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 4.0),
    ]
    .into_iter()
    .enumerate()
    {
        let line = lines
            .iter()
            .find(|l| l.starts_with(&format!("view={k} method=reference")))
            .unwrap();
        let text = std::fs::read_to_string(dir.path().join(format!("view-{k}.txt"))).unwrap();
        let found: Vec<usize> = text.lines().map(|l| l.parse().unwrap()).collect();
        assert!(line.contains(&format!("visible={}", found.len())), "{line}");
        let agree = ds
            .cloud
            .positions
            .iter()
            .enumerate()
            .filter(|&(i, &p)| {
                sphere_point_visible(DVec3::ZERO, p, eye) == found.binary_search(&i).is_ok()
            })
            .count();
        assert!(agree as f64 / 20_000.0 > 0.995, "view {k}: {agree}");
    }
}

#[test]
fn views_jsonl_round_trips_through_visible() {
    let dir = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_pointsight");
    let views = dir.path().join("views.jsonl");
    let out = Command::new(bin)
        .args([
            "views",
            "--dataset",
            "sphere-20000",
            "--format",
            "jsonl",
            "--out",
        ])
        .arg(&views)
        .output()
        .unwrap();
    assert!(out.status.success());
    let cams = cloud::io::views::read_views(&views).unwrap();
    assert_eq!(cams, load("sphere-20000").views);
    // The same view from the file and from the dataset give the same indices.
    let run = |args: &[&str]| {
        let out = Command::new(bin).args(args).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let single = dir.path().join("single.txt");
    run(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--view",
        "5",
        "--method",
        "hpr",
        "--out",
        single.to_str().unwrap(),
    ]);
    let many = dir.path().join("many");
    run(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--views",
        views.to_str().unwrap(),
        "--view",
        "5,7",
        "--method",
        "hpr",
        "--out",
        many.to_str().unwrap(),
    ]);
    assert_eq!(
        std::fs::read_to_string(single).unwrap(),
        std::fs::read_to_string(many.join("view-5.txt")).unwrap()
    );
    assert!(many.join("view-7.txt").exists() && !many.join("view-0.txt").exists());
}
