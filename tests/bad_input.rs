//! The malformed-input corpus (`tests/data/bad/`, written by its `make_bad.py`): every file
//! gives its own error, naming the file and the line or byte (`expected.tsv`), from the library
//! and from the command line (exit code 1, no panic); bad camera and parameter values on the
//! command line are refused; degenerate but valid inputs have their documented result.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cloud::io::{read, views::read_views};

fn bad_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/bad")
}

/// The rows of `expected.tsv`: file, location, part of the message.
fn expected() -> Vec<(String, String, String)> {
    let table = std::fs::read_to_string(bad_dir().join("expected.tsv")).expect("expected.tsv");
    table
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let fields: Vec<&str> = l.split('\t').collect();
            assert_eq!(fields.len(), 3, "expected.tsv row {l:?}");
            (
                fields[0].to_owned(),
                fields[1].to_owned(),
                fields[2].to_owned(),
            )
        })
        .collect()
}

/// The library's error for one corpus file.
fn library_error(path: &Path) -> String {
    let is_views = path.extension().is_some_and(|e| e == "jsonl");
    let result = if is_views {
        read_views(path).map(|_| ())
    } else {
        read(path).map(|_| ())
    };
    match result {
        Ok(()) => panic!("{} was read without an error", path.display()),
        Err(e) => e.to_string(),
    }
}

fn pointsight(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

#[test]
fn every_corpus_file_is_listed_once() {
    let rows = expected();
    let mut listed: Vec<&str> = rows.iter().map(|r| r.0.as_str()).collect();
    listed.sort_unstable();
    let before = listed.len();
    listed.dedup();
    assert_eq!(before, listed.len(), "a file is listed twice");
    let mut files: Vec<String> = std::fs::read_dir(bad_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !matches!(n.as_str(), "make_bad.py" | "expected.tsv" | "README.md"))
        .collect();
    files.sort_unstable();
    assert_eq!(files, listed, "tests/data/bad and expected.tsv differ");
    // Every reader has its corpus.
    for ext in [
        "ply", "off", "obj", "xyz", "pcd", "las", "laz", "e57", "jsonl",
    ] {
        assert!(
            files.iter().filter(|f| f.ends_with(ext)).count() >= 2,
            "too few .{ext} files"
        );
    }
}

#[test]
fn every_corpus_file_gives_its_error_naming_file_and_place() {
    for (file, location, message) in expected() {
        let path = bad_dir().join(&file);
        let err = library_error(&path);
        assert!(
            err.contains(&format!("{file}: {location}: ")),
            "{file}: {err:?} should name the file and {location:?}"
        );
        assert!(err.contains(&message), "{file}: {err:?} lacks {message:?}");
    }
}

#[test]
fn the_command_line_exits_1_with_the_same_message() {
    // A folder of this test's own (outputs are locked: another run's would be refused).
    let out_dir = tempfile::tempdir().unwrap();
    for (file, location, message) in expected() {
        let path = bad_dir().join(&file);
        let out = if file.ends_with(".jsonl") {
            pointsight(&[
                "visible".as_ref(),
                "--dataset".as_ref(),
                "sphere-20000".as_ref(),
                "--views".as_ref(),
                path.as_os_str(),
                "--view".as_ref(),
                "all".as_ref(),
                "--method".as_ref(),
                "raycast".as_ref(),
                "--out".as_ref(),
                out_dir.path().join("views-out").as_os_str(),
            ])
        } else {
            pointsight(&["inspect".as_ref(), path.as_os_str()])
        };
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{file}: {err}");
        assert!(!err.contains("panicked"), "{file}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains(&format!("{file}: {location}: ")),
            "{file}: {err:?}"
        );
        assert!(err.contains(&message), "{file}: {err:?} lacks {message:?}");
        // Said once: the message is not repeated by the error chain.
        assert_eq!(err.matches(message.as_str()).count(), 1, "{file}: {err:?}");
    }
}

/// Bad camera and parameter values on the command line: exit 1 (our message) or 2 (the
/// argument parser's), never a crash.
#[test]
fn bad_cameras_and_parameters_on_the_command_line_are_refused() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["--view", "0", "--method", "raycast", "--set", "width=0"],
            "image size 0x720",
        ),
        (
            &["--eye", "0,0,5", "--method", "raycast", "--width", "0"],
            "image size 0x720",
        ),
        (
            &["--eye", "0,0,5", "--method", "raycast", "--fov-y", "-10"],
            "vertical field of view -10",
        ),
        (
            &["--eye", "0,0,5", "--method", "raycast", "--fov-y", "180"],
            "vertical field of view 180",
        ),
        (
            &["--eye", "nan,0,0", "--method", "raycast"],
            "\"nan\" is not finite",
        ),
        (
            &["--eye", "1e400,0,0", "--method", "raycast"],
            "is not finite",
        ),
        (
            &["--eye", "0,0,5", "--target", "0,0,5", "--method", "raycast"],
            "eye and target coincide",
        ),
        (
            &[
                "--eye", "0,0,5", "--target", "0,0,0", "--up", "0,0,1", "--method", "raycast",
            ],
            "parallel to the view direction",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "gamma=nan"],
            "gamma: must be finite",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "gamma=-1"],
            "spherical flipping needs R > max",
        ),
        (
            &["--view", "0", "--method", "raycast", "--set", "radius=0"],
            "radius: must be positive",
        ),
        (
            &["--view", "0", "--method", "splat", "--set", "width=70000"],
            "at most 65534 pixels a side",
        ),
        (
            &[
                "--view",
                "0",
                "--method",
                "raycast",
                "--set",
                "width=100000",
                "--set",
                "height=100000",
            ],
            "refused before allocating",
        ),
        (
            &[
                "--view",
                "0",
                "--method",
                "raycast",
                "--set",
                "width=4294967295",
                "--set",
                "height=4294967295",
            ],
            "refused before allocating",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "bogus=1"],
            "unknown parameter bogus",
        ),
        // The registry's parameter errors, in `--set` words.
        (
            &["--view", "0", "--method", "hpr", "--set", "gamma=x"],
            "error: --set gamma=x: method hpr: expected a number or auto (invalid float literal)\n",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "kernel=box"],
            "error: --set kernel=box: method hpr: expected linear, exp, log or expdecay\n",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "gamma"],
            "error: --set gamma: expected [METHOD.]KEY=VALUE\n",
        ),
        (&["--view", "99", "--method", "hpr"], "view 99"),
        // Image options without an eye would be silently ignored: refused instead.
        (
            &["--view", "0", "--method", "raycast", "--width", "64"],
            "--eye",
        ),
    ];
    let out_dir = tempfile::tempdir().unwrap();
    let out_file = out_dir.path().join("bad-params.txt");
    for (args, message) in cases {
        let mut all: Vec<&std::ffi::OsStr> = vec![
            "visible".as_ref(),
            "--dataset".as_ref(),
            "sphere-20000".as_ref(),
            "--out".as_ref(),
            out_file.as_os_str(),
        ];
        all.extend(args.iter().map(std::ffi::OsStr::new));
        let out = pointsight(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            matches!(out.status.code(), Some(1 | 2)),
            "{args:?}: exit {:?}: {err}",
            out.status.code()
        );
        assert!(err.contains(message), "{args:?}: {err:?} lacks {message:?}");
    }
}

/// A cloud written to a temporary XYZ file.
fn xyz_file(dir: &Path, name: &str, points: &[[f64; 3]]) -> PathBuf {
    let text: String = points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write the test cloud");
    path
}

/// `visible` of `method` on `cloud` from `eye`; HPR at Katz's γ = 3 (these results are for a
/// fixed γ: its default, `auto`, estimates the cloud's spacing from neighbours a three-point
/// cloud does not have).
fn visible(cloud: &Path, eye: &str, method: &str, out: &Path) -> Output {
    let gamma: &[&std::ffi::OsStr] = if method == "hpr" {
        &["--set".as_ref(), "gamma=3".as_ref()]
    } else {
        &[]
    };
    pointsight(
        &[
            &[
                "visible".as_ref(),
                "--cloud".as_ref(),
                cloud.as_os_str(),
                "--eye".as_ref(),
                eye.as_ref(),
                "--target".as_ref(),
                "0,0,0".as_ref(),
                "--method".as_ref(),
                method.as_ref(),
                "--out".as_ref(),
                out.as_os_str(),
            ],
            gamma,
        ]
        .concat(),
    )
}

fn visible_set(out: &Path) -> Vec<usize> {
    std::fs::read_to_string(out)
        .expect("the visible set")
        .lines()
        .map(|l| l.parse().expect("an index"))
        .collect()
}

/// Degenerate but valid clouds, and the eye on a point: their documented results.
#[test]
fn degenerate_valid_inputs_have_their_documented_result() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("visible.txt");

    // Three points: HPR's hull of three flipped points plus the eye is a tetrahedron, every
    // point on it: all visible.
    let three = xyz_file(
        dir.path(),
        "three.xyz",
        &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, -1.0, 0.0]],
    );
    let o = visible(&three, "0,0,5", "hpr", &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(visible_set(&out), vec![0, 1, 2]);

    // All coplanar, seen from off the plane: every point visible to HPR (a flat patch faces the
    // eye) and to the ray cast.
    let grid: Vec<[f64; 3]> = (0..20)
        .flat_map(|i| {
            (0..20).map(move |j| [f64::from(i) * 0.1 - 1.0, f64::from(j) * 0.1 - 1.0, 0.0])
        })
        .collect();
    let plane = xyz_file(dir.path(), "plane.xyz", &grid);
    for method in ["hpr", "raycast"] {
        let o = visible(&plane, "0.05,0.05,3", method, &out);
        assert!(
            o.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(visible_set(&out).len(), grid.len(), "{method} on a plane");
    }

    // All identical: one position, so every method refuses with the reason (no direction,
    // no spacing) rather than dividing by zero.
    let same = xyz_file(dir.path(), "same.xyz", &[[0.5, 0.5, 0.5]; 10]);
    for method in ["hpr", "raycast", "splat"] {
        let o = visible(&same, "0,0,5", method, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{method} on identical points: {err}"
        );
        assert!(err.starts_with("error: "), "{method}: {err}");
    }

    // Duplicates: a point repeated keeps both copies' fate equal under HPR (both flip to the
    // same place, so both are hull vertices or neither).
    let mut dup = grid.clone();
    dup.push(grid[0]);
    let dups = xyz_file(dir.path(), "dups.xyz", &dup);
    let o = visible(&dups, "0.05,0.05,3", "hpr", &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let set = visible_set(&out);
    assert_eq!(set.contains(&0), set.contains(&grid.len()), "{set:?}");

    // The eye on a point: every method and the ground truth refuse alike (HPR
    // refused, the ray cast returned that point alone, the splats 3,620 points of a sphere,
    // the reference none).
    let mut ball: Vec<[f64; 3]> = grid.iter().map(|p| [p[0], p[1], -1.0]).collect();
    ball.push([0.0, 0.0, 3.0]);
    let eye_on = xyz_file(dir.path(), "eye_on.xyz", &ball);
    for method in ["hpr", "raycast", "splat", "reference"] {
        let o = visible(&eye_on, "0,0,3", method, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{method}: {err}");
        assert!(
            err.contains("the eye at (0, 0, 3) is 0 from point 400")
                && err.contains("seen from a point of the cloud, visibility is undefined"),
            "{method}: {err}"
        );
    }
}

// ---- Nothing lost, nothing hung. Each case asserts the error, and that nothing was
// left (no scratch, partial or lock file), lost (what was there is as it was) or left running.

/// `pointsight` with string arguments.
fn ps(args: &[&str]) -> Output {
    let os: Vec<&std::ffi::OsStr> = args.iter().map(std::ffi::OsStr::new).collect();
    pointsight(&os)
}

fn stderr_of(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("a folder")
        .map(|e| {
            e.expect("an entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    v.sort();
    v
}

/// Asserts that `dir` holds exactly `want` (no scratch, partial or lock file beside them).
fn holds_exactly(dir: &Path, want: &[&str]) {
    let mut want: Vec<String> = want.iter().map(|s| (*s).to_owned()).collect();
    want.sort();
    assert_eq!(names(dir), want, "{}", dir.display());
}

/// `n` points of a wavy sheet (no normals), as a binary PLY.
fn sheet(path: &Path, n: usize, copies: usize) {
    let mut positions: Vec<cloud::glam::DVec3> = (0..n)
        .map(|i| {
            let (x, y) = ((i % 1000) as f64 * 0.01, (i / 1000) as f64 * 0.01);
            cloud::glam::DVec3::new(x, y, 0.2 * (3.0 * x).sin() * (2.0 * y).cos())
        })
        .collect();
    let at = positions[n / 3];
    positions.extend(std::iter::repeat_n(at, copies));
    let c = cloud::PointCloud {
        positions,
        ..Default::default()
    };
    cloud::io::ply_write::write_ply(path, &c).expect("the PLY is written");
}

#[cfg(unix)]
#[test]
fn file_outputs_replace_only_regular_files_and_never_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cloud = d.join("s.ply");
    sheet(&cloud, 5_000, 0);
    let cloud_bytes = std::fs::read(&cloud).unwrap();
    let c = cloud.to_str().unwrap();
    let p = |name: &str| d.join(name).to_str().unwrap().to_owned();
    // A directory, a FIFO, a socket: refused, named, left as they were.
    std::fs::create_dir(d.join("folder")).unwrap();
    let fifo = Command::new("mkfifo")
        .arg(d.join("fifo"))
        .status()
        .is_ok_and(|s| s.success());
    let _socket = std::os::unix::net::UnixListener::bind(d.join("sock")).unwrap();
    let mut cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["export", "--dataset", "sphere-20000", "--out", &p("folder")]
                .into_iter()
                .map(String::from)
                .collect(),
            "is a directory",
        ),
        (
            vec!["views", "--dataset", "sphere-20000", "--out", &p("sock")]
                .into_iter()
                .map(String::from)
                .collect(),
            "is a socket",
        ),
    ];
    if fifo {
        cases.push((
            vec!["lod-build", "--cloud", c, "--out", &p("fifo")]
                .into_iter()
                .map(String::from)
                .collect(),
            "is a FIFO",
        ));
        cases.push((
            vec![
                "visible",
                "--cloud",
                c,
                "--eye",
                "5,5,5",
                "--method",
                "hpr",
                "--out",
                &p("fifo"),
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            "is a FIFO",
        ));
    }
    // The output is the input (by device and inode; a link to it too).
    std::os::unix::fs::symlink("s.ply", d.join("alias.ply")).unwrap();
    for out in [c.to_owned(), p("alias.ply")] {
        cases.push((
            vec!["lod-build", "--cloud", c, "--out", &out]
                .into_iter()
                .map(String::from)
                .collect(),
            "is the input",
        ));
    }
    cases.push((
        vec![
            "visible", "--cloud", c, "--eye", "5,5,5", "--method", "hpr", "--out", c,
        ]
        .into_iter()
        .map(String::from)
        .collect(),
        "is the input",
    ));
    // A folder output where a file is.
    cases.push((
        vec![
            "run",
            "reference",
            "--quick",
            "--datasets",
            "sphere-20000",
            "--out",
            c,
        ]
        .into_iter()
        .map(String::from)
        .collect(),
        "a folder output is a directory",
    ));
    for (args, message) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = ps(&args);
        let err = stderr_of(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err:?} lacks {message:?}");
    }
    assert_eq!(
        std::fs::read(&cloud).unwrap(),
        cloud_bytes,
        "the input was replaced"
    );
    assert!(d.join("folder").is_dir() && names(&d.join("folder")).is_empty());
    if fifo {
        let t = std::fs::symlink_metadata(d.join("fifo"))
            .unwrap()
            .file_type();
        assert!(std::os::unix::fs::FileTypeExt::is_fifo(&t));
    }
    // A link to a regular file is written through: the file replaced, the link kept.
    std::fs::create_dir(d.join("real")).unwrap();
    std::fs::write(d.join("real/out.ply"), b"old").unwrap();
    std::os::unix::fs::symlink("real/out.ply", d.join("link.ply")).unwrap();
    let o = ps(&[
        "export",
        "--dataset",
        "sphere-20000",
        "--out",
        &p("link.ply"),
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let t = std::fs::symlink_metadata(d.join("link.ply"))
        .unwrap()
        .file_type();
    assert!(t.is_symlink());
    assert!(
        std::fs::read(d.join("real/out.ply"))
            .unwrap()
            .starts_with(b"ply\n")
    );
    let mut want = vec!["alias.ply", "folder", "link.ply", "real", "s.ply", "sock"];
    if fifo {
        want.push("fifo");
    }
    holds_exactly(d, &want);
    holds_exactly(&d.join("real"), &["out.ply"]);
}

#[test]
fn coincident_points_are_bounded_work_and_a_cloud_of_one_position_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Every point at one position: no surface, refused at once, in or out of core.
    let same = xyz_file(d, "same.xyz", &[[0.5, 0.25, 1.0]; 2_000]);
    let out = d.join("same.qsplat");
    for extra in [&["--memory-limit", "64MiB"][..], &["--in-memory"][..]] {
        let mut args = vec![
            "lod-build",
            "--cloud",
            same.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = ps(&args);
        let err = stderr_of(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains("same.xyz") && err.contains("no surface: all 2000 points coincide"),
            "{err}"
        );
    }
    // One point: the file named (it was "need 3 <= k <= 1").
    let one = xyz_file(d, "one.xyz", &[[0.0, 0.0, 1.0]]);
    let o = ps(&[
        "lod-build",
        "--cloud",
        one.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        stderr_of(&o).contains("one.xyz: the point cloud has no surface: 1 point"),
        "{}",
        stderr_of(&o)
    );
    // A sheet of 30,000 points with 20,000 copies of one of them (its lod-build took 47 s at
    // 64 MiB before the grouping, 0.2 s without the copies): built out of core in chunks, the
    // same bytes as in memory (the canonical order kept across chunk and halo).
    let dups = d.join("dups.ply");
    sheet(&dups, 30_000, 20_000);
    let o = ps(&["inspect", dups.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("distinct_positions=30000 duplicates=20000 most_copies=20001"),
        "{text}"
    );
    let (ooc, mem) = (d.join("ooc.qsplat"), d.join("mem.qsplat"));
    let start = std::time::Instant::now();
    let o = ps(&[
        "lod-build",
        "--cloud",
        dups.to_str().unwrap(),
        "--memory-limit",
        "64MiB",
        "--out",
        ooc.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(!stdout.contains("chunks=1 "), "out of core: {stdout}");
    eprintln!(
        "lod-build of 30,000 + 20,000 copies at 64 MiB: {:.1} s",
        start.elapsed().as_secs_f64()
    );
    let o = ps(&[
        "lod-build",
        "--cloud",
        dups.to_str().unwrap(),
        "--in-memory",
        "--out",
        mem.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(std::fs::read(&ooc).unwrap() == std::fs::read(&mem).unwrap());
    holds_exactly(
        d,
        &[
            "dups.ply",
            "mem.qsplat",
            "one.xyz",
            "ooc.qsplat",
            "same.xyz",
        ],
    );
}

/// The real bunny with 20,000 copies of one of its points: the neighbour candidates a point
/// stay within a small constant of the bunny's (counted, not timed).
#[test]
fn the_bunny_with_20000_copies_costs_a_small_constant_more() {
    if std::env::var("POINTSIGHT_REAL_DATA").as_deref() != Ok("1") {
        eprintln!("POINTSIGHT_REAL_DATA is not 1: skipping the real-data check (run `just test`)");
        return;
    }
    let data = std::env::var_os("POINTSIGHT_DATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench-data"),
        PathBuf::from,
    );
    let bunny = harness::datasets::Datasets::default()
        .load("bunny-69451", &data)
        .expect("bunny-69451 loads after `pointsight fetch`")
        .cloud
        .positions;
    let per_point = |pts: &[cloud::glam::DVec3]| {
        let knn = cloud::knn::Knn::new(pts, |i| i).unwrap();
        let k = std::num::NonZero::new(16).unwrap();
        let mut n = 0u64;
        for p in pts {
            knn.canonical_knn_counted(*p, k, &mut n);
        }
        n as f64 / pts.len() as f64
    };
    let base = per_point(&bunny);
    let mut with = bunny.clone();
    with.extend(std::iter::repeat_n(bunny[777], 20_000));
    let e = per_point(&with);
    eprintln!("bunny: {base:.1} candidates a point; with 20,000 copies: {e:.1}");
    assert!(e <= 3.0 * base, "{e} against {base}");
}

#[test]
fn a_laz_whose_count_is_below_its_chunks_is_refused() {
    // Two LASzip chunks (50,000 and 10,000 points); the header then says 1,000 (it built 1,000
    // points without a word before).
    let dir = tempfile::tempdir().unwrap();
    let laz = dir.path().join("lying.laz");
    let c = cloud::PointCloud {
        positions: (0..60_000)
            .map(|i| cloud::glam::DVec3::new(f64::from(i) * 1e-3, (f64::from(i) * 0.1).sin(), 0.0))
            .collect(),
        ..Default::default()
    };
    cloud::io::las::write_las(&laz, &c).unwrap();
    let mut bytes = std::fs::read(&laz).unwrap();
    bytes[107..111].copy_from_slice(&1000u32.to_le_bytes());
    bytes[247..255].copy_from_slice(&1000u64.to_le_bytes());
    std::fs::write(&laz, &bytes).unwrap();
    let err = read(&laz).unwrap_err().to_string();
    assert!(
        err.contains("the header announces 1000 points but the LAZ chunk table holds 2 chunks"),
        "{err}"
    );
    let out = dir.path().join("out.qsplat");
    let o = ps(&[
        "lod-build",
        "--cloud",
        laz.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("LAZ chunk table holds 2 chunks"));
    holds_exactly(dir.path(), &["lying.laz"]);
}

#[cfg(unix)]
#[test]
fn the_memory_guard_takes_the_address_space_limit() {
    // 10^8 x 1 pixels of the reference's depth buffer (2.3 GiB) under a 1.5 GB address-space
    // limit: refused with the limit named, where the allocation aborted the process.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.txt");
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1500000 && exec '{}' visible --dataset sphere-20000 --eye 0,0,5 \
             --width 100000000 --height 1 --method reference --out '{}'",
            env!("CARGO_BIN_EXE_pointsight"),
            out.display()
        ))
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .unwrap();
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("refused before allocating"), "{err}");
    let free_gib = cloud::memory::headroom().map_or(0, |(b, _)| b >> 30);
    if free_gib >= 3 {
        assert!(err.contains("RLIMIT_AS"), "{err}");
    }
    holds_exactly(dir.path(), &[]);
}

#[test]
fn an_eye_too_far_is_refused_alike() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.txt");
    let o_str = out.to_str().unwrap();
    // At 10^300 the ground truth called all 20,000 points visible and HPR said "coplanar".
    for eye in ["0,0,1e300", "0.3,0.2,1e8"] {
        for method in ["hpr", "raycast", "splat", "reference"] {
            let o = ps(&[
                "visible",
                "--dataset",
                "sphere-20000",
                "--eye",
                eye,
                "--method",
                method,
                "--out",
                o_str,
            ]);
            let err = stderr_of(&o);
            assert_eq!(o.status.code(), Some(1), "{eye} {method}: {err}");
            assert!(
                err.contains("the cloud is below the precision of its coordinates"),
                "{eye} {method}: {err}"
            );
        }
    }
    // 10^6 diameters away: a view.
    let o = ps(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--eye",
        "0,0,1e6",
        "--method",
        "hpr",
        "--out",
        o_str,
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    holds_exactly(dir.path(), &["v.txt"]);
}

/// Runs `cmd`, killing it (and failing) when it has not ended after `seconds`.
fn within(mut cmd: Command, seconds: u64) -> Output {
    let mut child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the command starts");
    let start = std::time::Instant::now();
    loop {
        if child.try_wait().expect("its state").is_some() {
            return child.wait_with_output().expect("its output");
        }
        if start.elapsed().as_secs() > seconds {
            let _ = child.kill();
            let _ = child.wait();
            panic!("still running after {seconds} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

#[cfg(unix)]
#[test]
fn a_fifo_as_lod_file_and_a_colmap_model_cut_short_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    if Command::new("mkfifo")
        .arg(d.join("built.qsplat"))
        .status()
        .is_ok_and(|s| s.success())
    {
        std::fs::write(
            d.join("pointsight.toml"),
            "[datasets.piped]\nlod_file = \"built.qsplat\"\n",
        )
        .unwrap();
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_pointsight"));
        cmd.args(["run", "lod", "--quick", "--datasets", "piped", "--out"])
            .arg(d.join("r"))
            .arg("--manifest")
            .arg(d.join("pointsight.toml"))
            .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data");
        let o = within(cmd, 120);
        let err = stderr_of(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("not a regular file"), "{err}");
        holds_exactly(d, &["built.qsplat", "pointsight.toml"]);
    }
    // COLMAP's images.txt cut after its first image, its header saying 3: an error (it was
    // read as 1 view).
    let colmap = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/colmap");
    let model = d.join("model");
    std::fs::create_dir(&model).unwrap();
    std::fs::copy(colmap.join("cameras.txt"), model.join("cameras.txt")).unwrap();
    let images = std::fs::read_to_string(colmap.join("images.txt")).unwrap();
    let cut: String = images
        .lines()
        .take_while(|l| !l.starts_with("2 "))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(model.join("images.txt"), cut).unwrap();
    let out = d.join("views");
    let o = ps(&[
        "visible",
        "--dataset",
        "sphere-20000",
        "--views",
        model.to_str().unwrap(),
        "--method",
        "raycast",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(
            "images.txt: line 4: truncated: the header announces 3 images but the data ends after 1"
        ),
        "{err}"
    );
    assert!(!out.exists());
}

/// A process id no process has (above the kernel's maximum).
fn dead_pid() -> u32 {
    std::fs::read_to_string("/proc/sys/kernel/pid_max")
        .ok()
        .and_then(|s| s.trim().parse::<u32>().ok())
        .map_or(u32::MAX - 1, |m| m + 1)
}

/// Starts `pointsight args`, waits until a path in `dir` whose name contains `marker` appears
/// (the run is under way), and returns the child.
fn started(args: &[&str], dir: &Path, marker: &str) -> std::process::Child {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("pointsight starts");
    let start = std::time::Instant::now();
    while !names(dir).iter().any(|n| n.contains(marker)) {
        if let Some(status) = child.try_wait().expect("its state") {
            panic!("{args:?} ended ({status}) before {marker} appeared");
        }
        assert!(start.elapsed().as_secs() < 300, "{marker} never appeared");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child
}

#[cfg(unix)]
#[test]
fn signals_remove_scratch_and_exit_128_plus_the_signal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cloud = d.join("big.ply");
    sheet(&cloud, 400_000, 0);
    let out = d.join("big.qsplat");
    let args = [
        "lod-build",
        "--cloud",
        cloud.to_str().unwrap(),
        "--memory-limit",
        "64MiB",
        "--out",
        out.to_str().unwrap(),
    ];
    for (name, number) in [("INT", 2), ("TERM", 15), ("HUP", 1)] {
        let child = started(&args, d, ".big.qsplat.chunks-");
        let pid = child.id().to_string();
        let killed = Command::new("kill")
            .args(["-s", name, &pid])
            .status()
            .unwrap();
        assert!(killed.success());
        let o = child.wait_with_output().unwrap();
        assert_eq!(
            o.status.code(),
            Some(128 + number),
            "SIG{name}: {}",
            stderr_of(&o)
        );
        // No scratch folder, no partial file, no lock file, and the process gone.
        holds_exactly(d, &["big.ply"]);
    }
    // An experiment stopped in its staging folder: the folder gone, the previous results as
    // they were.
    let previous = d.join("r");
    let run = [
        "run",
        "reference",
        "--quick",
        "--datasets",
        "sphere-20000",
        "--out",
        previous.to_str().unwrap(),
    ];
    // The previous results: a run's own folder (one that is not pointsight's is refused).
    let o = ps(&run);
    assert!(o.status.success(), "{}", stderr_of(&o));
    let before = names(&previous);
    let results = std::fs::read(previous.join("results.csv")).unwrap();
    let child = started(&run, d, ".r.partial-");
    assert!(
        Command::new("kill")
            .args(["-s", "TERM", &child.id().to_string()])
            .status()
            .unwrap()
            .success()
    );
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(143), "{}", stderr_of(&o));
    holds_exactly(d, &["big.ply", "r"]);
    assert_eq!(names(&previous), before);
    assert_eq!(
        std::fs::read(previous.join("results.csv")).unwrap(),
        results
    );
    std::fs::remove_dir_all(&previous).unwrap();
    // A second run into an output being written is refused, naming the first.
    let first = started(&args, d, ".big.qsplat.chunks-");
    let o = ps(&args);
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!(
            "is being written by another pointsight (host {}, process {})",
            cloud::scratch::host(),
            first.id()
        )),
        "{err}"
    );
    let o = first.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr_of(&o));
    holds_exactly(d, &["big.ply", "big.qsplat"]);
}

#[test]
fn stale_scratch_of_dead_runs_is_reclaimed_and_other_hosts_left() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let host = cloud::scratch::host();
    let dead = dead_pid();
    let stale = d.join(format!(".s.qsplat.chunks-{host}-{dead}-0"));
    let other = d.join(format!(".s.qsplat.chunks-elsewhere-{host}-{dead}-0"));
    let partial = d.join(format!(".r.partial-{host}-{dead}-0"));
    for p in [&stale, &other, &partial] {
        std::fs::create_dir(p).unwrap();
        std::fs::write(p.join("junk.csv"), b"left by a killed run").unwrap();
    }
    // `clean` lists (a dry run), then removes what is stale (its temporary folder its own:
    // clean lists the external methods' folders there too, which other tests' runs hold).
    let tmp = tempfile::tempdir().unwrap();
    let clean = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_pointsight"))
            .arg("clean")
            .args(args)
            .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
            .env("TMPDIR", tmp.path())
            .output()
            .expect("the pointsight binary runs")
    };
    let o = clean(&[d.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(
        text.contains("state=stale") && text.contains("another host's"),
        "{text}"
    );
    assert!(
        text.contains("2 stale path(s): pointsight clean --remove"),
        "{text}"
    );
    assert!(stale.exists() && partial.exists());
    // A run beside them reclaims this host's dead ones and never reuses another's staging.
    let cloud = d.join("s.ply");
    sheet(&cloud, 5_000, 0);
    let o = ps(&[
        "lod-build",
        "--cloud",
        cloud.to_str().unwrap(),
        "--out",
        d.join("s.qsplat").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(!stale.exists() && !partial.exists() && other.exists());
    let o = ps(&[
        "run",
        "reference",
        "--quick",
        "--datasets",
        "sphere-20000",
        "--out",
        d.join("r").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(!d.join("r/junk.csv").exists());
    let o = clean(&["--remove", d.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("0 stale path(s) reclaimed"), "{text}");
    let mut want = vec![
        "r".to_owned(),
        "s.ply".to_owned(),
        "s.qsplat".to_owned(),
        other.file_name().unwrap().to_string_lossy().into_owned(),
    ];
    want.sort();
    assert_eq!(names(d), want);
}

/// An eye inside the object or among its points: said once, in plain words; HPR's `gamma=auto`
/// says what its rule needs; the robust operator refuses without sending the user to HPR.
#[test]
fn an_eye_inside_the_object_or_among_its_points_is_said_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.txt");
    let o_str = out.to_str().unwrap();
    // Inside the ball of the sphere-and-square scene, near the middle of its bounding box.
    let inside = |method: &str| {
        ps(&[
            "visible",
            "--dataset",
            "sphere-plane-24000",
            "--eye",
            "0,0.05,0.9",
            "--method",
            method,
            "--out",
            o_str,
        ])
    };
    let o = inside("raycast");
    let err = stderr_of(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(err.matches("inside the mesh").count(), 1, "{err}");
    assert!(
        err.contains("note: dataset sphere-plane-24000: the eye is inside the mesh"),
        "{err}"
    );
    let o = inside("hpr");
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("gamma=auto chooses how far HPR flips the points from how far the eye is")
            && err.contains("move the eye at least about")
            && err.contains("or radius=R with R >"),
        "{err}"
    );
    let o = inside("robust");
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("inside the cloud's convex hull")
            && err.contains("raycast or splat")
            && !err.contains("use hpr"),
        "{err}"
    );
    // Among the points: a sheet 0.01 apart, the eye 0.003 above one of them.
    let sheet: Vec<[f64; 3]> = (0..100)
        .flat_map(|i| (0..100).map(move |j| [i as f64 * 0.01, j as f64 * 0.01, 0.0]))
        .collect();
    let cloud = xyz_file(dir.path(), "sheet.xyz", &sheet);
    let o = ps(&[
        "visible",
        "--cloud",
        cloud.to_str().unwrap(),
        "--eye",
        "0.5,0.5,0.003",
        "--target",
        "0.5,0.5,-1",
        "--method",
        "raycast",
        "--out",
        o_str,
    ]);
    let err = stderr_of(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("the eye is among the points (0.0030 from the nearest")
            && err.contains("move the eye away from the points"),
        "{err}"
    );
    // From outside, nothing is said.
    let o = ps(&[
        "visible",
        "--dataset",
        "sphere-plane-24000",
        "--method",
        "raycast",
        "--out",
        o_str,
    ]);
    assert!(o.status.success());
    assert_eq!(stderr_of(&o), "");
}
