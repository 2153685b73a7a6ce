//! The method registry: the one place a visibility method plugs into the harness.
//!
//! A method is a [`Method`] (name, parameters, and `prepare`, which builds whatever it keeps
//! per dataset: a BVH, a k-d tree) returning a [`Prepared`] that answers one view at a time.
//! Adding a method is one adapter module and one line in [`METHODS`]. Methods return indices;
//! the harness, not the method, scores them against the reference (ann-benchmarks' rule).
//! `seconds` in every report is the time of [`Prepared::visible`] alone: loading and
//! per-dataset preparation are excluded (and reported separately where they matter).

mod exact;
pub mod hpr;
pub mod params;
pub mod raycast;
mod reference;
mod splat;

use std::time::Instant;

use anyhow::{Context, Result};
use cloud::Camera;

use crate::datasets::Dataset;
pub use params::{ParamSpec, Params};

/// What a method says about one view.
#[derive(Debug, Clone, Default)]
pub struct Output {
    /// Indices of the visible points, ascending, without repeats.
    pub visible: Vec<u32>,
    /// Rays cast (0 for methods that cast none).
    pub rays: u64,
    /// For per-pixel methods: the image size and, per pixel (row-major), the point it shows
    /// (`u32::MAX` for none).
    pub pixels: Option<PixelChoice>,
}

/// The point each pixel of a per-pixel method shows.
#[derive(Debug, Clone)]
pub struct PixelChoice {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Point per pixel, row-major; `u32::MAX` where none.
    pub point: Vec<u32>,
}

/// Per-dataset state of a method, answering views.
pub trait Prepared: Sync {
    /// The visible points from `camera`.
    fn visible(&self, camera: &Camera) -> Result<Output>;
}

/// A visibility method.
pub trait Method: Sync {
    /// Name on the command line.
    fn name(&self) -> &'static str;
    /// One line for listings.
    fn summary(&self) -> &'static str;
    /// The `--set` keys it accepts.
    fn params(&self) -> &'static [ParamSpec];
    /// Reads `params` and builds the per-dataset state.
    fn prepare<'a>(&self, dataset: &'a Dataset, params: &Params) -> Result<Box<dyn Prepared + 'a>>;
    /// True when several views are faster answered in parallel (one view per thread) than
    /// one after another (methods whose single view already uses every core say false).
    fn parallel_views(&self) -> bool {
        false
    }
}

/// Every method, in listing order.
pub static METHODS: &[&dyn Method] = &[
    &reference::ReferenceMethod,
    &exact::ExactMethod,
    &splat::SplatMethod,
    &hpr::HprMethod,
    &raycast::RaycastMethod,
];

/// Looks a method up by name.
pub fn method(name: &str) -> Result<&'static dyn Method> {
    METHODS
        .iter()
        .copied()
        .find(|m| m.name() == name)
        .with_context(|| {
            format!(
                "unknown method {name:?}; known methods: {}",
                METHODS
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
}

/// Prepares `method` on `dataset`, rejecting parameters it does not read.
pub fn prepare<'a>(
    method: &dyn Method,
    dataset: &'a Dataset,
    params: &Params,
) -> Result<Box<dyn Prepared + 'a>> {
    let prepared = method.prepare(dataset, params)?;
    params.check_all_read(method.name(), method.params())?;
    Ok(prepared)
}

/// Runs one view and times it.
pub fn timed(prepared: &dyn Prepared, camera: &Camera) -> Result<(Output, f64)> {
    let start = Instant::now();
    let out = prepared.visible(camera)?;
    Ok((out, start.elapsed().as_secs_f64()))
}

/// Indices of the true entries of `flags`.
pub fn indices_of(flags: &[bool]) -> Vec<u32> {
    flags
        .iter()
        .enumerate()
        .filter_map(|(i, &f)| f.then_some(i as u32))
        .collect()
}

/// The camera at the resolution `params` asks for (`width`, `height`), else the view's.
pub fn camera_with_resolution(
    camera: &Camera,
    width: Option<u32>,
    height: Option<u32>,
) -> Result<Camera> {
    match (width, height) {
        (None, None) => Ok(*camera),
        (w, h) => {
            Ok(camera.with_resolution(w.unwrap_or(camera.width), h.unwrap_or(camera.height))?)
        }
    }
}
