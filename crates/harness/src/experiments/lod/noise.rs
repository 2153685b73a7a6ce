//! Level of detail under noise (the `robustness` experiment's `lod.csv`): every LOD method of
//! the registry with a sweep is built on each noisy cloud (isotropic Gaussian noise of
//! [`LOD_NOISE`] density spacings, seeded; colours from the clean source's texture
//! coordinates, so they follow the surface, not the noise) through the measurement kernel,
//! and its finest setting (the most splats, per view) is rendered against the *clean*
//! full-cloud render of the same view (PSNR, SSIM), beside the noisy full cloud itself
//! (`full`): how much of the loss is the noise and how much the selection.

use anyhow::Result;
use cloud::degrade::{Degradation, Unit};
use registry::kernel;
use serde::{Deserialize, Serialize};
use splat::render::{Splat, render};

use super::{lod_data, methods_to_run, render_params};
use crate::experiments::Context;

/// Noise levels, density spacings.
pub const LOD_NOISE: &[f64] = &[0.0, 0.25, 0.5, 1.0, 2.0];

/// One LOD selection on one view of a noisy cloud, against the clean full render.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LodRow {
    /// Dataset.
    pub dataset: String,
    /// Noise σ, density spacings.
    pub sigma: f64,
    /// Method (`full`: every noisy point).
    pub method: String,
    /// Setting.
    pub params: String,
    /// View.
    pub view: usize,
    /// Splats drawn.
    pub points_rendered: usize,
    /// PSNR against the clean full render, dB.
    pub psnr: f64,
    /// SSIM against the clean full render.
    pub ssim: f64,
}

/// The rows for one clean dataset, seen from `views` (pinhole), noise seeded with `seed`.
pub fn rows(
    ctx: &Context,
    name: &str,
    clean: &cloud::PointCloud,
    views: &[cloud::Camera],
    seed: u64,
) -> Result<Vec<LodRow>> {
    // Texture coordinates of the clean points (the colours follow the source, not the noise).
    let centre = clean.bbox().map(|b| b.center()).unwrap_or_default();
    let uvs = clean
        .uvs
        .clone()
        .unwrap_or_else(|| srn::param::spherical_uvs(&clean.positions, centre));
    let mut base = clean.clone();
    base.uvs = Some(uvs.clone());
    let full = lod_data(base)?.full_splats();
    let targets: Vec<_> = views
        .iter()
        .map(|cam| render(&full, cam, &render_params()))
        .collect();
    let kviews = kernel::View::all(views);
    let methods = methods_to_run(ctx);
    let mut rows = Vec::new();
    for &sigma in LOD_NOISE {
        let d = cloud::degrade::apply(
            clean,
            &[Degradation::Noise {
                sigma,
                unit: Unit::Spacing,
                along_normal: false,
            }],
            seed,
        )?;
        let mut noisy = d.cloud;
        noisy.uvs = Some(d.source.iter().map(|&s| uvs[s as usize]).collect());
        let data = lod_data(noisy)?;
        let input = data.input();
        // Per view: each method's finest selection (the most splats; on a tie the later
        // setting, as the selection loop before the kernel kept).
        let mut finest: Vec<Vec<(&str, String, Vec<Splat>)>> = vec![Vec::new(); views.len()];
        for (m, settings) in &methods {
            let mut best: Vec<Option<(String, Vec<Splat>)>> = vec![None; views.len()];
            let cell = kernel::LodCell {
                method: m,
                settings,
                views: &kviews,
                repeats: 1,
                build_repeats: 1,
            };
            kernel::run_lod(&cell, &input, |k, v, selection| {
                if let Ok(s) = selection
                    && best[v]
                        .as_ref()
                        .is_none_or(|(_, b)| s.splats.len() >= b.len())
                {
                    best[v] = Some((settings[k].label(), s.splats));
                }
            })?;
            for (v, b) in best.into_iter().enumerate() {
                if let Some((params, splats)) = b {
                    finest[v].push((m.name, params, splats));
                }
            }
        }
        let noisy_full = data.full_splats();
        for (view, cam) in views.iter().enumerate() {
            let target = &targets[view];
            let mut push = |method: &str, params: String, splats: &[Splat]| {
                let img = render(splats, cam, &render_params());
                rows.push(LodRow {
                    dataset: name.to_owned(),
                    sigma,
                    method: method.to_owned(),
                    params,
                    view,
                    points_rendered: splats.len(),
                    psnr: registry::scoring::psnr(target, &img),
                    ssim: registry::scoring::ssim(target, &img),
                });
            };
            push("full", String::new(), &noisy_full);
            for (method, params, splats) in &finest[view] {
                push(method, params.clone(), splats);
            }
        }
    }
    Ok(rows)
}
