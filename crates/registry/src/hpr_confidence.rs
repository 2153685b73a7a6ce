//! `hpr-confidence`: Katz and Tal's visibility-confidence score (`hpr::confidence`) with the
//! visible set the points whose score reaches `threshold`; the score itself goes out in
//! [`Output::score`].
//!
//! The grid of kernel parameters is `from`, `to`, `steps` (defaults per kernel below: for the
//! linear kernel the γ range of `hpr`'s own sweep). `from=auto` (linear kernel) centres it on
//! `hpr::auto`'s γ for the view, from max(γ − 2, 0.1) to γ + 2: our rule, not the paper's (the
//! paper gives none); threshold 0.5 of it is then close to `hpr` with `gamma=auto`.

use cloud::Camera;
use hpr::confidence::{Grid, confidence, threshold};
use hpr::properties::Family;
use hull::ConvexHull;

use crate::error::{Error, Result};
use crate::hpr::{auto_gamma_for, refuse_orthographic};
use crate::{Input, Method, Output, ParamSpec, Params, Prepared};

/// The visibility-confidence score, thresholded.
pub struct HprConfidenceMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "kernel",
        default: "linear",
        help: "kernel family: linear, exp, log, expdecay (hpr::properties)",
    },
    ParamSpec {
        key: "from",
        default: "1.5 (linear), -1e-2 (exp), 30 (log), 1e-2 (expdecay)",
        help: "the grid's parameter farthest from the kernel's limit, or auto (linear: hpr::auto's gamma - 2, per view)",
    },
    ParamSpec {
        key: "to",
        default: "5.5 (linear), -1e-5 (exp), 1e5 (log), 1e-6 (expdecay)",
        help: "the grid's parameter nearest the kernel's limit (ignored with from=auto: gamma + 2)",
    },
    ParamSpec {
        key: "steps",
        default: "5",
        help: "grid size m (1..=1024): the score is the fraction of the m parameters at which a point is visible",
    },
    ParamSpec {
        key: "threshold",
        default: "0.5",
        help: "visible = score >= threshold, in (0, 1]",
    },
    ParamSpec {
        key: "hull",
        default: "own",
        help: "hull implementation: own, qhull, qhull-qj, parry, quickhull, chull",
    },
];

/// The default grid ends of `family`.
fn default_range(family: Family) -> (f64, f64) {
    match family {
        Family::Linear => (1.5, 5.5),
        Family::Exponential => (-1e-2, -1e-5),
        Family::Log => (30.0, 1e5),
        Family::ExpDecay => (1e-2, 1e-6),
    }
}

enum GridRule {
    Fixed(Grid),
    /// `from=auto`: centred on `hpr::auto`'s γ per view.
    Auto {
        scale: hpr::auto::CloudScale,
        steps: usize,
    },
}

struct Prep<'a> {
    points: &'a [cloud::glam::DVec3],
    grid: GridRule,
    threshold: f64,
    hull: Box<dyn ConvexHull>,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        refuse_orthographic("hpr-confidence", camera)?;
        let mut detail = Vec::new();
        let auto_grid;
        let grid = match &self.grid {
            GridRule::Fixed(g) => g,
            GridRule::Auto { scale, steps } => {
                let g = auto_gamma_for(scale, self.points, camera.eye);
                let (from, to) = ((g - 2.0).max(0.1), (g + 2.0).max(0.2));
                detail.push(("gamma_from".to_owned(), format!("{from:.3}")));
                detail.push(("gamma_to".to_owned(), format!("{to:.3}")));
                auto_grid = Grid::new(Family::Linear, from, to, *steps)?;
                &auto_grid
            }
        };
        let c = confidence(self.points, camera.eye, grid, self.hull.as_ref())?;
        let visible = threshold(&c.score, self.threshold)?;
        Ok(Output {
            visible,
            detail,
            score: Some(c.score),
            ..Output::default()
        })
    }
}

impl Method for HprConfidenceMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 x (the peak per point at 10^7 points less the cloud's 48): a scale cell of
        // the dragon at its default setting peaked at 1789 MB.
        crate::Scale::PerPoint(164)
    }
    fn name(&self) -> &'static str {
        "hpr-confidence"
    }

    fn summary(&self) -> &'static str {
        "HPR visibility-confidence score (Katz & Tal 2015): fraction of a kernel-parameter grid at which a point is on the hull, thresholded"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn parallel_views(&self) -> bool {
        true
    }

    fn family(&self, _setting: &crate::Setting) -> String {
        "hpr-confidence".into()
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let kernel: String = params.get("kernel", "linear".to_owned())?;
        let family = Family::by_name(&kernel).ok_or_else(|| {
            Error::Unsupported(format!(
                "--set kernel={kernel}: expected linear, exp, log or expdecay"
            ))
        })?;
        let steps: usize = params.get("steps", 5)?;
        let t: f64 = params.get("threshold", 0.5)?;
        // Checked here, so that a bad threshold fails before any view.
        threshold(&[], t)?;
        let from: Option<String> = params.get_opt("from")?;
        let to: Option<f64> = params.get_opt("to")?;
        let (lo, hi) = default_range(family);
        let grid = if from.as_deref() == Some("auto") {
            if family != Family::Linear {
                return Err(Error::Unsupported(
                    "from=auto applies to the linear kernel only".into(),
                ));
            }
            if to.is_some() {
                return Err(Error::Unsupported(
                    "from=auto sets the whole grid: drop --set to".into(),
                ));
            }
            // Checks steps now.
            Grid::new(Family::Linear, 1.0, 2.0, steps)?;
            GridRule::Auto {
                scale: hpr::auto::CloudScale::of(&input.cloud.positions)?,
                steps,
            }
        } else {
            let from = match from {
                None => lo,
                Some(text) => text.parse::<f64>().map_err(|e| Error::BadValue {
                    key: "from".into(),
                    value: text.clone(),
                    reason: e.to_string(),
                })?,
            };
            GridRule::Fixed(Grid::new(family, from, to.unwrap_or(hi), steps)?)
        };
        let hull: String = params.get("hull", "own".to_owned())?;
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            grid,
            threshold: t,
            hull: hull::by_name(&hull)?,
        }))
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::synth::sphere_scene;
    use cloud::{Camera, Model};

    use super::*;

    fn run(set: &[&str], camera: &Camera) -> Result<Output> {
        let scene = sphere_scene(3_000);
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let params = Params::parse(set)?;
        let p = crate::kernel::prepare(&HprConfidenceMethod, input, &params)?;
        p.visible(camera)
    }

    fn pinhole() -> Camera {
        let model = Model::pinhole_fov(50.0, 320, 240).unwrap();
        Camera::look_at(
            DVec3::new(0.3, 0.2, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            model,
            320,
            240,
        )
        .unwrap()
    }

    #[test]
    fn the_score_goes_out_and_the_visible_set_is_its_threshold() {
        for set in [
            &["threshold=0.6"][..],
            &["from=auto", "steps=3", "threshold=1"],
            &["kernel=exp", "steps=3", "threshold=0.3"],
            &["kernel=log", "from=100", "to=10000", "steps=3"],
            &["kernel=expdecay", "steps=2", "threshold=1"],
        ] {
            let out = run(set, &pinhole()).unwrap();
            let score = out.score.as_ref().expect("a score");
            assert_eq!(score.len(), 3_000);
            let t: f64 = set
                .iter()
                .find_map(|s| s.strip_prefix("threshold="))
                .map_or(0.5, |v| v.parse().unwrap());
            assert_eq!(out.visible, threshold(score, t).unwrap(), "{set:?}");
            assert!(out.visible.len() > 300, "{set:?}: {}", out.visible.len());
        }
        let auto = run(&["from=auto"], &pinhole()).unwrap();
        assert!(auto.detail.iter().any(|(k, _)| k == "gamma_from"));
    }

    #[test]
    fn spherical_cameras_run_and_orthographic_ones_are_refused() {
        let eye = DVec3::new(0.3, 0.2, 3.0);
        let sph = Camera::look_at(eye, DVec3::ZERO, DVec3::Y, Model::Spherical, 512, 256).unwrap();
        let a = run(&[], &sph).unwrap();
        let b = run(&[], &pinhole()).unwrap();
        assert_eq!(a.visible, b.visible, "the answer depends on the eye alone");
        let ortho = Camera::look_at(
            eye,
            DVec3::ZERO,
            DVec3::Y,
            Model::Orthographic {
                view_width: 3.0,
                view_height: 3.0,
            },
            100,
            100,
        )
        .unwrap();
        let err = run(&[], &ortho).unwrap_err().to_string();
        assert!(
            err.contains("orthographic") && err.contains("viewpoint"),
            "{err}"
        );
    }

    #[test]
    fn bad_parameters_are_errors() {
        let cam = pinhole();
        for (set, needle) in [
            (&["threshold=NaN"][..], "threshold"),
            (&["threshold=0"], "threshold"),
            (&["steps=0"], "steps"),
            (&["kernel=cubic"], "kernel=cubic"),
            (&["kernel=exp", "from=auto"], "linear kernel only"),
            (&["from=auto", "to=4"], "drop --set to"),
            (&["from=x"], "from"),
            (&["kernel=exp", "from=0.5"], "from"),
            (&["from=5", "to=2"], "to"),
            (&["hull=nope"], "unknown hull"),
            (&["gamma=3"], "gamma"),
        ] {
            let err = run(set, &cam).unwrap_err().to_string();
            assert!(err.contains(needle), "{set:?}: {err}");
        }
    }
}
