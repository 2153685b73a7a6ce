//! `splat`: the point-only z-buffer baseline (`splat::visibility`), with its disc rule or a
//! GPU point renderer's (`rule=sprite`, `splat::sprite`).

use std::sync::Mutex;

use crate::error::{Error, Result};
use cloud::Camera;
use splat::{SplatParams, SplatScratch, Splatter};

use crate::{
    Input, Method, Output, ParamSpec, Params, PixelChoice, Prepared, camera_with_resolution,
};

/// The splat baseline.
pub struct SplatMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "radius_px",
        default: "2",
        help: "splat radius in pixels",
    },
    ParamSpec {
        key: "depth_tolerance",
        default: "0.01",
        help: "relative depth tolerance",
    },
    ParamSpec {
        key: "rule",
        default: "disc",
        help: "disc (a disc of radius_px at the point's pixel, relative tolerance there) or sprite (a GPU point renderer's: a square of 2 x radius_px pixels at the exact projection, one world tolerance depth_tolerance x the eye's distance to the centroid along the view axis; VTK's vtkSelectVisiblePoints)",
    },
    ParamSpec {
        key: "width",
        default: "view's",
        help: "buffer width in pixels",
    },
    ParamSpec {
        key: "height",
        default: "view's",
        help: "buffer height in pixels",
    },
];

struct Prep {
    splatter: Splatter,
    scratch: Mutex<SplatScratch>,
    params: SplatParams,
    width: Option<u32>,
    height: Option<u32>,
}

impl Prepared for Prep {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, self.width, self.height)?;
        let mut scratch = self
            .scratch
            .lock()
            .map_err(|_| Error::Unsupported("splat scratch poisoned".into()))?;
        let out = self
            .splatter
            .visibility(&camera, &self.params, &mut scratch, true)?;
        Ok(Output {
            visible: out.visible,
            rays: 0,
            pixels: Some(PixelChoice {
                width: camera.width,
                height: camera.height,
                point: out.pixel_point,
            }),
            reported_seconds: None,
            detail: Vec::new(),
            score: None,
        })
    }
}

impl Method for SplatMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
        crate::Scale::PerPoint(45)
    }
    fn name(&self) -> &'static str {
        "splat"
    }

    fn summary(&self) -> &'static str {
        "baseline: point splats into a z-buffer, visible within a depth tolerance of the nearest"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let d = SplatParams::default();
        let rule = match params.get("rule", "disc".to_owned())?.as_str() {
            "disc" => splat::Rule::Disc,
            "sprite" => splat::Rule::Sprite,
            other => {
                return Err(Error::BadValue {
                    key: "rule".into(),
                    value: other.to_owned(),
                    reason: "expected disc or sprite".into(),
                });
            }
        };
        Ok(Box::new(Prep {
            splatter: Splatter::new(&input.cloud.positions)?,
            scratch: Mutex::new(SplatScratch::default()),
            params: SplatParams {
                radius_px: params.get("radius_px", d.radius_px)?,
                depth_tolerance: params.get("depth_tolerance", d.depth_tolerance)?,
                rule,
            },
            width: params.get_opt("width")?,
            height: params.get_opt("height")?,
        }))
    }
}
