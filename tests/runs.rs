//! A run's folders on disk: `pointsight merge` takes the shard folders of both layouts (`run
//! EXPERIMENT --shard K/N --out DIR` and `bench --shard K/N --reports DIR`), and a run that
//! fails leaves neither its staging folder nor a changed previous report behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn pointsight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_METHODS", "/nonexistent-methods")
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = pointsight(args);
    assert!(
        out.status.success(),
        "pointsight {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("stdout is UTF-8")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pointsight-runs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temporary folder");
    d
}

/// The CSV without its timing columns.
fn untimed(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(path).expect("csv file");
    let header = r.headers().expect("csv header").clone();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| !h.contains("seconds"))
        .map(|(i, _)| i)
        .collect();
    let mut rows = vec![keep.iter().map(|&i| header[i].to_owned()).collect()];
    for rec in r.records() {
        let rec = rec.expect("csv row");
        rows.push(keep.iter().map(|&i| rec[i].to_owned()).collect());
    }
    rows
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("readable folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// One or two settings per built-in visibility method.
const SMALL: &str = r#"
[hpr]
[[hpr.grid]]
gamma = [3.0, "auto"]
[raycast]
[[raycast.grid]]
radius = "auto"
size = [{width = 320, height = 180}]
[splat]
[[splat.grid]]
radius_px = [2.0]
"#;

/// A new user's sharded run: two shards written with `run ... --out DIR`, merged.
#[test]
fn merge_takes_the_folders_run_shard_out_writes() {
    let root = tmp("merge");
    // Small grids keep the test fast; the layout is the case's.
    let config = root.join("small.toml");
    std::fs::write(&config, SMALL).unwrap();
    let run = [
        "run",
        "visibility",
        "--quick",
        "--datasets",
        "sphere-20000",
        "--config",
        config.to_str().unwrap(),
        "--repeats",
        "1",
    ];
    let whole = root.join("whole");
    ok(&[&run[..], &["--out", whole.to_str().unwrap()]].concat());
    let shards: Vec<PathBuf> = (1..=2).map(|k| root.join(format!("s{k}"))).collect();
    for (k, dir) in shards.iter().enumerate() {
        let shard = format!("{}/2", k + 1);
        ok(&[
            &run[..],
            &["--shard", &shard, "--out", dir.to_str().unwrap()],
        ]
        .concat());
        assert!(dir.join("metadata.json").exists());
    }
    let merged = root.join("m");
    let text = ok(&[
        "merge",
        "--out",
        merged.to_str().unwrap(),
        shards[0].to_str().unwrap(),
        shards[1].to_str().unwrap(),
    ]);
    assert!(text.starts_with("visibility: merged into"), "{text}");
    let whole_rows = untimed(&whole.join("results.csv"));
    assert!(whole_rows.len() > 2, "{whole_rows:?}");
    // Each shard holds part of the rows; merged, they are the unsharded run's.
    let s1 = untimed(&shards[0].join("results.csv"));
    assert!(s1.len() > 1 && s1.len() < whole_rows.len());
    assert_eq!(untimed(&merged.join("visibility/results.csv")), whole_rows);
    assert!(merged.join("visibility/summary.md").exists());
    assert!(merged.join("README.md").exists());
    // The bench layout (DIR/EXPERIMENT/) still merges, mixed with the run layout.
    let bench_like = root.join("b2");
    std::fs::create_dir_all(&bench_like).unwrap();
    std::fs::rename(&shards[1], bench_like.join("visibility")).unwrap();
    let merged2 = root.join("m2");
    ok(&[
        "merge",
        "--out",
        merged2.to_str().unwrap(),
        shards[0].to_str().unwrap(),
        bench_like.to_str().unwrap(),
    ]);
    assert_eq!(untimed(&merged2.join("visibility/results.csv")), whole_rows);
    // A folder of neither layout is named, with both layouts.
    let empty = root.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = pointsight(&[
        "merge",
        "--out",
        root.join("m3").to_str().unwrap(),
        empty.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("no experiment results in")
            && err.contains("--out DIR")
            && err.contains("--reports DIR"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// A run that fails after its staging folder was made (a dataset that does not load: the
/// bunny without `pointsight fetch`) removes the staging folder and keeps the previous report.
#[test]
fn a_failed_run_leaves_no_staging_folder_and_the_previous_report() {
    let root = tmp("failed");
    let out = root.join("visibility");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("results.csv"), "previous results\n").unwrap();
    // The previous report is pointsight's: its metadata lists what it wrote.
    let meta = r#"{"experiment": "visibility", "date_utc": "2026-01-01T00:00:00Z",
        "git_revision": "unknown", "git_dirty": false, "rustc": "rustc", "cpu": "cpu",
        "cores": 2, "os": "linux", "command": "pointsight", "quick": true, "datasets": [],
        "parameters": null, "seconds": 1.0, "files": ["results.csv"]}"#;
    std::fs::write(out.join("metadata.json"), meta).unwrap();
    let run = pointsight(&[
        "run",
        "visibility",
        "--quick",
        "--datasets",
        "bunny",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(err.contains("pointsight fetch"), "{err}");
    assert_eq!(names_in(&root), vec!["visibility".to_owned()]);
    assert_eq!(names_in(&out), vec!["metadata.json", "results.csv"]);
    assert_eq!(
        std::fs::read_to_string(out.join("results.csv")).unwrap(),
        "previous results\n"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// `--time-budget`: a call stops repeating once its runs took that long (0: one run each),
/// `inf` makes every `--repeats` run; the rows say how many runs they had.
#[test]
fn the_time_budget_sets_how_many_runs_a_call_gets() {
    let root = tmp("budget");
    let config = root.join("small.toml");
    std::fs::write(&config, SMALL).unwrap();
    // Each row's (status, samples) from `run EXPERIMENT --quick ... --time-budget BUDGET`.
    let rows = |experiment: &str, extra: &[&str], budget: &str| -> Vec<(String, String)> {
        let out = root.join(format!("{experiment}-{budget}"));
        let mut args = vec![
            "run",
            experiment,
            "--quick",
            "--datasets",
            "sphere-20000",
            "--repeats",
            "3",
            "--time-budget",
            budget,
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        ok(&args);
        let mut r = csv::Reader::from_path(out.join("results.csv")).expect("results.csv");
        let h = r.headers().unwrap().clone();
        let col = |name: &str| h.iter().position(|c| c == name).expect(name);
        let (status, samples) = (col("status"), col("samples"));
        r.records()
            .map(|rec| {
                let rec = rec.unwrap();
                (rec[status].to_owned(), rec[samples].to_owned())
            })
            .collect()
    };
    let check = |once: Vec<String>, all: Vec<String>| {
        assert!(
            !once.is_empty() && once.iter().all(|s| s == "1"),
            "{once:?}"
        );
        assert!(
            all.len() == once.len() && all.iter().all(|s| s == "3"),
            "{all:?}"
        );
    };
    // Every visibility row, through the measurement kernel.
    let config = ["--config", config.to_str().unwrap()];
    let every = |budget| -> Vec<String> {
        rows("visibility", &config, budget)
            .into_iter()
            .map(|(_, samples)| samples)
            .collect()
    };
    check(every("0"), every("inf"));
    // The hull experiment's own loop over hull implementations honours the same budget (its
    // skipped configurations are rows without runs).
    let ran = |budget| -> Vec<String> {
        rows("hull", &[], budget)
            .into_iter()
            .filter(|(status, _)| status == "ok")
            .map(|(_, samples)| samples)
            .collect()
    };
    check(ran("0"), ran("inf"));
    let _ = std::fs::remove_dir_all(&root);
}
