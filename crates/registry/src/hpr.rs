//! `hpr`: Hidden Point Removal (`hpr` crate) with any hull implementation.

use crate::error::{Error, Result};
use cloud::Camera;
use hpr::{HprParams, Kernel, Radius};
use hull::ConvexHull;

use crate::{Input, Method, Output, ParamSpec, Params, Prepared};

/// HPR.
pub struct HprMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "gamma",
        default: "3 (linear), -0.05 (exp), 1000 (log), 0.001 (expdecay)",
        help: "linear: R = max|p - C| * 10^gamma, or auto (hpr::auto's rule, per view); exp: the exponent (< 0); log: R = max|p - C| * 10^gamma (> 0); expdecay: the rate (> 0)",
    },
    ParamSpec {
        key: "radius",
        default: "-",
        help: "absolute flipping radius R (linear kernel; overrides gamma)",
    },
    ParamSpec {
        key: "kernel",
        default: "linear",
        help: "linear (spherical flipping), exp (Katz & Tal 2015), log: ln(R/d), expdecay: exp(-gamma d / max d) (hpr::properties)",
    },
    ParamSpec {
        key: "perturb",
        default: "0",
        help: "uniform noise of +-perturb * R on each flipped coordinate (seed 000: 0.01)",
    },
    ParamSpec {
        key: "hull",
        default: "own",
        help: "hull implementation: own, qhull, qhull-qj, parry, quickhull, chull",
    },
    ParamSpec {
        key: "seed",
        default: "0",
        help: "seed of the perturbation",
    },
];

/// Default exponent of the exponential kernel.
pub const DEFAULT_EXP_GAMMA: f64 = -0.05;

/// Default exponent of the logarithmic kernel (R = max|p - C| * 10^gamma).
pub const DEFAULT_LOG_GAMMA: f64 = 1000.0;

/// Default rate of the exponential-decay kernel.
pub const DEFAULT_EXPDECAY_GAMMA: f64 = 1e-3;

/// Reads the kernel (`kernel`, `gamma`, `radius`) from `params` (`gamma=auto` reads as the
/// default γ here; see [`wants_auto_gamma`]).
pub fn kernel_from(params: &Params) -> Result<Kernel> {
    let kernel_name: String = params.get("kernel", "linear".to_owned())?;
    let gamma: Option<f64> = if wants_auto_gamma(params)? {
        None
    } else {
        params.get_opt("gamma")?
    };
    let radius: Option<f64> = params.get_opt("radius")?;
    if radius.is_some() && kernel_name != "linear" {
        return Err(Error::Unsupported(
            "--set radius applies to the linear kernel only".into(),
        ));
    }
    Ok(match kernel_name.as_str() {
        "linear" => match (radius, gamma) {
            (Some(r), _) => Kernel::Linear(Radius::Absolute(r)),
            (None, g) => Kernel::Linear(Radius::Gamma(g.unwrap_or(3.0))),
        },
        "exp" => {
            if radius.is_some() {
                return Err(Error::Unsupported(
                    "parameter radius applies to the linear kernel only (kernel=exp)".into(),
                ));
            }
            Kernel::Exponential(gamma.unwrap_or(DEFAULT_EXP_GAMMA))
        }
        "log" => Kernel::Log(gamma.unwrap_or(DEFAULT_LOG_GAMMA)),
        "expdecay" => Kernel::ExpDecay(gamma.unwrap_or(DEFAULT_EXPDECAY_GAMMA)),
        other => {
            return Err(Error::BadValue {
                key: "kernel".into(),
                value: other.to_owned(),
                reason: "expected linear, exp, log or expdecay".into(),
            });
        }
    })
}

/// Reads HPR's parameters from `params` (`gamma=auto` reads as the default γ here; see
/// [`wants_auto_gamma`]).
pub fn hpr_params(params: &Params) -> Result<(HprParams, String)> {
    let kernel = kernel_from(params)?;
    let hull: String = params.get("hull", "own".to_owned())?;
    Ok((
        HprParams {
            kernel,
            perturb: params.get("perturb", 0.0)?,
            seed: params.get("seed", 0)?,
        },
        hull,
    ))
}

/// True for `gamma=auto` (linear kernel): γ from `hpr::auto::auto_gamma` per view.
pub fn wants_auto_gamma(params: &Params) -> Result<bool> {
    let text: Option<String> = params.get_opt("gamma")?;
    let auto = text.as_deref() == Some("auto");
    if auto && params.get("kernel", "linear".to_owned())? != "linear" {
        return Err(Error::Unsupported(
            "gamma=auto applies to the linear kernel only".into(),
        ));
    }
    Ok(auto)
}

/// HPR-type methods need a viewpoint: pinhole and spherical cameras have one (their centre of
/// projection); an orthographic camera is refused with the reason.
pub fn refuse_orthographic(method: &str, camera: &Camera) -> Result<()> {
    if matches!(camera.model(), cloud::Model::Orthographic { .. }) {
        return Err(Error::Unsupported(format!(
            "{method} does not support {} cameras: HPR flips the cloud about a viewpoint and an \
             orthographic camera has none (its centre of projection is at infinity); use a \
             distant pinhole camera, or raycast, splat or reference",
            camera.model().name()
        )));
    }
    Ok(())
}

/// γ of `hpr::auto` for a view from `eye` (the largest distance from the eye measured here).
pub fn auto_gamma_for(
    scale: &hpr::auto::CloudScale,
    points: &[cloud::glam::DVec3],
    eye: cloud::glam::DVec3,
) -> f64 {
    use rayon::prelude::*;
    let max_distance = points
        .par_iter()
        .map(|p| (*p - eye).length())
        .reduce(|| 0.0, f64::max);
    hpr::auto::auto_gamma(scale, eye, max_distance)
}

struct Prep<'a> {
    points: &'a [cloud::glam::DVec3],
    params: HprParams,
    hull: Box<dyn ConvexHull>,
    /// For `gamma=auto`: the cloud's scale, measured once.
    auto: Option<hpr::auto::CloudScale>,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        refuse_orthographic("hpr", camera)?;
        let mut detail = Vec::new();
        let params = match &self.auto {
            Some(scale) => {
                let gamma = auto_gamma_for(scale, self.points, camera.eye);
                detail.push(("gamma_value".to_owned(), format!("{gamma:.3}")));
                HprParams {
                    kernel: Kernel::Linear(Radius::Gamma(gamma)),
                    ..self.params
                }
            }
            None => self.params,
        };
        let v = hpr::visible(self.points, camera.eye, &params, self.hull.as_ref())?;
        Ok(Output {
            visible: v.visible,
            detail,
            ..Output::default()
        })
    }
}

impl Method for HprMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
        crate::Scale::PerPoint(130)
    }
    fn name(&self) -> &'static str {
        "hpr"
    }

    fn summary(&self) -> &'static str {
        "Hidden Point Removal (Katz et al. 2007): spherical flipping + convex hull (seed 000)"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn parallel_views(&self) -> bool {
        true
    }

    fn family(&self, setting: &crate::Setting) -> String {
        match setting.text("kernel").as_deref() {
            Some("exp") => "hpr-exp".into(),
            Some("log") => "hpr-log".into(),
            Some("expdecay") => "hpr-expdecay".into(),
            _ => "hpr-linear".into(),
        }
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let auto = wants_auto_gamma(params)?;
        let (params, hull) = hpr_params(params)?;
        let auto = if auto {
            Some(hpr::auto::CloudScale::of(&input.cloud.positions)?)
        } else {
            None
        };
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            params,
            hull: hull::by_name(&hull)?,
            auto,
        }))
    }
}
