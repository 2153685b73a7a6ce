//! `splat`: the point-only z-buffer baseline (`splat::visibility`), with its disc rule or a
//! GPU point renderer's (`rule=sprite`, `splat::sprite`).

use std::sync::Mutex;

use cloud::Camera;
use splat::{SplatParams, SplatScratch, Splatter};

use crate::card::{Card, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{
    Input, Method, Output, PixelChoice, Prepared, Setup, camera_with_resolution,
};

/// The card.
pub static CARD: Card = Card::new(
    "splat",
    "baseline: point splats into a z-buffer, visible within a depth tolerance of the nearest",
    Kind::Visibility(&Splat),
    &[RADIUS_PX, DEPTH_TOLERANCE, RULE, WIDTH, HEIGHT],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(45),
)
.with_made_for(Metric::Pixels);

const RADIUS_PX: Param = Param::value("radius_px", "2.0", "splat radius in pixels");
const DEPTH_TOLERANCE: Param = Param::value("depth_tolerance", "0.01", "relative depth tolerance");
const RULE: Param = Param::implied(
    "rule",
    "disc",
    "disc (a disc of radius_px at the point's pixel, relative tolerance there) or sprite (a GPU point renderer's: a square of 2 x radius_px pixels at the exact projection, one world tolerance depth_tolerance x the eye's distance to the centroid along the view axis; VTK's vtkSelectVisiblePoints)",
);
/// The buffer's width.
pub(crate) const WIDTH: Param = Param::rule("width", "the view's", "buffer width in pixels");
/// The buffer's height.
pub(crate) const HEIGHT: Param = Param::rule("height", "the view's", "buffer height in pixels");

/// The method.
struct Splat;

/// Its setting.
struct Args {
    params: SplatParams,
    width: Option<u32>,
    height: Option<u32>,
}

impl Method for Splat {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let rule = match r.get::<String>(&RULE)?.as_str() {
            "disc" => splat::Rule::Disc,
            "sprite" => splat::Rule::Sprite,
            other => return Err(r.bad(&RULE, other, "expected disc or sprite")),
        };
        Ok(Box::new(Args {
            params: SplatParams {
                radius_px: r.get(&RADIUS_PX)?,
                depth_tolerance: r.get(&DEPTH_TOLERANCE)?,
                rule,
            },
            width: r.opt(&WIDTH)?,
            height: r.opt(&HEIGHT)?,
        }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        Ok(Box::new(Prep {
            splatter: Splatter::new(&input.cloud.positions).map_err(Error::method)?,
            scratch: Mutex::new(SplatScratch::default()),
            args: self,
        }))
    }
}

struct Prep<'a> {
    splatter: Splatter,
    scratch: Mutex<SplatScratch>,
    args: &'a Args,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, self.args.width, self.args.height)?;
        let mut scratch = self
            .scratch
            .lock()
            .map_err(|_| Error::Unsupported("splat scratch poisoned".into()))?;
        let out = self
            .splatter
            .visibility(&camera, &self.args.params, &mut scratch, true)
            .map_err(Error::method)?;
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
