//! `pointsight view --lod`: one page of level-of-detail selections, in 3D, each splat at its
//! size: the full-detail cloud (every point at the `lod` experiment's reference radius) and
//! each chosen LOD method's selection for one view with its eye moved to `--distance` times
//! its distance from the target (the `lod` experiment's distances).
//!
//! The clouds are prepared as the `lod` experiment prepares them
//! ([`crate::experiments::lod::lod_data`]: marble-texture colours, estimated normals), every
//! method is built and selects once through the measurement kernel
//! (`registry::kernel::run_lod`), and each selection is rendered by `splat::render` at the
//! view's camera, as the experiment does, for its PSNR against the full-detail render and its
//! covered-pixel count (which the browser tests compare with the page's own picture).
//!
//! Layout (read by `web/src/lod.js`): per method, its splats' centres quantised to u16 per
//! axis over one box for all methods (as [`super::page::quantise`]), radii quantised to u16
//! over [0, `rmax`], and colours as u8 RGB, each shaded once as `splat::render` shades them
//! for the page's view (albedo · (ambient + (1 − ambient)·|n·l|), l towards the eye), so the
//! picture through the view's camera is the experiment's. A method's splats beyond the page's
//! limit are a uniform subsample (a seeded shuffle's prefix), which the page says.

use anyhow::{Context, Result, bail};
use cloud::Camera;
use registry::{Card, Params, Setting, kernel};
use splat::render::{Splat, render};

use super::page::{bundle, order, quantise_coord};
use crate::datasets::Dataset;
use crate::experiments::lod::{at_distance, lod_data, render_params};

/// `--distance`'s default: the `lod` experiment's farther distance.
pub const DEFAULT_DISTANCE: f64 = crate::experiments::lod::FAR_DISTANCE;

/// Bytes of one splat on the page before base64: centre (6), radius (2), colour (3).
pub const SPLAT_BYTES: usize = 11;

/// One method's selection for the page.
#[derive(Debug, Clone)]
pub struct Selected {
    /// Method name (`full detail` for the whole cloud).
    pub name: String,
    /// Its setting, `k=v` pairs joined by `;`.
    pub setting: String,
    /// The splats.
    pub splats: Vec<Splat>,
    /// Seconds of the selection (one run; `None` for the full detail, which selects nothing).
    pub seconds: Option<f64>,
    /// PSNR of its render against the full-detail render (dB; infinite for the full detail).
    pub psnr: f64,
    /// Pixels its render covers at the view's camera.
    pub covered: usize,
}

/// A chosen LOD method, its parameters and their label.
pub type ChosenLod = (&'static Card, Params, String);

/// The LOD methods to show: those named, else every available one with a sweep default, each
/// at its sweep's default setting with the `--set` pairs over it ([`super::apply_set`]).
pub fn choose(
    catalogue: &registry::Catalogue,
    names: Option<&[String]>,
    set: &[String],
) -> Result<Vec<ChosenLod>> {
    let sweeps = catalogue.sweeps(None)?;
    let label = |m: &Card| {
        sweeps
            .methods
            .get(m.name)
            .and_then(registry::MethodSweep::default_setting)
            .map(|s| s.label())
    };
    let base: Vec<(&'static Card, String)> = match names {
        None => catalogue
            .lod_cards()
            .into_iter()
            .filter(|m| m.availability().is_ok())
            .filter_map(|m| Some((m, label(m)?)))
            .collect(),
        Some(names) => {
            let mut out: Vec<(&'static Card, String)> = Vec::new();
            for name in names {
                let m = catalogue
                    .card_named(name.trim())
                    .filter(|m| m.is_lod())
                    .with_context(|| {
                        format!(
                            "no level-of-detail method {:?} (`pointsight methods` lists them)",
                            name.trim()
                        )
                    })?;
                if let Err(why) = m.availability() {
                    bail!("method {} cannot run here: {why}", m.name);
                }
                if out.iter().any(|(o, _)| o.name == m.name) {
                    bail!("--methods names {} twice", m.name);
                }
                out.push((m, label(m).unwrap_or_default()));
            }
            out
        }
    };
    if base.is_empty() {
        bail!("no level-of-detail method to show: name some with --methods");
    }
    let settings = super::apply_set(catalogue, &base, set)?;
    Ok(base
        .into_iter()
        .zip(settings)
        .map(|((m, _), (params, label))| (m, params, label))
        .collect())
}

/// A method that could not select, and why.
pub type Failed = (String, anyhow::Error);

/// The full detail and each chosen method's selection at `camera` (view `view`), each with its
/// render's PSNR against the full detail's; the methods that failed (to build or to select),
/// each with its error, apart.
pub fn select(
    ds: &Dataset,
    view: usize,
    camera: &Camera,
    chosen: &[ChosenLod],
) -> Result<(Vec<Selected>, Vec<Failed>)> {
    let data = lod_data(ds.cloud.clone())?;
    let input = data.input();
    let full = data.full_splats();
    let reference = render(&full, camera, &render_params());
    let mut out = vec![Selected {
        name: "full detail".into(),
        setting: format!("every point, radius {:.4e}", data.radius),
        covered: reference.covered.iter().filter(|&&c| c).count(),
        splats: full,
        seconds: None,
        psnr: f64::INFINITY,
    }];
    let views = [kernel::View {
        index: view,
        camera: *camera,
    }];
    let mut failed = Vec::new();
    for (m, _, label) in chosen {
        let settings = [Setting::parse(label)];
        let cell = kernel::LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: 1,
            build_repeats: 1,
        };
        let mut got = None;
        let sel = kernel::run_lod(&cell, &input, |_, _, sel| {
            got = Some(sel.map_err(|e| e.to_string()));
        })
        .map_err(anyhow::Error::from)
        .and_then(|_| {
            got.context("the kernel made no selection")?
                .map_err(anyhow::Error::msg)
        });
        let sel = match sel {
            Ok(sel) => sel,
            Err(e) => {
                failed.push((
                    m.name.to_owned(),
                    e.context(format!("{} at {label}", m.name)),
                ));
                continue;
            }
        };
        let img = render(&sel.splats, camera, &render_params());
        out.push(Selected {
            name: m.name.to_owned(),
            setting: label.clone(),
            psnr: registry::scoring::psnr(&reference, &img),
            covered: img.covered.iter().filter(|&&c| c).count(),
            splats: sel.splats,
            seconds: Some(sel.timing.median),
        });
    }
    Ok((out, failed))
}

/// One LOD page's content.
#[derive(Debug, Clone, Copy)]
pub struct LodPage<'a> {
    /// The run's methods, whose families style the page.
    pub catalogue: &'a registry::Catalogue,
    /// The dataset.
    pub ds: &'a Dataset,
    /// The view's index.
    pub view: usize,
    /// The eye's distance factor.
    pub distance: f64,
    /// The camera (the view's, at the distance).
    pub camera: &'a Camera,
    /// The selections, full detail first.
    pub selected: &'a [Selected],
    /// At most this many splats per method.
    pub max_splats: Option<usize>,
    /// A sentence for the page (what it shows, in a report).
    pub note: Option<&'a str>,
}

fn b64(bytes: &[u8]) -> String {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

impl LodPage<'_> {
    /// The page's data (the JSON the script reads).
    pub fn data(&self) -> Result<serde_json::Value> {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut rmax = 0.0f64;
        for s in self.selected.iter().flat_map(|m| &m.splats) {
            let p = s.center.to_array();
            if !p.iter().all(|x| x.is_finite()) || !s.radius.is_finite() || s.radius < 0.0 {
                bail!("a splat has a centre or radius that is not finite");
            }
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            rmax = rmax.max(f64::from(s.radius));
        }
        if !lo[0].is_finite() {
            bail!("no splat to show: every selection is empty");
        }
        let cam = self.camera;
        let ambient = render_params().ambient;
        let mut methods = Vec::new();
        let mut subsampled = Vec::new();
        for m in self.selected {
            let n = m.splats.len();
            let mut ord = order(n, 2007);
            let shown = self.max_splats.map_or(n, |k| k.min(n));
            ord.truncate(shown);
            if shown < n {
                subsampled.push(format!("{}: {shown} of {n}", m.name));
            }
            let mut centers = Vec::with_capacity(6 * shown);
            let mut radii = Vec::with_capacity(2 * shown);
            let mut colors = Vec::with_capacity(3 * shown);
            for &i in &ord {
                let s = &m.splats[i as usize];
                let p = s.center.to_array();
                for k in 0..3 {
                    centers.extend_from_slice(&quantise_coord(p[k], lo[k], hi[k]).to_le_bytes());
                }
                let r = quantise_coord(f64::from(s.radius), 0.0, rmax);
                radii.extend_from_slice(&r.to_le_bytes());
                // splat::render's shading for this view: a headlight, two-sided.
                let to_eye = (cam.eye - s.center).normalize_or_zero().as_vec3();
                let shade = ambient + (1.0 - ambient) * s.normal.dot(to_eye).abs();
                let c = (s.albedo * shade).clamp(cloud::glam::Vec3::ZERO, cloud::glam::Vec3::ONE);
                colors.extend_from_slice(&[
                    (c.x * 255.0).round() as u8,
                    (c.y * 255.0).round() as u8,
                    (c.z * 255.0).round() as u8,
                ]);
            }
            methods.push(serde_json::json!({
                "name": m.name,
                "setting": m.setting,
                "n": shown,
                "n_total": n,
                "seconds": m.seconds,
                "psnr": if m.psnr.is_finite() { Some(m.psnr) } else { None },
                "covered_px": m.covered,
                "centers": b64(&centers),
                "radii": b64(&radii),
                "colors": b64(&colors),
            }));
        }
        let subsample = if subsampled.is_empty() {
            String::new()
        } else {
            format!(
                " A uniform subsample of the splats is on this page ({}; `pointsight view --lod` \
                 without --max-points writes them all); PSNR and coverage are those of every \
                 splat.",
                subsampled.join(", ")
            )
        };
        let target = cam.target;
        // Each method's look in every figure of the report, beside its name.
        Ok(super::page::with_styles(
            self.catalogue,
            serde_json::json!({
                "kind": "lod",
                "title": format!("{}, view {}, level of detail at {}× distance", self.ds.name(), self.view, self.distance),
                "dataset": self.ds.name(),
                "view": self.view,
                "distance": self.distance,
                "note": format!(
                    "{}Each splat at its world radius, coloured and shaded as splat::render draws it \
                     for this view (the shading stays that of the view's eye while you orbit). PSNR: \
                     each method's render against the full detail's at the view's camera, as in the \
                     lod experiment.{subsample}",
                    self.note.map(|s| format!("{s} ")).unwrap_or_default()
                ),
                "box": {"min": lo, "max": hi},
                "rmax": rmax,
                "camera": {
                    "model": cam.model().name(),
                    "eye": cam.eye.to_array(),
                    "target": target.to_array(),
                    "forward": cam.forward().to_array(),
                    "right": cam.right().to_array(),
                    "up": cam.true_up().to_array(),
                    "fov_y_deg": super::page::fov_y_deg(cam),
                    "width": cam.width,
                    "height": cam.height,
                },
                "methods": methods,
            }),
        ))
    }

    /// The whole page, `script` (the viewer bundle) embedded.
    pub fn html(&self, script: &str) -> Result<String> {
        let data = self.data()?;
        super::page::html_of(&data, script)
    }
}

/// What `view --lod` was asked, beyond [`super::Request`].
#[derive(Debug, Clone, Copy)]
pub struct LodRequest {
    /// The eye's distance factor (at least 1e-3).
    pub distance: f64,
}

/// Runs a `view --lod` request: the selections, then the page (and the full detail's render).
pub fn run(
    run: &crate::run::Run,
    req: &super::Request,
    lod: LodRequest,
    data_dir: &std::path::Path,
) -> Result<super::Written> {
    let script = bundle()?;
    if req.max_points == Some(0) {
        bail!("--max-points must be at least 1");
    }
    if !(lod.distance.is_finite() && lod.distance >= 1e-3) {
        bail!(
            "--distance must be a number of at least 0.001, got {}",
            lod.distance
        );
    }
    // The methods and their settings, typed, before any data is read.
    let chosen = choose(&run.catalogue, req.methods.as_deref(), &req.set)?;
    let ds = crate::visible::load_source(run, &req.source, data_dir)?;
    let camera = at_distance(ds.view(req.view)?, lod.distance)?;
    let (selected, failed) = select(&ds, req.view, &camera, &chosen)?;
    if let Some((_, e)) = failed.into_iter().next() {
        return Err(e);
    }
    let html = LodPage {
        catalogue: &run.catalogue,
        ds: &ds,
        view: req.view,
        distance: lod.distance,
        camera: &camera,
        selected: &selected,
        max_splats: req.max_points,
        note: None,
    }
    .html(&script)?;
    if let Some(png) = &req.png {
        let img = render(&selected[0].splats, &camera, &render_params());
        crate::output::write_png(png, img.width, img.height, &img.rgb)?;
    }
    crate::output::write_atomic(&req.out, html.as_bytes())?;
    Ok(super::Written {
        path: req.out.clone(),
        points: ds.cloud.len(),
        shown: selected
            .iter()
            .map(|s| {
                req.max_points
                    .map_or(s.splats.len(), |k| k.min(s.splats.len()))
            })
            .sum(),
        methods: selected.len(),
        bytes: html.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantised_radii_and_shading_follow_the_splats() {
        let ds = crate::datasets::Datasets::default()
            .load("sphere-20000", std::path::Path::new("/nonexistent"))
            .unwrap();
        let view = 0;
        let camera = at_distance(ds.view(view).unwrap(), 2.0).unwrap();
        let base = ds.view(view).unwrap();
        let want = base.target + (base.eye - base.target) * 2.0;
        assert!((camera.eye - want).length() < 1e-9);
        let chosen = choose(
            &registry::Catalogue::builtin(),
            Some(&["qsplat".to_owned()]),
            &["threshold_px=8".into()],
        )
        .unwrap();
        assert_eq!(chosen[0].2, "threshold_px=8");
        let (selected, failed) = select(&ds, view, &camera, &chosen).unwrap();
        assert!(failed.is_empty());
        assert_eq!(selected.len(), 2);
        assert_eq!(selected[0].splats.len(), ds.cloud.len());
        // A coarser selection: fewer splats, some bigger, a finite PSNR.
        assert!(selected[1].splats.len() < selected[0].splats.len());
        assert!(selected[1].psnr.is_finite() && selected[1].psnr > 10.0);
        let page = LodPage {
            catalogue: &registry::Catalogue::builtin(),
            ds: &ds,
            view,
            distance: 2.0,
            camera: &camera,
            selected: &selected,
            max_splats: Some(1000),
            note: None,
        };
        let data = page.data().unwrap();
        let m = &data["methods"][1];
        assert_eq!(m["n"], 1000.min(selected[1].splats.len()));
        let rmax = data["rmax"].as_f64().unwrap();
        let max_r = selected[1]
            .splats
            .iter()
            .map(|s| s.radius)
            .fold(0.0, f32::max);
        assert!(f64::from(max_r) <= rmax);
        use base64::Engine as _;
        let radii = base64::engine::general_purpose::STANDARD
            .decode(m["radii"].as_str().unwrap())
            .unwrap();
        let ord = order(selected[1].splats.len(), 2007);
        for (k, &i) in ord.iter().take(50).enumerate() {
            let q = u16::from_le_bytes([radii[2 * k], radii[2 * k + 1]]);
            let back = f64::from(q) / 65535.0 * rmax;
            let r = f64::from(selected[1].splats[i as usize].radius);
            assert!(
                (back - r).abs() <= 0.5 * rmax / 65535.0 + 1e-9,
                "{back} vs {r}"
            );
        }
        assert!(data["note"].as_str().unwrap().contains("uniform subsample"));
        // Bad requests: an unknown method, a pair no method takes.
        assert!(
            choose(
                &registry::Catalogue::builtin(),
                Some(&["nosuch".to_owned()]),
                &[]
            )
            .is_err()
        );
        assert!(
            choose(
                &registry::Catalogue::builtin(),
                Some(&["qsplat".to_owned()]),
                &["gamma=2".into()]
            )
            .is_err()
        );
    }
}
