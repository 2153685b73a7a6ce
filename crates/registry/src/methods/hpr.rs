//! `hpr`: Hidden Point Removal (Katz, Tal and Basri 2007, seed 000; the `hpr` crate) with any
//! hull implementation. Also the kernel reading the HPR-type methods share (`hpr-approx`,
//! `hpr-confidence`): the kernel and its γ, or `gamma=auto` (`hpr::auto`'s rule, per view), and
//! the refusal of cameras without a viewpoint.

use cloud::Camera;
use cloud::glam::DVec3;
use hpr::{HprParams, Kernel, Radius};
use hull::ConvexHull;

use crate::card::{Card, Comparison, Family, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::setting::Setting;
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "hpr",
    "Hidden Point Removal (Katz et al. 2007): spherical flipping + convex hull (seed 000)",
    Kind::Visibility(&Hpr),
    &[GAMMA, RADIUS, KERNEL, PERTURB, HULL, SEED],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(130),
)
.with_family(Family::Of(family))
.with_parallel_views()
.with_compared_in(&[Comparison::Mehra2010, Comparison::Biasutti2019])
.with_exact();

/// The kernel's parameter, by kernel.
pub(crate) const GAMMA: Param = Param::per(
    "gamma",
    "kernel",
    &[
        ("linear", "auto"),
        ("exp", "-0.05"),
        ("log", "1000"),
        ("expdecay", "0.001"),
    ],
    "linear: R = max|p - C| * 10^gamma, or auto (hpr::auto's rule, per view); exp: the exponent (< 0); log: R = max|p - C| * 10^gamma (> 0); expdecay: the rate (> 0)",
);

/// An absolute radius in place of γ.
pub(crate) const RADIUS: Param = Param::rule(
    "radius",
    "-",
    "absolute flipping radius R (linear kernel; overrides gamma)",
);

/// The kernel.
pub(crate) const KERNEL: Param = Param::value(
    "kernel",
    "linear",
    "linear (spherical flipping), exp (Katz & Tal 2015), log: ln(R/d), expdecay: exp(-gamma d / max d) (hpr::properties)",
);

const PERTURB: Param = Param::value(
    "perturb",
    "0.0",
    "uniform noise of +-perturb * R on each flipped coordinate (seed 000: 0.01)",
);

/// The hull implementation.
pub(crate) const HULL: Param = Param::implied(
    "hull",
    "own",
    "hull implementation: own, qhull, qhull-qj, parry, quickhull, chull",
);

const SEED: Param = Param::value("seed", "2007", "seed of the perturbation");

/// HPR's families: one per kernel.
fn family(setting: &Setting) -> &'static str {
    match setting.text("kernel").as_deref() {
        Some("exp") => "hpr-exp",
        Some("log") => "hpr-log",
        Some("expdecay") => "hpr-expdecay",
        _ => "hpr-linear",
    }
}

/// The kernel of an HPR-type setting: as given, or `gamma=auto`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum KernelChoice {
    /// The kernel the setting names.
    Fixed(Kernel),
    /// `gamma=auto`: the linear kernel with `hpr::auto`'s γ per view.
    Auto,
}

/// Reads `kernel`, `gamma` (its default by kernel) and `radius` (which overrides γ).
pub(crate) fn read_kernel(r: &mut Reader<'_>) -> Result<KernelChoice> {
    let kernel: String = r.get(&KERNEL)?;
    if !matches!(kernel.as_str(), "linear" | "exp" | "log" | "expdecay") {
        return Err(r.bad(&KERNEL, &kernel, "expected linear, exp, log or expdecay"));
    }
    let only_linear = format!("applies to the linear kernel only (kernel={kernel})");
    if let Some(radius) = r.given::<f64>(&RADIUS)? {
        if kernel != "linear" {
            return Err(r.bad(&RADIUS, radius, only_linear));
        }
        // It overrides γ, given or not.
        r.given_text(&GAMMA)?;
        return Ok(KernelChoice::Fixed(Kernel::Linear(Radius::Absolute(
            radius,
        ))));
    }
    // Every kernel has a default γ.
    let gamma = r.text(&GAMMA)?.unwrap_or_default();
    if gamma == "auto" {
        return if kernel == "linear" {
            Ok(KernelChoice::Auto)
        } else {
            Err(r.bad(&GAMMA, gamma, only_linear))
        };
    }
    let g = gamma
        .parse::<f64>()
        .map_err(|e| r.bad(&GAMMA, &gamma, format!("expected a number or auto ({e})")))?;
    Ok(KernelChoice::Fixed(match kernel.as_str() {
        "linear" => Kernel::Linear(Radius::Gamma(g)),
        "exp" => Kernel::Exponential(g),
        "log" => Kernel::Log(g),
        _ => Kernel::ExpDecay(g),
    }))
}

/// Reads `hull`: the implementation, made once.
pub(crate) fn read_hull(r: &mut Reader<'_>) -> Result<Box<dyn ConvexHull>> {
    let name: String = r.get(&HULL)?;
    hull::by_name(&name).map_err(|e| r.bad(&HULL, &name, e.to_string()))
}

/// HPR-type methods need a viewpoint: pinhole and spherical cameras have one (their centre of
/// projection); an orthographic camera is refused with the reason.
pub(crate) fn refuse_orthographic(method: &str, camera: &Camera) -> Result<()> {
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
pub(crate) fn auto_gamma_for(scale: &hpr::auto::CloudScale, points: &[DVec3], eye: DVec3) -> f64 {
    use rayon::prelude::*;
    let max_distance = points
        .par_iter()
        .map(|p| (*p - eye).length())
        .reduce(|| 0.0, f64::max);
    hpr::auto::auto_gamma(scale, eye, max_distance)
}

/// A kernel choice on one cloud: the fixed kernel, or the cloud's scale measured once for
/// `gamma=auto`.
pub(crate) enum KernelRule {
    /// The kernel the setting names.
    Fixed(Kernel),
    /// `gamma=auto`.
    Auto(hpr::auto::CloudScale),
}

impl KernelRule {
    /// The rule of `choice` on `points`.
    pub(crate) fn of(choice: KernelChoice, points: &[DVec3]) -> Result<Self> {
        Ok(match choice {
            KernelChoice::Fixed(k) => Self::Fixed(k),
            KernelChoice::Auto => {
                Self::Auto(hpr::auto::CloudScale::of(points).map_err(Error::method)?)
            }
        })
    }

    /// The kernel for a view from `eye`; an automatic γ is added to `detail` as `gamma_value`.
    /// Fails when the rule gives no usable γ (an eye near the middle of the cloud: the
    /// error says what the rule needs, [`auto_too_close`]).
    pub(crate) fn for_view(
        &self,
        points: &[DVec3],
        eye: DVec3,
        detail: &mut Vec<(String, String)>,
    ) -> Result<Kernel> {
        match self {
            Self::Fixed(k) => Ok(*k),
            Self::Auto(scale) => {
                let gamma = auto_gamma_for(scale, points, eye);
                if !(gamma > 0.0) {
                    return Err(auto_too_close(scale, points, eye, gamma));
                }
                detail.push(("gamma_value".to_owned(), format!("{gamma:.3}")));
                Ok(Kernel::Linear(Radius::Gamma(gamma)))
            }
        }
    }
}

/// Why `gamma=auto` cannot serve a view from `eye` (its γ, `gamma`, is not positive), in the
/// user's words: the rule reads γ from the eye's distance d to the middle of the cloud's box,
/// γ = log10(κ·D·d²/(s²·m)), which is positive only beyond d = s·√(m / (κ·D)); nearer, the
/// flipping sphere would not hold the cloud.
fn auto_too_close(
    scale: &hpr::auto::CloudScale,
    points: &[DVec3],
    eye: DVec3,
    gamma: f64,
) -> Error {
    let m = points
        .iter()
        .map(|p| (*p - eye).length())
        .fold(0.0, f64::max);
    let d = (eye - scale.center).length();
    let needed = scale.spacing * (m / (hpr::auto::KAPPA * scale.diagonal)).sqrt();
    Error::Unsupported(format!(
        "gamma=auto chooses how far HPR flips the points from how far the eye is from the \
         cloud, and this eye is too close: it is {d:.4} from the middle of the cloud's bounding \
         box ({:.4} across, points about {:.4} apart), where the rule gives gamma {gamma:.3}, a \
         flipping sphere no larger than the cloud (HPR needs gamma > 0). The rule is made for \
         an eye outside the object looking at it: move the eye at least about {needed:.4} from \
         the box's middle (outside the object), or give the setting yourself: gamma=G with G > 0 \
         (larger keeps more points), or radius=R with R > {m:.4} (the farthest point's distance \
         from this eye)",
        scale.diagonal, scale.spacing
    ))
}

/// The method.
struct Hpr;

/// Its setting.
struct Args {
    kernel: KernelChoice,
    perturb: f64,
    seed: u64,
    hull: Box<dyn ConvexHull>,
}

impl Method for Hpr {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        Ok(Box::new(Args {
            kernel: read_kernel(r)?,
            perturb: r.get(&PERTURB)?,
            seed: r.get(&SEED)?,
            hull: read_hull(r)?,
        }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let points = &input.cloud.positions;
        Ok(Box::new(Prep {
            points,
            args: self,
            kernel: KernelRule::of(self.kernel, points)?,
        }))
    }
}

struct Prep<'a> {
    points: &'a [DVec3],
    args: &'a Args,
    kernel: KernelRule,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        refuse_orthographic("hpr", camera)?;
        let mut detail = Vec::new();
        let params = HprParams {
            kernel: self.kernel.for_view(self.points, camera.eye, &mut detail)?,
            perturb: self.args.perturb,
            seed: self.args.seed,
        };
        let v = hpr::visible(self.points, camera.eye, &params, self.args.hull.as_ref())
            .map_err(Error::method)?;
        Ok(Output {
            visible: v.visible,
            detail,
            ..Output::default()
        })
    }
}
