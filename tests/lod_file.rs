//! A built QSplat file as a dataset (the manifest's `lod_file`), in child processes:
//! `pointsight lod-build` writes it out of core, the `lod` experiment selects from it without
//! loading it (rows in `results.csv`, reads in `file_reads.csv`, the reference streamed from
//! its leaves), and the experiments that need points refuse it by name.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};

fn pointsight(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .current_dir(cwd)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A bumpy ball with smooth colours, no normals (estimated, oriented away from the centroid: right
/// for a closed surface, so back-face culling leaves no holes).
fn write_cloud(path: &Path, n: usize) {
    let mut rng = seeded(9, "lod-file-test");
    let positions: Vec<DVec3> = (0..n)
        .map(|_| {
            let d = loop {
                let v = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
                let l = v.length();
                if l > 0.1 && l <= 1.0 {
                    break v / l;
                }
            };
            d * (3.0 + 0.2 * (4.0 * d.x).sin() * (3.0 * d.y).cos())
        })
        .collect();
    // Smooth colours (a function of the position), so that coarser levels average them
    // without losing much.
    let colors = positions
        .iter()
        .map(|p| {
            let c = |x: f64| (128.0 + 40.0 * x) as u8;
            [c(p.x), c(p.y), c(p.z)]
        })
        .collect();
    let c = cloud::PointCloud {
        positions,
        colors: Some(colors),
        ..cloud::PointCloud::default()
    };
    cloud::io::las::write_las(path, &c).expect("the LAZ is written");
}

/// `lod-build` of `ball.laz` by `method` at 80 MiB into `file`, then `run lod --quick` on it as
/// the dataset `name`; returns the output folder.
#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn build_and_run(d: &Path, method: &str, file: &str, name: &str) -> PathBuf {
    ok(&pointsight(
        &[
            "lod-build",
            "--cloud",
            "ball.laz",
            "--method",
            method,
            "--memory-limit",
            "80MiB",
            "--out",
            file,
        ],
        d,
    ));
    std::fs::write(
        d.join("pointsight.toml"),
        format!(
            "[datasets.{name}]\nlod_file = \"{file}\"\n\
             view_spec = {{ count = 8, width = 200, height = 150 }}\n"
        ),
    )
    .unwrap();
    ok(&pointsight(
        &[
            "run",
            "lod",
            "--quick",
            "--datasets",
            name,
            "--out",
            "out",
            "--repeats",
            "1",
        ],
        d,
    ));
    d.join("out")
}

/// Per setting of `results.csv` in `out`, in order: (setting, [splats, PSNR, holes] summed
/// over the views, views), every row `method` and ok with 1..=`max_points` splats; and the
/// rows.
#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn per_setting(
    out: &Path,
    expect: &str,
    max_points: usize,
) -> (Vec<(String, [f64; 3], f64)>, usize) {
    let mut rows = csv::Reader::from_path(out.join("results.csv")).unwrap();
    let headers = rows.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let (method, status, psnr, points, holes, params) = (
        col("method"),
        col("status"),
        col("psnr"),
        col("points_rendered"),
        col("hole_fraction"),
        col("params"),
    );
    let mut n = 0;
    let mut per: Vec<(String, [f64; 3], f64)> = Vec::new();
    for r in rows.records() {
        let r = r.unwrap();
        assert_eq!(&r[method], expect);
        assert_eq!(&r[status], "ok");
        let pts: usize = r[points].parse().unwrap();
        assert!(pts > 0 && pts <= max_points, "{pts} splats");
        let v = [
            pts as f64,
            r[psnr].parse().unwrap(),
            r[holes].parse().unwrap(),
        ];
        match per.iter_mut().find(|(p, _, _)| p == &r[params]) {
            Some((_, acc, k)) => {
                for (a, x) in acc.iter_mut().zip(v) {
                    *a += x;
                }
                *k += 1.0;
            }
            None => per.push((r[params].to_owned(), v, 1.0)),
        }
        n += 1;
    }
    (per, n)
}

#[test]
fn the_lod_experiment_selects_from_a_built_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_cloud(&d.join("ball.laz"), 120_000);
    let out = build_and_run(d, "qsplat", "ball.qsplat", "ball-built");
    let (per, n) = per_setting(&out, "qsplat", 120_000);
    // 8 views × 2 distances × the quick sweep's settings.
    assert!(n >= 32 && n % 16 == 0, "{n} rows");
    let mean = |k: usize, j: usize| per[k].1[j] / per[k].2;
    let (finest, coarsest) = (0, per.len() - 1);
    // The finest setting against the file's own leaves: measured 15.4 dB at 200 × 150 (the
    // splats are bounding spheres, larger than the leaves; the in-memory path gives the bunny
    // 19.5 dB at 2 px), no holes; the coarsest 4.6 dB with 1/200 of the splats.
    assert!(mean(finest, 1) > 12.0, "{per:?}");
    assert!(mean(finest, 2) < 0.01, "holes {per:?}");
    assert!(mean(coarsest, 0) < mean(finest, 0) / 4.0, "{per:?}");
    assert!(mean(coarsest, 1) + 5.0 < mean(finest, 1), "{per:?}");
    let mut reads = csv::Reader::from_path(out.join("file_reads.csv")).unwrap();
    let headers = reads.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let (read, cache, file) = (col("bytes_read"), col("cache_bytes"), col("file_bytes"));
    let mut total_read = 0u64;
    let mut file_bytes = 0u64;
    for r in reads.records() {
        let r = r.unwrap();
        let c: u64 = r[cache].parse().unwrap();
        file_bytes = r[file].parse().unwrap();
        assert!(c <= 64 << 20, "cache {c}");
        total_read += r[read].parse::<u64>().unwrap();
    }
    assert!(total_read > 0);
    assert_eq!(
        file_bytes,
        std::fs::metadata(d.join("ball.qsplat")).unwrap().len()
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("Selection from built files"), "{summary}");
    // The Builds table has the file's row (the file opened; its size per point), where it was
    // empty for a built file; seed 003's table was not asked for.
    let builds = std::fs::read_to_string(out.join("builds.csv")).unwrap();
    let row = builds
        .lines()
        .find(|l| l.starts_with("ball-built,qsplat,120000,"))
        .unwrap_or_else(|| panic!("no build row: {builds}"));
    let bytes_per_point: f64 = row.rsplit(',').next().unwrap().parse().unwrap();
    assert!(
        (bytes_per_point - file_bytes as f64 / 120_000.0).abs() < 1e-9,
        "{row}"
    );
    assert!(
        summary.contains("| ball-built | qsplat | 120000 |"),
        "{summary}"
    );
    // No SRN rows on a built file: the table is its header alone.
    let srn = std::fs::read_to_string(out.join("srn_table.csv")).unwrap();
    assert_eq!(srn.lines().count(), 1, "{srn}");
    assert!(srn.starts_with("model,dataset,"), "{srn}");
    assert!(out.join("strip_ball-built.png").exists());
    // The file's checksum is in the run's metadata.
    let meta = std::fs::read_to_string(out.join("metadata.json")).unwrap();
    assert!(meta.contains("ball.qsplat"), "{meta}");
}

#[test]
fn experiments_that_need_points_refuse_a_built_file_and_mistakes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("x.qsplat"), b"PSQSPLAT not really").unwrap();
    std::fs::write(
        d.join("pointsight.toml"),
        "[datasets.built]\nlod_file = \"x.qsplat\"\n",
    )
    .unwrap();
    let out = pointsight(
        &[
            "run",
            "visibility",
            "--quick",
            "--datasets",
            "built",
            "--out",
            "o",
        ],
        d,
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("lod_file") && err.contains("built"), "{err}");
    // The lod experiment reads the header and names what is wrong with it.
    let out = pointsight(
        &["run", "lod", "--quick", "--datasets", "built", "--out", "o"],
        d,
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("x.qsplat") && err.contains("corrupt"), "{err}");
    // A lod_file with a cloud is a mistake.
    std::fs::write(
        d.join("pointsight.toml"),
        "[datasets.built]\nlod_file = \"x.qsplat\"\ncloud = \"a.ply\"\n",
    )
    .unwrap();
    let out = pointsight(&["datasets"], d);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("lod_file is the whole dataset"), "{err}");
}

#[test]
fn the_lod_experiment_cuts_a_built_sequential_point_tree() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_cloud(&d.join("ball.laz"), 120_000);
    let out = build_and_run(d, "spt", "ball.spt", "ball-spt");
    let (per, _) = per_setting(&out, "spt", 120_000);
    assert!(per.len() >= 2, "{per:?}");
    let mean = |k: usize, j: usize| per[k].1[j] / per[k].2;
    let (finest, coarsest) = (0, per.len() - 1);
    // Measured: ε = 0.5 px 28,868 splats, 15.5 dB, no holes; ε = 8 px 96 splats, 6.0 dB.
    assert!(mean(finest, 1) > 12.0, "{per:?}");
    assert!(mean(finest, 2) < 0.01, "holes {per:?}");
    assert!(mean(coarsest, 0) < mean(finest, 0) / 4.0, "{per:?}");
    assert!(mean(coarsest, 1) + 5.0 < mean(finest, 1), "{per:?}");
    let reads = std::fs::read_to_string(out.join("file_reads.csv")).unwrap();
    assert!(reads.lines().count() > per.len(), "{reads}");
    let strip = image::open(out.join("strip_ball-spt.png")).unwrap();
    assert!(strip.width() > 200);
}
