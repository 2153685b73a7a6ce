//! `exact`: the segment–triangle test from the eye to every point (`truth::exact`).

use anyhow::Result;
use cloud::Camera;
use truth::ExactVisibility;

use super::{Method, Output, ParamSpec, Params, Prepared, indices_of};
use crate::datasets::Dataset;

/// The exact check.
pub struct ExactMethod;

struct Prep<'a> {
    dataset: &'a Dataset,
    exact: ExactVisibility,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let flags = self
            .exact
            .visibility(camera.eye, &self.dataset.cloud.positions)?;
        Ok(Output {
            visible: indices_of(&flags),
            rays: flags.len() as u64,
            ..Output::default()
        })
    }
}

impl Method for ExactMethod {
    fn name(&self) -> &'static str {
        "exact"
    }

    fn summary(&self) -> &'static str {
        "exact check: a segment from the eye to each point against the mesh (BVH, f64)"
    }

    fn params(&self) -> &'static [ParamSpec] {
        &[]
    }

    fn prepare<'a>(
        &self,
        dataset: &'a Dataset,
        _params: &Params,
    ) -> Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(Prep {
            dataset,
            exact: ExactVisibility::new(&dataset.mesh)?,
        }))
    }
}
