//! The interactive results page of an experiment: `EXPERIMENT/results.html`, one
//! self-contained HTML file (opens from disk, no server) holding the experiment's figures as
//! their JSON twins ([`super::figure`]) and the script `web/dist/results.js` (Observable Plot
//! and `web/src/results.js`, bundled by esbuild; `just web`), which draws them with the same
//! styles as the PNGs: hover names a point (method, setting, score with its interval, seconds),
//! a click on a legend entry hides a series, a filter hides families.
//!
//! The figures come in the order `summary.md` shows them (its `![..](ID.png)` links whose
//! `ID.json` is a figure twin), then any other twin by name. Written by `pointsight report`,
//! `tables`, `bench` and `merge` (through [`super::report::assemble`]) and by a run into its
//! own folder; without the built script, no page is written and the caller says so.

use std::path::Path;

use anyhow::{Context, Result};

use super::figure::FORMAT;
use super::write_atomic;

/// The environment variable naming a built results script instead of `web/dist/results.js`.
pub const BUNDLE_VAR: &str = "POINTSIGHT_RESULTS_JS";

/// The page's file name in an experiment's folder.
pub const PAGE: &str = "results.html";

/// The results script (looked for by `paths::script_candidates`: `$POINTSIGHT_RESULTS_JS`,
/// the clone's `web/dist/`, or installed beside the binary), or `None` when it is not built.
pub fn bundle() -> Result<Option<String>> {
    let candidates = crate::paths::script_candidates("results.js", BUNDLE_VAR);
    crate::paths::find_script(&candidates)
        .map(|p| {
            std::fs::read_to_string(p)
                .with_context(|| format!("cannot read the results script {}", p.display()))
        })
        .transpose()
}

/// The figure twins of `dir`, in the order its `summary.md` shows them.
pub fn figures(dir: &Path) -> Result<Vec<serde_json::Value>> {
    let mut names: Vec<String> = Vec::new();
    if let Ok(summary) = std::fs::read_to_string(dir.join("summary.md")) {
        for target in super::link_targets(&summary) {
            if let Some(stem) = target.strip_suffix(".png")
                && !names.iter().any(|n| n == stem)
            {
                names.push(stem.to_owned());
            }
        }
    }
    let mut others: Vec<String> = Vec::new();
    if dir.is_dir() {
        for entry in
            std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))?
        {
            let path = entry?.path();
            if path.extension().is_some_and(|e| e == "json")
                && let Some(stem) = path.file_stem().and_then(|s| s.to_str())
                && !names.iter().any(|n| n == stem)
            {
                others.push(stem.to_owned());
            }
        }
    }
    others.sort();
    let mut out = Vec::new();
    for name in names.into_iter().chain(others) {
        let path = dir.join(format!("{name}.json"));
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let Ok(value) = serde_json::from_str::<serde_json::Value>(&text) else {
            continue;
        };
        if value["format"] == FORMAT {
            out.push(value);
        }
    }
    Ok(out)
}

/// A link on the page.
#[derive(Debug, Clone)]
pub struct Link {
    /// Text.
    pub label: String,
    /// Target, relative to the page.
    pub href: String,
}

/// The page's data (the JSON the script reads).
pub fn data(
    experiment: &str,
    summary: &str,
    links: &[Link],
    figures: Vec<serde_json::Value>,
) -> serde_json::Value {
    serde_json::json!({
        "kind": "results",
        "experiment": experiment,
        "title": format!("pointsight results: {experiment}"),
        "note": format!(
            "{summary}. Hover a point for its method, setting, score and time; click a legend \
             entry to hide or show that series; untick a family to hide it everywhere. Each \
             figure's data is its JSON file, beside its PNG."
        ),
        "links": links.iter().map(|l| serde_json::json!({"label": l.label, "href": l.href})).collect::<Vec<_>>(),
        "markers": super::style::marker_shapes(),
        "figures": figures,
    })
}

/// A page of `data` with `script` embedded (as the viewer's pages: the JSON and the script
/// each in their own `<script>` element, `</` escaped).
pub fn html(data: &serde_json::Value, script: &str) -> Result<String> {
    let title = data["title"].as_str().unwrap_or("pointsight");
    super::data_page("pointsight report", title, data, script)
}

/// Writes `dir/results.html` for `experiment` when `dir` holds figures; `Ok(false)` when it
/// holds none (no page).
pub fn write_page(
    dir: &Path,
    experiment: &str,
    summary: &str,
    links: &[Link],
    script: &str,
) -> Result<bool> {
    let figures = figures(dir)?;
    if figures.is_empty() {
        return Ok(false);
    }
    let page = html(&data(experiment, summary, links, figures), script)?;
    write_atomic(&dir.join(PAGE), page.as_bytes())?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::figure::{Axis, Draw, Figure, Point, Series};

    #[test]
    fn the_page_holds_the_figures_in_the_summarys_order() {
        let dir = tempfile::tempdir().unwrap();
        let fig = |id: &str| {
            Figure::new(id, id, Axis::linear("x"), Axis::linear("y")).series(
                vec![Series::new(
                    "hpr",
                    "hpr-linear",
                    "best",
                    Draw::Line,
                    vec![Point::new(1.0, 2.0)],
                )],
                Vec::new(),
            )
        };
        let b = fig("b").write(dir.path()).unwrap();
        let a = fig("a").write(dir.path()).unwrap();
        fig("c").write(dir.path()).unwrap();
        // Not a figure: ignored.
        std::fs::write(dir.path().join("other.json"), "{\"x\": 1}").unwrap();
        std::fs::write(dir.path().join("summary.md"), format!("{b}{a}")).unwrap();
        let ids: Vec<String> = figures(dir.path())
            .unwrap()
            .iter()
            .map(|f| f["id"].as_str().unwrap().to_owned())
            .collect();
        assert_eq!(ids, ["b", "a", "c"]);
        let links = [Link {
            label: "report".into(),
            href: "../README.md#x".into(),
        }];
        assert!(
            write_page(
                dir.path(),
                "x",
                "what x does",
                &links,
                "/* script </script> */"
            )
            .unwrap()
        );
        let page = std::fs::read_to_string(dir.path().join(PAGE)).unwrap();
        assert!(
            page.contains("<\\/script> */</script>"),
            "the script cannot close its element"
        );
        let json = page
            .split("<script id=\"pointsight-data\" type=\"application/json\">")
            .nth(1)
            .and_then(|s| s.split("</script>").next())
            .unwrap();
        let data: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(data["figures"].as_array().unwrap().len(), 3);
        assert_eq!(data["links"][0]["href"], "../README.md#x");
        assert!(data["markers"]["triangle-down"].is_array());
        // A folder without figures gets no page.
        let empty = tempfile::tempdir().unwrap();
        assert!(!write_page(empty.path(), "x", "", &[], "").unwrap());
    }
}
