//! The one plug-in point: a throwaway visibility method (one card and its adapter below, one
//! `register` call) appears in the visibility experiment's CSV, plots and tables with no change
//! to the harness; sweeps come from a TOML file; a sharded run merged gives the unsharded CSVs.

use std::path::{Path, PathBuf};
use std::process::Command;

use cloud::Camera;
use harness::experiments::{self, Context};
use registry::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, args_of};
use registry::{
    Card, Family, Input, Kind, Memory, Method, MethodSweep, Output, Param, Prepared, Reader,
    Setting, Setup, Sweeps,
};

/// A card of this test: no memory figure, no peer.
fn card(
    name: &'static str,
    summary: &'static str,
    params: &'static [Param],
    sweep: Option<MethodSweep>,
    kind: Kind,
) -> &'static Card {
    Box::leak(Box::new(Card {
        name,
        summary,
        params,
        family: Family::Name,
        memory: Memory::Unknown,
        parallel_views: false,
        peer_of: None,
        peer_keys: &[],
        compared_in: &[],
        bare_node_bytes: None,
        sweep,
        program: None,
        made_for: registry::Metric::Points,
        exact: false,
        kind,
    }))
}

/// Test-only method: the `fraction` of the points nearest to the eye are called visible.
struct Nearest;

const FRACTION: Param = Param::value("fraction", "0.5", "share of the points kept");

/// Its setting.
struct NearestArgs(f64);

struct NearestPrep<'a> {
    points: &'a [cloud::glam::DVec3],
    fraction: f64,
}

impl Prepared for NearestPrep<'_> {
    fn visible(&self, camera: &Camera) -> registry::Result<Output> {
        let mut by: Vec<(f64, u32)> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| ((*p - camera.eye).length(), i as u32))
            .collect();
        by.sort_by(|a, b| a.0.total_cmp(&b.0));
        let keep = (self.fraction * by.len() as f64) as usize;
        let mut visible: Vec<u32> = by[..keep].iter().map(|x| x.1).collect();
        visible.sort_unstable();
        Ok(Output {
            visible,
            ..Output::default()
        })
    }
}

impl Method for Nearest {
    fn parse(&self, r: &mut Reader<'_>) -> registry::Result<Box<dyn Setup>> {
        Ok(Box::new(NearestArgs(r.get(&FRACTION)?)))
    }
}

impl Setup for NearestArgs {
    fn prepare<'a>(&'a self, input: Input<'a>) -> registry::Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(NearestPrep {
            points: &input.cloud.positions,
            fraction: self.0,
        }))
    }
}

/// Nearest's card, with its own sweep.
fn nearest() -> &'static Card {
    card(
        "test-nearest",
        "test only: the nearest fraction of the points",
        &[FRACTION],
        toml::from_str("[[grid]]\nfraction = [0.3, 0.5, 0.7]")
            .ok()
            .and_then(|t| MethodSweep::from_toml(&t, "test-nearest").ok()),
        Kind::Visibility(&Nearest),
    )
}

/// Small grids for the built-in methods, so the test stays fast.
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

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pointsight-plugin-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temporary folder");
    dir
}

#[test]
fn a_registered_method_reaches_the_csv_plots_and_tables() {
    let mut run = harness::run::Run::builtin();
    run.catalogue.add(nearest()).unwrap();
    assert!(
        run.catalogue.add(nearest()).is_err(),
        "a name is added once"
    );
    let sweeps = run
        .catalogue
        .sweeps(Some(Sweeps::parse(SMALL, "small").unwrap()))
        .unwrap();
    assert_eq!(sweeps.methods["test-nearest"].grid.len(), 3);
    let out = tmp("visibility");
    let ctx = Context {
        sweeps,
        repeats: 2,
        ..Context::new(
            std::sync::Arc::new(run),
            PathBuf::from("bench-data"),
            out.join("visibility"),
            true,
            vec!["sphere-plane-24000".into()],
        )
    };
    let exp = experiments::experiment("visibility").unwrap();
    assert!(experiments::run(exp, &ctx).unwrap());
    let dir = out.join("visibility");
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let mine: Vec<&str> = csv
        .lines()
        .filter(|l| l.contains(",test-nearest,"))
        .collect();
    // 3 settings × 2 views (quick), each scored.
    assert_eq!(mine.len(), 6, "{csv}");
    for line in &mine {
        assert!(line.contains(",2,ok,points,"), "{line}");
        assert!(line.contains("fraction="), "{line}");
    }
    // Plots: its own F1 chart (its swept parameter) and the Pareto plot.
    for png in ["f1_test-nearest.png", "pareto_sphere-plane-24000.png"] {
        let bytes = std::fs::read(dir.join(png)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG") && bytes.len() > 5_000,
            "{png}"
        );
    }
    // Tables: the best-setting table has its row.
    let summary = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(
        summary.contains("| sphere-plane-24000 | test-nearest | fraction="),
        "{summary}"
    );
    // Its figure, titled, linked from the summary.
    assert!(summary.contains("](f1_test-nearest.png)"), "{summary}");
    // The built-in families are still there, with the sweep of the file.
    assert_eq!(csv.lines().filter(|l| l.contains(",hpr,")).count(), 6);
    assert_eq!(csv.lines().filter(|l| l.contains(",raycast,")).count(), 4);
    let _ = std::fs::remove_dir_all(&out);
}

fn pointsight(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_METHODS", "/nonexistent-methods")
        .output()
        .expect("pointsight runs");
    assert!(
        out.status.success(),
        "pointsight {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The CSV without its timing columns.
fn untimed(path: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(path).expect("csv file");
    let header = r.headers().expect("csv header").clone();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        // Timing, and how many timed runs a call got (fewer once its runs took the time budget).
        .filter(|(_, h)| !h.contains("seconds") && *h != "samples")
        .map(|(i, _)| i)
        .collect();
    let mut rows = vec![keep.iter().map(|&i| header[i].to_owned()).collect()];
    for rec in r.records() {
        let rec = rec.expect("csv row");
        rows.push(keep.iter().map(|&i| rec[i].to_owned()).collect());
    }
    rows
}

#[test]
fn shards_merged_give_the_unsharded_csvs() {
    let root = tmp("shards");
    let config = root.join("small.toml");
    std::fs::write(&config, SMALL).unwrap();
    let config = config.to_str().unwrap();
    let common = [
        "run",
        "visibility",
        "--quick",
        "--datasets",
        "sphere-plane-24000,torus-22321",
        "--config",
        config,
    ];
    let whole = root.join("whole");
    pointsight(
        &[
            &common[..],
            &["--out", whole.join("visibility").to_str().unwrap()],
        ]
        .concat(),
    );
    let mut shard_dirs = Vec::new();
    for k in 1..=3 {
        let d = root.join(format!("shard{k}"));
        let shard = format!("{k}/3");
        let out = pointsight(
            &[
                &common[..],
                &[
                    "--shard",
                    &shard,
                    "--out",
                    d.join("visibility").to_str().unwrap(),
                ],
            ]
            .concat(),
        );
        assert!(out.status.success());
        shard_dirs.push(d);
    }
    // A shard holds only its cells: (dataset, view) dealt round-robin, 4 cells over 3 shards.
    let s1 = untimed(&shard_dirs[0].join("visibility/results.csv"));
    assert!(s1.len() > 1 && s1.len() < untimed(&whole.join("visibility/results.csv")).len());
    let merged = root.join("merged");
    let mut args = vec!["merge", "--out", merged.to_str().unwrap()];
    args.extend(shard_dirs.iter().map(|d| d.to_str().unwrap()));
    pointsight(&args);
    for csv in ["results.csv", "pixels.csv", "agreement.csv", "peers.csv"] {
        assert_eq!(
            untimed(&merged.join("visibility").join(csv)),
            untimed(&whole.join("visibility").join(csv)),
            "{csv}"
        );
    }
    assert!(merged.join("visibility/summary.md").exists());
    assert!(merged.join("visibility/renders.png").exists());
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(merged.join("visibility/metadata.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(meta["shards"].as_array().unwrap().len(), 3);
    assert!(meta["shards"][0]["cpu"].is_string());
    // A missing shard is an error naming it.
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(["merge", "--out", root.join("bad").to_str().unwrap()])
        .args(shard_dirs[..2].iter().map(|d| d.to_str().unwrap()))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("shard(s) 3/3 missing"));
    // A shard count from an edited metadata file is not a size to allocate by.
    let meta_path = shard_dirs[0].join("visibility/metadata.json");
    let text = std::fs::read_to_string(&meta_path).expect("metadata");
    let huge = text.replace("\"n\": 3", "\"n\": 1000000000000000000");
    assert_ne!(text, huge);
    let lone = root.join("lone/visibility");
    std::fs::create_dir_all(&lone).expect("folder");
    for f in std::fs::read_dir(shard_dirs[0].join("visibility")).expect("shard") {
        let f = f.expect("entry").path();
        std::fs::copy(&f, lone.join(f.file_name().expect("name"))).expect("copy");
    }
    std::fs::write(lone.join("metadata.json"), huge).expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(["merge", "--out", root.join("bad2").to_str().expect("utf-8")])
        .arg(root.join("lone"))
        .output()
        .expect("pointsight runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("and 999999999999999989 more missing"),
        "{err}"
    );
    // The settings are typed data: labels read back.
    let s = Setting::parse("gamma=3;kernel=linear;perturb=0.00001");
    assert_eq!(s.number("perturb"), Some(1e-5));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn bad_shard_and_config_are_errors() {
    for (args, needle) in [
        (vec!["--shard", "0/2"], "1 <= K <= N"),
        (vec!["--shard", "3/2"], "1 <= K <= N"),
        (vec!["--shard", "x"], "K/N"),
        (vec!["--repeats", "1001"], "1..=1000"),
        (vec!["--time-budget=-1"], "0 or more"),
        (vec!["--time-budget", "soon"], "0 or more"),
        (vec!["--config", "/nonexistent.toml"], "nonexistent.toml"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
            .args([
                "run",
                "visibility",
                "--quick",
                "--datasets",
                "sphere-plane-24000",
            ])
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    // The printed built-in sweeps are a valid config.
    let out = pointsight(&["sweeps"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let parsed = Sweeps::parse(&text, "printed").unwrap();
    let catalogue = registry::Catalogue::builtin();
    assert_eq!(
        catalogue.sweeps(Some(parsed)).unwrap(),
        catalogue.sweeps(None).unwrap()
    );
}

/// Test-only LOD method: every `k`-th point, splats grown by sqrt(k).
struct EveryKth;
struct EveryKthBuilt(usize);
struct EveryKthSel<'s> {
    input: &'s LodInput<'s>,
    n: usize,
    k: usize,
    kept: Vec<usize>,
}

const K: Param = Param::value("k", "2", "keep one point in k");

/// Its setting.
struct EveryKthArgs(usize);

impl LodMethod for EveryKth {
    fn parse(&self, r: &mut Reader<'_>) -> registry::Result<LodArgs> {
        Ok(Box::new(EveryKthArgs(r.get::<usize>(&K)?.max(1))))
    }
    fn build(&self, input: &LodInput<'_>) -> registry::Result<Box<dyn LodBuilt>> {
        Ok(Box::new(EveryKthBuilt(input.cloud.len())))
    }
}

impl LodBuilt for EveryKthBuilt {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.0,
            bytes: 0.0,
        }
    }
    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> registry::Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(EveryKthSel {
            input,
            n: self.0,
            k: args_of::<EveryKthArgs>(args, "test-every-kth")?.0,
            kept: Vec::new(),
        }))
    }
}

impl LodSelector for EveryKthSel<'_> {
    fn select(&mut self, _camera: &Camera) -> registry::Result<()> {
        self.kept = (0..self.n).step_by(self.k).collect();
        Ok(())
    }
    fn splats(&self) -> Vec<splat::render::Splat> {
        let r = self.input.radius * (self.k as f64).sqrt();
        self.kept
            .iter()
            .map(|&i| self.input.point_splat(i, r))
            .collect()
    }
}

#[test]
fn a_registered_lod_method_reaches_the_csv_plots_and_tables() {
    let mut run = harness::run::Run::builtin();
    run.catalogue
        .add(card(
            "test-every-kth",
            "test only: every k-th point",
            &[K],
            None,
            Kind::Lod(&EveryKth),
        ))
        .unwrap();
    let config = r#"
        [test-every-kth]
        [[test-every-kth.grid]]
        k = [2, 4]
        [qsplat]
        [[qsplat.grid]]
        threshold_px = 2.0
        [spt]
        [[spt.grid]]
        epsilon_px = 1.0
        [srn]
        [[srn.grid]]
        scale = 1.0
        [random]
        [[random.grid]]
        fraction = 0.25
    "#;
    let sweeps = run
        .catalogue
        .sweeps(Some(Sweeps::parse(config, "lod config").unwrap()))
        .unwrap();
    let out = tmp("lod");
    let ctx = Context {
        sweeps,
        repeats: 1,
        ..Context::new(
            std::sync::Arc::new(run),
            PathBuf::from("bench-data"),
            out.join("lod"),
            true,
            vec!["sphere-plane-24000".into()],
        )
    };
    let exp = experiments::experiment("lod").unwrap();
    assert!(experiments::run(exp, &ctx).unwrap());
    let dir = out.join("lod");
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let mine: Vec<&str> = csv
        .lines()
        .filter(|l| l.contains(",test-every-kth,"))
        .collect();
    // 2 settings × 8 views × 2 distances.
    assert_eq!(mine.len(), 32, "{csv}");
    assert!(mine.iter().any(|l| l.contains(",k=4,")));
    // Half the points at k = 2 (24,000 points).
    assert!(mine.iter().any(|l| l.contains(",k=2,12000,")), "{mine:?}");
    let builds = std::fs::read_to_string(dir.join("builds.csv")).unwrap();
    assert!(builds.contains("sphere-plane-24000,test-every-kth,24000,"));
    let summary = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(summary.contains("| test-every-kth | k=2 |"), "{summary}");
    for png in [
        "psnr_vs_points_sphere-plane-24000.png",
        "strip_sphere-plane-24000.png",
    ] {
        assert!(
            std::fs::read(dir.join(png))
                .unwrap()
                .starts_with(b"\x89PNG")
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}
