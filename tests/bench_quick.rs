//! `pointsight bench --quick` end to end on a synthetic dataset (no download) into a
//! temporary folder: every experiment's CSVs have their columns and rows, every PNG decodes to
//! a non-trivial image, `README.md` links only files that exist, and no staging folder is
//! left behind.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The CSVs each experiment must write, with the columns the issues fix.
const CSVS: &[(&str, &str)] = &[
    (
        "hull/results.csv",
        "dataset,n_points,view,gamma,hull,perturb,seconds,samples,n_visible,jaccard_vs_exact,f1_vs_reference,status,visible_sha256",
    ),
    (
        "visibility/results.csv",
        "dataset,n_points,view,method,family,params,detail,seconds,rays,n_visible,precision,recall,f1,off_surface_visible,seconds_min,seconds_max,samples,status",
    ),
    (
        "robustness/results.csv",
        "dataset,degradation,level,n_points,method,setting,params,view,precision,recall,f1,true_positives,false_positives,false_negatives,outliers,outliers_visible,seconds,status",
    ),
    (
        "scale/results.csv",
        "method,n_points,seconds,peak_rss_bytes,status,prepare_seconds,detail",
    ),
    (
        "lod/results.csv",
        "dataset,view,distance,method,params,points_rendered,seconds,psnr,ssim,hole_fraction,status",
    ),
];

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable folder") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            files_under(&path, out);
        } else {
            out.push(path);
        }
    }
}

fn bench(reports: &Path) {
    let out = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args([
            "bench",
            "--quick",
            "--datasets",
            "sphere-plane-24000",
            "--reports",
        ])
        .arg(reports)
        .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data")
        .output()
        .expect("the pointsight binary runs");
    assert!(
        out.status.success(),
        "bench failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Standard error is not a terminal here: no progress on it (warnings may be).
    let stderr = String::from_utf8_lossy(&out.stderr);
    for progress in [
        "experiment 1 of",
        "== reference",
        "done in",
        "viewer pages: ",
    ] {
        assert!(!stderr.contains(progress), "{progress}: {stderr}");
    }
}

#[test]
fn quick_bench_writes_a_complete_report() {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let reports = tmp.path().join("reports");
    bench(&reports);

    for (file, header) in CSVS {
        let text = std::fs::read_to_string(reports.join(file)).expect(file);
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some(*header), "{file}");
        let n_cols = header.split(',').count();
        let rows: Vec<&str> = lines.collect();
        assert!(!rows.is_empty(), "{file} has no rows");
        for row in &rows {
            let mut reader = csv::ReaderBuilder::new()
                .has_headers(false)
                .from_reader(row.as_bytes());
            let record = reader
                .records()
                .next()
                .expect("a record")
                .expect("valid CSV");
            assert_eq!(record.len(), n_cols, "{file}: {row}");
        }
    }
    // Every built-in method ran at every setting of its sweep without an error.
    let vis = std::fs::read_to_string(reports.join("visibility/results.csv")).expect("results");
    for row in vis.lines().skip(1) {
        assert!(row.ends_with(",ok"), "{row}");
    }
    for family in ["hpr-linear", "hpr-exp", "robust", "raycast", "splat"] {
        assert!(vis.contains(&format!(",{family},")), "{family}");
    }
    // Robustness: every built-in visibility method has an ok row for every degradation.
    let rob = std::fs::read_to_string(reports.join("robustness/results.csv")).expect("results");
    let mut reader = csv::Reader::from_reader(rob.as_bytes());
    let mut ok = std::collections::BTreeSet::new();
    for r in reader.records() {
        let r = r.expect("a record");
        if r.get(17) == Some("ok") {
            ok.insert((r[4].to_owned(), r[1].to_owned()));
        }
    }
    for method in [
        "hpr",
        "robust",
        "hpr-confidence",
        "hpr-approx",
        "raycast",
        "splat",
        "screenspace",
        "vardensity",
    ] {
        for degradation in ["clean", "noise", "outliers", "falloff", "jitter"] {
            assert!(
                ok.contains(&(method.to_owned(), degradation.to_owned())),
                "robustness: {method} has no ok row under {degradation}"
            );
        }
    }
    // Every experiment left its summary and metadata.
    for exp in ["reference", "hull", "background", "visibility", "lod"] {
        assert!(reports.join(exp).join("summary.md").is_file(), "{exp}");
        assert!(reports.join(exp).join("metadata.json").is_file(), "{exp}");
    }

    let mut files = Vec::new();
    files_under(&reports, &mut files);
    assert!(
        files
            .iter()
            .all(|f| !f.to_string_lossy().contains(".partial")),
        "a staging folder was left behind"
    );
    let pngs: Vec<&PathBuf> = files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    assert!(pngs.len() >= 10, "only {} PNG files", pngs.len());
    for png in &pngs {
        let bytes = std::fs::read(png).expect("readable");
        assert!(
            bytes.len() > 1000,
            "{} is {} bytes",
            png.display(),
            bytes.len()
        );
        let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
            .unwrap_or_else(|e| panic!("{} is not a PNG: {e}", png.display()));
        assert!(img.width() >= 64 && img.height() >= 64, "{}", png.display());
    }

    let readme = std::fs::read_to_string(reports.join("README.md")).expect("README.md");
    let links = harness::output::report::link_targets(&readme);
    assert!(
        links.len() >= 10,
        "README.md links only {} files",
        links.len()
    );
    for link in &links {
        assert!(
            reports.join(link).is_file(),
            "README.md links missing {link}"
        );
    }
    for exp in ["hull", "visibility", "lod"] {
        assert!(
            readme.contains(&format!("## {exp}")),
            "README.md lacks {exp}"
        );
    }
    assert!(readme.contains("git revision") && readme.contains("cores"));
}
