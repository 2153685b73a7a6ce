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
                std::env::temp_dir()
                    .join("pointsight-bad-views-out")
                    .as_os_str(),
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
            "error: --set gamma=x: invalid float literal\n",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "kernel=box"],
            "error: --set kernel=box: expected linear, exp, log or expdecay\n",
        ),
        (
            &["--view", "0", "--method", "hpr", "--set", "gamma"],
            "error: --set gamma: expected NAME=VALUE\n",
        ),
        (&["--view", "99", "--method", "hpr"], "view 99"),
        // Image options without an eye would be silently ignored: refused instead.
        (
            &["--view", "0", "--method", "raycast", "--width", "64"],
            "--eye",
        ),
    ];
    let out_file = std::env::temp_dir().join("pointsight-bad-params.txt");
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

    // The eye on a point: HPR refuses (the flip's direction is undefined there); the ray cast
    // returns that point alone (every ray starts inside its prism, distance 0).
    let mut ball: Vec<[f64; 3]> = grid.iter().map(|p| [p[0], p[1], -1.0]).collect();
    ball.push([0.0, 0.0, 3.0]);
    let eye_on = xyz_file(dir.path(), "eye_on.xyz", &ball);
    let o = visible(&eye_on, "0,0,3", "hpr", &out);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("the viewpoint coincides with point 400"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = visible(&eye_on, "0,0,3", "raycast", &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(visible_set(&out), vec![400]);
}
