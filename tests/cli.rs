//! The `pointsight` command's output contract, on synthetic datasets (no download needed).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cloud::glam::DVec3;
use cloud::synth::sphere_point_visible;

fn pointsight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = pointsight(args);
    assert!(
        out.status.success(),
        "pointsight {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("stdout is UTF-8")
}

fn fails_with(args: &[&str], message: &str) {
    let out = pointsight(args);
    assert!(!out.status.success(), "pointsight {args:?} should fail");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(message),
        "pointsight {args:?}: {err:?} lacks {message:?}"
    );
}

#[test]
fn datasets_lists_name_and_size_first() {
    let text = ok(&["datasets"]);
    let mut found = Vec::new();
    for line in text.lines() {
        let mut fields = line.split_whitespace();
        let name = fields.next().unwrap();
        let n: usize = fields.next().unwrap().parse().unwrap();
        found.push((name.to_owned(), n));
    }
    for expected in [
        ("bunny", 37_706),
        ("bunny-69451", 69_451),
        ("dragon-871414", 871_414),
        ("sphere-20000", 20_000),
        ("sphere-plane-24000", 24_000),
        ("torus-22321", 22_321),
    ] {
        assert!(
            found.contains(&(expected.0.to_owned(), expected.1)),
            "{expected:?} in {found:?}"
        );
    }
}

#[test]
fn views_csv_has_the_contract_header_and_sixteen_views() {
    let text = ok(&["views", "--dataset", "sphere-20000"]);
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "view,eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,fov_y_deg,width,height"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 16);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 13);
        assert_eq!(row[0], k as f64);
        let eye = DVec3::new(row[1], row[2], row[3]);
        assert!(eye.length() > 1.0, "the eye is outside the unit sphere");
    }
}

#[test]
fn export_writes_exactly_the_experiment_points() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("torus.ply");
    let text = ok(&[
        "export",
        "--dataset",
        "torus-22321",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(text.contains("points=22321"));
    let back = cloud::io::read(&path).unwrap().cloud;
    let ds = harness::datasets::Datasets::default()
        .load("torus-22321", Path::new("/nonexistent"))
        .unwrap();
    assert_eq!(back.positions, ds.cloud.positions);
    let bytes = std::fs::read(&path).unwrap();
    assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
}

#[test]
fn visible_follows_the_contract_and_is_right_on_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("visible.txt");
    let stdout = ok(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--view",
        "3",
        "--method",
        "reference",
        "--out",
        out.to_str().unwrap(),
    ]);
    let last = stdout.lines().last().unwrap();
    let fields: Vec<&str> = last.split(' ').collect();
    assert_eq!(fields.len(), 4, "{last}");
    assert_eq!(fields[0], "method=reference");
    assert_eq!(fields[1], "points=20000");
    let visible: usize = fields[2].strip_prefix("visible=").unwrap().parse().unwrap();
    let seconds: f64 = fields[3].strip_prefix("seconds=").unwrap().parse().unwrap();
    assert!(seconds > 0.0);
    let indices: Vec<usize> = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(indices.len(), visible);
    assert!(
        indices.windows(2).all(|w| w[0] < w[1]),
        "ascending, no repeats"
    );

    let ds = harness::datasets::Datasets::default()
        .load("sphere-20000", Path::new("/nonexistent"))
        .unwrap();
    let eye = ds.views[3].eye;
    let mut flags = vec![false; ds.cloud.len()];
    for &i in &indices {
        flags[i] = true;
    }
    let agree = ds
        .cloud
        .positions
        .iter()
        .zip(&flags)
        .filter(|&(&p, &f)| sphere_point_visible(DVec3::ZERO, p, eye) == f)
        .count();
    assert!(agree as f64 / 20_000.0 > 0.995, "{agree}");

    // `--out -`: the same indices on standard output, the contract lines on standard error,
    // and no file named `-`.
    let piped = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args([
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "3",
            "--method",
            "reference",
            "--out",
            "-",
        ])
        .current_dir(dir.path())
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .unwrap();
    assert!(piped.status.success());
    assert_eq!(
        String::from_utf8(piped.stdout).unwrap(),
        std::fs::read_to_string(&out).unwrap()
    );
    let stderr = String::from_utf8(piped.stderr).unwrap();
    assert!(
        stderr
            .lines()
            .last()
            .unwrap()
            .starts_with("method=reference points=20000 visible="),
        "{stderr}"
    );
    assert!(!dir.path().join("-").exists());
    fails_with(
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "all",
            "--method",
            "reference",
            "--out",
            "-",
        ],
        "many views need a folder",
    );
}

#[test]
fn bad_requests_fail_with_a_clear_message() {
    let out = "/tmp/pointsight-cli-test-never-written.txt";
    fails_with(
        &[
            "visible",
            "--dataset",
            "teapot",
            "--view",
            "0",
            "--method",
            "splat",
            "--out",
            out,
        ],
        "unknown dataset",
    );
    fails_with(
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "0",
            "--method",
            "magic",
            "--out",
            out,
        ],
        "unknown method",
    );
    fails_with(
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "16",
            "--method",
            "splat",
            "--out",
            out,
        ],
        "view 16 does not exist",
    );
    fails_with(
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "0",
            "--method",
            "splat",
            "--set",
            "radius=3",
            "--out",
            out,
        ],
        "unknown parameter radius",
    );
    fails_with(
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "0",
            "--method",
            "splat",
            "--set",
            "radius_px=big",
            "--out",
            out,
        ],
        "radius_px=big",
    );
    fails_with(
        &[
            "visible",
            "--dataset",
            "bunny",
            "--view",
            "0",
            "--method",
            "splat",
            "--out",
            out,
        ],
        "pointsight fetch",
    );
    fails_with(&["run", "nothing"], "unknown experiment");
    assert!(!Path::new(out).exists());
}

#[test]
fn run_writes_csv_plot_metadata_and_the_report_links_only_existing_files() {
    let dir = tempfile::tempdir().unwrap();
    let reports: PathBuf = dir.path().to_owned();
    let out = reports.join("reference");
    ok(&[
        "run",
        "reference",
        "--quick",
        "--datasets",
        "sphere-plane-24000",
        "--out",
        out.to_str().unwrap(),
    ]);
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.starts_with("dataset,n_points,view,variant,seconds,"));
    assert_eq!(csv.lines().count(), 1 + 4 * 2, "4 views x 2 variants");
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("metadata.json")).unwrap()).unwrap();
    for key in [
        "git_revision",
        "rustc",
        "cpu",
        "cores",
        "date_utc",
        "parameters",
    ] {
        assert!(meta.get(key).is_some(), "metadata lacks {key}");
    }
    let png = image::open(out.join("agreement.png")).unwrap();
    assert!(png.width() >= 600);

    ok(&["report", "--reports", reports.to_str().unwrap()]);
    let page = std::fs::read_to_string(reports.join("README.md")).unwrap();
    let links = harness::output::report::link_targets(&page);
    assert!(
        links.iter().any(|l| l == "reference/agreement.png"),
        "{links:?}"
    );
    for link in links {
        assert!(reports.join(&link).exists(), "README links missing {link}");
    }
    // Redrawing from the CSV gives the same summary.
    let before = std::fs::read_to_string(out.join("summary.md")).unwrap();
    ok(&["tables", "--reports", reports.to_str().unwrap()]);
    assert_eq!(
        std::fs::read_to_string(out.join("summary.md")).unwrap(),
        before
    );
}

/// Regression: a 100000 × 100000 ray cast used to abort the process (exit 134) allocating
/// 160 GB; the memory guard refuses it first, with the estimate.
#[test]
fn an_image_too_large_for_memory_is_refused_not_an_abort() {
    let out = pointsight(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--view",
        "0",
        "--method",
        "raycast",
        "--set",
        "width=100000",
        "--set",
        "height=100000",
        "--out",
        "/tmp/pointsight-never-written.txt",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("100000x100000") && err.contains("needs about 260.8 GiB"),
        "{err}"
    );
    assert!(!Path::new("/tmp/pointsight-never-written.txt").exists());
}
