//! `pointsight visible`: one method on one view (the output contract of a single file) or on
//! many views at once (a folder of index files).
//!
//! Per-dataset preparation (k-d tree, BVH) is done once; for many views, methods that say so
//! (`registry::Card::parallel_views`) answer views in parallel, the others one after another
//! (their single view already uses every core). The `--set` pairs are the method's setting,
//! typed by its card before the cloud is read (`registry::set`: one value each; a list is a
//! sweep, for `run`); a key left out is its default (the card's, as everywhere), and the line
//! before the last says
//! the setting as it ran: `setting=k=v;...`, every key the method read with its value.
//! When some of many views fail (an external program that dies at view 9), the views answered
//! are still written, each file whole, and the error names the first failure, how many views
//! were answered and which were not.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use cloud::Camera;
use cloud::glam::DVec3;

use crate::datasets::{self, Dataset};
use registry::scoring::Score;
use registry::{Output, Params, kernel};

use crate::output;

/// How `visible` runs many views.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ParallelViews {
    /// As the method prefers.
    Auto,
    /// One view per thread.
    Yes,
    /// One view after another.
    No,
}

/// A camera given on the command line (world coordinates); what is absent gets a default that
/// fits the cloud.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraFlags {
    /// Eye.
    pub eye: Option<[f64; 3]>,
    /// Target (default: the centre of the cloud's bounding box).
    pub target: Option<[f64; 3]>,
    /// Up (default +z, or +y when the view is along z).
    pub up: Option<[f64; 3]>,
    /// Vertical field of view, degrees (default: the cloud's bounding sphere, 5 % margin).
    pub fov_y_deg: Option<f64>,
    /// Image width (default 1280).
    pub width: Option<u32>,
    /// Image height (default 720).
    pub height: Option<u32>,
}

impl CameraFlags {
    /// The camera these flags describe around `cloud` (world coordinates).
    pub fn camera(&self, cloud: &[DVec3]) -> Result<Camera> {
        let eye = DVec3::from_array(self.eye.context("--eye X,Y,Z is needed with --cloud")?);
        let bbox = cloud::Aabb::from_points(cloud).context("the cloud is empty")?;
        let target = self.target.map_or(bbox.center(), DVec3::from_array);
        let up = self.up.map_or_else(
            || cloud::camera::json::default_up(target - eye),
            DVec3::from_array,
        );
        let fov = match self.fov_y_deg {
            Some(f) => f,
            None => {
                // The bounding sphere seen from the eye, 5 % margin; 90° from inside it. Only
                // r / d matters: both are computed on vectors divided by their largest
                // component, so clouds near the ends of the f64 range do not overflow.
                let (extent, to_eye) = (bbox.max - bbox.min, bbox.center() - eye);
                let unit = extent.abs().max_element().max(to_eye.abs().max_element());
                let unit = if unit > 0.0 && unit.is_finite() {
                    unit
                } else {
                    1.0
                };
                let r = 0.5 * (extent / unit).length();
                let d = (to_eye / unit).length();
                if d > 1.0001 * r {
                    // At least 10^-6 degrees: an eye too far for any field of view is refused
                    // by the view check (`Dataset::check_views`) with its reason.
                    ((2.0 * (r / d).asin()).to_degrees() * 1.05).clamp(1e-6, 170.0)
                } else {
                    90.0
                }
            }
        };
        Ok(Camera::new(
            eye,
            target,
            up,
            fov,
            self.width.unwrap_or(1280),
            self.height.unwrap_or(720),
        )?)
    }
}

/// Where the points, the mesh and the views come from: a dataset, or a user's files and camera
/// (shared by `visible`, `view` and `run`).
#[derive(Debug, Clone, Default)]
pub struct Source {
    /// Dataset name (ignored with `cloud`).
    pub dataset: Option<String>,
    /// A point file instead of a dataset.
    pub cloud: Option<PathBuf>,
    /// A mesh file for the ground truth (with `cloud`).
    pub mesh: Option<PathBuf>,
    /// How to read the cloud file.
    pub read: cloud::io::ReadOptions,
    /// E57: merge several scans (else one must be chosen).
    pub merge_scans: bool,
    /// Off-surface tolerance for scoring.
    pub surface_tolerance: Option<f64>,
    /// Score against a mesh that does not fit the points anyway (`datasets::fit`), whatever
    /// dataset this source names.
    pub allow_off_surface: bool,
    /// A camera from flags.
    pub camera: CameraFlags,
    /// A views file replacing the dataset's views.
    pub views: Option<PathBuf>,
}

impl Source {
    /// The name of the dataset this source loads: the cloud file's stem, else the dataset's.
    pub fn name(&self) -> Option<String> {
        match &self.cloud {
            Some(path) => Some(file_dataset_name(path)),
            None => self.dataset.clone(),
        }
    }

    /// This source's cameras over dataset `name` instead (no files of its own).
    pub fn for_dataset(&self, name: &str) -> Self {
        Self {
            dataset: Some(name.to_owned()),
            camera: self.camera.clone(),
            views: self.views.clone(),
            allow_off_surface: self.allow_off_surface,
            ..Self::default()
        }
    }
}

/// The dataset name of a user's point file: its stem.
pub fn file_dataset_name(path: &Path) -> String {
    path.file_stem()
        .map_or("cloud".into(), |s| s.to_string_lossy().into_owned())
}

/// What `visible` was asked.
#[derive(Debug, Clone)]
pub struct Request {
    /// The points, mesh and views.
    pub source: Source,
    /// `K`, `all` or `K1,K2,...`.
    pub view: String,
    /// Method name.
    pub method: String,
    /// `--set` pairs.
    pub set: Vec<String>,
    /// Output file (one view) or folder (many).
    pub out: PathBuf,
    /// Score against the reference.
    pub score: bool,
    /// How to run many views.
    pub parallel_views: ParallelViews,
    /// Runs per view (the reported seconds are their median).
    pub repeat: usize,
}

/// `samples=K median=T min=T q1=T q3=T max=T`: the spread of the repeated runs.
pub fn timing_line(t: &registry::timing::Timing) -> String {
    format!(
        "samples={} median={:.6} min={:.6} q1={:.6} q3={:.6} max={:.6}",
        t.samples, t.median, t.min, t.q1, t.q3, t.max
    )
}

/// The view indices `spec` names among `n` views.
pub fn parse_views(spec: &str, n: usize) -> Result<Vec<usize>> {
    if n == 0 {
        bail!("there are no views");
    }
    if spec == "all" {
        return Ok((0..n).collect());
    }
    let mut out = Vec::new();
    for part in spec.split(',') {
        let k: usize = part
            .trim()
            .parse()
            .with_context(|| format!("--view {spec:?}: expected all, K or K1,K2,..."))?;
        if k >= n {
            bail!("view {k} does not exist: there are views 0..{}", n - 1);
        }
        if out.contains(&k) {
            bail!("--view {spec:?}: view {k} given twice");
        }
        out.push(k);
    }
    Ok(out)
}

/// `--out -`: standard output.
fn to_stdout(out: &Path) -> bool {
    out.as_os_str() == "-"
}

fn indices_text(visible: &[u32]) -> String {
    let mut text = String::with_capacity(visible.len() * 8);
    for i in visible {
        text.push_str(&i.to_string());
        text.push('\n');
    }
    text
}

/// The score line: the reference's count, precision, recall, F1 (off-surface points left out
/// and counted), and whether the mesh fits the points (`mesh_fit=ok`, or `off-surface` when
/// `--allow-off-surface` let a mesh that does not fit be used: `datasets::fit`).
fn score_line(
    reference: &truth::Reference,
    ds: &Dataset,
    camera: &Camera,
    output: &Output,
    off_surface: Option<(&[bool], f64)>,
) -> Result<String> {
    let (off_surface, tolerance) = match off_surface {
        Some((f, t)) => (Some(f), t),
        None => (None, f64::NAN),
    };
    let truth = reference
        .visibility(
            ds.truth_points(),
            camera,
            &truth::ReferenceParams::default(),
        )?
        .visible;
    let s = Score::of_on_surface(&output.visible, &truth, off_surface);
    let off = off_surface.map_or(0, |f| f.iter().filter(|&&o| o).count());
    let off_visible = off_surface.map_or(0, |f| {
        output.visible.iter().filter(|&&i| f[i as usize]).count()
    });
    Ok(format!(
        "reference_visible={} off_surface={off} off_surface_visible={off_visible} \
         surface_tolerance={tolerance:.6} precision={:.4} recall={:.4} f1={:.4} mesh_fit={}",
        truth
            .iter()
            .enumerate()
            .filter(|&(i, &t)| t && off_surface.is_none_or(|f| !f[i]))
            .count(),
        s.precision(),
        s.recall(),
        s.f1(),
        ds.mesh_fit_mark()
    ))
}

/// The dataset `src` names, its views replaced by the views file or the camera flags when
/// given; the errors `visible` gives for bad input.
pub fn load_source(run: &crate::run::Run, src: &Source, data_dir: &Path) -> Result<Dataset> {
    let mut ds = match (&src.cloud, &src.dataset) {
        (Some(path), _) => {
            let is_e57 = src.read.format.or_else(|| cloud::io::Format::of_path(path))
                == Some(cloud::io::Format::E57);
            if is_e57 && src.read.scan.is_none() && !src.merge_scans {
                let n = cloud::io::e57::scan_count(path)?;
                if n > 1 {
                    bail!(
                        "{} holds {n} scans: choose one with --scan K (0..{}) or merge them \
                         with --merge-scans",
                        path.display(),
                        n - 1
                    );
                }
            }
            datasets::load_files(&datasets::FileDataset {
                name: file_dataset_name(path),
                description: format!("{}", path.display()),
                cloud: Some(path.clone()),
                sample: None,
                mesh: src.mesh.clone(),
                read: src.read.clone(),
                views: datasets::ViewsFrom::Spec(cloud::ViewSpec::default()),
                surface_tolerance: src.surface_tolerance,
                degrade: (Vec::new(), 1),
                allow_off_surface: src.allow_off_surface,
            })?
        }
        (None, Some(name)) => {
            if src.mesh.is_some() {
                bail!("--mesh goes with --cloud; a dataset has its own mesh");
            }
            run.datasets.load(name, data_dir)?
        }
        (None, None) => bail!("give --dataset NAME or --cloud FILE"),
    };
    if let Some(path) = &src.views {
        ds.views = cloud::io::views::read_views(path)?
            .iter()
            .map(|c| ds.camera_from_world(c))
            .collect();
    } else if src.camera.eye.is_some() {
        let world = ds.world_positions();
        ds.views = vec![ds.camera_from_world(&src.camera.camera(&world)?)];
    } else if src.cloud.is_some() {
        bail!(
            "with --cloud, give a camera: --eye X,Y,Z (and optionally --target, --up, --fov-y, --width, --height) or --views FILE"
        );
    }
    ds.check_views()?;
    // Views most methods were not made for, said once (a dataset loaded again warns no more).
    for line in datasets::eyes::find(&ds)?.lines(&ds.name, ds.views.len()) {
        crate::progress::warn_once(line);
    }
    if !ds.files.is_empty() {
        // A user's mesh, checked before it becomes a ground truth; built-in datasets are
        // samples of their own meshes.
        let allow = src.allow_off_surface || ds.allow_off_surface;
        let mesh = src
            .mesh
            .clone()
            .or_else(|| run.datasets.manifest_mesh(&ds.name));
        datasets::fit::check(&mut ds, allow, mesh.as_deref())?;
        if let Some(fit) = ds.mesh_fit.as_ref().filter(|f| f.allowed) {
            crate::progress::warn_once(format!(
                "warning: dataset {}: the mesh does not fit the points: {}; scored against it \
                 anyway (--allow-off-surface): rows marked mesh_fit=off-surface",
                ds.name,
                fit.text()
            ));
        }
    }
    Ok(ds)
}

/// A registry error of the `--set` pairs themselves in `--set` words (`--set PAIR: why`, as
/// `cli::frame_set` frames it); any other error as it is.
pub fn set_error(err: registry::Error) -> anyhow::Error {
    match err {
        registry::Error::BadPair { pair, reason } => anyhow::anyhow!("--set {pair}: {reason}"),
        other => other.into(),
    }
}

/// A method's setting typed by its card before any data is read (`registry::Card::check`),
/// its value errors naming the method: `--set KEY=VALUE: method M: why` for a key `set` gave,
/// `method M: parameter KEY=VALUE: why` for one from a default or `--config`.
pub fn typed(
    card: &registry::Card,
    params: &Params,
    set: &registry::Assignments,
) -> Result<registry::Setting> {
    card.check(params).map_err(|e| match e {
        registry::Error::BadValue { key, value, reason } => {
            if set.0.iter().any(|a| a.key == key && a.is_for(card)) {
                anyhow::anyhow!("--set {key}={value}: method {}: {reason}", card.name)
            } else {
                anyhow::anyhow!("method {}: parameter {key}={value}: {reason}", card.name)
            }
        }
        other => other.into(),
    })
}

/// Runs the request; prints the contract lines.
pub fn run(run: &crate::run::Run, req: &Request, data_dir: &Path) -> Result<()> {
    // The setting first, typed by the method's card: a bad value is refused before the cloud
    // is read.
    let set = registry::Assignments::parse(&req.set)?;
    set.one_setting("visible")?;
    let method = run.catalogue.card(&req.method)?;
    set.check_targets(&run.catalogue, &[method])?;
    let params = set.over_params(method, &Params::default());
    typed(method, &params, &set)?;
    let ds = load_source(run, &req.source, data_dir)?;
    let many = req.source.views.is_some() || req.view.parse::<usize>().is_err();
    let reference = if req.score {
        Some(truth::Reference::new(ds.mesh("--score")?)?)
    } else {
        None
    };
    let off = if req.score { ds.off_surface()? } else { None };
    let off_flags = off.as_ref().map(|(f, t)| (&f[..], *t));
    if !many {
        // The single-view contract: a file, `prepare_seconds`, then the contract line.
        let k: usize = req.view.parse()?;
        let views = [kernel::View {
            index: k,
            camera: *ds.view(k)?,
        }];
        let camera = views[0].camera;
        let cell = kernel::Cell {
            method,
            params,
            views: &views,
            repeats: req.repeat,
            budget: None,
            parallel: false,
        };
        let (prepared, answers) = kernel::collect(&cell, ds.input());
        let preparation = prepared?;
        let kernel::Answer { output, timing, .. } = answers
            .into_iter()
            .next()
            .context("the kernel answered no view")?
            .1
            .map_err(anyhow::Error::msg)?;
        // An external program's timing is its own reported compute time (`registry::kernel`).
        let seconds = timing.median;
        let mut lines = vec![format!(
            "prepare_seconds={:.6}{} rays={}",
            preparation.seconds,
            build_text(&preparation),
            output.rays
        )];
        if let Some(r) = &reference {
            lines.push(score_line(r, &ds, &camera, &output, off_flags)?);
        }
        lines.push(timing_line(&timing));
        lines.push(format!("setting={}", preparation.setting.label()));
        lines.push(format!(
            "method={} points={} visible={} seconds={seconds:.6}",
            method.name,
            ds.cloud.len(),
            output.visible.len()
        ));
        if to_stdout(&req.out) {
            // The indices are standard output; the lines that describe them go to standard
            // error, so that a pipe reads indices alone.
            use std::io::Write as _;
            std::io::stdout()
                .lock()
                .write_all(indices_text(&output.visible).as_bytes())
                .context("cannot write the indices to standard output")?;
            for line in lines {
                eprintln!("{line}");
            }
        } else {
            output::write_atomic(&req.out, indices_text(&output.visible).as_bytes())?;
            for line in lines {
                println!("{line}");
            }
        }
        return Ok(());
    }

    if to_stdout(&req.out) {
        bail!(
            "--out - writes one view's indices to standard output; many views need a folder \
             (--out DIR: view-K.txt each)"
        );
    }
    let chosen = parse_views(&req.view, ds.views.len())?;
    let views: Vec<kernel::View> = chosen
        .iter()
        .map(|&index| kernel::View {
            index,
            camera: ds.views[index],
        })
        .collect();
    let parallel = match req.parallel_views {
        ParallelViews::Auto => method.parallel_views,
        ParallelViews::Yes => true,
        ParallelViews::No => false,
    };
    let cell = kernel::Cell {
        method,
        params,
        views: &views,
        repeats: req.repeat,
        budget: None,
        parallel,
    };
    let start = Instant::now();
    let mut results: Vec<(usize, Output, f64)> = Vec::with_capacity(views.len());
    let mut failure = None;
    let mut failed = Vec::new();
    let prepared = kernel::run(&cell, ds.input(), |view, answer| match answer {
        Ok(a) => results.push((view.index, a.output, a.timing.median)),
        Err(e) => {
            failed.push(view.index);
            failure.get_or_insert_with(|| format!("view {}: {e}", view.index));
        }
    });
    let preparation = prepared?;
    let prepare_seconds = preparation.seconds;
    if results.is_empty()
        && let Some(f) = failure
    {
        bail!("{f}; none of the {} views was answered", views.len());
    }
    println!(
        "prepare_seconds={prepare_seconds:.6}{} views={} parallel_views={parallel}",
        build_text(&preparation),
        views.len(),
    );
    // The views' wall time, the per-dataset preparation excluded.
    let wall = start.elapsed().as_secs_f64() - prepare_seconds;
    // The folder is written whole, replacing only a views folder of pointsight's
    // (`output::folder`): the answers, and the metadata that lists them.
    output::folder::replace(&req.out, output::folder::Role::Views, |staging| {
        for (k, output, _) in &results {
            output::write_atomic(
                &staging.join(format!("view-{k}.txt")),
                indices_text(&output.visible).as_bytes(),
            )?;
        }
        let parameters = serde_json::json!({
            "method": method.name,
            "setting": preparation.setting.label(),
            "views": results.iter().map(|(k, _, _)| k).collect::<Vec<_>>(),
            "views_failed": &failed,
        });
        output::meta::RunMeta::now(
            output::folder::Role::VIEWS,
            false,
            std::slice::from_ref(&ds.name),
            parameters,
        )
        .write(staging)?;
        output::folder::seal(staging)
    })?;
    for (k, output, seconds) in &results {
        if let Some(r) = &reference {
            println!(
                "view={k} {}",
                score_line(r, &ds, &ds.views[*k], output, off_flags)?
            );
        }
        println!(
            "view={k} method={} points={} visible={} seconds={seconds:.6}",
            method.name,
            ds.cloud.len(),
            output.visible.len()
        );
    }
    if let Some(f) = failure {
        // The views answered are written (each file whole); the error names the ones not.
        let failed: Vec<String> = failed.iter().map(ToString::to_string).collect();
        bail!(
            "{f}; {} of the {} views were answered and written to {} (view-K.txt), views {} \
             were not",
            results.len(),
            views.len(),
            req.out.display(),
            failed.join(", ")
        );
    }
    println!("setting={}", preparation.setting.label());
    println!(
        "views={} points={} seconds={wall:.6} views_per_second={:.3}",
        results.len(),
        ds.cloud.len(),
        results.len() as f64 / wall.max(1e-12)
    );
    Ok(())
}

/// ` build_seconds=T` when the method reported its own build seconds (an external program's
/// `built` line), else nothing.
fn build_text(p: &kernel::Preparation) -> String {
    p.reported_seconds
        .map_or(String::new(), |s| format!(" build_seconds={s:.6}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_specs() {
        assert_eq!(parse_views("all", 3).unwrap(), vec![0, 1, 2]);
        assert_eq!(parse_views("2,0", 3).unwrap(), vec![2, 0]);
        assert!(
            parse_views("3", 3)
                .unwrap_err()
                .to_string()
                .contains("view 3 does not exist")
        );
        assert!(parse_views("1,1", 3).is_err());
        assert!(parse_views("one", 3).is_err());
    }
}
