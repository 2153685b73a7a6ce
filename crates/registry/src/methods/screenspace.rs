//! `screenspace`: Pintus, Gobbetti, Agus (VAST 2011), the open solid angle a pixel's
//! neighbours leave towards the viewer over a multi-level pyramid (`screenspace::pintus`).
//! Every camera model; per-pixel output (`Output::pixels`) and Ω per point (`Output::score`).
//! No automatic rule: the paper's text, where one would be, could not be read (see the
//! method crate's doc). Also the frame both screen-space adapters share (`vardensity` too):
//! the checked image size and the answer of a view.

use cloud::Camera;
use cloud::glam::DVec3;
use screenspace::PintusParams;

use crate::card::{Card, Comparison, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{
    Input, Method, Output, PixelChoice, Prepared, Setup, camera_with_resolution,
};

/// The card.
pub static CARD: Card = Card::new(
    "screenspace",
    "screen-space operator (Pintus et al. 2011): open solid angle left by a pixel's neighbours, multi-level",
    Kind::Visibility(&Screenspace),
    &[
        SECTORS,
        HALF_WIDTH,
        LEVELS,
        THRESHOLD,
        DEPTH_TOLERANCE,
        WIDTH,
        HEIGHT,
    ],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(26),
)
.with_compared_in(&[Comparison::Biasutti2019])
.with_made_for(Metric::Pixels);

const SECTORS: Param = Param::value("sectors", "8", "angular sectors around each pixel");
const HALF_WIDTH: Param = Param::value(
    "half_width",
    "2",
    "half width of the neighbour window, pixels of each level",
);
const LEVELS: Param = Param::value("levels", "3", "pyramid levels (1: the depth buffer alone)");
const THRESHOLD: Param = Param::value(
    "threshold",
    "0.25",
    "minimum open fraction of the hemisphere towards the viewer, in [0, 1]",
);
const DEPTH_TOLERANCE: Param = Param::value(
    "depth_tolerance",
    "0.01",
    "relative depth within which points sharing a kept pixel count visible (0: the paper's one point per pixel)",
);
/// The image's width.
pub(crate) const WIDTH: Param = Param::rule("width", "the view's", "image width in pixels");
/// The image's height.
pub(crate) const HEIGHT: Param = Param::rule("height", "the view's", "image height in pixels");

/// The method.
struct Screenspace;

impl Method for Screenspace {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let p = PintusParams {
            sectors: r.get(&SECTORS)?,
            half_width: r.get(&HALF_WIDTH)?,
            levels: r.get(&LEVELS)?,
            threshold: r.get(&THRESHOLD)?,
            depth_tolerance: r.get(&DEPTH_TOLERANCE)?,
        };
        p.validate().map_err(Error::method)?;
        Ok(Box::new(ScreenArgs::read(
            r,
            p,
            screenspace::pintus::visible,
        )?))
    }
}

/// A screen-space method crate's entry point (`screenspace::pintus::visible`, ...).
pub(crate) type ScreenFn<P> =
    fn(&[DVec3], &Camera, &P) -> screenspace::Result<screenspace::Verdict>;

/// A screen-space method's setting: its checked parameters, the image size and the crate's
/// function that answers a view.
pub(crate) struct ScreenArgs<P> {
    params: P,
    width: Option<u32>,
    height: Option<u32>,
    answer: ScreenFn<P>,
}

impl<P> ScreenArgs<P> {
    /// Reads `width` and `height` (none: the view's; at least one pixel each) beside the
    /// method's checked `params`.
    pub(crate) fn read(r: &mut Reader<'_>, params: P, answer: ScreenFn<P>) -> Result<Self> {
        let (width, height) = (r.opt::<u32>(&WIDTH)?, r.opt::<u32>(&HEIGHT)?);
        for (p, v) in [(&WIDTH, width), (&HEIGHT, height)] {
            if v == Some(0) {
                return Err(r.bad(p, 0, "must be at least 1 pixel"));
            }
        }
        Ok(Self {
            params,
            width,
            height,
            answer,
        })
    }
}

impl<P: Send + Sync> Setup for ScreenArgs<P> {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        cloud::points::check_finite(&input.cloud.positions)?;
        if input.cloud.positions.is_empty() {
            return Err(cloud::Error::EmptyCloud.into());
        }
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            args: self,
        }))
    }
}

struct Prep<'a, P> {
    points: &'a [DVec3],
    args: &'a ScreenArgs<P>,
}

impl<P: Sync> Prepared for Prep<'_, P> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, self.args.width, self.args.height)?;
        let v =
            (self.args.answer)(self.points, &camera, &self.args.params).map_err(Error::method)?;
        Ok(Output {
            visible: v.visible,
            rays: 0,
            pixels: Some(PixelChoice {
                width: v.width,
                height: v.height,
                point: v.pixel_point,
            }),
            reported_seconds: None,
            detail: vec![("occupied_pixels".to_owned(), v.occupied.to_string())],
            score: Some(v.score),
        })
    }
}
