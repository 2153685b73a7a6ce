//! `exact`: the segment–triangle test from the eye to every point (`truth::exact`).

use crate::error::Result;
use cloud::Camera;
use rayon::prelude::*;
use truth::ExactVisibility;

use crate::{Input, Method, Output, ParamSpec, Params, Prepared, indices_of};

/// The exact check.
pub struct ExactMethod;

struct Prep<'a> {
    points: &'a [cloud::glam::DVec3],
    exact: ExactVisibility,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        // Each point's own ray: from the eye, or from its foot on an orthographic near plane.
        let points = self.points;
        cloud::points::check_finite(points)?;
        let flags: Vec<bool> = points
            .par_iter()
            .map(|&p| self.exact.is_visible(camera.ray_origin_for(p), p))
            .collect();
        Ok(Output {
            visible: indices_of(&flags),
            rays: flags.len() as u64,
            ..Output::default()
        })
    }
}

impl Method for ExactMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
        crate::Scale::PerPoint(40)
    }
    fn name(&self) -> &'static str {
        "exact"
    }

    fn summary(&self) -> &'static str {
        "exact check: a segment from the eye to each point against the mesh (BVH, f64)"
    }

    fn params(&self) -> &'static [ParamSpec] {
        &[]
    }

    fn parallel_views(&self) -> bool {
        true
    }

    fn prepare<'a>(&self, input: Input<'a>, _params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            exact: ExactVisibility::new(input.mesh("the exact method")?)?,
        }))
    }
}
