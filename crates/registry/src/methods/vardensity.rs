//! `vardensity`: Biasutti, Bugeau, Aujol, Brédif (VISAPP 2019), a depth-relative score over
//! a screen-space k-nearest neighbourhood that needs no density assumption
//! (`screenspace::vardensity`). Every camera model, the spherical equirectangular image of
//! mobile LiDAR included; per-pixel output (`Output::pixels`) and the score per point
//! (`Output::score`). No automatic rule beyond the paper's own design (the neighbourhood
//! adapts to the projected density by itself); see the method crate's doc on what of the
//! paper could be read.

use screenspace::VardensityParams;

use super::screenspace::{HEIGHT, ScreenArgs, WIDTH};
use crate::card::{Card, Comparison, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Method, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "vardensity",
    "variable-density screen-space visibility (Biasutti et al. 2019): depth score over k screen neighbours",
    Kind::Visibility(&Vardensity),
    &[K, MAX_RADIUS, THRESHOLD, DEPTH_TOLERANCE, WIDTH, HEIGHT],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(26),
)
.with_compared_in(&[Comparison::Biasutti2019])
.with_made_for(Metric::Pixels);

const K: Param = Param::value("k", "8", "screen-space neighbours of each pixel");
const MAX_RADIUS: Param = Param::value("max_radius", "32", "farthest neighbour searched, pixels");
const THRESHOLD: Param = Param::value("threshold", "0.5", "minimum visibility score, in [0, 1]");
const DEPTH_TOLERANCE: Param = Param::value(
    "depth_tolerance",
    "0.01",
    "relative depth within which points sharing a kept pixel count visible (0: one point per pixel)",
);

/// The method.
struct Vardensity;

impl Method for Vardensity {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let p = VardensityParams {
            k: r.get(&K)?,
            max_radius: r.get(&MAX_RADIUS)?,
            threshold: r.get(&THRESHOLD)?,
            depth_tolerance: r.get(&DEPTH_TOLERANCE)?,
        };
        p.validate().map_err(Error::method)?;
        Ok(Box::new(ScreenArgs::read(
            r,
            p,
            screenspace::vardensity::visible,
        )?))
    }
}

#[cfg(test)]
mod tests {
    //! Both screen-space methods through the registry: every camera model answers with a
    //! per-pixel image and a score, and bad parameters or clouds are errors.

    use cloud::glam::DVec3;
    use cloud::{Camera, Model, PointCloud};

    use crate::error::{Error, Result};
    use crate::params::Params;
    use crate::visibility::Input;

    /// `name`'s setting read and prepared on `input`, or the first error.
    fn prepared(name: &str, input: Input<'_>, params: &Params) -> Result<()> {
        let card = crate::builtin_card(name).expect("built in");
        let (setup, _) = card.setup(params)?;
        setup.prepare(input).map(|_| ())
    }

    fn cameras() -> Vec<Camera> {
        let models = [
            Model::pinhole_fov(50.0, 64, 48).expect("fov"),
            Model::Orthographic {
                view_width: 5.0,
                view_height: 3.75,
            },
            Model::Spherical,
        ];
        models
            .into_iter()
            .map(|m| {
                Camera::look_at(
                    DVec3::new(1.5, -2.5, 4.0),
                    DVec3::new(0.0, 0.0, 0.5),
                    DVec3::Z,
                    m,
                    64,
                    48,
                )
                .expect("camera")
            })
            .collect()
    }

    #[test]
    fn every_camera_model_gives_pixels_and_scores() {
        let scene = cloud::synth::sphere_plane_scene(1_500, 3_000, 2).0;
        for name in ["screenspace", "vardensity"] {
            let card = crate::builtin_card(name).expect("built in");
            let params = Params::from_pairs(&[("depth_tolerance", "0.01".into())]);
            let input = Input {
                cloud: &scene.cloud,
                mesh: None,
            };
            let (setup, _) = card.setup(&params).expect("a setting");
            let prepared = setup.prepare(input).expect("prepare");
            for cam in cameras() {
                let out = prepared.visible(&cam).expect("visible");
                let px = out.pixels.as_ref().expect("per-pixel");
                assert_eq!(px.point.len(), 64 * 48);
                assert!(!out.visible.is_empty(), "{name} {}", cam.model().name());
                assert!(out.visible.windows(2).all(|w| w[0] < w[1]));
                // Every pixel shows a visible point or none.
                for &p in &px.point {
                    assert!(p == u32::MAX || out.visible.binary_search(&p).is_ok());
                }
                let score = out.score.as_ref().expect("a score");
                assert_eq!(score.len(), scene.cloud.positions.len());
            }
        }
    }

    #[test]
    fn bad_parameters_and_clouds_are_errors() {
        let scene = cloud::synth::sphere_plane_scene(100, 100, 2).0;
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let empty = PointCloud::default();
        for name in ["screenspace", "vardensity"] {
            for (k, v) in [
                ("threshold", "nan"),
                ("threshold", "2"),
                ("depth_tolerance", "-1"),
                ("width", "0"),
            ] {
                let params = Params::from_pairs(&[(k, v.into())]);
                let e = prepared(name, input, &params).expect_err("an error");
                assert!(
                    matches!(e, Error::Method(_) | Error::BadValue { .. }),
                    "{name} {k}={v}: {e}"
                );
            }
            let e = prepared(
                name,
                Input {
                    cloud: &empty,
                    mesh: None,
                },
                &Params::default(),
            )
            .expect_err("empty");
            assert!(matches!(e, Error::Cloud(cloud::Error::EmptyCloud)), "{e}");
        }
    }
}
