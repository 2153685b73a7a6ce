//! Output folders through every command that writes one (`run --out`, `merge --out`, `bench
//! --reports`, `visible --view all --out`): a missing folder is made, a folder pointsight wrote
//! is replaced, and anything else is refused before any work and left as it was: a user's
//! folder with notes and figures, the folder holding the command's input, one of pointsight's
//! with a user's file added, and the working folder (`--out .`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cloud::PointCloud;
use cloud::synth::sphere_plane_scene;

fn pointsight(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .current_dir(dir)
        .env("POINTSIGHT_METHODS", "/nonexistent-methods")
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

/// Runs a command that must be refused; returns its standard error.
fn refused(dir: &Path, args: &[&str]) -> String {
    let out = pointsight(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "pointsight {args:?}: {err}");
    err
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pointsight-folders-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temporary folder");
    d
}

/// A user's folder: notes and a folder of figures.
fn users_folder(dir: &Path) {
    std::fs::create_dir_all(dir.join("figs")).expect("figs");
    std::fs::write(dir.join("notes.txt"), "my notes").expect("notes");
    std::fs::write(dir.join("figs/one.png"), "not really a png").expect("figure");
}

fn users_folder_is_intact(dir: &Path) {
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).expect("notes kept"),
        "my notes"
    );
    assert!(dir.join("figs/one.png").is_file(), "figures kept");
}

/// A small scene as a PLY file, and a sweep small enough to run in seconds.
fn scene(dir: &Path) -> (PathBuf, PathBuf) {
    let (scene, _) = sphere_plane_scene(1_000, 2_000, 7);
    let cloud = dir.join("scene.ply");
    cloud::io::ply_write::write_ply(
        &cloud,
        &PointCloud {
            positions: scene.cloud.positions,
            ..PointCloud::default()
        },
    )
    .expect("the PLY file is written");
    let config = dir.join("small.toml");
    std::fs::write(
        &config,
        "[hpr]\n[[hpr.grid]]\ngamma = [3.0]\n[raycast]\n[[raycast.grid]]\nradius = \"auto\"\nsize = [{width = 160, height = 90}]\n",
    )
    .expect("config");
    (cloud, config)
}

fn run_visibility<'a>(cloud: &'a str, config: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "run",
        "visibility",
        "--quick",
        "--cloud",
        cloud,
        "--eye",
        "3,0.5,1",
        "--config",
        config,
        "--out",
        out,
    ]
}

#[test]
fn run_out_makes_replaces_or_refuses_a_folder() {
    let root = tmp("run");
    let (cloud, config) = scene(&root);
    let (cloud, config) = (cloud.to_str().unwrap(), config.to_str().unwrap());

    // A missing folder is made; run again, the folder (pointsight's) is replaced.
    ok(&root, &run_visibility(cloud, config, "mine/run"));
    assert!(root.join("mine/run/results.csv").is_file());
    ok(&root, &run_visibility(cloud, config, "mine/run"));

    // A user's folder is refused, named, and kept as it was.
    let thesis = root.join("mythesis");
    users_folder(&thesis);
    let err = refused(&root, &run_visibility(cloud, config, "mythesis"));
    assert!(
        err.contains("holds files pointsight did not write (figs/, notes.txt)"),
        "{err}"
    );
    users_folder_is_intact(&thesis);
    assert_eq!(std::fs::read_dir(&thesis).unwrap().count(), 2);

    // Pointsight's folder with a user's file added: refused, the file kept.
    std::fs::write(root.join("mine/run/notes.txt"), "mine").unwrap();
    let err = refused(&root, &run_visibility(cloud, config, "mine/run"));
    assert!(err.contains("(notes.txt)"), "{err}");
    assert!(root.join("mine/run/notes.txt").is_file());
    assert!(root.join("mine/run/results.csv").is_file());

    // The folder holding the input: refused whatever else it holds.
    let proj = root.join("proj");
    std::fs::create_dir(&proj).unwrap();
    std::fs::copy(cloud, proj.join("cloud.ply")).unwrap();
    let err = refused(&root, &run_visibility("proj/cloud.ply", config, "proj"));
    assert!(err.contains("an input of this command"), "{err}");
    assert!(proj.join("cloud.ply").is_file());

    // Run from inside the data's folder with `--out .`: refused in those words.
    let err = refused(&proj, &run_visibility("cloud.ply", config, "."));
    assert!(err.contains("`.` is the folder you are in"), "{err}");
    assert!(proj.join("cloud.ply").is_file());
    assert_eq!(std::fs::read_dir(&proj).unwrap().count(), 1);
}

#[test]
fn visible_for_many_views_makes_replaces_or_refuses_a_folder() {
    let root = tmp("visible");
    let (cloud, _) = scene(&root);
    let args = |out: &'static str| -> Vec<String> {
        [
            "visible",
            "--cloud",
            cloud.to_str().unwrap(),
            "--eye",
            "3,0.5,1",
            "--view",
            "all",
            "--method",
            "hpr",
            "--out",
            out,
        ]
        .map(str::to_owned)
        .to_vec()
    };
    let run = |out: &'static str| {
        let a = args(out);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        pointsight(&root, &a)
    };
    for _ in 0..2 {
        let out = run("answers");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(root.join("answers/view-0.txt").is_file());
    // An experiment's folder is not a views folder.
    let thesis = root.join("mythesis");
    users_folder(&thesis);
    let out = run("mythesis");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("(figs/, notes.txt)"), "{err}");
    users_folder_is_intact(&thesis);
    std::fs::write(root.join("answers/mine.txt"), "x").unwrap();
    let out = run("answers");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("(mine.txt)"));
    assert!(root.join("answers/mine.txt").is_file());
}

#[test]
fn bench_reports_and_merge_out_make_replace_or_refuse_a_folder() {
    let root = tmp("bench");
    let bench = |reports: &str| {
        pointsight(
            &root,
            &[
                "bench",
                "--quick",
                "--datasets",
                "sphere-plane-24000",
                "--experiments",
                "reference",
                "--reports",
                reports,
            ],
        )
    };
    for _ in 0..2 {
        let out = bench("reports");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(root.join("reports/reference/metadata.json").is_file());
    assert!(root.join("reports/README.md").is_file());

    let thesis = root.join("mythesis");
    users_folder(&thesis);
    let out = bench("mythesis");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("(figs/, notes.txt)"));
    users_folder_is_intact(&thesis);
    assert_eq!(std::fs::read_dir(&thesis).unwrap().count(), 2);

    // A user's file beside the report, or inside an experiment's folder: refused.
    for added in ["reports/mine.md", "reports/reference/mine.md"] {
        std::fs::write(root.join(added), "mine").unwrap();
        let out = bench("reports");
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("mine.md)"), "{err}");
        assert!(root.join(added).is_file());
        std::fs::remove_file(root.join(added)).unwrap();
    }

    // `merge --out`: the shards of a sharded run into a user's folder, then into a new one.
    let mut shards = Vec::new();
    for k in 1..=2 {
        let dir = format!("shard{k}");
        let shard = format!("{k}/2");
        ok(
            &root,
            &[
                "bench",
                "--quick",
                "--datasets",
                "sphere-plane-24000",
                "--experiments",
                "reference",
                "--shard",
                &shard,
                "--reports",
                &dir,
            ],
        );
        shards.push(dir);
    }
    let merge = |out: &str| {
        let mut args = vec!["merge", "--out", out];
        args.extend(shards.iter().map(String::as_str));
        pointsight(&root, &args)
    };
    let out = merge("mythesis");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("(figs/, notes.txt)"));
    users_folder_is_intact(&thesis);
    for _ in 0..2 {
        let out = merge("merged");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(root.join("merged/reference/results.csv").is_file());
    // A shard's folder is an input: merging into it is refused.
    let out = merge("shard1");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("is the input"), "{err}");
    assert!(root.join("shard1/reference/metadata.json").is_file());
}
