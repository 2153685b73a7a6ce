//! Experiment `lod`: level-of-detail methods against the full-cloud render, and seed 003's
//! Table 1.
//!
//! Every point gets a colour from a texture (the marble of `srn::texture`, through the cloud's
//! texture coordinates or, when it has none, the spherical parameterisation of
//! `srn::param`), so colour detail counts in the image comparison. For each dataset, view
//! (0..[`N_VIEWS`]) and distance (the view's eye moved along its ray to [`DISTANCES`] times
//! its distance to the target), the experiment renders (a dataset with fewer than [`N_VIEWS`]
//! views, such as one camera given with `run lod --eye`, is measured over the views it has):
//! - the *reference*: every point as a splat of radius [`REF_RADIUS`] density spacings
//!   (`cloud::spacing::density_spacing`: 1/sqrt(points per unit area); 1.5 spacings leave
//!   e^(−π·1.5²) ≈ 0.1 % of a randomly sampled surface uncovered), shaded by `splat::render`;
//! - every LOD method of the registry (QSplat, SPT, SRN, random; one built per dataset, one
//!   selection per setting of its sweep in `registry/src/sweeps.toml` or `--config`): `qsplat`
//!   (leaves of that radius) at projected-size thresholds in pixels; `spt` (leaf discs of that
//!   diameter) at ε in pixels (`spt::epsilon_for_pixels`); `srn` with the texture's masking
//!   importance at density scales (1 is the paper's setting), kept splats grown by 1/sqrt(I);
//!   `random`: each point kept when its seeded uniform number is below f, splats grown by
//!   1/sqrt(f).
//!
//! `results.csv` columns: dataset, view, distance, method, params, points_rendered, seconds
//! (the selection alone: traversal, cut or test; median of `--repeats` runs), psnr, ssim,
//! hole_fraction. PSNR is over the RGB pixels covered in either image (background excluded, so
//! the object's screen size does not inflate it; capped at 100 dB for identical images); SSIM
//! is on luma in 8 × 8 windows at a stride of 4 (C1 = (0.01·255)², C2 = (0.03·255)²) averaged
//! over the windows that touch the reference's covered pixels; hole_fraction is the share of
//! the reference's covered pixels that the LOD render leaves empty. `builds.csv`: build time
//! and size of each structure. `strip_DATASET.png`: view 0 at the near distance, each method
//! at three levels beside the reference.
//!
//! Seed 003 Table 1 (`srn_table.csv`, `srn_table.md`, PNGs in `srn/`): vase-7171 with a flower
//! texture, torus-22321 with the flower on one half (Figure 8), armadillo-200004 (standing in
//! for the gargoyle, which is not freely available) with the marble texture; SRN at density
//! scale 1; point counts and render times beside the paper's.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use cloud::{Camera, PointCloud};
use registry::lod::LodData;
use registry::scoring::{hole_fraction, psnr, ssim};
use registry::{Card, Setting, kernel};
use serde::{Deserialize, Serialize};
use splat::render::{Image, RenderParams, render};

use super::rules::curve::IDENTICAL_PSNR;
use super::{Context, Experiment, markdown_table};

mod budgets;
mod from_file;
pub mod noise;
mod peer_notes;
mod srn_table;
use crate::output::figure::{Axis, Draw, Figure, Point, Series};
use crate::output::render::{Panel, compose};
use crate::output::{distinct, read_csv, write_atomic, write_csv};
use crate::progress;
pub use from_file::{CACHE_BYTES as FILE_CACHE_BYTES, FileRead};
pub use srn_table::SrnRow;

/// Views per dataset: the first this many of its views (all of them when it has fewer; at
/// least one).
pub const N_VIEWS: usize = 8;
/// Eye distances, as multiples of the view's eye-to-target distance.
pub const DISTANCES: &[f64] = &[1.0, FAR_DISTANCE];

/// The farther of [`DISTANCES`] (the LOD pages' default).
pub const FAR_DISTANCE: f64 = 2.0;
/// Reference splat radius, in density spacings.
pub const REF_RADIUS: f64 = crate::lod_build::LEAF_RADIUS_SPACINGS;
/// Texture resolution of the procedural textures.
pub const TEXTURE_SIZE: usize = 512;
/// Seed of the random numbers (SRN, random baseline, marble texture).
pub const SEED: u64 = 2006;

/// The experiment.
pub struct LodExperiment;

/// One row of `results.csv` (the column order is the output contract).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// Dataset name.
    pub dataset: String,
    /// View index.
    pub view: usize,
    /// Eye distance factor.
    pub distance: f64,
    /// Method.
    pub method: String,
    /// Setting, `key=value` pairs joined by `;`.
    pub params: String,
    /// Splats drawn.
    pub points_rendered: usize,
    /// Selection time.
    pub seconds: f64,
    /// PSNR against the reference render, dB.
    pub psnr: f64,
    /// SSIM against the reference render.
    pub ssim: f64,
    /// Share of the reference's pixels left empty.
    pub hole_fraction: f64,
    /// `ok`, or `error: …` for a build or selection that failed (metrics NaN).
    #[serde(default = "ok_status")]
    pub status: String,
    /// The dataset's points, which the findings' budgets are shares of (0 in older results).
    #[serde(default)]
    pub n_points: usize,
}

impl Row {
    /// A row of no measurement yet (metrics NaN) with its status.
    pub fn new(
        dataset: String,
        view: usize,
        distance: f64,
        method: String,
        params: String,
        status: String,
    ) -> Self {
        Self {
            dataset,
            view,
            distance,
            method,
            params,
            points_rendered: 0,
            seconds: f64::NAN,
            psnr: f64::NAN,
            ssim: f64::NAN,
            hole_fraction: f64::NAN,
            status,
            n_points: 0,
        }
    }
}

fn ok_status() -> String {
    "ok".into()
}

/// One row of `builds.csv`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BuildRow {
    /// Dataset name.
    pub dataset: String,
    /// Method.
    pub method: String,
    /// Input points.
    pub n_points: usize,
    /// Build time, seconds.
    pub seconds: f64,
    /// Nodes or entries in the structure.
    pub nodes: usize,
    /// Bytes of the structure per input point (0 when not meaningful).
    pub bytes_per_point: f64,
}

/// `cloud` prepared for the LOD methods: colours from the marble texture, normals, the
/// reference splat radius ([`REF_RADIUS`] density spacings).
pub fn lod_data(cloud: PointCloud) -> Result<LodData> {
    Ok(LodData::prepare(
        cloud,
        Some(srn_table::marble_texture()),
        REF_RADIUS,
        SEED,
    )?)
}

/// Every LOD method with a non-empty sweep that can run here, with its settings (an external
/// one whose environment is missing is not run: [`methods_not_run`]).
pub(crate) fn methods_to_run(ctx: &Context) -> Vec<(&'static Card, Vec<Setting>)> {
    ctx.run
        .catalogue
        .lod_cards()
        .into_iter()
        .filter(|m| m.availability().is_ok())
        .filter_map(|m| {
            let settings = ctx.sweeps.methods.get(m.name)?.settings(ctx.quick);
            (!settings.is_empty()).then(|| (m, settings.to_vec()))
        })
        .collect()
}

/// The LOD methods with a sweep that cannot run here (a peer not installed), each with why.
pub(crate) fn methods_not_run(ctx: &Context) -> Vec<String> {
    ctx.run
        .catalogue
        .lod_cards()
        .into_iter()
        .filter(|m| {
            ctx.sweeps
                .methods
                .get(m.name)
                .is_some_and(|s| !s.settings(ctx.quick).is_empty())
        })
        .filter_map(|m| Some(format!("{}: {}", m.name, m.availability().err()?)))
        .collect()
}

/// The view's camera with the eye moved to `factor` times its distance from the target.
pub(crate) fn at_distance(cam: &Camera, factor: f64) -> Result<Camera> {
    Ok(Camera::look_at(
        cam.target + (cam.eye - cam.target) * factor,
        cam.target,
        cam.up,
        *cam.model(),
        cam.width,
        cam.height,
    )?)
}

pub(crate) fn render_params() -> RenderParams {
    RenderParams {
        background: [255, 255, 255],
        ..RenderParams::default()
    }
}

/// The bounding rectangle of the covered pixels, with a margin.
fn covered_box(img: &Image, margin: u32) -> (u32, u32, u32, u32) {
    let (mut x0, mut y0, mut x1, mut y1) = (img.width, img.height, 0, 0);
    for (i, &c) in img.covered.iter().enumerate() {
        if c {
            let (x, y) = (i as u32 % img.width, i as u32 / img.width);
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x + 1);
            y1 = y1.max(y + 1);
        }
    }
    if x1 <= x0 {
        return (0, 0, img.width, img.height);
    }
    (
        x0.saturating_sub(margin),
        y0.saturating_sub(margin),
        (x1 + margin).min(img.width),
        (y1 + margin).min(img.height),
    )
}

fn panel(title: String, img: &Image) -> Panel {
    Panel {
        title,
        width: img.width,
        height: img.height,
        rgb: img.rgb.clone(),
    }
}

/// Renders a selection, scores it against the reference into `row`; returns the render.
fn score(row: &mut Row, s: &kernel::Selection, reference: &Image, camera: &Camera) -> Image {
    let img = render(&s.splats, camera, &render_params());
    row.points_rendered = s.splats.len();
    row.seconds = s.timing.median;
    row.psnr = psnr(reference, &img);
    row.ssim = ssim(reference, &img);
    row.hole_fraction = hole_fraction(reference, &img);
    img
}

/// The kernel's views of the experiment and the (view, distance) of each.
type ViewsAt = (Vec<kernel::View>, Vec<(usize, f64)>);

/// Every (view, distance) of the experiment, in that order, as the kernel's views, with the
/// (view, distance) of each: the first [`N_VIEWS`] of `cameras` (all when there are fewer).
fn views_at(cameras: &[Camera]) -> Result<ViewsAt> {
    if cameras.is_empty() {
        anyhow::bail!("the lod experiment needs at least one view; the dataset has none");
    }
    let mut views = Vec::new();
    let mut at = Vec::new();
    for (view, camera) in cameras.iter().take(N_VIEWS).enumerate() {
        for &factor in DISTANCES {
            views.push(kernel::View {
                index: view,
                camera: at_distance(camera, factor)?,
            });
            at.push((view, factor));
        }
    }
    Ok((views, at))
}

fn measure_dataset(
    ctx: &Context,
    name: &str,
    rows: &mut Vec<Row>,
    builds: &mut Vec<BuildRow>,
    reads: &mut Vec<FileRead>,
) -> Result<()> {
    let mut ds = ctx.dataset(name)?;
    for v in &ds.views {
        v.require(
            "the lod experiment (QSplat's frustum, the splat renderer)",
            &["pinhole"],
        )?;
    }
    let data = lod_data(std::mem::take(&mut ds.cloud))?;
    let n = data.cloud.len();
    let full = data.full_splats();
    // Every (view, distance), in that order, with its reference render.
    let (views, at) = views_at(&ds.views)?;
    let references: Vec<Image> = views
        .iter()
        .map(|v| render(&full, &v.camera, &render_params()))
        .collect();
    let crop = covered_box(&references[0], 8);
    let mut strip: Vec<Panel> = vec![
        panel(format!("reference: {} points", full.len()), &references[0])
            .crop(crop.0, crop.1, crop.2, crop.3),
    ];
    let methods = methods_to_run(ctx);
    let bar = progress::bar(methods.len() as u64, format!("lod {name}"));
    let input = data.input();
    let mut ds_rows: Vec<(usize, Row)> = Vec::new();
    for (m, settings) in &methods {
        progress::at(name, m.name);
        let cell = kernel::LodCell {
            method: m,
            settings,
            views: &views,
            repeats: ctx.repeats,
            build_repeats: 1,
        };
        let mut levels: Vec<Panel> = Vec::new();
        // The reads of a method that selects from a file of its own (an external method's
        // `bytes_read`), its file's bytes filled in once the build says them.
        let mut m_reads: Vec<FileRead> = Vec::new();
        let built = kernel::run_lod(&cell, &input, |k, v, selection| {
            let (view, distance) = at[v];
            let mut row = Row::new(
                name.to_owned(),
                view,
                distance,
                m.name.to_owned(),
                settings[k].label(),
                "ok".into(),
            );
            row.n_points = n;
            match selection {
                Ok(s) => {
                    let img = score(&mut row, &s, &references[v], &views[v].camera);
                    if let Some(r) = s.reads {
                        m_reads.push(FileRead {
                            dataset: name.to_owned(),
                            method: m.name.to_owned(),
                            view,
                            distance,
                            params: row.params.clone(),
                            points_rendered: row.points_rendered,
                            seconds: row.seconds,
                            bytes_read: r.bytes_read,
                            cache_bytes: r.cache_bytes,
                            selection_bytes: r.selection_bytes,
                            file_bytes: 0,
                        });
                    }
                    // Three levels per method in the strip: the finest, the middle and the
                    // coarsest setting, at view 0 and the near distance.
                    let last = settings.len() - 1;
                    if v == 0 && (k == 0 || k == settings.len() / 2 || k == last) {
                        let title = format!("{} {}: {} splats", m.name, row.params, s.splats.len());
                        levels.push(panel(title, &img).crop(crop.0, crop.1, crop.2, crop.3));
                    }
                }
                Err(e) => {
                    eprintln!("lod: {} {} view {view}: {e}", m.name, row.params);
                    row.status = format!("error: {e}");
                }
            }
            ds_rows.push((v, row));
        });
        if let Ok(b) = &built {
            for mut r in m_reads {
                r.file_bytes = b.size.bytes as u64;
                reads.push(r);
            }
        }
        match built {
            Ok(b) => builds.push(BuildRow {
                dataset: name.to_owned(),
                method: m.name.to_owned(),
                n_points: n,
                seconds: b.timing.median,
                nodes: b.size.nodes,
                bytes_per_point: b.size.bytes / n as f64,
            }),
            Err(e) => {
                // A failed build: an error row per setting and view, and the run goes on.
                eprintln!("lod: {} build: {e}", m.name);
                for setting in settings {
                    for (v, &(view, distance)) in at.iter().enumerate() {
                        let mut row = Row::new(
                            name.to_owned(),
                            view,
                            distance,
                            m.name.to_owned(),
                            setting.label(),
                            format!("error: build: {e}"),
                        );
                        row.n_points = n;
                        ds_rows.push((v, row));
                    }
                }
            }
        }
        strip.extend(levels);
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Rows in (view, distance, method, setting) order: the loop ran method by method.
    ds_rows.sort_by_key(|(v, _)| *v);
    rows.extend(ds_rows.into_iter().map(|(_, r)| r));
    write_strip(
        ctx,
        name,
        strip,
        &methods.iter().map(|(m, _)| m.name).collect::<Vec<_>>(),
    )
}

/// `strip_NAME.png`: the reference, then each method's three levels, one row of four each.
fn write_strip(ctx: &Context, name: &str, strip: Vec<Panel>, methods: &[&str]) -> Result<()> {
    let mut panels = Vec::new();
    let reference = strip.first().cloned();
    for (k, pnl) in strip.into_iter().enumerate().skip(1) {
        if (k - 1) % 3 == 0
            && let Some(r) = &reference
        {
            panels.push(r.clone());
        }
        panels.push(pnl);
    }
    compose(
        &panels,
        4,
        &format!(
            "{name}, view 0: the full-cloud reference, then {} at three levels (rows)",
            methods.join(", ")
        ),
        &ctx.out_dir.join(format!("strip_{name}.png")),
    )
}

impl Experiment for LodExperiment {
    fn name(&self) -> &'static str {
        "lod"
    }

    fn summary(&self) -> &'static str {
        "level of detail: QSplat, SPT, SRN and a random subsample against the full-cloud render; seed 003 Table 1"
    }

    fn default_datasets(&self, quick: bool) -> &'static [&'static str] {
        if quick {
            &["bunny-69451"]
        } else {
            &["bunny-69451", "dragon-871414"]
        }
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let mut rows = Vec::new();
        let mut builds = Vec::new();
        let mut reads = Vec::new();
        for name in &ctx.datasets {
            progress::at(name, "");
            let file = if ctx.on_user_files() {
                None
            } else {
                ctx.run.datasets.lod_file(name)?
            };
            match file {
                Some(mut file) => {
                    if ctx.source.camera.eye.is_some() {
                        anyhow::bail!(
                            "dataset {name} is a built LOD file: its cameras come from a views \
                             file (--views FILE), not --eye"
                        );
                    }
                    if let Some(p) = &ctx.source.views {
                        file.views = cloud::io::views::read_views(p)?;
                    }
                    ctx.record_files(&file.files);
                    from_file::measure(ctx, &file, &mut rows, &mut reads, &mut builds)?;
                }
                None => measure_dataset(ctx, name, &mut rows, &mut builds, &mut reads)?,
            }
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        write_csv(&ctx.out_dir.join("builds.csv"), &builds)?;
        if !reads.is_empty() {
            write_csv(&ctx.out_dir.join("file_reads.csv"), &reads)?;
        }
        let srn_rows = srn_table::measure(ctx)?;
        write_csv(&ctx.out_dir.join("srn_table.csv"), &srn_rows)?;
        Ok(serde_json::json!({
            "views": N_VIEWS,
            "seed_tables": ctx.seed_tables,
            "distances": DISTANCES,
            "reference_radius_spacings": REF_RADIUS,
            "sweeps": ctx.run.catalogue.lod_cards()
                .iter()
                .filter_map(|m| {
                    let s = ctx.sweeps.methods.get(m.name)?;
                    Some((
                        m.name.to_owned(),
                        serde_json::json!(s.settings(ctx.quick).iter().map(Setting::label).collect::<Vec<_>>()),
                    ))
                })
                .collect::<serde_json::Map<_, _>>(),
            "repeats": ctx.repeats,
            "methods_not_run": methods_not_run(ctx),
            "texture_size": TEXTURE_SIZE,
            "seed": SEED,
        }))
    }

    fn render(&self, catalogue: &registry::Catalogue, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let builds: Vec<BuildRow> = read_csv(&dir.join("builds.csv"))?;
        let srn_rows: Vec<SrnRow> = read_csv(&dir.join("srn_table.csv"))?;
        let meta = crate::output::meta::RunMeta::read(dir)?;
        // A quick run's figures are indicative: its tables state no intervals.
        let quick = meta.quick;
        let parameters = meta.parameters;
        let repeats = parameters["repeats"]
            .as_u64()
            .unwrap_or(super::REPEATS as u64);
        let not_run: Vec<String> =
            serde_json::from_value(parameters["methods_not_run"].clone()).unwrap_or_default();
        let reads_path = dir.join("file_reads.csv");
        let reads: Vec<FileRead> = if reads_path.exists() {
            read_csv(&reads_path)?
        } else {
            Vec::new()
        };
        render_outputs(
            catalogue, dir, &rows, &builds, &srn_rows, repeats, &not_run, quick,
        )?;
        if reads.is_empty() {
            return Ok(());
        }
        let mut summary = std::fs::read_to_string(dir.join("summary.md"))?;
        summary.push_str(&from_file::table(&reads));
        write_atomic(&dir.join("summary.md"), summary.as_bytes())
    }
}

/// Means over views of (points, seconds, psnr, ssim, holes) per (dataset, distance, method,
/// params), in the order the settings first appear, and how many views gave an image identical
/// to the reference (their PSNR, the scorer's cap, is left out of the PSNR mean: NaN when every
/// view's was).
type Mean = (String, f64, f64, f64, f64, f64, usize);

fn means(rows: &[Row], dataset: &str, distance: f64, method: &str) -> Vec<Mean> {
    let mut order: Vec<String> = Vec::new();
    // Sums of the five, the views, the PSNR's views (not identical).
    let mut acc: BTreeMap<String, ([f64; 5], usize, usize)> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| r.dataset == dataset && r.distance == distance && r.method == method)
    {
        if !acc.contains_key(&r.params) {
            order.push(r.params.clone());
        }
        let e = acc.entry(r.params.clone()).or_default();
        let identical = r.psnr >= IDENTICAL_PSNR;
        for (k, v) in [
            r.points_rendered as f64,
            r.seconds,
            if identical { 0.0 } else { r.psnr },
            r.ssim,
            r.hole_fraction,
        ]
        .into_iter()
        .enumerate()
        {
            e.0[k] += v;
        }
        e.1 += 1;
        e.2 += usize::from(!identical);
    }
    order
        .into_iter()
        .filter_map(|p| {
            let (s, n, finite) = acc.get(&p)?;
            let n_f = *n as f64;
            let psnr = if *finite == 0 {
                f64::NAN
            } else {
                s[2] / *finite as f64
            };
            Some((
                p,
                s[0] / n_f,
                s[1] / n_f,
                psnr,
                s[3] / n_f,
                s[4] / n_f,
                n - finite,
            ))
        })
        .collect()
}

/// The figures' note on the settings of dataset `ds` left out of them because a view's image
/// was identical to the reference (PSNR at the scorer's cap): per method and distance, the
/// settings and on how many of their views; `None` when there is none.
fn identical_note(rows: &[Row], ds: &str, distances: &[f64], methods: &[String]) -> Option<String> {
    let mut parts = Vec::new();
    for m in methods {
        for &d in distances {
            let at: Vec<&Row> = rows
                .iter()
                .filter(|r| r.dataset == ds && r.distance == d && &r.method == m)
                .collect();
            let settings = distinct(at.iter().map(|r| r.params.as_str()));
            let mut listed = Vec::new();
            let mut every = true;
            for p in &settings {
                let views = at.iter().filter(|r| &r.params == p).count();
                let same = at
                    .iter()
                    .filter(|r| &r.params == p && r.psnr >= IDENTICAL_PSNR)
                    .count();
                every &= same == views;
                if same > 0 {
                    listed.push(format!("{p} ({same} of {views} views)"));
                }
            }
            if listed.is_empty() {
                continue;
            }
            parts.push(if every && settings.len() > 1 {
                format!("{m} ×{d}: all {} settings on every view", settings.len())
            } else {
                format!("{m} ×{d}: {}", listed.join(", "))
            });
        }
    }
    (!parts.is_empty()).then(|| {
        format!(
            "Not drawn, identical to the reference (no PSNR, the scorer's {IDENTICAL_PSNR:.0} dB \
             cap): {}.",
            parts.join("; ")
        )
    })
}

#[allow(clippy::too_many_arguments)]
fn render_outputs(
    catalogue: &registry::Catalogue,
    dir: &Path,
    rows: &[Row],
    builds: &[BuildRow],
    srn: &[SrnRow],
    repeats: u64,
    not_run: &[String],
    quick: bool,
) -> Result<()> {
    let datasets = distinct(rows.iter().map(|r| r.dataset.as_str()));
    let mut distances: Vec<f64> = rows.iter().map(|r| r.distance).collect();
    distances.sort_by(f64::total_cmp);
    distances.dedup();
    let methods = distinct(rows.iter().map(|r| r.method.as_str()));
    // The summary goes into the report under `## lod`: its own headings start at `###`.
    let mut summary = String::new();
    summary.push_str(
        "Each method's splats rendered with `splat::render` and compared with the full-cloud \
         render of the same view (PSNR over covered pixels, SSIM on luma, holes = reference \
         pixels left empty); `seconds` is the selection alone (an external method's own \
         reported seconds). Means over the views; an image identical to the reference (PSNR at \
         the scorer's 100 dB cap) is said so in the tables, not drawn at 100 dB. Each method has \
         its colour, each distance its marker; every figure's data is the JSON file of its \
         name.\n\n",
    );
    for n in not_run {
        summary.push_str(&format!("- not run: {n}\n"));
    }
    if !not_run.is_empty() {
        summary.push('\n');
    }
    summary.push_str(&budgets::methods_by_datasets(rows, quick));
    for ds in &datasets {
        let series_of = |f: &dyn Fn(&Mean) -> (f64, f64)| -> Vec<Series> {
            let mut out = Vec::new();
            for m in &methods {
                for &d in &distances {
                    let points: Vec<Point> = means(rows, ds, d, m)
                        .iter()
                        // A setting with a view identical to the reference has no PSNR there:
                        // left out of the figures (the tables say identical).
                        .filter(|mean| mean.6 == 0)
                        .map(|mean| {
                            let (x, y) = f(mean);
                            Point::new(x, y).seconds(mean.2).setting(mean.0.clone())
                        })
                        .collect();
                    if points.is_empty() {
                        continue;
                    }
                    out.push(
                        Series::new(m, m, &format!("×{d}"), Draw::Line, points)
                            .label(format!("{m}, distance ×{d}")),
                    );
                }
            }
            out
        };
        let note = identical_note(rows, ds, &distances, &methods);
        let psnr = Figure::new(
            format!("psnr_vs_points_{ds}"),
            format!("{ds}: PSNR against splats drawn (mean over views)"),
            Axis::log("points rendered"),
            Axis::linear("PSNR vs full render (dB)"),
        )
        .rules(budgets::rules(rows, ds))
        .notes(note.into_iter().collect())
        .series(series_of(&|m| (m.1, m.3)), Vec::new());
        let time = Figure::new(
            format!("time_vs_points_{ds}"),
            format!("{ds}: selection time against splats drawn"),
            Axis::log("points rendered"),
            Axis::log("selection time (s)"),
        )
        .series(series_of(&|m| (m.1, m.2)), Vec::new());
        summary.push_str(&format!("### {ds}\n\n"));
        summary.push_str(&psnr.write(dir)?);
        summary.push_str(&time.write(dir)?);
        summary.push_str(&format!("![renders](strip_{ds}.png)\n\n"));
        if let Some(text) = peer_notes::py3dtiles_note(rows, ds, &distances) {
            summary.push_str(&text);
        }
        summary.push_str(&budgets::tables(rows, ds, quick));
        let mut table = Vec::new();
        for &d in &distances {
            for m in &methods {
                for (p, pts, sec, ps, ss, holes, same) in means(rows, ds, d, m) {
                    let psnr_text = match same {
                        0 => format!("{ps:.2}"),
                        _ if ps.is_nan() => "identical".into(),
                        k => format!("{ps:.2} (identical on {k} views)"),
                    };
                    table.push(vec![
                        format!("×{d}"),
                        m.clone(),
                        p,
                        format!("{pts:.0}"),
                        format!("{:.3}", sec * 1e3),
                        psnr_text,
                        format!("{ss:.3}"),
                        format!("{:.2}", holes * 100.0),
                    ]);
                }
            }
        }
        summary.push_str(&markdown_table(
            &[
                "distance",
                "method",
                "setting",
                "points",
                "selection ms",
                "PSNR dB",
                "SSIM",
                "holes %",
            ],
            &table,
        ));
        summary.push('\n');
    }
    summary.push_str("### Builds\n\n");
    summary.push_str(&markdown_table(
        &[
            "dataset",
            "method",
            "points",
            "seconds",
            "nodes",
            "bytes per point",
            "QSplat bytes per point (4 a node, no colour)",
            "M points/s",
        ],
        &builds
            .iter()
            .map(|b| {
                vec![
                    b.dataset.clone(),
                    b.method.clone(),
                    b.n_points.to_string(),
                    format!("{:.3}", b.seconds),
                    b.nodes.to_string(),
                    if b.bytes_per_point > 0.0 {
                        format!("{:.2}", b.bytes_per_point)
                    } else {
                        "-".into()
                    },
                    // Bytes per point without colour, where the method's paper counts them
                    // (QSplat: 4 bytes a node, offset words included).
                    match catalogue
                        .card_named(&b.method)
                        .and_then(|c| c.bare_node_bytes)
                    {
                        Some(bytes) => {
                            format!(
                                "{:.2}",
                                f64::from(bytes) * b.nodes as f64 / b.n_points as f64
                            )
                        }
                        None => "-".into(),
                    },
                    format!("{:.2}", b.n_points as f64 / b.seconds / 1e6),
                ]
            })
            .collect::<Vec<_>>(),
    ));
    let table = srn_table::table(srn, repeats);
    write_atomic(&dir.join("srn_table.md"), table.as_bytes())?;
    summary.push('\n');
    summary.push_str(&table);
    write_atomic(&dir.join("summary.md"), summary.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::glam::DVec3;

    #[test]
    fn distance_moves_the_eye_along_its_ray() {
        let cam = Camera::new(
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::Y,
            40.0,
            64,
            48,
        )
        .unwrap();
        let far = at_distance(&cam, 2.0).unwrap();
        assert!((far.eye - DVec3::new(0.0, 0.0, 9.0)).length() < 1e-12);
        assert_eq!(far.target, cam.target);
    }
}
