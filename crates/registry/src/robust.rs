//! `robust`: visibility of noisy clouds (`robustvis` crate; Mehra, Tripathi, Sheffer and Mitra,
//! "Visibility of noisy point cloud data", C&G 2010): the dual-space hull and every point
//! within a depth band τ behind its surface, R and τ from the noise and concavity bounds
//! (`gamma=auto`, `noise=auto`, the default) or given.

use crate::error::{Error, Result};
use cloud::Camera;
use cloud::glam::DVec3;
use robustvis::bounds::{AutoRule, CloudScale};

use crate::{Input, Method, Output, ParamSpec, Params, Prepared};

/// The robust operator.
pub struct RobustMethod;

/// Default band, in noise standard deviations.
pub const DEFAULT_BAND: f64 = 3.0;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "gamma",
        default: "auto",
        help: "R = max|p - C| * 10^gamma, or auto: the concavity bound less the band (robustvis::bounds), per view",
    },
    ParamSpec {
        key: "radius",
        default: "-",
        help: "absolute flipping radius R (overrides gamma)",
    },
    ParamSpec {
        key: "noise",
        default: "auto",
        help: "noise standard deviation along the normal, a length, or auto: estimated from local plane fits",
    },
    ParamSpec {
        key: "band",
        default: "3",
        help: "depth band tau = band * noise (0: Katz's HPR exactly)",
    },
    ParamSpec {
        key: "tolerance",
        default: "-",
        help: "absolute depth band tau (overrides noise and band)",
    },
    ParamSpec {
        key: "seed",
        default: "0",
        help: "seed of the spacing and noise estimates' samples",
    },
];

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

struct Prep<'a> {
    points: &'a [DVec3],
    radius: RadiusChoice,
    band: BandChoice,
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
        let rule = match (&self.band, &self.scale) {
            (BandChoice::Rule(rule), Some(scale)) => {
                Some(robustvis::bounds::auto(scale, rule, eye, max_distance))
            }
            _ => None,
        };
        let tolerance = match (&self.band, &rule) {
            (BandChoice::Absolute(t), _) => *t,
            (BandChoice::Rule(_), Some(c)) => c.tolerance,
            (BandChoice::Rule(r), None) => r.band * r.noise.unwrap_or(0.0),
        };
        let radius = match self.radius {
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
        let v = robustvis::visible(self.points, eye, radius, tolerance)?;
        detail.push(("hull_vertices".to_owned(), v.hull_vertices.to_string()));
        Ok(Output {
            visible: v.visible,
            detail,
            score: Some(v.gaps.iter().map(|&g| -g as f32).collect()),
            ..Output::default()
        })
    }
}

fn number_or_auto(params: &Params, key: &'static str) -> Result<Option<Option<f64>>> {
    let text: Option<String> = params.get_opt(key)?;
    Ok(match text.as_deref() {
        None => None,
        Some("auto") => Some(None),
        Some(t) => Some(Some(t.parse::<f64>().map_err(|e| Error::BadValue {
            key: key.to_owned(),
            value: t.to_owned(),
            reason: format!("{e} (expected a number or auto)"),
        })?)),
    })
}

impl Method for RobustMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 x (the peak per point at 10^7 points less the cloud's 48): a scale cell of
        // the dragon at its default setting peaked at 1562 MB.
        crate::Scale::PerPoint(135)
    }
    fn name(&self) -> &'static str {
        "robust"
    }

    fn summary(&self) -> &'static str {
        "Visibility of noisy clouds (Mehra et al. 2010): dual-space hull + depth band from noise and concavity bounds"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn parallel_views(&self) -> bool {
        true
    }

    fn family(&self, _setting: &crate::Setting) -> String {
        "robust".into()
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let bad = |name: &'static str, reason: String| {
            Error::Robust(robustvis::RobustError::InvalidParameter { name, reason })
        };
        let radius = match (
            params.get_opt::<f64>("radius")?,
            number_or_auto(params, "gamma")?,
        ) {
            (Some(r), _) => RadiusChoice::Absolute(r),
            (None, None | Some(None)) => RadiusChoice::Auto,
            (None, Some(Some(g))) if g.is_finite() => RadiusChoice::Gamma(g),
            (None, Some(Some(g))) => return Err(bad("gamma", format!("must be finite, got {g}"))),
        };
        let band: f64 = params.get("band", DEFAULT_BAND)?;
        if !(band >= 0.0) || !band.is_finite() {
            return Err(bad(
                "band",
                format!("must be a finite number >= 0, got {band}"),
            ));
        }
        let noise = number_or_auto(params, "noise")?.flatten();
        if let Some(s) = noise
            && (!(s >= 0.0) || !s.is_finite())
        {
            return Err(bad(
                "noise",
                format!("must be a finite length >= 0, got {s}"),
            ));
        }
        let band = match params.get_opt::<f64>("tolerance")? {
            Some(t) => BandChoice::Absolute(t),
            None => BandChoice::Rule(AutoRule { band, noise }),
        };
        let seed: u64 = params.get("seed", 0)?;
        let needs_scale = matches!(radius, RadiusChoice::Auto)
            || matches!(band, BandChoice::Rule(AutoRule { noise: None, .. }));
        let scale = if needs_scale {
            Some(CloudScale::of(&input.cloud.positions, seed)?)
        } else {
            None
        };
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            radius,
            band,
            scale,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Method;
    use cloud::synth::sphere_scene;

    fn run(pairs: &[&str], camera: &Camera) -> Result<Output> {
        let scene = sphere_scene(3_000);
        let params = Params::parse(pairs)?;
        let prepared = RobustMethod.prepare(
            Input {
                cloud: &scene.cloud,
                mesh: None,
            },
            &params,
        )?;
        prepared.visible(camera)
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
