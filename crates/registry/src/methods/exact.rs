//! `exact`: the segment–triangle test from the eye to every point (`truth::exact`).

use cloud::Camera;
use rayon::prelude::*;
use truth::ExactVisibility;

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::Reader;
use crate::visibility::{Input, Method, Output, Prepared, Setup, indices_of};

/// The card.
pub static CARD: Card = Card::new(
    "exact",
    "exact check: a segment from the eye to each point against the mesh (BVH, f64)",
    Kind::Visibility(&Exact),
    &[],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(40),
)
.with_parallel_views();

/// The method (no parameters: it is its own setting).
struct Exact;

impl Method for Exact {
    fn parse(&self, _: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        Ok(Box::new(Exact))
    }
}

impl Setup for Exact {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            exact: ExactVisibility::new(input.mesh("the exact method")?).map_err(Error::method)?,
        }))
    }
}

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
