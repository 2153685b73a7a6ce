//! pointsight from anywhere: installed into a temporary prefix by
//! `scripts/install.sh` (this build's binary, a stand-in viewer script) and run from a temporary
//! folder with a temporary `HOME` and XDG folder, so nothing of the user's is read or written;
//! the folders' rule (`harness::paths`) inside a clone, found from a subfolder; `run
//! visibility` and `run lod` on your files in one command, the same rows as the manifest
//! route; `run lod` on four views; and `bench`'s progress under a pseudo-terminal (util-linux
//! `script`), none when standard error is not a terminal or with `--quiet`, and a quick bench
//! that leaves `reports/` as it was.
//!
//! With `POINTSIGHT_REAL_DATA=1` the installed binary also reads the fetched meshes from the
//! per-user data folder (copied there from this clone's `bench-data/meshes/`, which `fetch`
//! then finds present and checksummed).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The stand-in viewer script the sandbox installs.
const STAND_IN: &str = "window.pointsightStandIn = 42;";

fn clone_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the clone's root")
}

#[track_caller]
fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A temporary prefix with pointsight installed, a temporary HOME and XDG data folder, and a
/// working folder outside any clone.
struct Sandbox {
    _tmp: tempfile::TempDir,
    root: PathBuf,
    prefix: PathBuf,
    home: PathBuf,
    xdg: PathBuf,
    work: PathBuf,
}

impl Sandbox {
    fn new() -> Self {
        let tmp = tempfile::tempdir().expect("a temporary folder");
        let root = tmp.path().canonicalize().expect("canonical");
        let (prefix, home, xdg, work, dist) = (
            root.join("prefix"),
            root.join("home"),
            root.join("xdg"),
            root.join("work"),
            root.join("dist"),
        );
        for d in [&home, &xdg, &work, &dist] {
            std::fs::create_dir_all(d).expect("a folder");
        }
        std::fs::write(dist.join("viewer.js"), STAND_IN).expect("the stand-in");
        let out = Command::new("bash")
            .arg(clone_root().join("scripts/install.sh"))
            .arg("--prefix")
            .arg(&prefix)
            .arg("--bin")
            .arg(env!("CARGO_BIN_EXE_pointsight"))
            .arg("--web-dist")
            .arg(&dist)
            .env("HOME", &home)
            .current_dir(&work)
            .output()
            .expect("bash runs the install script");
        let said = ok(&out);
        assert!(said.contains("installed pointsight"), "{said}");
        Self {
            _tmp: tmp,
            root,
            prefix,
            home,
            xdg,
            work,
        }
    }

    /// `pointsight ARGS` from the PATH, in `dir`, with only the sandbox's folders.
    fn run_in(&self, dir: &Path, args: &[&str]) -> Output {
        let path = format!(
            "{}:{}",
            self.prefix.join("bin").display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let mut cmd = Command::new("pointsight");
        cmd.args(args)
            .current_dir(dir)
            .env("PATH", path)
            .env("HOME", &self.home)
            .env("XDG_DATA_HOME", &self.xdg);
        for var in [
            "POINTSIGHT_DATA",
            "POINTSIGHT_METHODS",
            "POINTSIGHT_MANIFEST",
            "POINTSIGHT_VIEWER_JS",
            "POINTSIGHT_RESULTS_JS",
        ] {
            cmd.env_remove(var);
        }
        cmd.output().expect("pointsight runs from the PATH")
    }

    fn run(&self, args: &[&str]) -> Output {
        self.run_in(&self.work, args)
    }
}

/// `KEY=VALUE` of `pointsight paths`.
fn path_of(paths: &str, key: &str) -> String {
    paths
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("no {key} in {paths}"))
        .to_owned()
}

#[test]
fn the_installed_binary_works_from_any_folder() {
    let s = Sandbox::new();
    let share = s.prefix.join("share/pointsight");
    assert!(share.join("methods/example-zbuffer/method.toml").is_file());
    assert_eq!(
        std::fs::read_to_string(share.join("web/viewer.js")).unwrap(),
        STAND_IN
    );

    let version = ok(&s.run(&["--version"]));
    let rev = version
        .trim()
        .strip_prefix("pointsight 0.0.0 (git ")
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or_else(|| panic!("{version}"));
    assert!(
        rev == "unknown" || (rev.len() == 10 && rev.chars().all(|c| c.is_ascii_hexdigit())),
        "{version}"
    );

    // The rule: the per-user data folder (XDG, else ~/.local/share), the methods and the
    // viewer's script beside the binary.
    let paths = ok(&s.run(&["paths"]));
    let data = s.xdg.join("pointsight");
    assert_eq!(
        path_of(&paths, "data"),
        format!("{} (the per-user data folder)", data.display())
    );
    assert_eq!(
        path_of(&paths, "methods"),
        format!(
            "{} (installed beside the binary)",
            share.join("methods").display()
        )
    );
    assert_eq!(
        path_of(&paths, "viewer.js"),
        share.join("web/viewer.js").display().to_string()
    );
    assert_eq!(path_of(&paths, "reports_quick"), "reports-quick");
    assert_eq!(path_of(&paths, "clone"), "-");
    let mut no_xdg = Command::new(s.prefix.join("bin/pointsight"));
    no_xdg
        .arg("paths")
        .current_dir(&s.work)
        .env("HOME", &s.home)
        .env_remove("XDG_DATA_HOME")
        .env_remove("POINTSIGHT_DATA");
    let without = ok(&no_xdg.output().unwrap());
    assert!(
        path_of(&without, "data").starts_with(&format!(
            "{} ",
            s.home.join(".local/share/pointsight").display()
        )),
        "{without}"
    );

    // The installed methods are found; a methods folder that cannot be read is named.
    let methods = s.run(&["methods"]);
    assert!(ok(&methods).contains("example-zbuffer"));
    assert_eq!(stderr(&methods), "");
    // `--methods-dir` adds to them; `--no-installed-methods` leaves them out.
    let none = s.root.join("no-methods");
    let added = s.run(&["--methods-dir", none.to_str().unwrap(), "methods"]);
    assert!(ok(&added).contains("example-zbuffer"));
    let methods = s.run(&[
        "--no-installed-methods",
        "--methods-dir",
        none.to_str().unwrap(),
        "methods",
    ]);
    assert!(!ok(&methods).contains("example-zbuffer"));
    let warning = stderr(&methods);
    assert!(
        warning.contains(&format!("the methods folder {}", none.display()))
            && warning.contains("cannot be read"),
        "{warning}"
    );

    // The data commands, from the working folder.
    let datasets = ok(&s.run(&["datasets"]));
    assert!(
        datasets
            .lines()
            .any(|l| l.starts_with("sphere-20000") && l.contains("generated")),
        "{datasets}"
    );
    let views = ok(&s.run(&["views", "--dataset", "sphere-20000"]));
    assert_eq!(views.lines().count(), 17);
    ok(&s.run(&["export", "--dataset", "sphere-20000", "--out", "sphere.ply"]));
    assert!(s.work.join("sphere.ply").is_file());
    let built = ok(&s.run(&[
        "lod-build",
        "--cloud",
        "sphere.ply",
        "--method",
        "qsplat",
        "--out",
        "sphere.qsplat",
    ]));
    assert!(built.starts_with("points=20000 "), "{built}");
    let inspect = ok(&s.run(&["inspect", "sphere.ply"]));
    assert!(inspect.contains("points=20000"), "{inspect}");
    let visible = ok(&s.run(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--method",
        "hpr",
        "--out",
        "v.txt",
    ]));
    assert!(visible.contains("method=hpr points=20000"), "{visible}");
    assert!(s.work.join("v.txt").is_file());

    // The page embeds the installed script; without it, the error says how to get it.
    let page = ok(&s.run(&[
        "view",
        "--dataset",
        "sphere-20000",
        "--methods",
        "hpr",
        "--out",
        "page.html",
    ]));
    assert!(page.starts_with("page=page.html"), "{page}");
    let html = std::fs::read_to_string(s.work.join("page.html")).unwrap();
    assert!(html.contains(STAND_IN));

    // An experiment, then its tables and report, into the working folder.
    let run = ok(&s.run(&["run", "reference", "--quick", "--datasets", "sphere-20000"]));
    assert!(
        run.contains("reference: results in reports-quick/reference"),
        "{run}"
    );
    assert!(s.work.join("reports-quick/README.md").is_file());
    assert!(!s.work.join("reports").exists());
    ok(&s.run(&["tables", "--reports", "reports-quick"]));
    let report = ok(&s.run(&["report", "--reports", "reports-quick"]));
    assert!(report.contains("reports-quick/README.md"), "{report}");

    std::fs::remove_dir_all(share.join("web")).unwrap();
    let missing = s.run(&["view", "--dataset", "sphere-20000", "--out", "page2.html"]);
    assert!(!missing.status.success());
    let why = stderr(&missing);
    for needle in [
        "viewer.js",
        "just web",
        "just install",
        share.join("web/viewer.js").to_str().unwrap(),
    ] {
        assert!(why.contains(needle), "{needle}: {why}");
    }
    assert!(!s.work.join("page2.html").exists());

    if std::env::var_os("POINTSIGHT_REAL_DATA").is_some() {
        // The fetched meshes in the per-user data folder: `fetch` finds them checksummed (no
        // download), `datasets` says ready, `visible` reads them.
        let meshes = data.join("meshes");
        std::fs::create_dir_all(&meshes).unwrap();
        for f in harness::fetch::MESH_FILES.iter().map(|m| m.file) {
            std::fs::copy(
                clone_root().join("bench-data/meshes").join(f),
                meshes.join(f),
            )
            .unwrap_or_else(|e| panic!("{f}: {e} (run `pointsight fetch` in the clone)"));
        }
        let fetched = ok(&s.run(&["fetch"]));
        assert!(
            fetched.contains("bunny00.off: present, checksum ok"),
            "{fetched}"
        );
        assert!(
            fetched.contains(&format!("data folder: {}", data.display())),
            "{fetched}"
        );
        let datasets = ok(&s.run(&["datasets"]));
        assert!(
            datasets
                .lines()
                .any(|l| l.starts_with("bunny-69451") && l.contains("ready")),
            "{datasets}"
        );
        let visible = ok(&s.run(&[
            "visible",
            "--dataset",
            "bunny-69451",
            "--method",
            "hpr",
            "--out",
            "bunny.txt",
        ]));
        assert!(visible.contains("method=hpr points=69451"), "{visible}");
    }
}

/// A folder with the clone's marker files (and nothing else of a clone).
#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn fake_clone(root: &Path) {
    for marker in harness::paths::CLONE_MARKERS {
        let p = root.join(marker);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, "").unwrap();
    }
}

#[test]
fn inside_a_clone_its_folders_are_used_from_any_subfolder() {
    let s = Sandbox::new();
    let clone = s.root.join("clone");
    fake_clone(&clone);
    let mine = clone.join("methods/mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::copy(
        clone_root().join("methods/example-zbuffer/method.toml"),
        mine.join("method.toml"),
    )
    .unwrap();
    std::fs::copy(
        clone_root().join("methods/example-zbuffer/zbuffer.py"),
        mine.join("zbuffer.py"),
    )
    .unwrap();
    // The protocol helper it imports (from ../_shared, or beside it).
    std::fs::copy(
        clone_root().join("methods/_shared/pointsight_protocol.py"),
        mine.join("pointsight_protocol.py"),
    )
    .unwrap();
    let sub = clone.join("a/b");
    std::fs::create_dir_all(&sub).unwrap();
    let paths = ok(&s.run_in(&sub, &["paths"]));
    assert_eq!(
        path_of(&paths, "data"),
        format!(
            "{} (the clone at {})",
            clone.join("bench-data").display(),
            clone.display()
        )
    );
    assert!(path_of(&paths, "methods").starts_with(&clone.join("methods").display().to_string()));
    assert_eq!(
        path_of(&paths, "reports"),
        clone.join("reports").display().to_string()
    );
    let methods = ok(&s.run_in(&sub, &["methods"]));
    assert!(methods.lines().any(|l| l.starts_with("mine ")), "{methods}");
    assert!(!methods.contains("example-zbuffer"), "{methods}");
    // The flag wins over the clone.
    let given = ok(&s.run_in(&sub, &["--data-dir", "/somewhere/else", "paths"]));
    assert_eq!(
        path_of(&given, "data"),
        "/somewhere/else (given by flag or environment variable)"
    );
}

/// A scene written by hand, as another tool would: a 4 × 4 floor (z = 0) sampled on a grid and
/// a box above it sampled on its five visible faces, as an ASCII PLY; the mesh as an OFF.
#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn write_scene(dir: &Path) {
    let mut points: Vec<[f64; 3]> = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            points.push([
                -2.0 + 0.1 * i as f64 + 0.05,
                -2.0 + 0.1 * j as f64 + 0.05,
                0.0,
            ]);
        }
    }
    let (lo, hi, z0, z1) = (-0.5, 0.5, 0.2, 1.2);
    for i in 0..12 {
        for j in 0..12 {
            let (u, v) = ((i as f64 + 0.5) / 12.0, (j as f64 + 0.5) / 12.0);
            let (x, y, z) = (lo + u, lo + v, z0 + v);
            points.push([x, y, z1]);
            points.push([lo, x, z]);
            points.push([hi, x, z]);
            points.push([x, lo, z]);
            points.push([x, hi, z]);
        }
    }
    let mut ply = format!(
        "ply\nformat ascii 1.0\ncomment written by hand\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nend_header\n",
        points.len()
    );
    for p in &points {
        ply.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    std::fs::write(dir.join("scene.ply"), ply).unwrap();
    let v = [
        [-2.0, -2.0, 0.0],
        [2.0, -2.0, 0.0],
        [2.0, 2.0, 0.0],
        [-2.0, 2.0, 0.0],
        [lo, lo, z0],
        [hi, lo, z0],
        [hi, hi, z0],
        [lo, hi, z0],
        [lo, lo, z1],
        [hi, lo, z1],
        [hi, hi, z1],
        [lo, hi, z1],
    ];
    let f = [
        [0, 1, 2],
        [0, 2, 3],
        [4, 6, 5],
        [4, 7, 6],
        [8, 9, 10],
        [8, 10, 11],
        [4, 5, 9],
        [4, 9, 8],
        [5, 6, 10],
        [5, 10, 9],
        [6, 7, 11],
        [6, 11, 10],
        [7, 4, 8],
        [7, 8, 11],
    ];
    let mut off = format!("OFF\n{} {} 0\n", v.len(), f.len());
    for p in v {
        off.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    for t in f {
        off.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
    std::fs::write(dir.join("scene.off"), off).unwrap();
}

const EYE: [&str; 8] = [
    "--eye", "3,-4,2.5", "--target", "0,0,0.5", "--up", "0,0,1", "--fov-y", "50",
];

/// The rows of `file`, each without the columns named in `timing`.
#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn rows_without(file: &Path, timing: &[&str]) -> Vec<Vec<String>> {
    let mut reader = csv::Reader::from_path(file).unwrap();
    let headers = reader.headers().unwrap().clone();
    let keep: Vec<usize> = (0..headers.len())
        .filter(|&k| !timing.contains(&&headers[k]))
        .collect();
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            keep.iter().map(|&k| r[k].to_owned()).collect()
        })
        .collect()
}

#[test]
fn run_visibility_on_your_files_gives_the_manifest_routes_rows() {
    let s = Sandbox::new();
    write_scene(&s.work);
    let mut args = vec![
        "run",
        "visibility",
        "--quick",
        "--repeats",
        "1",
        "--cloud",
        "scene.ply",
        "--mesh",
        "scene.off",
        "--out",
        "files",
    ];
    args.extend(EYE);
    args.extend(["--width", "320", "--height", "240"]);
    ok(&s.run(&args));

    // The manifest route: a folder with the manifest and a views file of the same camera.
    let m = s.work.join("manifest");
    std::fs::create_dir_all(&m).unwrap();
    std::fs::write(
        m.join("view.jsonl"),
        "{\"model\":\"pinhole\",\"width\":320,\"height\":240,\"eye\":[3,-4,2.5],\
         \"target\":[0,0,0.5],\"up\":[0,0,1],\"fov_y_deg\":50}\n",
    )
    .unwrap();
    std::fs::write(
        m.join("pointsight.toml"),
        "[datasets.scene]\ncloud = \"../scene.ply\"\nmesh = \"../scene.off\"\n\
         views = \"view.jsonl\"\n",
    )
    .unwrap();
    ok(&s.run_in(
        &m,
        &[
            "run",
            "visibility",
            "--quick",
            "--repeats",
            "1",
            "--datasets",
            "scene",
            "--out",
            "out",
        ],
    ));
    let timing = [
        "seconds",
        "seconds_min",
        "seconds_max",
        "samples",
        "wall_seconds",
    ];
    let from_files = rows_without(&s.work.join("files/results.csv"), &timing);
    let from_manifest = rows_without(&m.join("out/results.csv"), &timing);
    assert!(from_files.len() >= 10, "{} rows", from_files.len());
    assert!(
        from_files.iter().all(|r| r[0] == "scene" && r[2] == "0"),
        "{from_files:?}"
    );
    assert_eq!(from_files, from_manifest);
    // Scored against the mesh: F1 is a number.
    let f1: f64 = from_files[0][10].parse().unwrap();
    assert!(f1 > 0.5, "{:?}", from_files[0]);
    // A run into its own folder gets its own findings: one view, so indicative, no interval.
    let mut findings = csv::Reader::from_path(s.work.join("files/findings.csv")).unwrap();
    let header = findings.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let row = findings
        .records()
        .next()
        .expect("a finding for the scene")
        .unwrap();
    assert_eq!(&row[col("experiment")], "visibility", "{row:?}");
    assert_eq!(&row[col("indicative")], "true", "{row:?}");
    assert_eq!(&row[col("low")], "", "{row:?}");
    let md = std::fs::read_to_string(s.work.join("files/findings.md")).unwrap();
    assert!(md.starts_with("## Findings"), "{md}");
    // Without a camera, the same error as `visible`'s.
    let no_camera = s.run(&["run", "visibility", "--quick", "--cloud", "scene.ply"]);
    assert!(!no_camera.status.success());
    assert!(
        stderr(&no_camera).contains("give a camera: --eye"),
        "{}",
        stderr(&no_camera)
    );
}

/// `run scale` on a manifest dataset, the manifest and the methods folder given by flag from
/// a folder of their own: the cells (child processes) read the same manifest and methods as
/// the run (they knew neither: every row was "unknown dataset"), and the dataset's mesh is read
/// alone (a sample of 10^12 points was refused as 61.8 TiB before any cell ran).
#[test]
fn run_scale_on_a_manifest_dataset_reaches_its_cells() {
    let s = Sandbox::new();
    write_scene(&s.work);
    std::fs::write(
        s.work.join("m.toml"),
        "[datasets.scene]\nmesh = \"scene.off\"\nsample = { n = 1000000000000, seed = 1 }\n",
    )
    .unwrap();
    // A methods folder of one method under a name no other folder has (and the protocol
    // module the methods share), the installed ones left out.
    let installed = s.prefix.join("share/pointsight/methods");
    for (from, to) in [("example-zbuffer", "my-zbuffer"), ("_shared", "_shared")] {
        let to = s.root.join("my-methods").join(to);
        std::fs::create_dir_all(&to).unwrap();
        for f in std::fs::read_dir(installed.join(from)).unwrap() {
            let f = f.unwrap().path();
            if f.is_file() {
                std::fs::copy(&f, to.join(f.file_name().unwrap())).unwrap();
            }
        }
    }
    let sub = s.work.join("sub");
    std::fs::create_dir_all(&sub).unwrap();
    let methods = s.root.join("my-methods");
    ok(&s.run_in(
        &sub,
        &[
            "run",
            "scale",
            "--quick",
            "--max-points",
            "10000",
            "--manifest",
            "../m.toml",
            "--no-installed-methods",
            "--methods-dir",
            methods.to_str().unwrap(),
            "--datasets",
            "scene",
            "--out",
            "out",
        ],
    ));
    let rows = rows_without(&sub.join("out/results.csv"), &[]);
    let status = |m: &str| {
        rows.iter()
            .find(|r| r[0] == m)
            .map(|r| r[4].clone())
            .unwrap_or_else(|| panic!("no {m} row: {rows:?}"))
    };
    for m in ["hpr", "qsplat-build", "my-zbuffer"] {
        assert_eq!(status(m), "ok", "{m}: {rows:?}");
    }
    assert!(
        rows.iter()
            .all(|r| r[1] == "10000" && !r[4].starts_with("error")),
        "every cell at 10^4 points, none an error: {rows:?}"
    );
    // The mesh file is in the run's record, with its checksum.
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sub.join("out/metadata.json")).unwrap())
            .unwrap();
    let files = meta["user_files"].as_array().expect("user_files");
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(files[0].to_string().contains("scene.off"), "{files:?}");
}

#[test]
fn run_lod_takes_four_views_or_one_and_no_seed_table() {
    let s = Sandbox::new();
    write_scene(&s.work);
    std::fs::write(
        s.work.join("pointsight.toml"),
        "[datasets.scene4]\ncloud = \"scene.ply\"\n\
         view_spec = { count = 4, width = 160, height = 120 }\n",
    )
    .unwrap();
    ok(&s.run(&[
        "run",
        "lod",
        "--quick",
        "--repeats",
        "1",
        "--datasets",
        "scene4",
        "--out",
        "four",
    ]));
    let rows = rows_without(&s.work.join("four/results.csv"), &[]);
    let mut views: Vec<&str> = rows.iter().map(|r| r[1].as_str()).collect();
    views.dedup();
    views.sort();
    views.dedup();
    assert_eq!(views, ["0", "1", "2", "3"]);
    assert!(
        rows.iter().all(|r| r[0] == "scene4" && r[10] == "ok"),
        "{rows:?}"
    );
    let builds = std::fs::read_to_string(s.work.join("four/builds.csv")).unwrap();
    for method in ["qsplat", "spt", "srn", "random"] {
        assert!(
            builds.contains(&format!("scene4,{method},")),
            "{method}: {builds}"
        );
    }
    // Seed 003's table runs on its own datasets only: not here (a table of its header alone).
    let table = std::fs::read_to_string(s.work.join("four/srn_table.csv")).unwrap();
    assert!(
        table.starts_with("model,dataset,") && table.lines().count() == 1,
        "{table}"
    );
    let summary = std::fs::read_to_string(s.work.join("four/summary.md")).unwrap();
    assert!(
        summary.contains("Not run: this run did not ask for it"),
        "{summary}"
    );

    // One camera on the command line: one view, both distances.
    let mut args = vec![
        "run",
        "lod",
        "--quick",
        "--repeats",
        "1",
        "--cloud",
        "scene.ply",
        "--out",
        "one",
    ];
    args.extend(EYE);
    args.extend(["--width", "160", "--height", "120"]);
    ok(&s.run(&args));
    let rows = rows_without(&s.work.join("one/results.csv"), &[]);
    assert!(!rows.is_empty());
    assert!(
        rows.iter().all(|r| r[0] == "scene" && r[1] == "0"),
        "{rows:?}"
    );
    assert!(rows.iter().any(|r| r[2] == "2.0") && rows.iter().any(|r| r[2] == "1.0"));
    let table = std::fs::read_to_string(s.work.join("one/srn_table.csv")).unwrap();
    assert!(
        table.starts_with("model,dataset,") && table.lines().count() == 1,
        "{table}"
    );
}

/// The last line a terminal shows of `text`: after the last carriage return or newline, the
/// erase-line code that clears a bar dropped.
fn last_line(text: &str) -> &str {
    text.split(['\r', '\n'])
        .map(|l| l.trim_start_matches("\u{1b}[2K").trim())
        .rfind(|l| !l.is_empty())
        .unwrap_or_default()
}

/// `pointsight ARGS` under a pseudo-terminal (util-linux `script`) in `dir`: what the terminal
/// showed (standard output and standard error together).
fn under_pty(s: &Sandbox, dir: &Path, args: &[&str]) -> String {
    let line = std::iter::once("pointsight")
        .chain(args.iter().copied())
        .collect::<Vec<_>>()
        .join(" ");
    let out = Command::new("script")
        .args([
            "-qec",
            &format!("stty cols 200 2>/dev/null; {line}"),
            "/dev/null",
        ])
        .current_dir(dir)
        .env(
            "PATH",
            format!(
                "{}:{}",
                s.prefix.join("bin").display(),
                std::env::var("PATH").unwrap_or_default()
            ),
        )
        .env("HOME", &s.home)
        .env("XDG_DATA_HOME", &s.xdg)
        .env("POINTSIGHT_METHODS", s.root.join("empty-methods"))
        .env_remove("POINTSIGHT_DATA")
        .output()
        .expect("util-linux `script` runs (Debian: bsdutils/util-linux)");
    ok(&out)
}

#[test]
fn bench_shows_the_runs_progress_on_a_terminal_only_and_leaves_full_reports_alone() {
    let s = Sandbox::new();
    std::fs::create_dir_all(s.root.join("empty-methods")).unwrap();
    let clone = s.root.join("clone");
    fake_clone(&clone);
    // The clone's built results script (`just web`, which `just test` runs first), so that the
    // report has its pages and says nothing of a missing script.
    let built = clone_root().join("web/dist/results.js");
    assert!(built.is_file(), "web/dist/results.js: run `just web`");
    std::fs::create_dir_all(clone.join("web/dist")).unwrap();
    std::fs::copy(&built, clone.join("web/dist/results.js")).unwrap();
    let full = clone.join("reports/reference");
    std::fs::create_dir_all(&full).unwrap();
    std::fs::write(full.join("results.csv"), "the full run's results\n").unwrap();
    let sub = clone.join("sub");
    std::fs::create_dir_all(&sub).unwrap();
    let args = [
        "bench",
        "--quick",
        "--datasets",
        "sphere-20000",
        "--experiments",
        "reference,hull",
    ];

    let shown = under_pty(&s, &sub, &args);
    for needle in [
        "experiment 1 of 2: reference · time left ",
        "experiment 2 of 2: hull · time left ~",
        "sphere-20000",
    ] {
        assert!(shown.contains(needle), "{needle}: {shown}");
    }
    let last = last_line(&shown);
    assert!(last.starts_with("bench: 2 experiment(s) in "), "{last:?}");
    // The quick run went to reports-quick/; the full results are as they were.
    assert!(clone.join("reports-quick/reference/results.csv").is_file());
    assert!(clone.join("reports-quick/hull/results.csv").is_file());
    assert_eq!(
        std::fs::read_to_string(full.join("results.csv")).unwrap(),
        "the full run's results\n"
    );
    assert_eq!(std::fs::read_dir(clone.join("reports")).unwrap().count(), 1);

    // Again: the previous run's metadata gives the estimate from the start.
    let again = under_pty(&s, &sub, &args);
    assert!(
        again.contains("experiment 1 of 2: reference · time left ~"),
        "{again}"
    );
    assert!(!again.contains("time left estimating"), "{again}");

    // Standard error not a terminal: nothing on it; the same last line on standard output.
    let piped = s.run_in(
        &sub,
        &[
            "--methods-dir",
            s.root.join("empty-methods").to_str().unwrap(),
            "bench",
            "--quick",
            "--datasets",
            "sphere-20000",
            "--experiments",
            "reference,hull",
        ],
    );
    let stdout = ok(&piped);
    assert_eq!(stderr(&piped), "");
    assert!(
        stdout
            .trim_end()
            .lines()
            .last()
            .unwrap()
            .starts_with("bench: 2 experiment(s) in "),
        "{stdout}"
    );

    // --quiet on a terminal: no progress either.
    let quiet = under_pty(
        &s,
        &sub,
        &[
            "--quiet",
            "bench",
            "--quick",
            "--datasets",
            "sphere-20000",
            "--experiments",
            "reference",
        ],
    );
    assert!(!quiet.contains("experiment 1 of"), "{quiet}");
    assert!(!quiet.contains("=="), "{quiet}");
    assert!(!quiet.contains('\u{1b}'), "escape codes: {quiet:?}");
    assert!(
        quiet.trim().starts_with("bench: 1 experiment(s) in ") && quiet.trim().lines().count() == 1,
        "{quiet:?}"
    );
}
