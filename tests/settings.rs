//! One setting syntax on every command that runs a method: `--set [METHOD.]KEY=VALUE`, typed by
//! each method's card before any data is read (a bad value is the setting's error, never the
//! point file's), one value on `visible` and `view`, a list `A,B,C` a sweep on `run` and
//! `bench`; an unknown method or key is refused with what is accepted.

use std::path::Path;
use std::process::{Command, Output};

fn pointsight(args: &[&str], script: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_METHODS", "/nonexistent-methods")
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .env("POINTSIGHT_VIEWER_JS", script)
        .output()
        .expect("the pointsight binary runs")
}

/// The standard error of a command that must fail.
fn fails(args: &[&str], script: &Path) -> String {
    let out = pointsight(args, script);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} should fail: {err}");
    err
}

#[test]
fn a_bad_value_is_refused_before_the_point_file_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "").unwrap();
    // A point file that is not there: an error about it would mean it was read first.
    let missing = dir.path().join("absent-huge.laz");
    let missing = missing.to_str().unwrap();
    let out = dir.path().join("out.txt");
    let out = out.to_str().unwrap();
    let page = dir.path().join("p.html");
    let page = page.to_str().unwrap();
    let visible = |set: &str| {
        fails(
            &[
                "visible", "--cloud", missing, "--eye", "0,0,5", "--method", "hpr", "--set", set,
                "--out", out,
            ],
            &script,
        )
    };
    for (set, message) in [
        (
            "gamma=abc",
            "error: --set gamma=abc: method hpr: expected a number or auto",
        ),
        (
            "kernel=box",
            "error: --set kernel=box: method hpr: expected linear, exp, log or expdecay",
        ),
        (
            "perturb=x",
            "error: --set perturb=x: method hpr: expected a number",
        ),
        (
            "hpr.seed=-1",
            "error: --set seed=-1: method hpr: expected a whole number",
        ),
    ] {
        let err = visible(set);
        assert!(err.contains(message), "{set}: {err}");
        assert!(
            !err.contains("absent-huge"),
            "{set}: the file was read first: {err}"
        );
    }
    // `view` and `view --lod` type every chosen method's setting first too.
    for lod in [false, true] {
        let (methods, set) = if lod {
            ("qsplat", "qsplat.threshold_px=wide")
        } else {
            ("hpr,splat", "splat.radius_px=big")
        };
        let mut args = vec![
            "view",
            "--cloud",
            missing,
            "--eye",
            "1,2,3",
            "--methods",
            methods,
            "--set",
            set,
            "--out",
            page,
        ];
        if lod {
            args.push("--lod");
        }
        let err = fails(&args, &script);
        assert!(
            err.contains("method ") && err.contains("expected a number"),
            "{err}"
        );
        assert!(!err.contains("absent-huge"), "{err}");
    }
    // `run` and `bench`, before any dataset is made.
    for args in [
        &[
            "run",
            "visibility",
            "--datasets",
            "sphere-20000",
            "--set",
            "hpr.gamma=3,abc",
        ][..],
        &[
            "bench",
            "--experiments",
            "visibility",
            "--datasets",
            "sphere-20000",
            "--set",
            "hpr.gamma=3,abc",
        ],
    ] {
        let start = std::time::Instant::now();
        let err = fails(args, &script);
        assert!(
            err.contains("error: --set gamma=abc: method hpr: expected a number or auto"),
            "{args:?}: {err}"
        );
        assert!(start.elapsed().as_secs_f64() < 30.0, "{args:?}");
    }
}

#[test]
fn one_setting_on_visible_and_view_unknown_names_listed() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "").unwrap();
    let out = dir.path().join("out.txt");
    let out = out.to_str().unwrap();
    let visible = |set: &str| {
        fails(
            &[
                "visible",
                "--dataset",
                "sphere-20000",
                "--method",
                "hpr",
                "--set",
                set,
                "--out",
                out,
            ],
            &script,
        )
    };
    let err = visible("gamma=2,3");
    assert!(
        err.contains("--set gamma=2,3: a list of values is a sweep, and sweeps are for `run` and `bench`; `visible` runs one setting"),
        "{err}"
    );
    let page = dir.path().join("p.html");
    let err = fails(
        &[
            "view",
            "--dataset",
            "sphere-20000",
            "--methods",
            "hpr",
            "--set",
            "hpr.gamma=2,3",
            "--out",
            page.to_str().unwrap(),
        ],
        &script,
    );
    assert!(err.contains("`view` runs one setting"), "{err}");
    // Unknown key: the method's keys; unknown method: the methods.
    let err = visible("gama=3");
    assert!(
        err.contains("unknown parameter gama for method hpr; it accepts: gamma, radius, kernel"),
        "{err}"
    );
    let err = visible("nosuch.gamma=3");
    assert!(
        err.contains("unknown method \"nosuch\"") && err.contains("raycast"),
        "{err}"
    );
    let err = visible("splat.radius_px=3");
    assert!(
        err.contains("method splat is not run here (the chosen: hpr)"),
        "{err}"
    );
    // `run`: a key no method with a sweep has, with their keys.
    let err = fails(
        &[
            "run",
            "visibility",
            "--datasets",
            "sphere-20000",
            "--set",
            "nokey=1",
        ],
        &script,
    );
    assert!(
        err.contains("--set nokey=1: no chosen method (") && err.contains("gamma"),
        "{err}"
    );
}

/// `run visibility --set hpr.gamma=2,3`: hpr measured at its default setting with γ at 2 and
/// at 3, nothing else of hpr's grid; the other methods at their grids.
#[test]
fn a_list_on_run_is_the_methods_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("viewer.js");
    std::fs::write(&script, "").unwrap();
    let config = dir.path().join("small.toml");
    std::fs::write(
        &config,
        "[raycast]\n[[raycast.grid]]\nradius = \"auto\"\nsize = [{width = 320, height = 180}]\n\
         [splat]\n[[splat.grid]]\nradius_px = [2.0]\n",
    )
    .unwrap();
    let results = dir.path().join("run");
    let out = pointsight(
        &[
            "run",
            "visibility",
            "--quick",
            "--datasets",
            "sphere-20000",
            "--config",
            config.to_str().unwrap(),
            "--set",
            "hpr.gamma=2,3",
            "--set",
            "radius_px=3",
            "--repeats",
            "1",
            "--out",
            results.to_str().unwrap(),
        ],
        &script,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut r = csv::Reader::from_path(results.join("results.csv")).expect("results.csv");
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).expect(name);
    let (method, params) = (col("method"), col("params"));
    let mut hpr = std::collections::BTreeSet::new();
    let mut splat = std::collections::BTreeSet::new();
    for rec in r.records() {
        let rec = rec.unwrap();
        match &rec[method] {
            "hpr" => hpr.insert(rec[params].to_owned()),
            "splat" => splat.insert(rec[params].to_owned()),
            _ => false,
        };
    }
    assert_eq!(
        hpr.into_iter().collect::<Vec<_>>(),
        [
            "gamma=2;kernel=linear;perturb=0;seed=2007",
            "gamma=3;kernel=linear;perturb=0;seed=2007"
        ]
    );
    // A key without a method: every method with it, over its default setting (after --config).
    assert!(
        !splat.is_empty() && splat.iter().all(|p| p.contains("radius_px=3")),
        "{splat:?}"
    );
}
