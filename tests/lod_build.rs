//! `pointsight lod-build` in a child process: the out-of-core QSplat and sequential point tree
//! files equal the in-memory ones byte for byte, the process's peak memory (VmHWM) stays within the limit, the
//! scratch folder beside `--out` is gone afterwards, normals a file gives (LAZ extra bytes) are
//! used as they are with only the spacing sample searched, and bad input (a limit too small, a
//! truncated LAZ, a LAS whose header lies about its point count, a NaN or zero-length normal)
//! fails with a message naming the cause and leaves no output file.

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
    cloud::io::las::write_las(path, &sheet(n, false)).expect("the LAZ is written");
}

/// The wavy sheet of `n` points with colours, and with `normals` its unit normals (the
/// gradient's, pointing up).
fn sheet(n: usize, normals: bool) -> cloud::PointCloud {
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
    let normals = normals.then(|| {
        positions
            .iter()
            .map(|p| {
                let dx = 0.3 * p.x.cos() * (0.7 * p.y).cos();
                let dy = -0.21 * p.x.sin() * (0.7 * p.y).sin();
                DVec3::new(-dx, -dy, 1.0).normalize().as_vec3()
            })
            .collect()
    });
    cloud::PointCloud {
        positions,
        colors: Some(colors),
        normals,
        ..cloud::PointCloud::default()
    }
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
        // Every point's normal estimated: each point searched at least once.
        assert!(
            stdout.contains(" normals=estimated ")
                && field(&stdout, "neighbour_queries") >= 400_000.0,
            "{method}: {stdout}"
        );
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

/// A LAZ whose extra bytes give unit normals: built with them as they are, in memory and out
/// of core the same bytes; no normal is estimated (no guide stage; only the spacing sample's
/// points searched, at most twice each, in a build whose normals are estimated every point
/// is); the file differs from the one built from the same points with estimated normals.
#[test]
#[allow(clippy::unwrap_used)] // a test: a failure is the test failing
fn given_normals_are_used_in_memory_and_out_of_core_and_none_is_estimated() {
    let dir = tempfile::tempdir().unwrap();
    let n = 200_000;
    let with = dir.path().join("given.laz");
    cloud::io::las::write_las(&with, &sheet(n, true)).unwrap();
    let without = dir.path().join("plain.laz");
    cloud::io::las::write_las(&without, &sheet(n, false)).unwrap();
    let sample = harness::lod_build::SPACING_SAMPLE as f64;
    for method in ["qsplat", "spt"] {
        let mem = dir.path().join(format!("{method}-mem.lod"));
        let run = pointsight(&[
            "lod-build",
            "--cloud",
            with.to_str().unwrap(),
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
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(stdout.contains(" normals=given "), "{stdout}");
        let ooc = dir.path().join(format!("{method}-ooc.lod"));
        let stdout = build_ooc(&with, method, "80MiB", &ooc);
        assert!(field(&stdout, "chunks") >= 4.0, "{method}: {stdout}");
        assert!(stdout.contains(" normals=given "), "{method}: {stdout}");
        let queries = field(&stdout, "neighbour_queries");
        assert!(
            queries >= sample / 2.0 && queries <= 2.0 * sample,
            "{method}: {queries} searches: {stdout}"
        );
        assert!(!stdout.contains("guide:"), "{method}: {stdout}");
        assert!(
            std::fs::read(&ooc).unwrap() == std::fs::read(&mem).unwrap(),
            "{method}: the bytes differ"
        );
        let estimated = dir.path().join(format!("{method}-estimated.lod"));
        let stdout = build_ooc(&without, method, "80MiB", &estimated);
        assert!(
            field(&stdout, "neighbour_queries") >= n as f64,
            "{method}: {stdout}"
        );
        assert!(
            std::fs::read(&estimated).unwrap() != std::fs::read(&mem).unwrap(),
            "{method}: the given normals made no difference"
        );
    }
    // A normal of NaN or of length zero in the file: refused, naming the file and the point.
    let mut bad = sheet(20_000, true);
    let path = dir.path().join("bad-normal.las");
    for value in [cloud::glam::Vec3::NAN, cloud::glam::Vec3::ZERO] {
        // Written with a unit normal, then the one of point 7 replaced in the records.
        if let Some(n) = bad.normals.as_mut() {
            n[7] = cloud::glam::Vec3::Z;
        }
        cloud::io::las::write_las(&dir.path().join("bad.las"), &bad).unwrap();
        let mut bytes = std::fs::read(dir.path().join("bad.las")).unwrap();
        let start = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
        let record = u16::from_le_bytes(bytes[105..107].try_into().unwrap()) as usize;
        let at = start + 7 * record + record - 12;
        for (k, v) in value.to_array().iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        for method in ["qsplat", "spt"] {
            let out = dir.path().join("bad.lod");
            let run = pointsight(&[
                "lod-build",
                "--cloud",
                path.to_str().unwrap(),
                "--method",
                method,
                "--memory-limit",
                "64MiB",
                "--out",
                out.to_str().unwrap(),
            ]);
            let err = String::from_utf8_lossy(&run.stderr);
            assert!(!run.status.success(), "{method}: {value}");
            assert!(
                err.contains("bad-normal.las") && err.contains("point 7 has the normal"),
                "{method}: {err}"
            );
            assert!(!out.exists());
        }
    }
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
