//! The report's viewer pages: for every real (fetched) dataset the visibility experiment ran,
//! the page of view 0 (the view of `renders.png`) with every default method, into
//! `reports/viewer/DATASET.html`; for every real dataset the `lod` experiment ran, the
//! level-of-detail page of view 0 at the experiment's farther distance with every default LOD
//! method, into `reports/viewer/DATASET-lod.html`. Each is at most [`MAX_PAGE_BYTES`] (a
//! uniform subsample when the whole would not fit, which the page says);
//! `reports/viewer/pages.json` lists them for the report page ([`section`]). Each links to its
//! experiment's interactive results page and to the report; each method shows its swatch, the
//! style it has in every figure. Pages of an earlier
//! report that this one no longer lists are removed ([`remove_stale`]): only the files this
//! module writes (those the previous `pages.json` listed, and pages named as it names them),
//! nothing else in the folder.

use crate::run::Run;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use super::{MethodRun, ONE_RUN, choose, lod, page, run_method};
use crate::datasets;
use crate::output::{read_csv, write_atomic};

/// A committed page's size limit.
pub const MAX_PAGE_BYTES: usize = 5 * 1024 * 1024;

/// One page of the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Entry {
    /// Dataset.
    pub dataset: String,
    /// View.
    pub view: usize,
    /// File name under `viewer/`.
    pub file: String,
    /// Points of the cloud.
    pub points: usize,
    /// Points on the page.
    pub shown: usize,
    /// Methods on the page.
    pub methods: Vec<String>,
    /// Size of the page.
    pub bytes: usize,
    /// `lod` for a level-of-detail page (`shown`: splats of all methods), else empty.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub kind: String,
}

/// Writes every page of the report ([`write_pages`], [`write_lod_pages`]) and
/// `viewer/pages.json` (nothing when there is no real dataset in the results).
pub fn write_all(run: &Run, reports: &Path, data_dir: &Path) -> Result<Vec<Entry>> {
    let previous = listed(reports);
    let mut entries = write_pages(
        run,
        reports,
        &real_datasets(reports, "visibility")?,
        data_dir,
    )?;
    entries.extend(write_lod_pages(
        run,
        reports,
        &real_datasets(reports, "lod")?,
        data_dir,
    )?);
    if !entries.is_empty() {
        write_atomic(
            &reports.join("viewer/pages.json"),
            serde_json::to_string_pretty(&entries)?.as_bytes(),
        )?;
    }
    remove_stale(reports, &previous, &entries)?;
    Ok(entries)
}

/// The files the `pages.json` of `reports` lists (none when there is none or it is unreadable).
fn listed(reports: &Path) -> Vec<String> {
    std::fs::read(reports.join("viewer/pages.json"))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Vec<Entry>>(&bytes).ok())
        .map(|entries| entries.into_iter().map(|e| e.file).collect())
        .unwrap_or_default()
}

/// True for a file name this module writes: `DATASET.html` or `DATASET-lod.html` for a
/// built-in dataset from fetched files.
fn is_page_name(file: &str) -> bool {
    let Some(stem) = file.strip_suffix(".html") else {
        return false;
    };
    let dataset = stem.strip_suffix("-lod").unwrap_or(stem);
    datasets::REGISTRY
        .iter()
        .any(|d| d.name == dataset && d.needs_fetch())
}

/// Removes from `reports/viewer/` the pages an earlier report wrote (`previous`, or named as
/// this module names them) that `entries` no longer lists, and `pages.json` when nothing is
/// listed; anything else in the folder stays.
pub fn remove_stale(reports: &Path, previous: &[String], entries: &[Entry]) -> Result<()> {
    let dir = reports.join("viewer");
    let Ok(read) = std::fs::read_dir(&dir) else {
        return Ok(());
    };
    for entry in read {
        let name = entry?.file_name().to_string_lossy().into_owned();
        let owned = is_page_name(&name) || previous.contains(&name);
        let stale = owned && !entries.iter().any(|e| e.file == name);
        if stale || (name == "pages.json" && entries.is_empty()) {
            let path = dir.join(&name);
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove the stale page {}", path.display()))?;
        }
    }
    Ok(())
}

/// The datasets of `experiment`'s results (in `reports/EXPERIMENT/results.csv`) that come
/// from fetched files.
pub fn real_datasets(reports: &Path, experiment: &str) -> Result<Vec<String>> {
    #[derive(Deserialize)]
    struct R {
        dataset: String,
    }
    let path = reports.join(experiment).join("results.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let rows: Vec<R> = read_csv(&path)?;
    let names = crate::output::distinct(rows.iter().map(|r| r.dataset.as_str()));
    Ok(names
        .into_iter()
        .filter(|d| datasets::info(d).is_ok_and(|i| i.needs_fetch()))
        .collect())
}

/// A report page's data with links to the report and to `experiment`'s results page (written
/// beside it by `pointsight report`, [`crate::output::results`]).
fn with_links(mut data: serde_json::Value, experiment: &str) -> serde_json::Value {
    data["links"] = serde_json::json!([
        {
            "label": format!("the {experiment} experiment's figures (interactive)"),
            "href": format!("../{experiment}/{}", crate::output::results::PAGE),
        },
        {"label": "the report", "href": format!("../README.md#{experiment}")},
    ]);
    data
}

/// The page `html_at(k)` for the largest limit k from `start` down (5 % at a time) whose page
/// is at most [`MAX_PAGE_BYTES`], or the page at k = 1; with that k.
fn fit(start: usize, html_at: impl Fn(usize) -> Result<String>) -> Result<(String, usize)> {
    let mut k = start;
    loop {
        let html = html_at(k)?;
        if html.len() <= MAX_PAGE_BYTES || k <= 1 {
            return Ok((html, k));
        }
        k = (k as f64 * 0.95) as usize;
    }
}

/// Writes the page of each of `names` (view 0); a dataset whose files are missing is left out
/// with a line on standard error.
pub fn write_pages(
    run: &Run,
    reports: &Path,
    names: &[String],
    data_dir: &Path,
) -> Result<Vec<Entry>> {
    if names.is_empty() {
        return Ok(Vec::new());
    }
    let script = page::bundle()?;
    let measured = measured_seconds(reports);
    let mut entries = Vec::new();
    for name in names {
        let ds = match run.datasets.load(name, data_dir) {
            Ok(ds) => ds,
            Err(e) => {
                eprintln!("viewer pages: {name} left out: {e:#}");
                continue;
            }
        };
        let view = 0;
        let camera = *ds.view(view)?;
        let mut runs = Vec::new();
        for (m, params, setting) in choose(&run.catalogue, None, &[])? {
            match run_method(m, &ds, &params, view, &camera) {
                Ok((out, seconds)) => {
                    let (seconds, timing) =
                        page_seconds(&measured, name, view, m.name, &setting, seconds);
                    runs.push(MethodRun {
                        name: m.name.to_owned(),
                        setting,
                        visible: out.visible,
                        seconds,
                        timing,
                    });
                }
                Err(e) => eprintln!("viewer pages: {name}: {} left out: {e:#}", m.name),
            }
        }
        let truth = page::Truth::of(&ds, &camera, &runs)?;
        // Bytes per point: 6 of position and one bit per set, base64 (4/3).
        let per_point = (6.0 + (runs.len() + 2) as f64 / 8.0) * 4.0 / 3.0;
        let budget = MAX_PAGE_BYTES.saturating_sub(script.len() + 64 * 1024) as f64;
        let max_points = ((budget / per_point) as usize).clamp(1, ds.cloud.len());
        let note = format!(
            "The report's page of {name}, view {view} (the view of renders.png), every method at \
             its default setting."
        );
        let (html, max_points) = fit(max_points, |k| {
            let data = page::Page {
                catalogue: &run.catalogue,
                ds: &ds,
                view,
                camera: &camera,
                runs: &runs,
                truth: &truth,
                max_points: Some(k),
                note: Some(&note),
            }
            .data()?;
            page::html_of(&with_links(data, "visibility"), &script)
        })?;
        let file = format!("{name}.html");
        write_atomic(&reports.join("viewer").join(&file), html.as_bytes())?;
        crate::progress::note(format!(
            "viewer pages: {file}: {} of {} points, {} bytes",
            max_points,
            ds.cloud.len(),
            html.len()
        ));
        entries.push(Entry {
            dataset: name.clone(),
            view,
            file,
            points: ds.cloud.len(),
            shown: max_points,
            methods: runs.iter().map(|r| r.name.clone()).collect(),
            bytes: html.len(),
            kind: String::new(),
        });
    }
    Ok(entries)
}

/// A row of `visibility/results.csv`, as far as a page's seconds need it.
#[derive(Debug, Deserialize)]
struct Measured {
    dataset: String,
    view: usize,
    method: String,
    params: String,
    seconds: Option<f64>,
    samples: Option<u32>,
    status: String,
}

/// A page's seconds for `method` at `setting` on `view` of `dataset`: the visibility
/// experiment's median where it timed that very setting there, else `one_run` (the run made
/// for the page); with what they are.
fn page_seconds(
    measured: &[Measured],
    dataset: &str,
    view: usize,
    method: &str,
    setting: &str,
    one_run: f64,
) -> (f64, String) {
    measured
        .iter()
        .find(|r| {
            r.dataset == dataset
                && r.view == view
                && r.method == method
                && r.params == setting
                && r.status == "ok"
        })
        .and_then(|r| {
            Some((
                r.seconds?,
                format!("median of {} runs in the visibility experiment", r.samples?),
            ))
        })
        .unwrap_or((one_run, ONE_RUN.to_owned()))
}

/// The visibility experiment's timed rows under `reports` (none when it has no results or
/// they cannot be read: the pages then say "one run").
fn measured_seconds(reports: &Path) -> Vec<Measured> {
    let path = reports.join("visibility").join("results.csv");
    if !path.is_file() {
        return Vec::new();
    }
    read_csv(&path).unwrap_or_else(|e| {
        eprintln!("viewer pages: seconds from one run each: {e:#}");
        Vec::new()
    })
}

/// Writes the level-of-detail page of each of `names` (view 0 at the `lod` experiment's
/// farther distance, every default LOD method); a dataset whose files are missing, or a
/// method that fails on it, is left out with a line on standard error.
pub fn write_lod_pages(
    run: &Run,
    reports: &Path,
    names: &[String],
    data_dir: &Path,
) -> Result<Vec<Entry>> {
    if names.is_empty() {
        return Ok(Vec::new());
    }
    let script = page::bundle()?;
    let distance = lod::DEFAULT_DISTANCE;
    let mut entries = Vec::new();
    for name in names {
        let ds = match run.datasets.load(name, data_dir) {
            Ok(ds) => ds,
            Err(e) => {
                eprintln!("viewer pages: {name} (LOD) left out: {e:#}");
                continue;
            }
        };
        let view = 0;
        let camera = crate::experiments::lod::at_distance(ds.view(view)?, distance)?;
        let (selected, failed) =
            lod::select(&ds, view, &camera, &lod::choose(&run.catalogue, None, &[])?)?;
        // A method that cannot select here is left out, not the page.
        for (method, e) in failed {
            eprintln!("viewer pages: {name} (LOD): {method} left out: {e:#}");
        }
        let total: usize = selected.iter().map(|s| s.splats.len()).sum();
        // Bytes per splat, base64 (4/3); the limit is per method, so scale by the largest.
        let per_splat = lod::SPLAT_BYTES as f64 * 4.0 / 3.0;
        let budget = MAX_PAGE_BYTES.saturating_sub(script.len() + 64 * 1024) as f64;
        let largest = selected.iter().map(|s| s.splats.len()).max().unwrap_or(1);
        let max_splats = if (total as f64) * per_splat <= budget {
            largest
        } else {
            // Every selection capped at the same count: find it by halving the excess.
            let fits = |k: usize| {
                selected
                    .iter()
                    .map(|s| s.splats.len().min(k))
                    .sum::<usize>() as f64
                    * per_splat
                    <= budget
            };
            let (mut lo, mut hi) = (1usize, largest);
            while lo < hi {
                let mid = (lo + hi).div_ceil(2);
                if fits(mid) { lo = mid } else { hi = mid - 1 }
            }
            lo
        };
        let note = format!(
            "The report's level-of-detail page of {name}, view {view} at {distance}× its              distance (the lod experiment's farther distance), every LOD method at its default              setting."
        );
        let (html, max_splats) = fit(max_splats, |k| {
            let data = lod::LodPage {
                catalogue: &run.catalogue,
                ds: &ds,
                view,
                distance,
                camera: &camera,
                selected: &selected,
                max_splats: Some(k),
                note: Some(&note),
            }
            .data()?;
            page::html_of(&with_links(data, "lod"), &script)
        })?;
        let file = format!("{name}-lod.html");
        write_atomic(&reports.join("viewer").join(&file), html.as_bytes())?;
        let shown: usize = selected
            .iter()
            .map(|s| s.splats.len().min(max_splats))
            .sum();
        crate::progress::note(format!(
            "viewer pages: {file}: {shown} of {total} splats, {} bytes",
            html.len()
        ));
        entries.push(Entry {
            dataset: name.clone(),
            view,
            file,
            points: total,
            shown,
            methods: selected.iter().map(|s| s.name.clone()).collect(),
            bytes: html.len(),
            kind: "lod".into(),
        });
    }
    Ok(entries)
}

/// Rewrites the report's viewer pages (`viewer/pages.json`) from their own embedded data,
/// without measuring: the current viewer script, each method's style, the links to the
/// results pages (`pointsight tables`). Returns how many; none when the viewer script is not
/// built (said on standard error) or there are no pages.
pub fn refresh(run: &Run, reports: &Path) -> Result<usize> {
    let list = reports.join("viewer/pages.json");
    if !list.exists() {
        return Ok(0);
    }
    let text = std::fs::read_to_string(&list)
        .with_context(|| format!("cannot read {}", list.display()))?;
    let entries: Vec<Entry> =
        serde_json::from_str(&text).with_context(|| format!("malformed {}", list.display()))?;
    let script = match page::bundle() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("viewer pages not refreshed: {e:#}");
            return Ok(0);
        }
    };
    const OPEN: &str = "<script id=\"pointsight-data\" type=\"application/json\">";
    let mut n = 0;
    for e in &entries {
        let path = reports.join("viewer").join(&e.file);
        let html = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let json = html
            .split_once(OPEN)
            .and_then(|(_, rest)| rest.split_once("</script>"))
            .map(|(json, _)| json)
            .with_context(|| format!("{} holds no page data", path.display()))?;
        let data: serde_json::Value = serde_json::from_str(json)
            .with_context(|| format!("malformed page data in {}", path.display()))?;
        let experiment = if e.kind == "lod" { "lod" } else { "visibility" };
        let page = page::html_of(
            &with_links(page::with_styles(&run.catalogue, data), experiment),
            &script,
        )?;
        write_atomic(&path, page.as_bytes())?;
        n += 1;
    }
    Ok(n)
}

/// The report page's section on the viewer pages (empty when there are none).
pub fn section(reports: &Path) -> Result<String> {
    let path = reports.join("viewer/pages.json");
    if !path.exists() {
        return Ok(String::new());
    }
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let entries: Vec<Entry> =
        serde_json::from_str(&text).with_context(|| format!("malformed {}", path.display()))?;
    if entries.is_empty() {
        return Ok(String::new());
    }
    let mut s = String::from(
        "\n## viewer\n\nInteractive 3D pages (open from disk, no server): every method's visible \
         set of view 0 against the reference, in the colours of renders.png; orbit, look \
         through the view's camera, switch methods; and level-of-detail pages, each LOD \
         method's selection with every splat at its size. `pointsight view` (`--lod`) writes \
         them for any dataset, view and methods.\n\n",
    );
    for e in entries.iter().filter(|e| e.kind == "lod") {
        let sample = if e.shown < e.points {
            format!("a uniform subsample of {} of {} splats", e.shown, e.points)
        } else {
            format!("all {} splats", e.points)
        };
        s.push_str(&format!(
            "- [{}, view {}, level of detail](viewer/{}): each splat at its size, at the lod \
             experiment's farther distance; {sample}; {}; {:.1} MiB\n",
            e.dataset,
            e.view,
            e.file,
            e.methods.join(", "),
            e.bytes as f64 / (1024.0 * 1024.0)
        ));
    }
    for e in entries.iter().filter(|e| e.kind != "lod") {
        let sample = if e.shown < e.points {
            format!("a uniform subsample of {} of {} points", e.shown, e.points)
        } else {
            format!("all {} points", e.points)
        };
        s.push_str(&format!(
            "- [{}, view {}](viewer/{}): {sample}; {}; {:.1} MiB\n",
            e.dataset,
            e.view,
            e.file,
            e.methods.join(", "),
            e.bytes as f64 / (1024.0 * 1024.0)
        ));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_pages_go_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let viewer = dir.path().join("viewer");
        std::fs::create_dir_all(&viewer).unwrap();
        for f in [
            "bunny.html",
            "dragon-871414.html",
            "dragon-871414-lod.html",
            "mine.html",
            "listed-before.html",
            "notes.txt",
            "pages.json",
        ] {
            std::fs::write(viewer.join(f), "x").unwrap();
        }
        let keep = Entry {
            dataset: "bunny".into(),
            view: 0,
            file: "bunny.html".into(),
            points: 1,
            shown: 1,
            methods: Vec::new(),
            bytes: 1,
            kind: String::new(),
        };
        remove_stale(dir.path(), &["listed-before.html".into()], &[keep]).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(&viewer)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        // The dragon's pages (named as this module names them) and the page the previous
        // listing had are gone; the user's files stay, and so does the listing.
        assert_eq!(left, ["bunny.html", "mine.html", "notes.txt", "pages.json"]);
        remove_stale(dir.path(), &[], &[]).unwrap();
        assert!(!viewer.join("pages.json").exists());
        assert!(!viewer.join("bunny.html").exists());
        assert!(viewer.join("mine.html").exists());
    }

    #[test]
    fn the_section_links_every_page_and_says_when_subsampled() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(section(dir.path()).unwrap(), "");
        let entries = vec![
            Entry {
                dataset: "dragon-871414".into(),
                view: 0,
                file: "dragon-871414.html".into(),
                points: 871_414,
                shown: 500_000,
                methods: vec!["hpr".into(), "raycast".into()],
                bytes: 5_000_000,
                kind: String::new(),
            },
            Entry {
                dataset: "bunny-69451".into(),
                view: 0,
                file: "bunny-69451-lod.html".into(),
                points: 120_000,
                shown: 90_000,
                methods: vec!["full detail".into(), "qsplat".into()],
                bytes: 4_000_000,
                kind: "lod".into(),
            },
            Entry {
                dataset: "bunny".into(),
                view: 0,
                file: "bunny.html".into(),
                points: 37_706,
                shown: 37_706,
                methods: vec!["hpr".into()],
                bytes: 900_000,
                kind: String::new(),
            },
        ];
        write_atomic(
            &dir.path().join("viewer/pages.json"),
            serde_json::to_string(&entries).unwrap().as_bytes(),
        )
        .unwrap();
        let s = section(dir.path()).unwrap();
        assert!(
            s.contains("[dragon-871414, view 0](viewer/dragon-871414.html)"),
            "{s}"
        );
        assert!(
            s.contains("a uniform subsample of 500000 of 871414 points"),
            "{s}"
        );
        assert!(s.contains("all 37706 points"), "{s}");
        assert!(
            s.contains("[bunny-69451, view 0, level of detail](viewer/bunny-69451-lod.html)")
                && s.contains("a uniform subsample of 90000 of 120000 splats"),
            "{s}"
        );
        // No results: no real dataset to draw.
        assert!(real_datasets(dir.path(), "visibility").unwrap().is_empty());
    }

    /// The committed report's pages take every default method's seconds from the visibility
    /// experiment's medians (its labels and the pages' settings agree), and a setting the
    /// experiment never timed keeps the page's own run, said so. A default method the committed
    /// report predates (no row of it at all) is the one exception; most default methods must
    /// be there.
    #[test]
    fn pages_show_the_experiments_median_for_every_default_method() {
        let reports = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../reports");
        let measured = measured_seconds(&reports);
        assert!(!measured.is_empty(), "no committed visibility results");
        let dataset = &measured[0].dataset;
        let defaults = choose(&registry::Catalogue::builtin(), None, &[]).unwrap();
        let in_report: Vec<_> = defaults
            .into_iter()
            .filter(|(m, _, _)| measured.iter().any(|r| r.method == m.name))
            .collect();
        let all = choose(&registry::Catalogue::builtin(), None, &[])
            .unwrap()
            .len();
        assert!(
            in_report.len() + 1 >= all,
            "only {} of {all} default methods in the committed report",
            in_report.len()
        );
        for (m, _, setting) in in_report {
            let (seconds, timing) = page_seconds(&measured, dataset, 0, m.name, &setting, -1.0);
            assert!(
                seconds >= 0.0 && timing.starts_with("median of "),
                "{} at {setting:?} on {dataset}: {timing}",
                m.name
            );
        }
        let (seconds, timing) = page_seconds(&measured, dataset, 0, "hpr", "gamma=-7", 0.25);
        assert_eq!((seconds, timing.as_str()), (0.25, ONE_RUN));
    }
}
