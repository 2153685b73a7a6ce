//! The viewer page: the data of one view (points, the reference, every method's visible set)
//! in a compact binary form embedded as base64 in JSON, and the viewer's script (three.js,
//! bundled by esbuild in `web/`), in one HTML file that opens from disk.
//!
//! The points are written in a seeded shuffled order, so every prefix is a uniform
//! subsample: the page draws a prefix first, and a page limited to M points (`--max-points`,
//! the report's pages) is the first M. Positions are quantised to 16 bits per axis over the
//! shown points' bounding box (error ≤ extent / 131,070 per axis); the reference, the
//! off-surface flags and each method's visible set are bitsets (bit i: bit i & 7 of byte
//! i >> 3). The layout is read by `web/src/data.js`.

use std::path::PathBuf;

use anyhow::{Result, bail};
use base64::Engine as _;
use cloud::Camera;
use cloud::rng::RngExt as _;
use truth::{Reference, ReferenceParams};

use super::MethodRun;
use crate::datasets::Dataset;
use crate::output::render::{FALSE_NEGATIVE, FALSE_POSITIVE, HIDDEN, TRUE_POSITIVE};
use registry::scoring::Score;

/// Colour of off-surface points and outliers (a class apart, never scored).
pub const OFF_SURFACE: [u8; 3] = [255, 150, 0];

/// The environment variable naming a built viewer script instead of `web/dist/viewer.js`.
pub const BUNDLE_VAR: &str = "POINTSIGHT_VIEWER_JS";

/// Where the viewer's script is looked for (`crate::paths::script_candidates`):
/// `$POINTSIGHT_VIEWER_JS`, else the clone's `web/dist/viewer.js`, else
/// `PREFIX/share/pointsight/web/viewer.js` beside the binary.
pub fn bundle_candidates() -> Vec<PathBuf> {
    crate::paths::script_candidates("viewer.js", BUNDLE_VAR)
}

/// The viewer's script, or an error saying how to build or install it.
pub fn bundle() -> Result<String> {
    crate::paths::script("viewer.js", BUNDLE_VAR)
}

/// The family a page's method is styled by (`output::style`): the registry's at its setting;
/// the LOD page's `full detail`, the full cloud's (`full`).
pub fn method_family(catalogue: &registry::Catalogue, name: &str, setting: &str) -> String {
    if name == "full detail" {
        "full".to_owned()
    } else {
        crate::output::style::family(catalogue, name, setting)
    }
}

/// A page's data with each method's family and style (in `variant` `default`: every page shows
/// the methods at their default setting) and the marker shapes its swatches are drawn from.
pub fn with_styles(
    catalogue: &registry::Catalogue,
    mut data: serde_json::Value,
) -> serde_json::Value {
    if let Some(methods) = data["methods"].as_array_mut() {
        for m in methods {
            let family = method_family(
                catalogue,
                m["name"].as_str().unwrap_or_default(),
                m["setting"].as_str().unwrap_or_default(),
            );
            m["style"] = serde_json::json!(crate::output::style::style(&family, "default"));
            m["family"] = serde_json::json!(family);
        }
    }
    data["markers"] = crate::output::style::marker_shapes();
    data
}

/// What the methods are coloured against.
#[derive(Debug, Clone)]
pub struct Truth {
    /// Per point, visible (the reference) or called visible by most methods (no mesh).
    pub visible: Vec<bool>,
    /// True: the reference; false: the methods' majority.
    pub is_reference: bool,
    /// Per point, off the surface or an outlier; `None` when not known.
    pub off: Option<Vec<bool>>,
}

impl Truth {
    /// The reference on the dataset's mesh, or the methods' majority without one.
    pub fn of(ds: &Dataset, camera: &Camera, runs: &[MethodRun]) -> Result<Self> {
        let n = ds.cloud.len();
        match &ds.mesh {
            Some(mesh) => Ok(Self {
                visible: Reference::new(mesh)?
                    .visibility(ds.truth_points(), camera, &ReferenceParams::default())?
                    .visible,
                is_reference: true,
                off: ds.off_surface()?.map(|(f, _)| f),
            }),
            None => {
                let mut votes = vec![0usize; n];
                for r in runs {
                    for &i in &r.visible {
                        votes[i as usize] += 1;
                    }
                }
                Ok(Self {
                    visible: votes.iter().map(|&v| 2 * v > runs.len()).collect(),
                    is_reference: false,
                    off: ds.outliers.clone(),
                })
            }
        }
    }
}

/// A seeded shuffle of `0..n`: every prefix is a uniform sample without replacement.
pub fn order(n: usize, seed: u64) -> Vec<u32> {
    let mut rng = cloud::rng::seeded(seed, "view-order");
    let mut out: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        out.swap(i, j);
    }
    out
}

/// `flags` in `order` as a bitset.
pub fn bitset(order: &[u32], flag: impl Fn(usize) -> bool) -> Vec<u8> {
    let mut out = vec![0u8; order.len().div_ceil(8)];
    for (k, &i) in order.iter().enumerate() {
        if flag(i as usize) {
            out[k >> 3] |= 1 << (k & 7);
        }
    }
    out
}

/// `v` in [`lo`, `hi`] as u16 (rounded, clamped; 0 when the range is empty).
pub fn quantise_coord(v: f64, lo: f64, hi: f64) -> u16 {
    let extent = hi - lo;
    if extent > 0.0 {
        ((v - lo) / extent * 65535.0).round().clamp(0.0, 65535.0) as u16
    } else {
        0
    }
}

/// The points in `order`, quantised to u16 per axis over their box (little-endian x, y, z),
/// and the box.
pub fn quantise(
    points: &[cloud::glam::DVec3],
    order: &[u32],
) -> Result<(Vec<u8>, [f64; 3], [f64; 3])> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in order {
        let p = points[i as usize].to_array();
        for k in 0..3 {
            if !p[k].is_finite() {
                bail!("point {i} has a coordinate that is not finite");
            }
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if order.is_empty() {
        bail!("the cloud is empty: nothing to show");
    }
    let mut out = Vec::with_capacity(6 * order.len());
    for &i in order {
        let p = points[i as usize].to_array();
        for k in 0..3 {
            out.extend_from_slice(&quantise_coord(p[k], lo[k], hi[k]).to_le_bytes());
        }
    }
    Ok((out, lo, hi))
}

fn b64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

pub use crate::output::escape_html;

/// One page's content.
#[derive(Debug, Clone, Copy)]
pub struct Page<'a> {
    /// The run's methods, whose families style the page.
    pub catalogue: &'a registry::Catalogue,
    /// The dataset (internal coordinates: points and camera alike).
    pub ds: &'a Dataset,
    /// The view's index.
    pub view: usize,
    /// The view's camera.
    pub camera: &'a Camera,
    /// The methods' answers.
    pub runs: &'a [MethodRun],
    /// What they are coloured against.
    pub truth: &'a Truth,
    /// At most this many points.
    pub max_points: Option<usize>,
    /// A sentence for the page (what it shows, in a report).
    pub note: Option<&'a str>,
}

impl Page<'_> {
    /// The page's data (the JSON the script reads).
    pub fn data(&self) -> Result<serde_json::Value> {
        let ds = self.ds;
        let n_total = ds.cloud.len();
        let mut ord = order(n_total, 2007);
        let shown = self.max_points.map_or(n_total, |m| m.min(n_total));
        ord.truncate(shown);
        let (positions, lo, hi) = quantise(&ds.cloud.positions, &ord)?;
        let truth = &self.truth.visible;
        let off = self.truth.off.as_deref();
        let is_off = |i: usize| off.is_some_and(|f| f[i]);
        let mut methods = Vec::new();
        for r in self.runs {
            let mut flags = vec![false; n_total];
            for &i in &r.visible {
                flags[i as usize] = true;
            }
            // Counts on the page's points, class by class, as the page colours them.
            let (mut tp, mut fnn, mut fp, mut hidden, mut off_n) = (0usize, 0, 0, 0, 0);
            for &i in &ord {
                let i = i as usize;
                match (is_off(i), truth[i], flags[i]) {
                    (true, _, _) => off_n += 1,
                    (false, true, true) => tp += 1,
                    (false, true, false) => fnn += 1,
                    (false, false, true) => fp += 1,
                    (false, false, false) => hidden += 1,
                }
            }
            let s = Score::of_on_surface(&r.visible, truth, off);
            methods.push(serde_json::json!({
                "name": r.name,
                "setting": r.setting,
                "visible": b64(&bitset(&ord, |i| flags[i])),
                "n_visible_total": r.visible.len(),
                "seconds": r.seconds,
                "timing": r.timing,
                "scores": [s.precision(), s.recall(),
                    if self.truth.is_reference { s.f1() } else { s.jaccard() }],
                "counts": {"tp": tp, "fn": fnn, "fp": fp, "hidden": hidden, "off": off_n},
            }));
        }
        let cam = self.camera;
        let subsample = if shown < n_total {
            format!(
                " This page shows a uniform subsample of {shown} of the {n_total} points \
                 (`pointsight view` without --max-points writes them all); the scores are \
                 those of the whole cloud."
            )
        } else {
            String::new()
        };
        let against = if self.truth.is_reference {
            "Colours against the reference (the mesh's z-buffer)."
        } else {
            "This cloud has no mesh, so no ground truth: colours against the methods' \
             majority (a point is 'visible' when more than half the methods call it so)."
        };
        let off_count = off.map_or(0, |f| f.iter().filter(|&&o| o).count());
        let off_note = if off_count > 0 {
            format!(" Orange: {off_count} off-surface points and outliers, left out of the scores.")
        } else {
            String::new()
        };
        // Each method's look in every figure of the report, beside its name.
        Ok(with_styles(
            self.catalogue,
            serde_json::json!({
                "title": format!("{}, view {}", ds.name(), self.view),
                "dataset": ds.name(),
                "view": self.view,
                "n": shown,
                "n_total": n_total,
                "note": format!("{}{against}{off_note}{subsample}",
                    self.note.map(|s| format!("{s} ")).unwrap_or_default()),
                "box": {"min": lo, "max": hi},
                "positions": b64(&positions),
                "truth": b64(&bitset(&ord, |i| truth[i])),
                "truth_kind": if self.truth.is_reference { "reference" } else { "majority" },
                "off": off.map(|f| b64(&bitset(&ord, |i| f[i]))),
                "score_columns": if self.truth.is_reference {
                    ["precision", "recall", "F1"]
                } else {
                    ["P*", "R*", "Jaccard*"]
                },
                "score_note": if self.truth.is_reference {
                    "Precision, recall and F1 of the whole cloud against the reference (off-surface points left out); click a row to show that method."
                } else {
                    "*: against the methods' majority, whole cloud; click a row to show that method."
                },
                "camera": {
                    "model": cam.model().name(),
                    "eye": cam.eye.to_array(),
                    "target": cam.target.to_array(),
                    "forward": cam.forward().to_array(),
                    "right": cam.right().to_array(),
                    "up": cam.true_up().to_array(),
                    "fov_y_deg": fov_y_deg(cam),
                    "width": cam.width,
                    "height": cam.height,
                },
                "colors": {
                    "hidden": HIDDEN, "tp": TRUE_POSITIVE, "fn": FALSE_NEGATIVE,
                    "fp": FALSE_POSITIVE, "off": OFF_SURFACE,
                },
                "methods": methods,
            }),
        ))
    }

    /// The whole page, `script` (the viewer bundle) embedded.
    pub fn html(&self, script: &str) -> Result<String> {
        html_of(&self.data()?, script)
    }
}

/// A page of `data` (the JSON the script reads) with `script` (the viewer bundle) embedded.
pub fn html_of(data: &serde_json::Value, script: &str) -> Result<String> {
    let title = data["title"].as_str().unwrap_or("pointsight");
    crate::output::data_page(
        "pointsight view",
        &format!("pointsight: {title}"),
        data,
        script,
    )
}

/// The vertical field of view of a pinhole camera (from its focal length, so off-centre
/// principal points keep their scale); `None` for other models.
pub(super) fn fov_y_deg(cam: &Camera) -> Option<f64> {
    match *cam.model() {
        cloud::camera::Model::Pinhole { fy, .. } => {
            Some((2.0 * (0.5 * cam.height as f64 / fy).atan()).to_degrees())
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;

    use super::*;

    #[test]
    fn order_is_a_seeded_permutation_with_uniform_prefixes() {
        let a = order(10_000, 2007);
        assert_eq!(a, order(10_000, 2007));
        assert_ne!(a, order(10_000, 2008));
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &v)| v as usize == i));
        // A prefix of 1,000 holds about a tenth of each tenth of the indices.
        for decile in 0..10u32 {
            let k = a[..1000].iter().filter(|&&i| i / 1000 == decile).count();
            assert!((60..=140).contains(&k), "decile {decile}: {k}");
        }
    }

    #[test]
    fn bitsets_follow_the_order() {
        let ord = [3u32, 0, 2, 1, 4, 5, 6, 7, 8];
        let bits = bitset(&ord, |i| i == 3 || i == 8);
        assert_eq!(bits, vec![0b0000_0001, 0b0000_0001]);
    }

    #[test]
    fn quantisation_is_within_half_a_step() {
        let pts: Vec<DVec3> = (0..100)
            .map(|i| DVec3::new(i as f64 * 0.37, -(i as f64).sqrt(), 5.0))
            .collect();
        let ord = order(pts.len(), 1);
        let (bytes, lo, hi) = quantise(&pts, &ord).unwrap();
        assert_eq!(bytes.len(), 600);
        for (k, &i) in ord.iter().enumerate() {
            for a in 0..3 {
                let q = u16::from_le_bytes([bytes[6 * k + 2 * a], bytes[6 * k + 2 * a + 1]]);
                let extent = hi[a] - lo[a];
                let back = lo[a] + q as f64 / 65535.0 * extent;
                assert!((back - pts[i as usize][a]).abs() <= 0.5 * extent / 65535.0 + 1e-12);
            }
        }
        assert!(quantise(&[DVec3::new(f64::NAN, 0.0, 0.0)], &[0]).is_err());
        assert!(quantise(&pts, &[]).is_err());
    }

    #[test]
    fn html_cannot_be_closed_early() {
        assert_eq!(escape_html("<a & \"b\">"), "&lt;a &amp; &quot;b&quot;&gt;");
    }
}
