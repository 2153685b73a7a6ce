//! `reference`: the mesh z-buffer ground truth (`truth::reference`) as a method, so it can be
//! exported and timed like the others. Its defaults are the ground truth's
//! (`truth::ReferenceParams::default`, which the experiments score against; a test keeps the
//! two equal).

use cloud::Camera;
use truth::{Reference, ReferenceParams};

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Input, Method, Output, Prepared, Setup, indices_of};

/// The card.
pub static CARD: Card = Card::new(
    "reference",
    "ground truth: the mesh's depth buffer (>= 2048 px), each point's own ray tested against the triangles it shows",
    Kind::Visibility(&ReferenceMethod),
    &[TOLERANCE_PX, MIN_LONG_SIDE, GRAZING_COS, EXACT_FALLBACK],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(40),
)
.with_parallel_views();

const TOLERANCE_PX: Param =
    Param::implied("tolerance_px", "0.5", "depth tolerance in reference pixels");
const MIN_LONG_SIDE: Param = Param::implied(
    "min_long_side",
    "2048",
    "minimum long side of the depth buffer",
);
const GRAZING_COS: Param = Param::implied(
    "grazing_cos",
    "0.2",
    "|cos| below which a candidate triangle makes a point ambiguous",
);
const EXACT_FALLBACK: Param = Param::implied(
    "exact_fallback",
    "true",
    "resolve ambiguous points with the exact test",
);

/// The method.
struct ReferenceMethod;

impl Method for ReferenceMethod {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        Ok(Box::new(Args(ReferenceParams {
            tolerance_px: r.get(&TOLERANCE_PX)?,
            min_long_side: r.get(&MIN_LONG_SIDE)?,
            grazing_cos: r.get(&GRAZING_COS)?,
            exact_fallback: r.get(&EXACT_FALLBACK)?,
        })))
    }
}

/// Its setting.
struct Args(ReferenceParams);

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            reference: Reference::new(input.mesh("the reference")?).map_err(Error::method)?,
            params: &self.0,
        }))
    }
}

struct Prep<'a> {
    points: &'a [cloud::glam::DVec3],
    reference: Reference,
    params: &'a ReferenceParams,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let view = self
            .reference
            .visibility(self.points, camera, self.params)
            .map_err(Error::method)?;
        Ok(Output {
            visible: indices_of(&view.visible),
            ..Output::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;

    #[test]
    fn its_defaults_are_the_ground_truths() {
        let params = Params::default();
        let mut r = Reader::new(CARD.name, CARD.params, &params);
        let read = ReferenceParams {
            tolerance_px: r.get(&TOLERANCE_PX).unwrap(),
            min_long_side: r.get(&MIN_LONG_SIDE).unwrap(),
            grazing_cos: r.get(&GRAZING_COS).unwrap(),
            exact_fallback: r.get(&EXACT_FALLBACK).unwrap(),
        };
        assert_eq!(read, ReferenceParams::default());
    }
}
