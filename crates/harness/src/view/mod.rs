//! `pointsight view`: one self-contained HTML page (no server) showing, in 3D, every chosen
//! method's visible set from one view against the reference, in the colours of
//! `renders.png`.
//!
//! The points, mesh and camera come exactly as `visible` takes them
//! ([`crate::visible::load_source`]); the methods are those named, else every registered method
//! with a sweep that can run here (external methods and installed peers included) at its
//! sweep's default setting, `--set` pairs over it (`registry::set`; typed by each method before
//! any data is read). The ground truth is the reference
//! (`truth::Reference`, the mesh's z-buffer, as in the visibility experiment); off-surface
//! points and outliers ([`crate::datasets::Dataset::off_surface`]) are a class apart and left
//! out of the scores. Without a mesh, the classes are against the methods' majority vote and
//! the page says so. The page itself is [`page`]; the script it embeds is three.js bundled by
//! esbuild in `web/` (`just web`). `view --lod` writes the level-of-detail page instead
//! ([`lod`]).

pub mod lod;
pub mod page;
pub mod report;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::Camera;
use registry::{Card, Catalogue, Output, Params};

use crate::datasets::Dataset;
use crate::output;
use crate::visible;

/// What `view` was asked.
#[derive(Debug, Clone)]
pub struct Request {
    /// The points, mesh and views.
    pub source: visible::Source,
    /// The view's index.
    pub view: usize,
    /// Method names; `None`: the defaults ([`default_methods`]).
    pub methods: Option<Vec<String>>,
    /// `KEY=VALUE` or `METHOD.KEY=VALUE` pairs over the methods' default settings.
    pub set: Vec<String>,
    /// At most this many points on the page.
    pub max_points: Option<usize>,
    /// Also write the static render of the view here.
    pub png: Option<PathBuf>,
    /// The page.
    pub out: PathBuf,
}

/// One method's answer for the view.
#[derive(Debug, Clone)]
pub struct MethodRun {
    /// Method name.
    pub name: String,
    /// Its setting, `k=v` pairs joined by `;`.
    pub setting: String,
    /// Visible indices, ascending.
    pub visible: Vec<u32>,
    /// The method's seconds.
    pub seconds: f64,
    /// What `seconds` is: one run here, or the experiment's median.
    pub timing: String,
}

/// How a page's seconds were taken when the method ran once for the page.
pub const ONE_RUN: &str = "one run";

/// What was written.
#[derive(Debug, Clone)]
pub struct Written {
    /// The page.
    pub path: PathBuf,
    /// Points of the cloud.
    pub points: usize,
    /// Points on the page.
    pub shown: usize,
    /// Methods on the page.
    pub methods: usize,
    /// Size of the page.
    pub bytes: usize,
}

impl Written {
    /// The output line: `page=FILE points=N shown=M methods=K bytes=B`.
    pub fn line(&self) -> String {
        format!(
            "page={} points={} shown={} methods={} bytes={}",
            self.path.display(),
            self.points,
            self.shown,
            self.methods,
            self.bytes
        )
    }
}

/// Every registered method with a sweep default that can run here (external methods and
/// installed peers included), in registry order, with that default's label.
pub fn default_methods(catalogue: &Catalogue) -> Result<Vec<(&'static Card, String)>> {
    let sweeps = catalogue.sweeps(None)?;
    Ok(catalogue
        .visibility_cards()
        .into_iter()
        .filter(|m| m.availability().is_ok())
        .filter_map(|m| {
            let s = sweeps.methods.get(m.name)?.default_setting()?;
            Some((m, s.label()))
        })
        .collect())
}

/// A chosen method, its parameters and their label (`k=v` pairs joined by `;`).
pub type Chosen = (&'static Card, Params, String);

/// The chosen methods with their parameters: each method's default setting (its sweep's, else
/// its card's), then the `--set` pairs that are its (`METHOD.KEY=VALUE`, or `KEY=VALUE` for every
/// chosen method that has KEY). A pair no chosen method takes is an error.
pub fn choose(
    catalogue: &Catalogue,
    names: Option<&[String]>,
    set: &[String],
) -> Result<Vec<Chosen>> {
    let sweeps = catalogue.sweeps(None)?;
    let base: Vec<(&'static Card, String)> = match names {
        None => default_methods(catalogue)?,
        Some(names) => {
            let mut out = Vec::new();
            for name in names {
                let m = catalogue.card(name.trim())?;
                if m.is_lod() {
                    bail!("{} is a level-of-detail method: show it with --lod", m.name);
                }
                if let Err(why) = m.availability() {
                    bail!("method {} cannot run here: {why}", m.name);
                }
                if out.iter().any(|(o, _): &(&Card, String)| o.name == m.name) {
                    bail!("--methods names {} twice", m.name);
                }
                let label = sweeps
                    .methods
                    .get(m.name)
                    .and_then(registry::MethodSweep::default_setting)
                    .unwrap_or_else(|| m.default_setting())
                    .label();
                out.push((m, label));
            }
            out
        }
    };
    if base.is_empty() {
        bail!("no method to show: name some with --methods");
    }
    let settings = apply_set(catalogue, &base, set)?;
    Ok(base
        .into_iter()
        .zip(settings)
        .map(|((m, _), (params, label))| (m, params, label))
        .collect())
}

/// Each method's default `label` (`k=v` pairs joined by `;`) with the `--set` pairs that are
/// its (`METHOD.KEY=VALUE`, or `KEY=VALUE` for every method with KEY; `registry::set`, one
/// value each), as parameters and their sorted label, typed by each method's card (no data is
/// read). A pair no method takes is an error naming what they accept.
pub fn apply_set(
    catalogue: &Catalogue,
    methods: &[(&'static Card, String)],
    set: &[String],
) -> Result<Vec<(Params, String)>> {
    let set = registry::Assignments::parse(set).map_err(visible::set_error)?;
    set.one_setting("view").map_err(visible::set_error)?;
    let cards: Vec<&Card> = methods.iter().map(|(m, _)| *m).collect();
    set.check_targets(catalogue, &cards)
        .map_err(visible::set_error)?;
    methods
        .iter()
        .map(|(m, label)| {
            let pairs: Vec<&str> = label.split(';').filter(|kv| kv.contains('=')).collect();
            let params = set.over_params(m, &Params::parse(&pairs)?);
            visible::typed(m, &params, &set)?;
            let label = params.canonical();
            Ok((params, label))
        })
        .collect()
}

/// Runs one method on view `view` (whose camera is `camera`) through the measurement kernel:
/// preparation, then one timed run (the one place this module runs a method).
pub fn run_method(
    method: &Card,
    ds: &Dataset,
    params: &Params,
    view: usize,
    camera: &Camera,
) -> Result<(Output, f64)> {
    let views = [registry::kernel::View {
        index: view,
        camera: *camera,
    }];
    let cell = registry::kernel::Cell {
        method,
        params: params.clone(),
        views: &views,
        repeats: 1,
        budget: None,
        parallel: false,
    };
    let (prepared, answers) = registry::kernel::collect(&cell, ds.input());
    prepared?;
    let answer = answers
        .into_iter()
        .next()
        .context("the kernel answered no view")?
        .1
        .map_err(anyhow::Error::msg)?;
    Ok((answer.output, answer.timing.median))
}

/// Runs the request: every method on the view, then the page (and the static render).
pub fn run(run: &crate::run::Run, req: &Request, data_dir: &Path) -> Result<Written> {
    // The script first: a missing bundle is reported before any work.
    let script = page::bundle()?;
    if req.max_points == Some(0) {
        bail!("--max-points must be at least 1");
    }
    // The methods and their settings, typed, before any data is read.
    let chosen = choose(&run.catalogue, req.methods.as_deref(), &req.set)?;
    let ds = visible::load_source(run, &req.source, data_dir)?;
    let camera = *ds.view(req.view)?;
    let mut runs = Vec::new();
    for (m, params, setting) in &chosen {
        let (out, seconds) = run_method(m, &ds, params, req.view, &camera)
            .with_context(|| format!("method {} on view {}", m.name, req.view))?;
        runs.push(MethodRun {
            name: m.name.to_owned(),
            setting: setting.clone(),
            visible: out.visible,
            seconds,
            timing: ONE_RUN.to_owned(),
        });
    }
    let truth = page::Truth::of(&ds, &camera, &runs)?;
    let html = page::Page {
        catalogue: &run.catalogue,
        ds: &ds,
        view: req.view,
        camera: &camera,
        runs: &runs,
        truth: &truth,
        max_points: req.max_points,
        note: None,
    }
    .html(&script)?;
    if let Some(png) = &req.png {
        let panel = output::render::classified_panel(
            "reference",
            &camera,
            &ds.cloud.positions,
            &truth.visible,
            None,
        );
        output::write_png(png, panel.width, panel.height, &panel.rgb)?;
    }
    output::write_atomic(&req.out, html.as_bytes())?;
    Ok(Written {
        path: req.out.clone(),
        points: ds.cloud.len(),
        shown: req
            .max_points
            .map_or(ds.cloud.len(), |m| m.min(ds.cloud.len())),
        methods: runs.len(),
        bytes: html.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_swept_methods() {
        let names: Vec<&str> = default_methods(&Catalogue::builtin())
            .unwrap()
            .iter()
            .map(|(m, _)| m.name)
            .collect();
        for m in ["hpr", "raycast", "splat"] {
            assert!(names.contains(&m), "{names:?}");
        }
        assert!(!names.contains(&"reference"), "{names:?}");
    }

    fn error_of(r: Result<Vec<Chosen>>) -> String {
        match r {
            Ok(_) => panic!("expected an error"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn set_pairs_go_to_the_methods_that_have_them() {
        let names = ["hpr".to_owned(), "splat".to_owned()];
        let chosen = choose(
            &Catalogue::builtin(),
            Some(&names),
            &["gamma=3.5".into(), "splat.radius_px=1".into()],
        )
        .unwrap();
        assert!(chosen[0].2.contains("gamma=3.5"), "{}", chosen[0].2);
        assert!(chosen[1].2.contains("radius_px=1"), "{}", chosen[1].2);
        assert!(!chosen[1].2.contains("gamma"), "{}", chosen[1].2);
        let err = error_of(choose(
            &Catalogue::builtin(),
            Some(&names),
            &["nonsense=1".into()],
        ));
        assert!(err.contains("no chosen method"), "{err}");
        let err = error_of(choose(
            &Catalogue::builtin(),
            Some(&["nosuch".to_owned()]),
            &[],
        ));
        assert!(err.contains("nosuch"), "{err}");
        let err = error_of(choose(
            &Catalogue::builtin(),
            Some(&["hpr".to_owned(), "hpr".to_owned()]),
            &[],
        ));
        assert!(err.contains("twice"), "{err}");
    }
}
