//! `vardensity`: Biasutti, Bugeau, Aujol, Brédif (VISAPP 2019), a depth-relative score over
//! a screen-space k-nearest neighbourhood that needs no density assumption
//! (`screenspace::biasutti`). Every camera model, the spherical equirectangular image of
//! mobile LiDAR included; per-pixel output (`Output::pixels`) and the score per point
//! (`Output::score`). No automatic rule beyond the paper's own design (the neighbourhood
//! adapts to the projected density by itself); see the method crate's doc on what of the
//! paper could be read.

use screenspace::BiasuttiParams;

use crate::error::Result;
use crate::screenspace::Prep;
use crate::{Input, Method, ParamSpec, Params, Prepared};

/// Biasutti et al.'s variable-density visibility.
pub struct VardensityMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "k",
        default: "8",
        help: "screen-space neighbours of each pixel",
    },
    ParamSpec {
        key: "max_radius",
        default: "32",
        help: "farthest neighbour searched, pixels",
    },
    ParamSpec {
        key: "threshold",
        default: "0.5",
        help: "minimum visibility score, in [0, 1]",
    },
    ParamSpec {
        key: "depth_tolerance",
        default: "0",
        help: "relative depth within which points sharing a kept pixel count visible (0: one point per pixel)",
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

impl Method for VardensityMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 x (the peak per point at 10^7 points less the cloud's 48): a scale cell of
        // the dragon at its default setting peaked at 688 MB.
        crate::Scale::PerPoint(26)
    }
    fn name(&self) -> &'static str {
        "vardensity"
    }

    fn summary(&self) -> &'static str {
        "variable-density screen-space visibility (Biasutti et al. 2019): depth score over k screen neighbours"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let d = BiasuttiParams::default();
        let p = BiasuttiParams {
            k: params.get("k", d.k)?,
            max_radius: params.get("max_radius", d.max_radius)?,
            threshold: params.get("threshold", d.threshold)?,
            depth_tolerance: params.get("depth_tolerance", d.depth_tolerance)?,
        };
        p.validate()?;
        Prep::boxed(input, params, p, screenspace::biasutti::visible)
    }
}

#[cfg(test)]
mod tests {
    //! Both screen-space methods through the registry: every camera model answers with a
    //! per-pixel image and a score, and bad parameters or clouds are errors.

    use cloud::glam::DVec3;
    use cloud::{Camera, Model, PointCloud};

    use crate::{Error, Input, Params};

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
            let m = crate::method(name).expect("registered");
            let params = Params::from_pairs(&[("depth_tolerance", "0.01".into())]);
            let input = Input {
                cloud: &scene.cloud,
                mesh: None,
            };
            let prepared = crate::kernel::prepare(m, input, &params).expect("prepare");
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
            let m = crate::method(name).expect("registered");
            for (k, v) in [
                ("threshold", "nan"),
                ("threshold", "2"),
                ("depth_tolerance", "-1"),
                ("width", "0"),
            ] {
                let params = Params::from_pairs(&[(k, v.into())]);
                let e = crate::kernel::prepare(m, input, &params)
                    .err()
                    .expect("an error");
                assert!(
                    matches!(e, Error::Screenspace(_) | Error::BadValue { .. }),
                    "{name} {k}={v}: {e}"
                );
            }
            let e = crate::kernel::prepare(
                m,
                Input {
                    cloud: &empty,
                    mesh: None,
                },
                &Params::default(),
            )
            .err()
            .expect("empty");
            assert!(matches!(e, Error::Cloud(cloud::Error::EmptyCloud)), "{e}");
        }
    }
}
