//! Experiment `lod`: level-of-detail methods against the full-cloud render, and seed 003's
//! Table 1.
//!
//! Every point gets a colour from a texture (the marble of `srn::texture`, through the cloud's
//! texture coordinates or, when it has none, the spherical parameterisation of
//! `srn::param`), so colour detail counts in the image comparison. For each dataset, view
//! (0..[`N_VIEWS`]) and distance (the view's eye moved along its ray to [`DISTANCES`] times
//! its distance to the target), the experiment renders:
//! - the *reference*: every point as a splat of radius [`REF_RADIUS`] density spacings
//!   (`cloud::spacing::density_spacing`: 1/sqrt(points per unit area); 1.5 spacings leave
//!   e^(−π·1.5²) ≈ 0.1 % of a randomly sampled surface uncovered), shaded by `splat::render`;
//! - every LOD method of `registry::lod` (QSplat, SPT, SRN, random; one built per dataset, one
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
use std::time::Instant;

use anyhow::{Context as _, Result};
use cloud::glam::{Vec2, Vec3};
use cloud::{Camera, PointCloud};
use registry::image_score::{hole_fraction, psnr, ssim};
use registry::lod::{LodBuilt, LodInput, LodMethod, albedo};
use serde::{Deserialize, Serialize};
use splat::render::{Image, RenderParams, Splat, render};
use srn::texture::Texture;

use super::{Context, Experiment, markdown_table};

mod srn_table;
use crate::output::plot::{Chart, Mark, Series};
use crate::output::render::{Panel, compose};
use crate::output::{distinct, read_csv, write_atomic, write_csv};
use crate::progress;
pub use srn_table::SrnRow;

/// Views per dataset.
pub const N_VIEWS: usize = 8;
/// Eye distances, as multiples of the view's eye-to-target distance.
pub const DISTANCES: &[f64] = &[1.0, 2.0];
/// Reference splat radius, in density spacings.
pub const REF_RADIUS: f64 = 1.5;
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

/// A dataset prepared for the LOD methods: the coloured cloud and every LOD method with a
/// sweep, built on it.
pub(crate) struct Prepared {
    cloud: PointCloud,
    colors: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    texture: Texture,
    ref_radius: f64,
    built: Vec<(&'static dyn LodMethod, Box<dyn LodBuilt>)>,
}

fn colorize(cloud: &mut PointCloud, texture: &Texture) -> Vec<Vec2> {
    let uvs = match &cloud.uvs {
        Some(uvs) => uvs.clone(),
        None => {
            let center = cloud::Aabb::from_points(&cloud.positions)
                .map(|b| b.center())
                .unwrap_or_default();
            srn::param::spherical_uvs(&cloud.positions, center)
        }
    };
    cloud.colors = Some(
        uvs.iter()
            .map(|&uv| {
                let c = texture.sample(uv) * 255.0;
                [c.x as u8, c.y as u8, c.z as u8]
            })
            .collect(),
    );
    uvs
}

pub(crate) fn prepare(
    ctx: &Context,
    name: &str,
    mut cloud: PointCloud,
    builds: &mut Vec<BuildRow>,
) -> Result<Prepared> {
    let texture = srn_table::marble_texture();
    let uvs = colorize(&mut cloud, &texture);
    let n = cloud.len();
    let spacing = cloud::spacing::density_spacing(&cloud.positions, 8, 20_000, 1)?;
    let ref_radius = REF_RADIUS * spacing;
    let colors = cloud
        .colors
        .as_ref()
        .context("colours were just set")?
        .iter()
        .map(|&c| albedo(c))
        .collect();
    // A scan without normals gets k-nearest-neighbour estimates (16 neighbours, oriented away
    // from the centroid), as a user's scan file often has none.
    let normals = match cloud.normals.clone() {
        Some(n) => n,
        None => cloud::normals::estimate_normals(
            &cloud.positions,
            16.min(cloud.len()),
            cloud::normals::Orientation::AwayFromCentroid,
        )?,
    };
    let mut p = Prepared {
        cloud,
        colors,
        normals,
        uvs,
        texture,
        ref_radius,
        built: Vec::new(),
    };
    // Every LOD method with a sweep, built once (build time: one run).
    for m in registry::lod::all() {
        if ctx
            .sweeps
            .methods
            .get(m.name())
            .is_none_or(|s| s.settings(ctx.quick).is_empty())
        {
            continue;
        }
        let start = Instant::now();
        let built = m.build(&p.input())?;
        let seconds = start.elapsed().as_secs_f64();
        let size = built.size();
        builds.push(BuildRow {
            dataset: name.to_owned(),
            method: m.name().to_owned(),
            n_points: n,
            seconds,
            nodes: size.nodes,
            bytes_per_point: size.bytes / n as f64,
        });
        p.built.push((m, built));
    }
    Ok(p)
}

impl Prepared {
    fn input(&self) -> LodInput<'_> {
        LodInput {
            cloud: &self.cloud,
            normals: &self.normals,
            albedo: &self.colors,
            uvs: &self.uvs,
            texture: &self.texture,
            radius: self.ref_radius,
            seed: SEED,
        }
    }

    pub(crate) fn full_splats(&self) -> Vec<Splat> {
        let input = self.input();
        (0..self.cloud.len())
            .map(|i| input.point_splat(i, self.ref_radius))
            .collect()
    }
}

/// A method's drawable output for one setting.
pub(crate) struct Selection {
    pub(crate) method: &'static str,
    pub(crate) params: String,
    pub(crate) splats: Vec<Splat>,
    pub(crate) seconds: f64,
}

/// Every built method at every setting of its sweep, for `cam`: the selection alone is timed
/// (`LodSelector::select`), the splats are made afterwards.
pub(crate) fn selections(ctx: &Context, p: &Prepared, cam: &Camera) -> Result<Vec<Selection>> {
    let input = p.input();
    let mut out = Vec::new();
    for (m, built) in &p.built {
        let Some(sweep) = ctx.sweeps.methods.get(m.name()) else {
            continue;
        };
        for setting in sweep.settings(ctx.quick) {
            let mut sel = built.selector(&input, &setting.params())?;
            let ((), t) = ctx.timed(|| Ok(sel.select(cam)?))?;
            out.push(Selection {
                method: m.name(),
                params: setting.label(),
                splats: sel.splats(),
                seconds: t.median,
            });
        }
    }
    Ok(out)
}

/// The view's camera with the eye moved to `factor` times its distance from the target.
fn at_distance(cam: &Camera, factor: f64) -> Result<Camera> {
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

fn measure_dataset(
    ctx: &Context,
    name: &str,
    rows: &mut Vec<Row>,
    builds: &mut Vec<BuildRow>,
) -> Result<()> {
    let mut ds = ctx.dataset(name)?;
    for v in &ds.views {
        v.require(
            "the lod experiment (QSplat's frustum, the splat renderer)",
            &["pinhole"],
        )?;
    }
    let p = prepare(ctx, name, std::mem::take(&mut ds.cloud), builds)?;
    let full = p.full_splats();
    let bar = progress::bar((N_VIEWS * DISTANCES.len()) as u64, format!("lod {name}"));
    let mut strip: Vec<Panel> = Vec::new();
    for view in 0..N_VIEWS {
        for (d, &factor) in DISTANCES.iter().enumerate() {
            let cam = at_distance(ds.view(view)?, factor)?;
            let reference = render(&full, &cam, &render_params());
            let sels = selections(ctx, &p, &cam)?;
            let keep_strip = view == 0 && d == 0;
            let crop = covered_box(&reference, 8);
            if keep_strip {
                strip.push(
                    panel(format!("reference: {} points", full.len()), &reference)
                        .crop(crop.0, crop.1, crop.2, crop.3),
                );
            }
            let mut by_method: BTreeMap<&str, Vec<(usize, Panel)>> = BTreeMap::new();
            for s in &sels {
                let img = render(&s.splats, &cam, &render_params());
                rows.push(Row {
                    dataset: name.to_owned(),
                    view,
                    distance: factor,
                    method: s.method.to_owned(),
                    params: s.params.clone(),
                    points_rendered: s.splats.len(),
                    seconds: s.seconds,
                    psnr: psnr(&reference, &img),
                    ssim: ssim(&reference, &img),
                    hole_fraction: hole_fraction(&reference, &img),
                });
                if keep_strip {
                    let title = format!("{} {}: {} splats", s.method, s.params, s.splats.len());
                    by_method.entry(s.method).or_default().push((
                        s.splats.len(),
                        panel(title, &img).crop(crop.0, crop.1, crop.2, crop.3),
                    ));
                }
            }
            // Three levels per method: the finest, the middle and the coarsest setting.
            for (m, _) in &p.built {
                if let Some(levels) = by_method.remove(m.name()) {
                    let n = levels.len();
                    for (k, (_, pnl)) in levels.into_iter().enumerate() {
                        if k == 0 || k == n / 2 || k == n - 1 {
                            strip.push(pnl);
                        }
                    }
                }
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    // Layout: the reference, then each method's three levels on one row of four.
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
            p.built
                .iter()
                .map(|(m, _)| m.name())
                .collect::<Vec<_>>()
                .join(", ")
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
        for name in &ctx.datasets {
            measure_dataset(ctx, name, &mut rows, &mut builds)?;
        }
        write_csv(&ctx.out_dir.join("results.csv"), &rows)?;
        write_csv(&ctx.out_dir.join("builds.csv"), &builds)?;
        let srn_rows = srn_table::measure(ctx)?;
        write_csv(&ctx.out_dir.join("srn_table.csv"), &srn_rows)?;
        Ok(serde_json::json!({
            "views": N_VIEWS,
            "distances": DISTANCES,
            "reference_radius_spacings": REF_RADIUS,
            "sweeps": registry::lod::all()
                .iter()
                .filter_map(|m| {
                    let s = ctx.sweeps.methods.get(m.name())?;
                    Some((
                        m.name().to_owned(),
                        serde_json::json!(s.settings(ctx.quick).iter().map(registry::Setting::label).collect::<Vec<_>>()),
                    ))
                })
                .collect::<serde_json::Map<_, _>>(),
            "repeats": ctx.repeats,
            "texture_size": TEXTURE_SIZE,
            "seed": SEED,
        }))
    }

    fn render(&self, dir: &Path) -> Result<()> {
        let rows: Vec<Row> = read_csv(&dir.join("results.csv"))?;
        let builds: Vec<BuildRow> = read_csv(&dir.join("builds.csv"))?;
        let srn_rows: Vec<SrnRow> = read_csv(&dir.join("srn_table.csv"))?;
        let repeats = crate::output::meta::RunMeta::read(dir)?.parameters["repeats"]
            .as_u64()
            .unwrap_or(super::REPEATS as u64);
        render_outputs(dir, &rows, &builds, &srn_rows, repeats)
    }
}

/// Means over views of (points, seconds, psnr, ssim, holes) per (dataset, distance, method,
/// params), in the order the settings first appear.
type Mean = (String, f64, f64, f64, f64, f64);

fn means(rows: &[Row], dataset: &str, distance: f64, method: &str) -> Vec<Mean> {
    let mut order: Vec<String> = Vec::new();
    let mut acc: BTreeMap<String, ([f64; 5], usize)> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| r.dataset == dataset && r.distance == distance && r.method == method)
    {
        if !acc.contains_key(&r.params) {
            order.push(r.params.clone());
        }
        let e = acc.entry(r.params.clone()).or_default();
        for (k, v) in [
            r.points_rendered as f64,
            r.seconds,
            r.psnr,
            r.ssim,
            r.hole_fraction,
        ]
        .into_iter()
        .enumerate()
        {
            e.0[k] += v;
        }
        e.1 += 1;
    }
    order
        .into_iter()
        .filter_map(|p| {
            let (s, n) = acc.get(&p)?;
            let n = *n as f64;
            Some((p, s[0] / n, s[1] / n, s[2] / n, s[3] / n, s[4] / n))
        })
        .collect()
}

fn render_outputs(
    dir: &Path,
    rows: &[Row],
    builds: &[BuildRow],
    srn: &[SrnRow],
    repeats: u64,
) -> Result<()> {
    let datasets = distinct(rows.iter().map(|r| r.dataset.as_str()));
    let mut distances: Vec<f64> = rows.iter().map(|r| r.distance).collect();
    distances.sort_by(f64::total_cmp);
    distances.dedup();
    let methods = distinct(rows.iter().map(|r| r.method.as_str()));
    let mut summary = String::from("# Level of detail\n\n");
    summary.push_str(
        "Each method's splats rendered with `splat::render` and compared with the full-cloud \
         render of the same view (PSNR over covered pixels, SSIM on luma, holes = reference \
         pixels left empty); `seconds` is the selection alone. Means over the views.\n\n",
    );
    for ds in &datasets {
        let series_of = |f: &dyn Fn(&Mean) -> (f64, f64)| -> Vec<Series> {
            let mut out = Vec::new();
            for (mi, m) in methods.iter().enumerate() {
                for (di, &d) in distances.iter().enumerate() {
                    let pts: Vec<(f64, f64)> = means(rows, ds, d, m).iter().map(f).collect();
                    if pts.is_empty() {
                        continue;
                    }
                    let mut s = Series::new(
                        format!("{m}, distance ×{d}"),
                        pts,
                        if di == 0 {
                            Mark::LinePoints
                        } else {
                            Mark::Points
                        },
                    );
                    s.color = Some(mi);
                    out.push(s);
                }
            }
            out
        };
        Chart {
            title: format!("{ds}: PSNR against splats drawn (mean over views)"),
            x_label: "points rendered".into(),
            y_label: "PSNR vs full render (dB)".into(),
            x_log: true,
            series: series_of(&|m| (m.1, m.3)),
            ..Chart::default()
        }
        .save(&dir.join(format!("psnr_vs_points_{ds}.png")), 1000, 650)?;
        Chart {
            title: format!("{ds}: selection time against splats drawn"),
            x_label: "points rendered".into(),
            y_label: "selection time (s)".into(),
            x_log: true,
            y_log: true,
            series: series_of(&|m| (m.1, m.2)),
            ..Chart::default()
        }
        .save(&dir.join(format!("time_vs_points_{ds}.png")), 1000, 650)?;
        summary.push_str(&format!(
            "## {ds}\n\n![PSNR](psnr_vs_points_{ds}.png)\n\n![time](time_vs_points_{ds}.png)\n\n![renders](strip_{ds}.png)\n\n"
        ));
        let mut table = Vec::new();
        for &d in &distances {
            for m in &methods {
                for (p, pts, sec, ps, ss, holes) in means(rows, ds, d, m) {
                    table.push(vec![
                        format!("×{d}"),
                        m.clone(),
                        p,
                        format!("{pts:.0}"),
                        format!("{:.3}", sec * 1e3),
                        format!("{ps:.2}"),
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
    summary.push_str("## Builds\n\n");
    summary.push_str(&markdown_table(
        &[
            "dataset",
            "method",
            "points",
            "seconds",
            "nodes",
            "bytes per point",
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
                    // QSplat without colour: 4 bytes a node (offset words included).
                    if b.method == "qsplat" {
                        format!("{:.2}", 4.0 * b.nodes as f64 / b.n_points as f64)
                    } else {
                        "-".into()
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
