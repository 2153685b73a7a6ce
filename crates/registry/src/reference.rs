//! `reference`: the mesh z-buffer ground truth (`truth::reference`) as a method, so it can be
//! exported and timed like the others.

use crate::error::Result;
use cloud::Camera;
use truth::{Reference, ReferenceParams};

use crate::{Input, Method, Output, ParamSpec, Params, Prepared, indices_of};

/// The reference.
pub struct ReferenceMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "tolerance_px",
        default: "0.5",
        help: "depth tolerance in reference pixels",
    },
    ParamSpec {
        key: "min_long_side",
        default: "2048",
        help: "minimum long side of the depth buffer",
    },
    ParamSpec {
        key: "grazing_cos",
        default: "0.2",
        help: "|cos| below which a candidate triangle makes a point ambiguous",
    },
    ParamSpec {
        key: "exact_fallback",
        default: "true",
        help: "resolve ambiguous points with the exact test",
    },
];

struct Prep<'a> {
    points: &'a [cloud::glam::DVec3],
    reference: Reference,
    params: ReferenceParams,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let view = self
            .reference
            .visibility(self.points, camera, &self.params)?;
        Ok(Output {
            visible: indices_of(&view.visible),
            ..Output::default()
        })
    }
}

impl Method for ReferenceMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
        crate::Scale::PerPoint(40)
    }
    fn name(&self) -> &'static str {
        "reference"
    }

    fn summary(&self) -> &'static str {
        "ground truth: the mesh's depth buffer (>= 2048 px), each point's own ray tested against the triangles it shows"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn parallel_views(&self) -> bool {
        true
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let d = ReferenceParams::default();
        let params = ReferenceParams {
            tolerance_px: params.get("tolerance_px", d.tolerance_px)?,
            min_long_side: params.get("min_long_side", d.min_long_side)?,
            grazing_cos: params.get("grazing_cos", d.grazing_cos)?,
            exact_fallback: params.get("exact_fallback", d.exact_fallback)?,
        };
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            reference: Reference::new(input.mesh("the reference")?)?,
            params,
        }))
    }
}
