//! Shards on a real Slurm: `scripts/slurm-bench.sh` submits `run visibility --shard K/3` as a
//! job array of three tasks and `pointsight merge` as a job depending on it, on a single-node
//! cluster of Debian's slurmctld, slurmd and munge that `scripts/slurm-local.sh` installs
//! (apt-get, when missing) and starts in a temporary folder; the merged CSVs are an unsharded
//! run's, timings aside. A shard that fails is named with its log and nothing is merged.
//!
//! The cluster runs when `POINTSIGHT_SLURM=1` (CI sets it; it needs root, apt-get and a free
//! TCP port pair from 6817). Its daemons are stopped (by their pids) and its folders removed
//! when the test ends, passed or failed. The script's own argument checks always run.

use std::collections::BTreeMap;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

/// The sweeps of `tests/plugin.rs`' shards test: small and quick, no timing in the outcome.
const SMALL: &str = r#"
repeats = 2
[hpr]
[[hpr.grid]]
gamma = [2.0, 3.0]
[[hpr.grid]]
gamma = "auto"
[raycast]
[[raycast.grid]]
radius_factor = [1.0, 1.5]
size = [{width = 320, height = 180}]
[splat]
[[splat.grid]]
radius_px = [1.0, 2.0]
"#;

const DATASETS: &str = "sphere-plane-24000,torus-22321";

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scripts")
        .join(name)
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A single-node Slurm cluster in a temporary folder, stopped and removed when dropped.
struct Cluster {
    dir: tempfile::TempDir,
}

impl Cluster {
    fn conf(&self) -> PathBuf {
        self.dir.path().join("slurm.conf")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Cancels the cluster's jobs, then stops slurmd, slurmctld and munged by their pid
        // files; the folder goes with `dir` right after.
        match Command::new(script("slurm-local.sh"))
            .arg("stop")
            .arg(self.dir.path())
            .output()
        {
            Ok(out) if out.status.success() => {}
            Ok(out) => eprintln!("slurm-local.sh stop failed: {}", text(&out.stderr)),
            Err(e) => eprintln!("slurm-local.sh stop did not run: {e}"),
        }
    }
}

/// `findings.csv`'s columns that no timing decides.
fn verdicts(path: &Path) -> Vec<Vec<String>> {
    const KEEP: [&str; 10] = [
        "experiment",
        "condition",
        "method",
        "setting",
        "metric",
        "value",
        "low",
        "high",
        "n_views",
        "verdict",
    ];
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let header = r.headers().expect("csv header").clone();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| KEEP.contains(h))
        .map(|(i, _)| i)
        .collect();
    r.records()
        .map(|rec| {
            let rec = rec.expect("a csv record");
            keep.iter().map(|&i| rec[i].to_owned()).collect()
        })
        .collect()
}

/// The CSV without its timing columns.
fn untimed(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
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

/// `builds.csv` as (dataset, method, setting) → views answered. A sharded run prepares a
/// cloud once in each shard that owns some of its views, so its merged file has a row per
/// shard that ran the preparation; together they answered the unsharded run's views.
fn views_per_build(path: &Path) -> BTreeMap<(String, String, String), usize> {
    let rows = untimed(path);
    let col = |name: &str| {
        rows[0]
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()))
    };
    let (d, m, p, v) = (col("dataset"), col("method"), col("params"), col("views"));
    let mut sum = BTreeMap::new();
    for r in &rows[1..] {
        *sum.entry((r[d].clone(), r[m].clone(), r[p].clone()))
            .or_default() += r[v].parse::<usize>().expect("views is a count");
    }
    sum
}

/// The script under a deadline (coreutils' `timeout`: a cluster that never runs the jobs
/// fails the test instead of hanging it).
fn slurm_bench(work: &Path, conf: &Path, methods: &Path, args: &[&str]) -> Output {
    Command::new("timeout")
        .args(["--kill-after=5", "240"])
        .arg(script("slurm-bench.sh"))
        .args(args)
        .current_dir(work)
        .env("SLURM_CONF", conf)
        .env("SLURM_BENCH_POLL", "1")
        .env("POINTSIGHT_METHODS", methods)
        .output()
        .expect("timeout and bash run")
}

#[test]
fn a_sharded_run_on_slurm_merges_into_the_unsharded_csvs() {
    if std::env::var("POINTSIGHT_SLURM").as_deref() != Ok("1") {
        eprintln!("POINTSIGHT_SLURM is not 1: skipping the single-node Slurm cluster");
        return;
    }
    let t0 = Instant::now();
    let out = Command::new(script("slurm-local.sh"))
        .arg("install")
        .output()
        .expect("slurm-local.sh runs");
    assert!(
        out.status.success(),
        "installing Slurm: {}",
        text(&out.stderr)
    );
    let installed = t0.elapsed();

    // The guard exists before the start, so that daemons of a start that failed halfway stop.
    let cluster = Cluster {
        dir: tempfile::Builder::new()
            .prefix("ps-slurm")
            .tempdir()
            .expect("temporary folder"),
    };
    let out = Command::new(script("slurm-local.sh"))
        .arg("start")
        .arg(cluster.dir.path())
        .output()
        .expect("slurm-local.sh runs");
    assert!(
        out.status.success(),
        "starting the cluster: {}",
        text(&out.stderr)
    );
    let started = t0.elapsed();

    // The jobs run from a working folder of their own, with no external methods.
    let work = tempfile::tempdir().expect("temporary folder");
    let work = work.path();
    let methods = work.join("no-methods");
    std::fs::create_dir(&methods).expect("folder");
    std::fs::write(work.join("small.toml"), SMALL).expect("write the sweeps");
    let run = [
        "run",
        "visibility",
        "--quick",
        "--datasets",
        DATASETS,
        "--config",
        "small.toml",
    ];

    let whole = work.join("whole");
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(run)
        .arg("--out")
        .arg(&whole)
        .current_dir(work)
        .env("POINTSIGHT_METHODS", &methods)
        .output()
        .expect("pointsight runs");
    assert!(out.status.success(), "unsharded: {}", text(&out.stderr));
    let unsharded = t0.elapsed();

    let bin = env!("CARGO_BIN_EXE_pointsight");
    let args = [
        &["--bin", bin, "--shards", "3", "--out", "sharded"][..],
        &["--time", "10", "--mem", "1G", "--wait", "--"],
        &run,
    ]
    .concat();
    let out = slurm_bench(work, &cluster.conf(), &methods, &args);
    let err = text(&out.stderr);
    assert!(out.status.success(), "slurm-bench.sh: {err}");
    let sharded = work.join("sharded");
    assert_eq!(
        text(&out.stdout).lines().last(),
        Some(sharded.join("merged").to_str().expect("utf-8")),
        "the last line of stdout is the merged folder"
    );
    assert!(err.contains("all 3 shards succeeded"), "{err}");
    let merged_at = t0.elapsed();

    // Each shard ran as a task of the array and wrote its own folder.
    for k in 1..=3 {
        let log = std::fs::read_to_string(sharded.join(format!("slurm/shard-{k}.log")))
            .expect("the shard's log");
        assert!(log.contains(&format!("shard {k}/3, array task ")), "{log}");
        assert!(sharded.join(format!("shard-{k}/results.csv")).exists());
    }
    let merged = sharded.join("merged/visibility");
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(merged.join("metadata.json")).expect("merged metadata"),
    )
    .expect("metadata is JSON");
    let ks: Vec<u64> = meta["shards"]
        .as_array()
        .expect("the merged metadata lists its shards")
        .iter()
        .map(|s| s["shard"]["k"].as_u64().expect("a shard's k"))
        .collect();
    assert_eq!(ks, [1, 2, 3]);

    // Every CSV of the unsharded run, timings aside.
    let mut compared = Vec::new();
    for entry in std::fs::read_dir(&whole).expect("the unsharded folder") {
        let name = entry.expect("entry").file_name();
        let name = name.to_str().expect("utf-8").to_owned();
        if !name.ends_with(".csv") {
            continue;
        }
        if name == "builds.csv" {
            assert_eq!(
                views_per_build(&merged.join(&name)),
                views_per_build(&whole.join(&name)),
                "{name}: the views each preparation answered"
            );
        } else if name == "findings.csv" {
            // The verdicts, without what timings decide (costs, the cheapest choice).
            assert_eq!(
                verdicts(&merged.join(&name)),
                verdicts(&whole.join(&name)),
                "{name}"
            );
        } else if std::fs::metadata(whole.join(&name)).expect("csv").len() == 0 {
            // A table without rows is an empty file in both.
            assert_eq!(std::fs::read(merged.join(&name)).expect("csv").len(), 0);
        } else {
            assert_eq!(
                untimed(&merged.join(&name)),
                untimed(&whole.join(&name)),
                "{name}"
            );
        }
        compared.push(name);
    }
    compared.sort();
    assert!(
        compared.contains(&"results.csv".to_owned()) && compared.contains(&"pixels.csv".into()),
        "{compared:?}"
    );
    assert!(merged.join("summary.md").exists());

    // A shard that fails (exit status 3) and one whose job script dies (SIGKILL) are named
    // with their logs; the merge never runs.
    let fake = work.join("failing-pointsight");
    std::fs::write(
        &fake,
        "#!/bin/sh\ncase \" $* \" in\n\
         *\" --shard 2/3 \"*) echo 'injected failure' >&2; exit 3 ;;\n\
         *\" --shard 3/3 \"*) kill -KILL $PPID; sleep 5 ;;\n\
         esac\nexit 0\n",
    )
    .expect("write the fake binary");
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    let out = slurm_bench(
        work,
        &cluster.conf(),
        &methods,
        &[
            "--bin",
            fake.to_str().expect("utf-8"),
            "-n",
            "3",
            "-o",
            "failing",
            "--wait",
            "--",
            "run",
            "visibility",
        ],
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let logs = work.join("failing/slurm");
    for needle in [
        "shard 2/3 failed: pointsight exited with status 3".to_owned(),
        format!("its log: {}", logs.join("shard-2.log").display()),
        "injected failure".to_owned(),
        "shard 3/3 failed: no exit status".to_owned(),
        format!("its log: {}", logs.join("shard-3.log").display()),
        "2 of 3 shard(s) failed".to_owned(),
        "DependencyNeverSatisfied".to_owned(),
    ] {
        assert!(err.contains(&needle), "{needle:?} not in: {err}");
    }
    assert!(!err.contains("shard 1/3 failed"), "{err}");
    assert!(!work.join("failing/merged").exists());
    // The same report later, from the run's folder alone.
    let out = Command::new(script("slurm-bench.sh"))
        .args(["--check", "failing"])
        .current_dir(work)
        .env("SLURM_CONF", cluster.conf())
        .output()
        .expect("bash runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("shard 2/3 failed: pointsight exited with status 3"));

    eprintln!(
        "slurm: installed in {:.1} s, cluster up at {:.1} s, unsharded run {:.1} s, \
         sharded and merged {:.1} s, failing run {:.1} s",
        installed.as_secs_f64(),
        (started - installed).as_secs_f64(),
        (unsharded - started).as_secs_f64(),
        (merged_at - unsharded).as_secs_f64(),
        (t0.elapsed() - merged_at).as_secs_f64(),
    );
}

/// What the script refuses before it submits anything: no Slurm needed.
#[test]
fn the_script_says_what_is_wrong_before_submitting() {
    let empty = tempfile::tempdir().expect("temporary folder");
    // No sbatch on the PATH (an empty PATH: bash by its absolute path).
    let out = Command::new("/bin/bash")
        .arg(script("slurm-bench.sh"))
        .args(["-n", "3", "-o", "x", "--", "run", "visibility"])
        .current_dir(empty.path())
        .env("PATH", empty.path())
        .output()
        .expect("bash runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("sbatch not found on PATH"),
        "{}",
        text(&out.stderr)
    );
    for (args, needle) in [
        (
            &["-n", "0"][..],
            "--shards expects a whole number >= 1, got '0'",
        ),
        (&["--shards=x"], "--shards expects a whole number"),
        (&["--partition"], "--partition needs a value"),
        (
            &["--", "view"],
            "must start with `bench` or `run EXPERIMENT`, got 'view'",
        ),
        (
            &["--", "run", "--quick"],
            "`run` needs the experiment's name first",
        ),
        (
            &["--", "bench", "--shard", "1/2"],
            "pointsight's --shard is set by this script",
        ),
        (
            &["--", "run", "visibility", "--out=x"],
            "pointsight's --out=x is set by this script",
        ),
        (&["--frobnicate"], "unknown option --frobnicate"),
    ] {
        let out = Command::new(script("slurm-bench.sh"))
            .args(args)
            .current_dir(empty.path())
            .output()
            .expect("bash runs");
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    // Nothing was written.
    assert_eq!(std::fs::read_dir(empty.path()).expect("folder").count(), 0);
}
