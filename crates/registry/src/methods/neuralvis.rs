//! `neuralvis`: the learned visibility of Wang et al., "Neural Visibility of Point Sets" (2025;
//! the `neuralvis` crate), our training of their design. The feature pass (the octree U-Net)
//! runs once per cloud in `prepare`, and is the build time the kernel reports apart; each view
//! runs the head alone. The visible set is the points whose P(visible) reaches `threshold`,
//! and P(visible) goes out as the score.

use std::path::Path;

use cloud::Camera;
use cloud::glam::DVec3;
use neuralvis::{Features, Model};

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "neuralvis",
    "learned: Neural Visibility of Point Sets (Wang et al. 2025), octree U-Net features once per cloud + view-direction MLP per view; our training of their design on 29 CGAL meshes",
    Kind::Visibility(&NeuralVis),
    &[THRESHOLD, DEPTH, WEIGHTS],
    // The features (63 f32 a point) and the build's keys, positions and indices, with a margin.
    Memory::PerPoint(400),
);

const THRESHOLD: Param = Param::value(
    "threshold",
    "0.5",
    "a point is visible when its P(visible) reaches this (0.5: the paper's argmax)",
);
const DEPTH: Param = Param::rule(
    "depth",
    "the weights'",
    "octree depth of the feature pass (the committed weights were trained at 8)",
);
const WEIGHTS: Param = Param::implied(
    "weights",
    neuralvis::COMMITTED,
    "weights file (.nvw, from scripts/train-neuralvis.sh), or committed: the weights built in",
);

/// The method.
struct NeuralVis;

/// Its setting: the network (loaded and checked) and the threshold.
struct Args {
    model: Model,
    threshold: f32,
}

impl Method for NeuralVis {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let threshold: f32 = r.get(&THRESHOLD)?;
        if !(0.0..=1.0).contains(&threshold) {
            return Err(r.bad(&THRESHOLD, threshold, "expected a probability in [0, 1]"));
        }
        let weights: String = r.get(&WEIGHTS)?;
        let model = if weights == neuralvis::COMMITTED {
            Model::committed()
        } else {
            Model::load(Path::new(&weights))
        }
        .map_err(Error::method)?;
        let model = match r.opt::<u32>(&DEPTH)? {
            Some(d) if d != model.weights().config.depth => model
                .with_depth(d)
                .map_err(|e| r.bad(&DEPTH, d, e.to_string()))?,
            _ => model,
        };
        Ok(Box::new(Args { model, threshold }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let start = std::time::Instant::now();
        let features = self
            .model
            .features(&input.cloud.positions)
            .map_err(Error::method)?;
        Ok(Box::new(Prep {
            points: &input.cloud.positions,
            features,
            seconds: start.elapsed().as_secs_f64(),
            args: self,
        }))
    }
}

struct Prep<'a> {
    points: &'a [DVec3],
    features: Features,
    seconds: f64,
    args: &'a Args,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let p = self
            .args
            .model
            .probabilities(&self.features, self.points, camera)
            .map_err(Error::method)?;
        Ok(Output {
            visible: neuralvis::visible(&p, self.args.threshold),
            score: Some(p),
            ..Output::default()
        })
    }

    fn reported_build_seconds(&self) -> Option<f64> {
        Some(self.seconds)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;

    fn setup(pairs: &[&str]) -> Result<Box<dyn Setup>> {
        Ok(CARD.setup(&Params::parse(pairs)?)?.0)
    }

    #[test]
    fn settings_are_checked_before_any_work() {
        assert!(setup(&["threshold=1.5"]).is_err());
        assert!(setup(&["depth=3"]).is_err());
        let err = setup(&["weights=/no/such/file.nvw"])
            .err()
            .expect("missing weights");
        assert!(err.to_string().contains("/no/such/file.nvw"), "{err}");
        assert!(setup(&["colour=red"]).is_err());
    }

    #[test]
    fn answers_a_sphere_with_its_near_side() {
        let scene = cloud::synth::sphere_scene(2000);
        let camera = Camera::new(
            DVec3::new(0.5, 1.0, 4.0),
            DVec3::ZERO,
            DVec3::Y,
            40.0,
            640,
            480,
        )
        .expect("camera");
        let s = setup(&[]).expect("default setting");
        let prep = s
            .prepare(Input {
                cloud: &scene.cloud,
                mesh: None,
            })
            .expect("feature pass");
        let out = prep.visible(&camera).expect("a view");
        assert_eq!(out.score.as_ref().map(Vec::len), Some(2000));
        assert!(prep.reported_build_seconds().is_some());
        let p = &scene.cloud.positions;
        let eye = camera.eye;
        let facing = |i: u32| (eye - p[i as usize]).dot(p[i as usize]) > 0.0;
        let agree = out.visible.iter().filter(|&&i| facing(i)).count();
        // From 4.1 radii a sphere shows 38 % of its surface.
        assert!(
            (400..=1200).contains(&out.visible.len()),
            "{} of 2000 visible",
            out.visible.len()
        );
        assert!(
            agree as f64 >= 0.8 * out.visible.len() as f64,
            "{agree} of {} facing the eye",
            out.visible.len()
        );
    }
}
