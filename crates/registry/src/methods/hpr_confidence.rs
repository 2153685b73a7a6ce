//! `hpr-confidence`: Katz and Tal's visibility-confidence score (`hpr::confidence`) with the
//! visible set the points whose score reaches `threshold`; the score itself goes out in
//! [`Output::score`].
//!
//! The grid of kernel parameters is `from`, `to`, `steps` (defaults per kernel: for the linear
//! kernel the γ range of `hpr`'s own sweep). `from=auto` (linear kernel) centres it on
//! `hpr::auto`'s γ for the view, from max(γ − 2, 0.1) to γ + 2: our rule, not the paper's (the
//! paper gives none); threshold 0.5 of it is then close to `hpr` with `gamma=auto`.

use cloud::Camera;
use cloud::glam::DVec3;
use hpr::confidence::{Grid, confidence, threshold};
use hpr::properties::Family as KernelFamily;
use hull::ConvexHull;

use super::hpr::{HULL, KERNEL, auto_gamma_for, read_hull, refuse_orthographic};
use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "hpr-confidence",
    "HPR visibility-confidence score (Katz & Tal 2015): fraction of a kernel-parameter grid at which a point is on the hull, thresholded",
    Kind::Visibility(&HprConfidence),
    &[KERNEL, FROM, TO, STEPS, THRESHOLD, HULL],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(164),
)
.with_parallel_views();

const FROM: Param = Param::per(
    "from",
    "kernel",
    &[
        ("linear", "1.5"),
        ("exp", "-1e-2"),
        ("log", "30"),
        ("expdecay", "1e-2"),
    ],
    "the grid's parameter farthest from the kernel's limit, or auto (linear: hpr::auto's gamma - 2, per view)",
)
.unnamed();

const TO: Param = Param::per(
    "to",
    "kernel",
    &[
        ("linear", "5.5"),
        ("exp", "-1e-5"),
        ("log", "1e5"),
        ("expdecay", "1e-6"),
    ],
    "the grid's parameter nearest the kernel's limit (not with from=auto: gamma + 2)",
)
.unnamed();

const STEPS: Param = Param::value(
    "steps",
    "5",
    "grid size m (1..=1024): the score is the fraction of the m parameters at which a point is visible",
);

const THRESHOLD: Param = Param::value(
    "threshold",
    "0.6",
    "visible = score >= threshold, in (0, 1]",
);

/// The method.
struct HprConfidence;

enum GridRule {
    Fixed(Grid),
    /// `from=auto`: centred on `hpr::auto`'s γ per view.
    Auto {
        steps: usize,
    },
}

/// Its setting.
struct Args {
    grid: GridRule,
    threshold: f64,
    hull: Box<dyn ConvexHull>,
}

impl Method for HprConfidence {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let kernel: String = r.get(&KERNEL)?;
        let family = KernelFamily::by_name(&kernel)
            .ok_or_else(|| r.bad(&KERNEL, &kernel, "expected linear, exp, log or expdecay"))?;
        let steps: usize = r.get(&STEPS)?;
        let t: f64 = r.get(&THRESHOLD)?;
        // Checked here, so that a bad threshold fails before any view.
        threshold(&[], t).map_err(Error::method)?;
        let from: String = r.get(&FROM)?;
        let grid = if from == "auto" {
            if family != KernelFamily::Linear {
                return Err(r.bad(
                    &FROM,
                    "auto",
                    format!("applies to the linear kernel only (kernel={kernel})"),
                ));
            }
            if let Some(to) = r.given_text(&TO)? {
                return Err(r.bad(&TO, to, "from=auto sets the whole grid: leave to out"));
            }
            // Checks steps now.
            Grid::new(KernelFamily::Linear, 1.0, 2.0, steps).map_err(Error::method)?;
            GridRule::Auto { steps }
        } else {
            let from = from
                .parse::<f64>()
                .map_err(|e| r.bad(&FROM, &from, e.to_string()))?;
            let to: f64 = r.get(&TO)?;
            GridRule::Fixed(Grid::new(family, from, to, steps).map_err(Error::method)?)
        };
        Ok(Box::new(Args {
            grid,
            threshold: t,
            hull: read_hull(r)?,
        }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let points = &input.cloud.positions;
        let scale = match self.grid {
            GridRule::Auto { .. } => {
                Some(hpr::auto::CloudScale::of(points).map_err(Error::method)?)
            }
            GridRule::Fixed(_) => None,
        };
        Ok(Box::new(Prep {
            points,
            args: self,
            scale,
        }))
    }
}

struct Prep<'a> {
    points: &'a [DVec3],
    args: &'a Args,
    /// The cloud's scale, for `from=auto`.
    scale: Option<hpr::auto::CloudScale>,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        refuse_orthographic("hpr-confidence", camera)?;
        let mut detail = Vec::new();
        let auto_grid;
        let grid = match (&self.args.grid, &self.scale) {
            (GridRule::Fixed(g), _) => g,
            (GridRule::Auto { steps }, Some(scale)) => {
                let g = auto_gamma_for(scale, self.points, camera.eye);
                let (from, to) = ((g - 2.0).max(0.1), (g + 2.0).max(0.2));
                detail.push(("gamma_from".to_owned(), format!("{from:.3}")));
                detail.push(("gamma_to".to_owned(), format!("{to:.3}")));
                auto_grid =
                    Grid::new(KernelFamily::Linear, from, to, *steps).map_err(Error::method)?;
                &auto_grid
            }
            (GridRule::Auto { .. }, None) => {
                return Err(Error::Unsupported("from=auto: no cloud scale".into()));
            }
        };
        let c = confidence(self.points, camera.eye, grid, self.args.hull.as_ref())
            .map_err(Error::method)?;
        let visible = threshold(&c.score, self.args.threshold).map_err(Error::method)?;
        Ok(Output {
            visible,
            detail,
            score: Some(c.score),
            ..Output::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::synth::sphere_scene;
    use cloud::{Camera, Model};

    use super::*;
    use crate::params::Params;

    fn run(set: &[&str], camera: &Camera) -> Result<Output> {
        let scene = sphere_scene(3_000);
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let (setup, _) = CARD.setup(&Params::parse(set)?)?;
        setup.prepare(input)?.visible(camera)
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
                .map_or(0.6, |v| v.parse().unwrap());
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
            (&["from=auto", "to=4"], "leave to out"),
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
