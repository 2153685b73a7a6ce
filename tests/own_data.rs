//! Your own data, as a new user brings it: a scan file and a mesh file that are not built-in
//! datasets, scored with `visible --score`; a manifest with a dataset without a mesh through
//! `run visibility`; a noisy scan against its mesh (off-surface points scored apart); a
//! georeferenced cloud giving the same visible sets as the same cloud near the origin.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use cloud::synth::sphere_plane_scene;
use cloud::{PointCloud, TriMesh};

fn pointsight(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .current_dir(dir)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let out = pointsight(dir, args);
    assert!(
        out.status.success(),
        "pointsight {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8")
}

fn write_off(path: &Path, mesh: &TriMesh, shift: DVec3) {
    let mut s = format!("OFF\n{} {} 0\n", mesh.vertices.len(), mesh.triangles.len());
    for v in &mesh.vertices {
        let v = *v + shift;
        s.push_str(&format!("{:?} {:?} {:?}\n", v.x, v.y, v.z));
    }
    for t in &mesh.triangles {
        s.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
    std::fs::write(path, s).expect("the OFF file is written");
}

fn write_ply(path: &Path, points: &[DVec3]) {
    let cloud = PointCloud {
        positions: points.to_vec(),
        ..PointCloud::default()
    };
    cloud::io::ply_write::write_ply(path, &cloud).expect("the PLY file is written");
}

fn field(line: &str, key: &str) -> f64 {
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
        .unwrap_or_else(|| panic!("{key} in {line}"))
        .parse()
        .expect("a number")
}

/// Distance from `p` to the sphere-plane scene's surface, analytically.
fn scene_distance(p: DVec3) -> f64 {
    let g = cloud::synth::SpherePlane::default();
    let sphere = ((p - g.center).length() - g.radius).abs();
    let dx = (p.x.abs() - g.half_side).max(0.0);
    let dy = (p.y.abs() - g.half_side).max(0.0);
    let square = (dx * dx + dy * dy + p.z * p.z).sqrt();
    sphere.min(square)
}

/// A scan of the sphere-plane scene with ±0.002 noise along the normals and 3 % outliers 0.2
/// to 0.4 off the surface, with its mesh; also the points.
fn noisy_scan(dir: &Path) -> (PathBuf, PathBuf, Vec<DVec3>) {
    let (scene, _) = sphere_plane_scene(1_500, 3_000, 11);
    let mut rng = seeded(5, "own-data-noise");
    let mut points = scene.cloud.positions.clone();
    let normals = scene.cloud.normals.clone().expect("the scene has normals");
    for (p, n) in points.iter_mut().zip(&normals) {
        let r: f64 = rng.random();
        if r < 0.03 {
            *p += n.as_dvec3() * (0.2 + 0.2 * rng.random::<f64>());
        } else {
            *p += n.as_dvec3() * ((rng.random::<f64>() - 0.5) * 0.004);
        }
    }
    let scan = dir.join("scan.ply");
    write_ply(&scan, &points);
    let mesh = dir.join("scene.off");
    write_off(&mesh, &scene.mesh, DVec3::ZERO);
    (scan, mesh, points)
}

#[test]
fn a_scan_and_its_mesh_from_files_scored_with_off_surface_points_apart() {
    let dir = tempfile::tempdir().unwrap();
    let (scan, mesh, points) = noisy_scan(dir.path());
    let out = dir.path().join("visible.txt");
    let stdout = ok(
        dir.path(),
        &[
            "visible",
            "--cloud",
            scan.to_str().unwrap(),
            "--mesh",
            mesh.to_str().unwrap(),
            "--score",
            "--eye",
            "0.5,-3,4",
            "--method",
            "hpr",
            // Katz's γ (its default is hpr::auto's rule): the figures below are for it.
            "--set",
            "gamma=3",
            // 3 % outliers 0.2 to 0.4 off the surface, beyond the mesh check's 1 % past 3
            // spacings: the user says so.
            "--allow-off-surface",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let lines: Vec<&str> = stdout.lines().collect();
    let last = lines.last().unwrap();
    assert!(
        last.starts_with("method=hpr points=4500 visible="),
        "{last}"
    );
    let score = lines.iter().find(|l| l.contains("precision=")).unwrap();
    // Off-surface: the points farther from the surface than the tolerance (one density
    // spacing), counted analytically here (the mesh's icosphere sags by < 1e-4).
    let off = field(score, "off_surface") as usize;
    let tolerance = field(score, "surface_tolerance");
    let expected = points
        .iter()
        .filter(|&&p| scene_distance(p) > tolerance)
        .count();
    assert!(expected > 100, "{expected}");
    assert!(off.abs_diff(expected) <= 2, "{off} vs {expected}: {score}");
    assert!(field(score, "f1") > 0.85, "{score}");
    let indices: Vec<usize> = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(indices.len() as f64, field(last, "visible"));
    assert!(indices.windows(2).all(|w| w[0] < w[1]));
    // A cloud without a camera is a clear error; so is scoring without a mesh.
    let bad = pointsight(
        dir.path(),
        &[
            "visible",
            "--cloud",
            scan.to_str().unwrap(),
            "--method",
            "hpr",
            "--out",
            "x.txt",
        ],
    );
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--eye"));
    let bad = pointsight(
        dir.path(),
        &[
            "visible",
            "--cloud",
            scan.to_str().unwrap(),
            "--eye",
            "0,0,5",
            "--score",
            "--method",
            "hpr",
            "--out",
            "x.txt",
        ],
    );
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("needs a mesh"));
    assert!(!dir.path().join("x.txt").exists());
}

#[test]
fn a_manifest_runs_the_visibility_experiment_with_and_without_a_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (scan, mesh, _) = noisy_scan(dir.path());
    std::fs::write(
        dir.path().join("pointsight.toml"),
        format!(
            "[datasets.my-scan]\ncloud = {:?}\nmesh = {:?}\nview_spec = {{ count = 2 }}\n\
             allow_off_surface = true\n\n\
             [datasets.bare-scan]\ncloud = {:?}\ndescription = \"the scan alone\"\n",
            scan.file_name().unwrap(),
            mesh.file_name().unwrap(),
            scan.file_name().unwrap()
        ),
    )
    .unwrap();
    let listing = ok(dir.path(), &["datasets"]);
    assert!(
        listing.contains("my-scan") && listing.contains("the scan alone"),
        "{listing}"
    );
    let out = dir.path().join("vis");
    ok(
        dir.path(),
        &[
            "run",
            "visibility",
            "--quick",
            "--datasets",
            "my-scan,bare-scan",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let results = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let header: Vec<&str> = results.lines().next().unwrap().split(',').collect();
    let f1 = header.iter().position(|h| *h == "f1").unwrap();
    let mut scored = 0;
    let mut unscored = 0;
    for line in results.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        match cols[0] {
            "my-scan" => {
                assert!(cols[f1].parse::<f64>().unwrap() > 0.0, "{line}");
                scored += 1;
            }
            "bare-scan" => {
                assert_eq!(cols[f1], "NaN", "{line}");
                unscored += 1;
            }
            other => panic!("{other}"),
        }
    }
    assert!(scored > 10 && unscored > 10);
    let agreement = std::fs::read_to_string(out.join("agreement.csv")).unwrap();
    assert!(agreement.lines().count() > 2, "{agreement}");
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        summary.contains("bare-scan: no mesh, no ground truth"),
        "{summary}"
    );
    let meta = std::fs::read_to_string(out.join("metadata.json")).unwrap();
    assert!(
        meta.contains("scan.ply") && meta.contains("sha256"),
        "{meta}"
    );
}

/// Runs `pointsight` in `dir`: exit code, standard output, standard error.
fn run_in(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = pointsight(dir, args);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_mesh_that_does_not_fit_the_points_is_refused_or_marked() {
    // The clean scene's points against its mesh scaled ten times, shifted, and another
    // surface (a ball alone): each refused by `visible --score` and `run` with the share far
    // from the mesh, the median distance and the likely cause; `--allow-off-surface` goes on
    // with the rows marked. The right mesh passes, marked ok.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (scene, _) = sphere_plane_scene(1_500, 3_000, 11);
    write_ply(&d.join("scan.ply"), &scene.cloud.positions);
    write_off(&d.join("scene.off"), &scene.mesh, DVec3::ZERO);
    // Ten times as large about the ball's centre (about the origin, the square would stay
    // under its points).
    let c = DVec3::new(0.0, 0.0, 1.0);
    let tenfold = TriMesh {
        vertices: scene
            .mesh
            .vertices
            .iter()
            .map(|v| c + (*v - c) * 10.0)
            .collect(),
        ..scene.mesh.clone()
    };
    write_off(&d.join("tenfold.off"), &tenfold, DVec3::ZERO);
    // Shifted up by 1 (sideways, most of the square would stay under its points).
    write_off(
        &d.join("shifted.off"),
        &scene.mesh,
        DVec3::new(0.0, 0.0, 1.0),
    );
    // Another surface in the same box: the scene upside down (the square on top).
    let (lo, hi) = {
        let b = scene.mesh.bbox().unwrap();
        (b.min.z, b.max.z)
    };
    let flipped = TriMesh {
        vertices: scene
            .mesh
            .vertices
            .iter()
            .map(|v| DVec3::new(v.x, v.y, lo + hi - v.z))
            .collect(),
        ..scene.mesh.clone()
    };
    write_off(&d.join("flipped.off"), &flipped, DVec3::ZERO);
    let visible = |mesh: &str, extra: &[&str]| {
        let mut args = vec![
            "visible", "--cloud", "scan.ply", "--mesh", mesh, "--score", "--eye", "0.5,-3,4",
            "--method", "hpr", "--set", "gamma=3", "--out", "v.txt",
        ];
        args.extend_from_slice(extra);
        run_in(d, &args)
    };
    for (mesh, share, cause) in [
        (
            "tenfold.off",
            "100.0 %",
            "(a factor of 10: units, millimetres against centimetres?)",
        ),
        (
            "shifted.off",
            "",
            "offset: the points' bounding box is shifted by (",
        ),
        ("flipped.off", "", "another mesh: the bounding boxes agree"),
    ] {
        let (code, stdout, stderr) = visible(mesh, &[]);
        assert_eq!(code, 1, "{mesh}: {stdout}");
        assert!(
            stderr.contains(&format!(
                "dataset scan: the mesh {mesh} does not fit the points"
            )) && stderr.contains(share)
                && stderr.contains("of the points lie farther than")
                && stderr.contains("median distance")
                && stderr.contains(cause)
                && stderr.contains("--allow-off-surface"),
            "{mesh}: {stderr}"
        );
        assert!(!d.join("v.txt").exists(), "{mesh}: nothing written");
    }
    // Told to go on: the score is marked, and the warning says why, once.
    let (code, stdout, stderr) = visible("tenfold.off", &["--allow-off-surface"]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("mesh_fit=off-surface"), "{stdout}");
    assert_eq!(
        stderr.matches("the mesh does not fit the points").count(),
        1,
        "{stderr}"
    );
    // The right mesh: no warning, marked ok.
    let (code, stdout, stderr) = visible("scene.off", &[]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("mesh_fit=ok"), "{stdout}");
    assert!(!stderr.contains("does not fit"), "{stderr}");
    // `run` on the same pair: refused before measuring, then marked rows when allowed.
    let run = |extra: &[&str]| {
        let mut args = vec![
            "run",
            "visibility",
            "--quick",
            "--cloud",
            "scan.ply",
            "--mesh",
            "tenfold.off",
            "--eye",
            "0.5,-3,4",
            "--out",
            "vis",
        ];
        args.extend_from_slice(extra);
        run_in(d, &args)
    };
    let (code, _, stderr) = run(&[]);
    assert_eq!(code, 1);
    assert!(stderr.contains("does not fit the points"), "{stderr}");
    assert!(!d.join("vis").exists());
    let (code, _, stderr) = run(&["--allow-off-surface"]);
    assert_eq!(code, 0, "{stderr}");
    let results = std::fs::read_to_string(d.join("vis/results.csv")).unwrap();
    let header: Vec<&str> = results.lines().next().unwrap().split(',').collect();
    let fit = header.iter().position(|h| *h == "mesh_fit").unwrap();
    assert!(
        results
            .lines()
            .skip(1)
            .all(|l| l.split(',').nth(fit) == Some("off-surface"))
    );
    let summary = std::fs::read_to_string(d.join("vis/summary.md")).unwrap();
    assert!(
        summary.contains("scan: scored against a mesh that does not fit its points"),
        "{summary}"
    );
    let meta = std::fs::read_to_string(d.join("vis/metadata.json")).unwrap();
    assert!(
        meta.contains("far_share") && meta.contains("likely_cause"),
        "{meta}"
    );
    // A dataset with a mesh has no agreement rows: the table is its header (it was 0 bytes).
    assert_eq!(
        std::fs::read_to_string(d.join("vis/agreement.csv")).unwrap(),
        "dataset,view,a,b,jaccard\n"
    );
    assert!(
        std::fs::read_to_string(d.join("vis/peers.csv"))
            .unwrap()
            .starts_with("dataset,view,peer,")
    );
}

#[test]
fn a_degraded_manifest_dataset_is_checked_at_its_clean_points() {
    // Noise and 5 % outliers on purpose: the check measures the clean source positions and
    // leaves the outliers out, so the dataset passes; the same mesh scaled does not.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ball = cloud::synth::sphere_scene(200).mesh;
    write_off(&d.join("ball.off"), &ball, DVec3::ZERO);
    let big = TriMesh {
        vertices: ball.vertices.iter().map(|v| *v * 3.0).collect(),
        ..ball.clone()
    };
    write_off(&d.join("big.off"), &big, DVec3::ZERO);
    std::fs::write(
        d.join("pointsight.toml"),
        "[datasets.noisy]\ncloud = \"ball.ply\"\nmesh = \"ball.off\"\n\
         degrade = [\"noise:sigma=2\", \"outliers:fraction=0.05\"]\n\
         [datasets.wrong]\ncloud = \"ball.ply\"\nmesh = \"big.off\"\n",
    )
    .unwrap();
    let samples = cloud::sample::sample_surface(&ball, 3_000, 4).unwrap();
    write_ply(&d.join("ball.ply"), &samples.positions);
    let score = |dataset: &str| {
        run_in(
            d,
            &[
                "visible",
                "--dataset",
                dataset,
                "--score",
                "--method",
                "hpr",
                "--out",
                "v.txt",
            ],
        )
    };
    let (code, stdout, stderr) = score("noisy");
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("mesh_fit=ok"), "{stdout}");
    let (code, _, stderr) = score("wrong");
    assert_eq!(code, 1);
    assert!(
        stderr.contains("dataset wrong:")
            && stderr.contains("big.off does not fit")
            && stderr.contains("scale: the mesh is 3.0"),
        "{stderr}"
    );
}

#[test]
fn a_georeferenced_cloud_gives_the_same_visible_sets_as_near_the_origin() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) = sphere_plane_scene(1_000, 2_000, 3);
    // Coordinates on a 2^-20 grid, so that both copies are exact; the offset a survey's.
    let snap = |p: DVec3| (p * 1_048_576.0).round() / 1_048_576.0;
    let near: Vec<DVec3> = scene.cloud.positions.iter().map(|&p| snap(p)).collect();
    let offset = DVec3::new(512_000.0, 4_194_304.0, 128.0);
    let far: Vec<DVec3> = near.iter().map(|&p| p + offset).collect();
    for (a, b) in near.iter().zip(&far) {
        assert_eq!(*b - offset, *a);
    }
    write_ply(&dir.path().join("near.ply"), &near);
    write_ply(&dir.path().join("far.ply"), &far);
    write_off(&dir.path().join("near.off"), &scene.mesh, DVec3::ZERO);
    write_off(&dir.path().join("far.off"), &scene.mesh, offset);
    let eye = DVec3::new(0.75, -2.5, 3.25);
    for method in ["hpr", "raycast", "splat", "reference"] {
        let mut answers = Vec::new();
        for (name, shift) in [("near", DVec3::ZERO), ("far", offset)] {
            let e = eye + shift;
            let out = dir.path().join(format!("{name}-{method}.txt"));
            ok(
                dir.path(),
                &[
                    "visible",
                    "--cloud",
                    &format!("{name}.ply"),
                    "--mesh",
                    &format!("{name}.off"),
                    "--eye",
                    &format!("{},{},{}", e.x, e.y, e.z),
                    "--target",
                    &format!("{},{},{}", shift.x, shift.y, shift.z + 0.5),
                    "--method",
                    method,
                    "--out",
                    out.to_str().unwrap(),
                ],
            );
            answers.push(std::fs::read_to_string(out).unwrap());
        }
        assert!(answers[0].lines().count() > 500, "{method}");
        assert_eq!(
            answers[0], answers[1],
            "{method}: georeferenced and local differ"
        );
    }
}

/// Exact at every magnitude. The same scene multiplied by 2^±665 (about 1e±200, far
/// outside where squared distances, the flip and the exact predicates hold) is rescaled by a
/// power of two on loading, so every method gives the same visible set as at unit scale.
#[test]
fn a_cloud_near_the_ends_of_the_f64_range_gives_the_same_visible_sets() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) = sphere_plane_scene(1_000, 2_000, 3);
    let eye = DVec3::new(0.75, -2.5, 3.25);
    let target = DVec3::new(0.0, 0.0, 0.5);
    for method in ["hpr", "raycast", "splat", "reference", "exact"] {
        let mut answers = Vec::new();
        for k in [0, 665, -665] {
            let f = 2f64.powi(k);
            let name = format!("scale{k}");
            let pts: Vec<DVec3> = scene.cloud.positions.iter().map(|&p| p * f).collect();
            write_ply(&dir.path().join(format!("{name}.ply")), &pts);
            let mesh = TriMesh {
                vertices: scene.mesh.vertices.iter().map(|&v| v * f).collect(),
                ..scene.mesh.clone()
            };
            write_off(&dir.path().join(format!("{name}.off")), &mesh, DVec3::ZERO);
            let (e, t) = (eye * f, target * f);
            let out = dir.path().join(format!("{name}-{method}.txt"));
            ok(
                dir.path(),
                &[
                    "visible",
                    "--cloud",
                    &format!("{name}.ply"),
                    "--mesh",
                    &format!("{name}.off"),
                    "--eye",
                    &format!("{:?},{:?},{:?}", e.x, e.y, e.z),
                    "--target",
                    &format!("{:?},{:?},{:?}", t.x, t.y, t.z),
                    "--method",
                    method,
                    "--out",
                    out.to_str().unwrap(),
                ],
            );
            answers.push(std::fs::read_to_string(out).unwrap());
        }
        assert!(answers[0].lines().count() > 500, "{method}");
        assert_eq!(answers[0], answers[1], "{method}: 2^665 differs");
        assert_eq!(answers[0], answers[2], "{method}: 2^-665 differs");
    }
}

#[test]
fn the_readme_examples_run_on_the_example_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("visible.txt");
    let stdout = ok(
        &root,
        &[
            "visible",
            "--cloud",
            "examples/own-data/scan.ply",
            "--mesh",
            "examples/own-data/scene.off",
            "--score",
            "--eye",
            "3,-4,2.5",
            "--method",
            "hpr",
            "--set",
            "gamma=3",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    // The figures the README quotes.
    assert!(
        stdout.contains("reference_visible=2974 off_surface=56 off_surface_visible=40"),
        "{stdout}"
    );
    assert!(
        stdout.contains("method=hpr points=6000 visible=4348"),
        "{stdout}"
    );
    let listing = ok(
        &root,
        &[
            "--manifest",
            "examples/own-data/pointsight.toml",
            "datasets",
        ],
    );
    assert!(listing.contains("room-scan") && listing.contains("room-scan-bare"));
    let scanner = dir.path().join("scanner");
    let stdout = ok(
        &root,
        &[
            "visible",
            "--cloud",
            "examples/own-data/scan.ply",
            "--mesh",
            "examples/own-data/scene.off",
            "--score",
            "--views",
            "examples/own-data/scanner.jsonl",
            "--view",
            "all",
            "--method",
            "raycast",
            "--out",
            scanner.to_str().unwrap(),
        ],
    );
    assert!(
        stdout
            .lines()
            .last()
            .unwrap()
            .starts_with("views=1 points=6000"),
        "{stdout}"
    );
    assert!(
        field(stdout.lines().nth(1).unwrap(), "f1") > 0.8,
        "{stdout}"
    );
}

#[test]
fn an_e57_file_with_two_scans_is_one_dataset_per_scan_or_merged() {
    let dir = tempfile::tempdir().unwrap();
    let e57 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/formats/tiny.e57");
    std::fs::copy(&e57, dir.path().join("site.e57")).unwrap();
    std::fs::write(
        dir.path().join("pointsight.toml"),
        "[datasets.site]\ncloud = \"site.e57\"\n\n[datasets.site-all]\ncloud = \"site.e57\"\nmerge_scans = true\n",
    )
    .unwrap();
    let listing = ok(dir.path(), &["datasets"]);
    for name in ["site-scan-0", "site-scan-1", "site-all"] {
        assert!(
            listing.lines().any(|l| l.starts_with(name)),
            "{name}: {listing}"
        );
    }
    // Each scan's dataset is viewed from its own scanner (a spherical camera).
    let views = ok(
        dir.path(),
        &["views", "--dataset", "site-scan-1", "--format", "jsonl"],
    );
    assert!(
        views.contains("\"model\":\"spherical\"") && views.lines().count() == 1,
        "{views}"
    );
    let out = dir.path().join("v.txt");
    // Katz's γ: its default, hpr::auto's rule, needs more than five points' neighbours.
    let base = [
        "visible", "--cloud", "site.e57", "--eye", "0,0,5", "--method", "hpr", "--set", "gamma=3",
        "--out",
    ];
    let mut args = base.to_vec();
    args.push(out.to_str().unwrap());
    let refused = pointsight(dir.path(), &args);
    assert!(String::from_utf8_lossy(&refused.stderr).contains("holds 2 scans"));
    let mut one = args.clone();
    one.extend(["--scan", "1"]);
    assert!(ok(dir.path(), &one).contains("points=5 "));
    let mut all = args.clone();
    all.push("--merge-scans");
    assert!(ok(dir.path(), &all).contains("points=10 "));
}

/// A manifest of samples of meshes the registry does not know, far from the origin: `n` points
/// plainly sampled (`plain`), the same with noise (`noisy`, loaded whole), and `n` samples of a
/// flat square whose heights are all `-0.0` (`flat`: the whole dataset's are `0.0`).
fn sampled_manifest(dir: &Path, n: usize) {
    let (scene, _) = sphere_plane_scene(400, 800, 7);
    write_off(
        &dir.join("site.off"),
        &scene.mesh,
        DVec3::new(512_000.25, 4_194_304.5, 128.0),
    );
    std::fs::write(
        dir.join("flat.off"),
        "OFF\n4 2 0\n512000 4194304 -0.0\n512001 4194304 -0.0\n512001 4194305 -0.0\n\
         512000 4194305 -0.0\n3 0 1 2\n3 0 2 3\n",
    )
    .expect("the flat mesh is written");
    std::fs::write(
        dir.join("pointsight.toml"),
        format!(
            "[datasets.plain]\nmesh = \"site.off\"\nsample = {{ n = {n}, seed = 9 }}\n\n\
             [datasets.noisy]\nmesh = \"site.off\"\nsample = {{ n = {n}, seed = 9 }}\n\
             degrade = [\"noise:sigma=0.5\"]\n\n\
             [datasets.flat]\nmesh = \"flat.off\"\nsample = {{ n = {n}, seed = 4 }}\n"
        ),
    )
    .expect("the manifest is written");
}

#[test]
fn a_sampled_dataset_is_exported_as_it_is_drawn_into_the_whole_exports_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    sampled_manifest(d, 150_000);
    // The whole dataset, exactly (PLY keeps every bit), then what `export` writes of it as LAS
    // or LAZ when it holds it, against the streamed files (three batches of draws).
    for name in ["plain", "flat"] {
        let ply = ok(
            d,
            &["export", "--dataset", name, "--out", &format!("{name}.ply")],
        );
        assert!(ply.contains("points=150000"), "{ply}");
        let whole = cloud::io::read(&d.join(format!("{name}.ply")))
            .unwrap()
            .cloud;
        assert!(
            whole.positions.iter().all(|p| p.x > 500_000.0),
            "world coordinates"
        );
        if name == "flat" {
            assert!(whole.positions.iter().all(|p| p.z.to_bits() == 0), "+0.0");
        }
        for ext in ["laz", "las"] {
            let file = format!("{name}.{ext}");
            let line = ok(d, &["export", "--dataset", name, "--out", &file]);
            assert!(
                line.contains("points=150000 ") && line.contains("scale="),
                "{line}"
            );
            let reference = d.join(format!("reference.{ext}"));
            let scale = cloud::io::las::write_las(&reference, &whole).unwrap();
            assert!(line.contains(&format!("scale={scale:e}")), "{line}");
            assert_eq!(
                std::fs::read(d.join(&file)).unwrap(),
                std::fs::read(&reference).unwrap(),
                "{file}: the streamed file is the whole one's"
            );
        }
    }
    // A degraded sample is loaded whole, as before: its points are not the draws.
    let noisy = ok(d, &["export", "--dataset", "noisy", "--out", "noisy.laz"]);
    assert!(noisy.contains("points=150000"), "{noisy}");
    let moved = cloud::io::read(&d.join("noisy.laz")).unwrap().cloud;
    let plain = cloud::io::read(&d.join("plain.laz")).unwrap().cloud;
    assert_eq!(moved.len(), plain.len());
    assert_ne!(moved.positions, plain.positions);
}

/// `export --normals`: a sampled dataset's normals (its triangles') as extra bytes in LAS and
/// LAZ, streamed, and as `nx ny nz` in PLY from the whole dataset; `inspect` names them.
#[test]
fn a_sampled_datasets_normals_are_exported_as_extra_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    sampled_manifest(d, 20_000);
    ok(
        d,
        &[
            "export",
            "--dataset",
            "plain",
            "--out",
            "n.ply",
            "--normals",
        ],
    );
    let whole = cloud::io::read(&d.join("n.ply")).unwrap().cloud;
    let want = whole.normals.expect("normals in the PLY");
    for file in ["n.laz", "n.las"] {
        ok(
            d,
            &["export", "--dataset", "plain", "--out", file, "--normals"],
        );
        let back = cloud::io::read(&d.join(file)).unwrap();
        let got = back.cloud.normals.expect("normals in the LAS");
        assert_eq!(got.len(), want.len());
        // The streamed export's from the mesh file's coordinates, the PLY's from the
        // dataset's recentred ones: the same triangles' normals within rounding.
        let worst = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{file}: {worst}");
        let inspect = ok(d, &["inspect", file]);
        assert!(
            inspect.contains("normals=NormalX,NormalY,NormalZ (LAS extra bytes, f32)"),
            "{inspect}"
        );
    }
    // Without the flag, none.
    ok(d, &["export", "--dataset", "plain", "--out", "p.laz"]);
    assert!(
        cloud::io::read(&d.join("p.laz"))
            .unwrap()
            .cloud
            .normals
            .is_none()
    );
}

#[cfg(unix)]
#[test]
fn a_sample_larger_than_memory_is_exported_as_las_within_it() {
    // 6 * 10^6 points need 389 MiB loaded whole: under a 400 MB (390.6 MiB) address-space
    // limit, less what the process maps before it samples (about 80 MiB), the PLY export is
    // refused before allocating, and the LAZ one streams them in about 17 MiB.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let n = 6_000_000;
    sampled_manifest(d, n);
    let run = |out: &str| {
        Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -v 400000 && exec '{}' export --dataset plain --out {out}",
                env!("CARGO_BIN_EXE_pointsight")
            ))
            .current_dir(d)
            .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
            .output()
            .unwrap()
    };
    let refused = run("whole.ply");
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{err}");
    assert!(err.contains("refused before allocating"), "{err}");
    assert!(!d.join("whole.ply").exists());
    let streamed = run("big.laz");
    let out = String::from_utf8_lossy(&streamed.stdout);
    assert!(
        streamed.status.success(),
        "{}",
        String::from_utf8_lossy(&streamed.stderr)
    );
    assert!(out.contains(&format!("points={n} ")), "{out}");
    let header = las::Reader::from_path(d.join("big.laz"))
        .unwrap()
        .header()
        .clone();
    assert_eq!(header.number_of_points(), n as u64);
}
