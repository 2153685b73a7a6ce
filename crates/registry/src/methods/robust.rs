//! `robust`: visibility of noisy clouds (`robustvis` crate; Mehra, Tripathi, Sheffer and Mitra,
//! "Visibility of noisy point cloud data", C&G 2010): the dual-space hull and every point
//! within a depth band τ behind its surface, R and τ from the noise and concavity bounds
//! (`gamma=auto`, `noise=auto`, the default) or given.

use cloud::Camera;
use cloud::glam::DVec3;
use robustvis::bounds::{AutoRule, CloudScale};

use crate::card::{Card, Comparison, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "robust",
    "Visibility of noisy clouds (Mehra et al. 2010): dual-space hull + depth band from noise and concavity bounds",
    Kind::Visibility(&Robust),
    &[GAMMA, RADIUS, NOISE, BAND, TOLERANCE, SEED],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(135),
)
.with_parallel_views()
.with_compared_in(&[Comparison::Mehra2010]);

const GAMMA: Param = Param::value(
    "gamma",
    "auto",
    "R = max|p - C| * 10^gamma, or auto: the concavity bound less the band (robustvis::bounds), per view",
);
const RADIUS: Param = Param::rule(
    "radius",
    "-",
    "absolute flipping radius R (overrides gamma)",
);
const NOISE: Param = Param::value(
    "noise",
    "auto",
    "noise standard deviation along the normal, a length, or auto: estimated from local plane fits",
);
const BAND: Param = Param::value(
    "band",
    "3.0",
    "depth band tau = band * noise (0: Katz's HPR exactly)",
);
const TOLERANCE: Param = Param::rule(
    "tolerance",
    "-",
    "absolute depth band tau (overrides noise and band)",
);
const SEED: Param = Param::value(
    "seed",
    "2010",
    "seed of the spacing and noise estimates' samples",
);

/// The method.
struct Robust;

enum RadiusChoice {
    Auto,
    Gamma(f64),
    Absolute(f64),
}

enum BandChoice {
    /// τ = band · (given noise, or σ̂).
    Rule(AutoRule),
    Absolute(f64),
}

/// Its setting.
struct Args {
    radius: RadiusChoice,
    band: BandChoice,
    seed: u64,
}

/// `p`'s value: a number, or `None` for `auto`.
fn number_or_auto(r: &mut Reader<'_>, p: &Param) -> Result<Option<f64>> {
    let text: String = r.get(p)?;
    if text == "auto" {
        return Ok(None);
    }
    text.parse::<f64>()
        .map(Some)
        .map_err(|e| r.bad(p, &text, format!("{e} (expected a number or auto)")))
}

impl Method for Robust {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let radius = match r.given::<f64>(&RADIUS)? {
            Some(radius) => {
                // It overrides γ, given or not.
                r.given_text(&GAMMA)?;
                RadiusChoice::Absolute(radius)
            }
            None => match number_or_auto(r, &GAMMA)? {
                None => RadiusChoice::Auto,
                Some(g) if g.is_finite() => RadiusChoice::Gamma(g),
                Some(g) => return Err(r.bad(&GAMMA, g, "must be finite")),
            },
        };
        let band = match r.given::<f64>(&TOLERANCE)? {
            Some(t) => {
                // It overrides the noise and the band, given or not.
                r.given_text(&NOISE)?;
                r.given_text(&BAND)?;
                BandChoice::Absolute(t)
            }
            None => {
                let band: f64 = r.get(&BAND)?;
                if !(band >= 0.0) || !band.is_finite() {
                    return Err(r.bad(&BAND, band, "must be a finite number >= 0"));
                }
                let noise = number_or_auto(r, &NOISE)?;
                if let Some(s) = noise
                    && (!(s >= 0.0) || !s.is_finite())
                {
                    return Err(r.bad(&NOISE, s, "must be a finite length >= 0"));
                }
                BandChoice::Rule(AutoRule { band, noise })
            }
        };
        Ok(Box::new(Args {
            radius,
            band,
            seed: r.get(&SEED)?,
        }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let needs_scale = matches!(self.radius, RadiusChoice::Auto)
            || matches!(self.band, BandChoice::Rule(AutoRule { noise: None, .. }));
        let scale = if needs_scale {
            Some(CloudScale::of(&input.cloud.positions, self.seed).map_err(Error::method)?)
        } else {
            None
        };
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            args: self,
            scale,
        }))
    }
}

struct Prep<'a> {
    points: &'a [DVec3],
    args: &'a Args,
    /// The cloud's scale, when a rule needs it.
    scale: Option<CloudScale>,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        if matches!(camera.model(), cloud::Model::Orthographic { .. }) {
            return Err(Error::Unsupported(format!(
                "robust does not support {} cameras: it flips the cloud about a viewpoint and \
                 measures depths along rays from it, and an orthographic camera has none (its \
                 centre of projection is at infinity); use a distant pinhole camera, or \
                 raycast, splat or reference",
                camera.model().name()
            )));
        }
        let eye = camera.eye;
        let max_distance = self
            .points
            .iter()
            .map(|p| (*p - eye).length())
            .fold(0.0, f64::max);
        let mut detail = Vec::new();
        let rule = match (&self.args.band, &self.scale) {
            (BandChoice::Rule(rule), Some(scale)) => {
                Some(robustvis::bounds::auto(scale, rule, eye, max_distance))
            }
            _ => None,
        };
        let tolerance = match (&self.args.band, &rule) {
            (BandChoice::Absolute(t), _) => *t,
            (BandChoice::Rule(_), Some(c)) => c.tolerance,
            (BandChoice::Rule(r), None) => r.band * r.noise.unwrap_or(0.0),
        };
        let radius = match self.args.radius {
            RadiusChoice::Absolute(r) => r,
            RadiusChoice::Gamma(g) => max_distance * 10f64.powf(g),
            RadiusChoice::Auto => {
                let scale = self
                    .scale
                    .as_ref()
                    .ok_or_else(|| Error::Unsupported("gamma=auto: no cloud scale".into()))?;
                // The rule with the band actually used (an absolute tolerance included).
                let rule = AutoRule {
                    band: 1.0,
                    noise: Some(tolerance),
                };
                let c = robustvis::bounds::auto(scale, &rule, eye, max_distance);
                detail.push((
                    "gamma_value".to_owned(),
                    format!("{:.3}", c.gamma(max_distance)),
                ));
                detail.push(("r_concavity".to_owned(), format!("{:.4e}", c.r_concavity)));
                detail.push(("r_noise".to_owned(), format!("{:.4e}", c.r_noise)));
                detail.push(("clamped".to_owned(), c.clamped.to_string()));
                c.radius
            }
        };
        if let Some(c) = rule {
            detail.push(("noise_value".to_owned(), format!("{:.4e}", c.noise)));
        }
        detail.push(("tolerance_value".to_owned(), format!("{tolerance:.4e}")));
        let v = robustvis::visible(self.points, eye, radius, tolerance).map_err(|e| match e {
            robustvis::RobustError::EyeInsideCloud => Error::Unsupported(format!(
                "{e}; from among the points, a method that traces rays or draws the points \
                 answers, as the ground truth does: raycast or splat"
            )),
            e => Error::method(e),
        })?;
        detail.push(("hull_vertices".to_owned(), v.hull_vertices.to_string()));
        Ok(Output {
            visible: v.visible,
            detail,
            score: Some(v.gaps.iter().map(|&g| -g as f32).collect()),
            ..Output::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;
    use cloud::synth::sphere_scene;

    fn run(pairs: &[&str], camera: &Camera) -> Result<Output> {
        let scene = sphere_scene(3_000);
        let (setup, _) = CARD.setup(&Params::parse(pairs)?)?;
        setup
            .prepare(Input {
                cloud: &scene.cloud,
                mesh: None,
            })?
            .visible(camera)
    }

    #[test]
    fn the_rules_report_what_they_chose_and_bad_parameters_are_errors() {
        let eye = DVec3::new(0.0, 0.0, 4.0);
        let camera = Camera::new(eye, DVec3::ZERO, DVec3::Y, 60.0, 640, 480).unwrap();
        let out = run(&[], &camera).unwrap();
        let keys: Vec<&str> = out.detail.iter().map(|(k, _)| k.as_str()).collect();
        for k in [
            "gamma_value",
            "r_concavity",
            "r_noise",
            "noise_value",
            "tolerance_value",
        ] {
            assert!(keys.contains(&k), "{keys:?}");
        }
        assert!(out.visible.len() > 1_000 && out.visible.len() < 2_000);
        assert_eq!(out.score.as_ref().map(Vec::len), Some(3_000));
        for bad in [
            &["band=-1"][..],
            &["noise=-0.1"],
            &["gamma=nan"],
            &["gamma=often"],
            &["tolerance=-1", "gamma=3"],
            &["radius=0.5"],
        ] {
            assert!(run(bad, &camera).is_err(), "{bad:?}");
        }
        // Spherical cameras have a viewpoint: the same answer; orthographic ones have none.
        let spherical =
            Camera::look_at(eye, DVec3::ZERO, DVec3::Y, cloud::Model::Spherical, 64, 32).unwrap();
        assert_eq!(run(&[], &spherical).unwrap().visible, out.visible);
        let ortho = Camera::look_at(
            eye,
            DVec3::ZERO,
            DVec3::Y,
            cloud::Model::Orthographic {
                view_width: 3.0,
                view_height: 3.0,
            },
            64,
            64,
        )
        .unwrap();
        let err = run(&[], &ortho).unwrap_err().to_string();
        assert!(
            err.contains("orthographic") && err.contains("viewpoint"),
            "{err}"
        );
    }
}
