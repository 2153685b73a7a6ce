//! `pointsight lod-build` in a child process: the out-of-core QSplat and sequential point tree
//! files equal the in-memory ones byte for byte, the process's peak memory (VmHWM) stays within the limit, the
//! scratch folder beside `--out` is gone afterwards, and bad input (a limit too small, a
//! truncated LAZ, a LAS whose header lies about its point count) fails with a message naming
//! the cause and leaves no output file.

use std::path::Path;
use std::process::{Command, Output};

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};

fn pointsight(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs")
}

fn field(stdout: &str, key: &str) -> f64 {
    stdout
        .split_whitespace()
        .find_map(|kv| kv.strip_prefix(&format!("{key}=")))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{key} missing in {stdout:?}"))
}

/// A wavy sheet with colours, no normals (so the build estimates them through halos).
fn write_cloud(path: &Path, n: usize) {
    let mut rng = seeded(5, "lod-build-test");
    let positions: Vec<DVec3> = (0..n)
        .map(|_| {
            let (x, y) = (rng.random::<f64>() * 10.0, rng.random::<f64>() * 10.0);
            DVec3::new(x, y, 0.3 * (x).sin() * (0.7 * y).cos())
        })
        .collect();
    let colors = (0..n)
        .map(|i| [(i % 251) as u8, (i % 127) as u8, 9])
        .collect();
    let c = cloud::PointCloud {
        positions,
        colors: Some(colors),
        ..cloud::PointCloud::default()
    };
    cloud::io::las::write_las(path, &c).expect("the LAZ is written");
}

/// `lod-build` of `laz` by `method` within `limit` into `out`, which must succeed: its
/// standard output.
fn build_ooc(laz: &Path, method: &str, limit: &str, out: &Path) -> String {
    let (laz, out) = (laz.display().to_string(), out.display().to_string());
    let run = pointsight(&[
        "lod-build",
        "--cloud",
        &laz,
        "--method",
        method,
        "--memory-limit",
        limit,
        "--out",
        &out,
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    String::from_utf8_lossy(&run.stdout).into_owned()
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("a readable folder")
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

#[test]
fn out_of_core_equals_in_memory_within_the_limit() {
    for method in ["qsplat", "spt"] {
        equal_within_the_limit(method);
    }
}

#[allow(clippy::unwrap_used)] // a test's helper: a failure is the test failing
fn equal_within_the_limit(method: &str) {
    let dir = tempfile::tempdir().unwrap();
    let laz = dir.path().join("sheet.laz");
    write_cloud(&laz, 400_000);
    let mem = dir.path().join("mem.lod");
    let run = pointsight(&[
        "lod-build",
        "--cloud",
        laz.to_str().unwrap(),
        "--method",
        method,
        "--in-memory",
        "--out",
        mem.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let want = std::fs::read(&mem).unwrap();
    {
        let limit_mib = 80u64;
        let out = dir.path().join(format!("ooc{limit_mib}.lod"));
        let stdout = build_ooc(&laz, method, &format!("{limit_mib}MiB"), &out);
        // Several chunks (the library's tests force two levels above them).
        assert!(field(&stdout, "chunks") >= 4.0, "{method}: {stdout}");
        // The scratch's peak on disk is part of what it wrote in all.
        let (peak_disk, written) = (
            field(&stdout, "scratch_peak_bytes"),
            field(&stdout, "scratch_bytes"),
        );
        assert!(
            peak_disk > 0.0 && peak_disk < written,
            "scratch peak {peak_disk}, written {written}: {stdout}"
        );
        let peak = field(&stdout, "peak_rss_bytes");
        assert!(
            peak <= (limit_mib << 20) as f64,
            "{method}: peak {peak} over {limit_mib} MiB: {stdout}"
        );
        // Every stage timed, in order, their seconds adding up to the build's.
        let stages: Vec<(String, f64)> = stdout
            .split_whitespace()
            .find_map(|kv| kv.strip_prefix("stage_seconds="))
            .unwrap_or_else(|| panic!("no stage_seconds: {stdout}"))
            .split(',')
            .map(|e| {
                let (k, v) = e.split_once(':').unwrap();
                (k.to_owned(), v.parse().unwrap())
            })
            .collect();
        let keys: Vec<&str> = stages.iter().map(|e| e.0.as_str()).collect();
        let prepare = ["read", "split", "guide", "normals", "halos"];
        let own: &[&str] = if method == "spt" {
            &["count", "distribute", "build", "merge"]
        } else {
            &["roots", "encode", "write"]
        };
        assert_eq!(keys, [&prepare[..], own].concat(), "{method}: {stdout}");
        let (sum, seconds) = (
            stages.iter().map(|e| e.1).sum::<f64>(),
            field(&stdout, "seconds"),
        );
        assert!(
            sum <= seconds + 0.02 && sum >= 0.9 * seconds - 0.02,
            "{method}: stages add up to {sum} s of {seconds} s: {stdout}"
        );
        let got = std::fs::read(&out).unwrap();
        assert!(
            got == want,
            "{method}, limit {limit_mib} MiB: the bytes differ"
        );
    }
    // No scratch folder is left.
    assert_eq!(entries(dir.path()), ["mem.lod", "ooc80.lod", "sheet.laz"]);
}

/// A cloud larger than memory holds at once (at 80 MiB, sets of about 930,000 of these
/// points): the split counts on disk, then writes subsets and splits each in memory; the
/// peak stays within the limit all the same.
#[test]
#[allow(clippy::unwrap_used)] // a test: a failure is the test failing
fn a_split_through_subsets_stays_within_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let laz = dir.path().join("sheet.laz");
    let n = 1_300_000;
    write_cloud(&laz, n);
    let out = dir.path().join("big.qsplat");
    let stdout = build_ooc(&laz, "qsplat", "80MiB", &out);
    // Records of 19 bytes (grid integers, colour, index) and 12-byte normals: the input, the
    // subsets and the chunks make three writes of most records.
    let per_point = field(&stdout, "scratch_bytes") / n as f64;
    assert!(per_point > 2.5 * 19.0 + 12.0, "no subsets? {stdout}");
    let peak = field(&stdout, "peak_rss_bytes");
    assert!(
        peak <= (80u64 << 20) as f64,
        "peak {peak} over 80 MiB: {stdout}"
    );
    assert_eq!(entries(dir.path()), ["big.qsplat", "sheet.laz"]);
}

#[test]
fn bad_input_fails_naming_the_cause_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let laz = dir.path().join("sheet.laz");
    write_cloud(&laz, 20_000);
    let out = dir.path().join("out.lod");
    let fails_with = |method: &str, cloud: &Path, limit: &str, message: &str| {
        let run = pointsight(&[
            "lod-build",
            "--cloud",
            cloud.to_str().unwrap(),
            "--method",
            method,
            "--memory-limit",
            limit,
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&run.stderr).into_owned();
        assert!(!run.status.success(), "{method} {limit} should fail");
        assert!(err.contains(message), "{method}: {err:?} lacks {message:?}");
        assert!(!out.exists());
        let left: Vec<String> = entries(dir.path())
            .into_iter()
            .filter(|e| e.starts_with('.'))
            .collect();
        assert!(left.is_empty(), "left behind: {left:?}");
    };
    let fails = |cloud: &Path, limit: &str, message: &str| {
        for method in ["qsplat", "spt"] {
            fails_with(method, cloud, limit, message);
        }
    };
    fails(
        &laz,
        "16MiB",
        "below what the out-of-core build can work in",
    );
    fails(&laz, "lots", "size \"lots\"");
    // A truncated LAZ.
    let bytes = std::fs::read(&laz).unwrap();
    let cut = dir.path().join("cut.laz");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    fails(&cut, "64MiB", "cut.laz");
    // A LAS whose header announces more points than the file holds.
    let las = dir.path().join("sheet.las");
    write_cloud(&las, 20_000);
    let mut b = std::fs::read(&las).unwrap();
    b[107..111].copy_from_slice(&30_000u32.to_le_bytes());
    if b[24] == 1 && b[25] >= 4 {
        b[247..255].copy_from_slice(&30_000u64.to_le_bytes());
    }
    let liar = dir.path().join("liar.las");
    std::fs::write(&liar, &b).unwrap();
    fails(&liar, "64MiB", "liar.las");
}
