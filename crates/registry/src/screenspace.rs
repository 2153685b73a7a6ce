//! `screenspace`: Pintus, Gobbetti, Agus (VAST 2011), the open solid angle a pixel's
//! neighbours leave towards the viewer over a multi-level pyramid (`screenspace::pintus`).
//! Every camera model; per-pixel output (`Output::pixels`) and Ω per point (`Output::score`).
//! No automatic rule: the paper's text, where one would be, could not be read (see the
//! method crate's doc).

use cloud::Camera;
use screenspace::PintusParams;

use crate::error::Result;
use crate::{
    Input, Method, Output, ParamSpec, Params, PixelChoice, Prepared, camera_with_resolution,
};

/// Pintus et al.'s screen-space visibility.
pub struct ScreenspaceMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "sectors",
        default: "8",
        help: "angular sectors around each pixel",
    },
    ParamSpec {
        key: "half_width",
        default: "2",
        help: "half width of the neighbour window, pixels of each level",
    },
    ParamSpec {
        key: "levels",
        default: "3",
        help: "pyramid levels (1: the depth buffer alone)",
    },
    ParamSpec {
        key: "threshold",
        default: "0.25",
        help: "minimum open fraction of the hemisphere towards the viewer, in [0, 1]",
    },
    ParamSpec {
        key: "depth_tolerance",
        default: "0",
        help: "relative depth within which points sharing a kept pixel count visible (0: the paper's one point per pixel)",
    },
    ParamSpec {
        key: "width",
        default: "view's",
        help: "image width in pixels",
    },
    ParamSpec {
        key: "height",
        default: "view's",
        help: "image height in pixels",
    },
];

/// A prepared screen-space method: its checked parameters, the image size and the crate's
/// function that answers a view.
pub(crate) struct Prep<'a, P> {
    points: &'a [cloud::glam::DVec3],
    params: P,
    width: Option<u32>,
    height: Option<u32>,
    answer: ScreenFn<P>,
}

/// A screen-space method crate's entry point (`screenspace::pintus::visible`, ...).
pub(crate) type ScreenFn<P> =
    fn(&[cloud::glam::DVec3], &Camera, &P) -> screenspace::Result<screenspace::Verdict>;

impl<'a, P: Sync> Prep<'a, P> {
    /// Checks the frame (see [`checked_frame`]) and prepares.
    pub(crate) fn boxed(
        input: Input<'a>,
        params: &Params,
        method: P,
        answer: ScreenFn<P>,
    ) -> Result<Box<dyn Prepared + 'a>>
    where
        P: 'a,
    {
        let (width, height) = checked_frame(input, params)?;
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            params: method,
            width,
            height,
            answer,
        }))
    }
}

/// The registry's output of a screen-space verdict.
/// The checks both screen-space adapters make before preparing: finite, non-empty points, and
/// the `width`/`height` they read (none: the view's), at least one pixel each.
pub(crate) fn checked_frame(
    input: Input<'_>,
    params: &Params,
) -> Result<(Option<u32>, Option<u32>)> {
    cloud::points::check_finite(&input.cloud.positions)?;
    if input.cloud.positions.is_empty() {
        return Err(cloud::Error::EmptyCloud.into());
    }
    let (width, height) = (params.get_opt("width")?, params.get_opt("height")?);
    for (name, v) in [("width", width), ("height", height)] {
        if v == Some(0) {
            return Err(screenspace::Error::InvalidParameter {
                name,
                reason: "0: must be at least 1 pixel".into(),
            }
            .into());
        }
    }
    Ok((width, height))
}

fn output(v: screenspace::Verdict) -> Output {
    Output {
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
    }
}

impl<P: Sync> Prepared for Prep<'_, P> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, self.width, self.height)?;
        Ok(output((self.answer)(self.points, &camera, &self.params)?))
    }
}

impl Method for ScreenspaceMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 x (the peak per point at 10^7 points less the cloud's 48): a scale cell of
        // the dragon at its default setting peaked at 687 MB.
        crate::Scale::PerPoint(26)
    }
    fn name(&self) -> &'static str {
        "screenspace"
    }

    fn summary(&self) -> &'static str {
        "screen-space operator (Pintus et al. 2011): open solid angle left by a pixel's neighbours, multi-level"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let d = PintusParams::default();
        let p = PintusParams {
            sectors: params.get("sectors", d.sectors)?,
            half_width: params.get("half_width", d.half_width)?,
            levels: params.get("levels", d.levels)?,
            threshold: params.get("threshold", d.threshold)?,
            depth_tolerance: params.get("depth_tolerance", d.depth_tolerance)?,
        };
        p.validate()?;
        Prep::boxed(input, params, p, screenspace::pintus::visible)
    }
}
