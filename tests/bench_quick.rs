//! `pointsight bench --quick` end to end on a synthetic dataset (no download) into a
//! temporary folder: every experiment's CSVs have their columns and rows, every PNG decodes to
//! a non-trivial image, `README.md` links only files that exist, and no staging folder is
//! left behind. Over the same run: every figure has its JSON twin, whose series have pairwise
//! distinct styles (context aside), and a method in a variant has one style in every figure;
//! each experiment with figures has its results page holding them; the combined README keeps
//! one top heading and its tables have as many cells a row as their header.

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
        "dataset,n_points,view,method,family,params,detail,seconds,rays,n_visible,precision,recall,f1,off_surface_visible,seconds_min,seconds_max,samples,status,made_for,visible_sha256,mesh_fit,wall_seconds",
    ),
    (
        "robustness/results.csv",
        "dataset,degradation,level,n_points,method,setting,params,view,precision,recall,f1,true_positives,false_positives,false_negatives,outliers,outliers_visible,seconds,status",
    ),
    (
        "scale/results.csv",
        "method,n_points,seconds,peak_rss_bytes,status,prepare_seconds,detail,runs_seconds,angle_median_deg,angle_p95_deg,sign_agreement,build_seconds",
    ),
    (
        "lod/results.csv",
        "dataset,view,distance,method,params,points_rendered,seconds,psnr,ssim,hole_fraction,status,n_points",
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

fn bench(reports: &Path, results_script: &Path) {
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
        .env("POINTSIGHT_RESULTS_JS", results_script)
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
    // A stand-in for web/dist/results.js (the browser tests drive the real one).
    let script = tmp.path().join("results.js");
    std::fs::write(&script, "/* results page script */").expect("writable");
    bench(&reports, &script);

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
        // The status, what the method was made for (points or pixels), its set's digest.
        assert!(
            row.contains(",ok,points,") || row.contains(",ok,pixels,"),
            "{row}"
        );
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

    figures_have_twins_with_distinct_and_consistent_styles(&reports, &files);
    readme_keeps_its_structure(&readme);
    quick_findings_are_indicative(&reports, &readme);
    the_audit_recomputes_every_finding(&reports);
}

/// The findings' second path, `scripts/audit_findings.py` (Python and pandas), recomputes every
/// row of this run's `findings.csv` from its results. The interpreter: `POINTSIGHT_AUDIT_PYTHON`,
/// else the clone's `.venv/bin/python` (`just python` installs pandas there). Under `just test`
/// (`POINTSIGHT_REAL_DATA=1`) or CI one without pandas fails the test; elsewhere it is said and
/// the audit left out.
fn the_audit_recomputes_every_finding(reports: &Path) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var_os("POINTSIGHT_AUDIT_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".venv/bin/python"));
    let has_pandas = Command::new(&python)
        .args(["-c", "import pandas"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_pandas {
        let required = std::env::var("POINTSIGHT_REAL_DATA").as_deref() == Ok("1")
            || std::env::var("CI").as_deref() == Ok("true");
        assert!(
            !required,
            "{} has no pandas: run `just python` (the audit of the findings needs it)",
            python.display()
        );
        eprintln!(
            "{} has no pandas: the findings' audit is left out (run `just python`)",
            python.display()
        );
        return;
    }
    let out = Command::new(&python)
        .arg(root.join("scripts/audit_findings.py"))
        .arg(reports)
        .output()
        .expect("the audit runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("identical"),
        "the audit disagrees with findings.csv:\n{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A quick run's report opens with its findings, says in both titles that they are
/// indicative, and prints no interval from fewer than 5 views (its findings.csv leaves them
/// empty; no table of any summary shows `value [low, high]`).
fn quick_findings_are_indicative(reports: &Path, readme: &str) {
    let headings: Vec<&str> = readme.lines().filter(|l| l.starts_with("## ")).collect();
    assert_eq!(
        headings.first().copied(),
        Some("## Findings — indicative (quick run)"),
        "{headings:?}"
    );
    let mut reader = csv::Reader::from_path(reports.join("findings.csv")).expect("findings.csv");
    let header = reader.headers().expect("a header").clone();
    let col = |name: &str| header.iter().position(|h| h == name).expect(name);
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.expect("a row")).collect();
    assert!(!rows.is_empty(), "no findings");
    for row in &rows {
        assert_eq!(&row[col("indicative")], "true", "{row:?}");
        let views: usize = row[col("n_views")].parse().unwrap_or(0);
        if views < 5 {
            assert!(
                row[col("low")].is_empty() && row[col("high")].is_empty(),
                "{row:?}"
            );
        }
    }
    let interval = has_interval;
    for exp in ["visibility", "robustness", "hull", "lod", "scale"] {
        let Ok(text) = std::fs::read_to_string(reports.join(exp).join("summary.md")) else {
            continue;
        };
        for line in text.lines().filter(|l| l.starts_with('|')) {
            assert!(
                !interval(line),
                "{exp}: an interval from a quick run: {line}"
            );
        }
    }
}

/// Whether `line` holds `NUMBER [NUMBER, NUMBER]` (a value with its interval).
fn has_interval(line: &str) -> bool {
    let number = |s: &str| {
        let s = s.trim().trim_end_matches('×');
        !s.is_empty() && s.trim_start_matches(['+', '-']).parse::<f64>().is_ok()
    };
    line.match_indices('[').any(|(at, _)| {
        let rest = &line[at + 1..];
        let Some(end) = rest.find(']') else {
            return false;
        };
        let inside: Vec<&str> = rest[..end].split(", ").collect();
        let before = line[..at].trim_end().rsplit(' ').next().unwrap_or("");
        inside.len() == 2 && inside.iter().all(|x| number(x)) && number(before)
    })
}

/// A series' identity: the same method in the same variant must look the same everywhere.
type Identity = (String, String, String);

fn figures_have_twins_with_distinct_and_consistent_styles(reports: &Path, files: &[PathBuf]) {
    let mut seen: std::collections::BTreeMap<Identity, (String, String)> = Default::default();
    let mut twins = 0;
    let mut experiments_with_figures = std::collections::BTreeSet::new();
    for png in files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
    {
        let json = png.with_extension("json");
        let name = png
            .strip_prefix(reports)
            .unwrap_or(png)
            .display()
            .to_string();
        // Pictures of point sets (renders, strips, SRN's images) have no data to re-plot.
        let stem = png.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if stem == "renders" || stem.starts_with("strip_") || name.contains("/srn/") {
            continue;
        }
        let text = std::fs::read_to_string(&json)
            .unwrap_or_else(|e| panic!("{name} has no JSON twin: {e}"));
        let fig: serde_json::Value = serde_json::from_str(&text).expect("a JSON twin");
        assert_eq!(fig["format"], "pointsight-figure/1", "{name}");
        assert_eq!(
            fig["png"].as_str(),
            png.file_name().and_then(|f| f.to_str()),
            "{name}"
        );
        twins += 1;
        if let Some(exp) = png.parent().and_then(|p| p.file_name()) {
            experiments_with_figures.insert(exp.to_string_lossy().into_owned());
        }
        // Pairwise distinct styles among the series that are not context.
        let mut in_figure: std::collections::BTreeMap<String, Identity> = Default::default();
        for panel in fig["panels"].as_array().expect("panels") {
            for s in panel["series"].as_array().expect("series") {
                let field = |k: &str| s[k].as_str().unwrap_or_default().to_owned();
                assert!(
                    s["points"].as_array().is_some_and(|p| !p.is_empty()) || s["context"] == true,
                    "{name}: {} has no point",
                    field("label")
                );
                if s["context"] == true {
                    continue;
                }
                let id = (field("method"), field("family"), field("variant"));
                let style = s["style"].to_string();
                if let Some(other) = in_figure.get(&style) {
                    assert_eq!(
                        other, &id,
                        "{name}: {other:?} and {id:?} share the style {style}"
                    );
                }
                in_figure.insert(style.clone(), id.clone());
                match seen.get(&id) {
                    Some((first, where_)) => assert_eq!(
                        first, &style,
                        "{id:?} looks one way in {where_} and another in {name}"
                    ),
                    None => {
                        seen.insert(id, (style, name.clone()));
                    }
                }
            }
        }
    }
    assert!(twins >= 10, "only {twins} figures with a twin");
    // The same method keeps its look across experiments (HPR's linear kernel is in the
    // visibility, robustness, background and scale figures).
    let hpr: Vec<&(String, String)> = seen
        .iter()
        .filter(|((_, family, _), _)| family == "hpr-linear")
        .map(|(_, v)| v)
        .collect();
    let colours: std::collections::BTreeSet<String> = hpr
        .iter()
        .map(|(style, _)| {
            let v: serde_json::Value = serde_json::from_str(style).expect("a style");
            v["color"].as_str().unwrap_or_default().to_owned()
        })
        .collect();
    assert!(hpr.len() >= 3, "hpr-linear in only {} variants", hpr.len());
    // Its colour, or a shade of it where another of its series shares a panel (synchronous and
    // background, auto and best): never another family's colour.
    let base = harness::output::style::style("hpr-linear", "").color;
    let shades: std::collections::BTreeSet<String> = harness::output::style::shades(base)
        .into_iter()
        .map(harness::output::style::hex)
        .collect();
    assert!(
        colours.contains(&harness::output::style::hex(base))
            && colours.iter().all(|c| shades.contains(c)),
        "hpr-linear has the colours {colours:?}, its shades being {shades:?}"
    );
    // Each experiment with figures has its results page, holding every figure.
    for exp in &experiments_with_figures {
        let page = std::fs::read_to_string(reports.join(exp).join("results.html"))
            .unwrap_or_else(|e| panic!("{exp} has no results page: {e}"));
        assert!(page.contains("/* results page script */"), "{exp}");
        for png in files.iter().filter(|p| {
            p.extension().is_some_and(|e| e == "png")
                && p.parent()
                    .and_then(|d| d.file_name())
                    .is_some_and(|d| d.to_string_lossy() == *exp)
                && p.with_extension("json").is_file()
        }) {
            let id = png.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
            assert!(
                page.contains(&format!("\"id\":\"{id}\"")),
                "{exp}/results.html lacks {id}"
            );
        }
    }
}

/// The combined README keeps its structure: one top heading (no experiment's own `#` heading
/// inside its section), and every table's rows have as many cells as its header.
fn readme_keeps_its_structure(readme: &str) {
    let top: Vec<&str> = readme.lines().filter(|l| l.starts_with("# ")).collect();
    assert_eq!(
        top,
        ["# pointsight results — indicative (quick run)"],
        "top headings"
    );
    let cells = |line: &str| line.trim().trim_matches('|').split('|').count();
    let mut header: Option<(usize, &str)> = None;
    for line in readme.lines() {
        if !line.starts_with('|') {
            header = None;
            continue;
        }
        match header {
            None => header = Some((cells(line), line)),
            Some((n, head)) => assert_eq!(
                cells(line),
                n,
                "a table row has not the header's cells:\n{head}\n{line}"
            ),
        }
    }
}

#[test]
fn the_interval_detector_finds_value_and_interval() {
    assert!(has_interval("| d | 12.80× [12.11, 13.53] | x |"));
    assert!(has_interval("| a | +0.143 [+0.143, +0.143] |"));
    assert!(!has_interval("| a | +0.143 (indicative: 2 views) |"));
    assert!(!has_interval("| [visibility](#visibility) | see [a, b] |"));
}
