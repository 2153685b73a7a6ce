//! `raycast`: point filtering by ray casting (`raycast` crate, seed 001), one ray per pixel.
//!
//! `primitive=disc` (beyond the seed) makes every point an oriented disc of the same radius:
//! the cloud's normals, else the estimates external methods are sent
//! ([`crate::external::estimated_normals`]), so that it meets point-cloud-utils' surfels on
//! their own terms.

use std::sync::Mutex;

use crate::error::{Error, Result};
use cloud::Camera;
use raycast::{CastParams, Primitive, RayCaster, RayList, Traversal};

use crate::{
    Input, Method, Output, ParamSpec, Params, PixelChoice, Prepared, camera_with_resolution,
};

/// The ray caster.
pub struct RaycastMethod;

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "radius",
        default: "-",
        help: "point radius in world units (overrides radius_factor), or auto: raycast::auto's rule (1.5 density spacings)",
    },
    ParamSpec {
        key: "radius_factor",
        default: "1.5",
        help: "point radius in density spacings 1/sqrt(points per area) (raycast::auto)",
    },
    ParamSpec {
        key: "width",
        default: "view's",
        help: "rays across (one per pixel)",
    },
    ParamSpec {
        key: "height",
        default: "view's",
        help: "rays down",
    },
    ParamSpec {
        key: "traversal",
        default: "exact",
        help: "exact (nearest hit) or seed (S1..S9, first hit ends)",
    },
    ParamSpec {
        key: "primitive",
        default: "sphere",
        help: "sphere (seed 001) or disc: an oriented disc per point, the cloud's normals or estimated ones (exact traversal)",
    },
];

struct Prep {
    caster: RayCaster,
    radius: f64,
    traversal: Traversal,
    primitive: Primitive,
    width: Option<u32>,
    height: Option<u32>,
    rays: Mutex<Option<RayList>>,
    /// The k-d tree's build (with the normals attached), seconds.
    build_seconds: f64,
}

impl Prepared for Prep {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, self.width, self.height)?;
        let mut rays = self
            .rays
            .lock()
            .map_err(|_| Error::Unsupported("ray list poisoned".into()))?;
        // The ray list is built once per image size and field of view, then re-aimed.
        if rays.as_ref().is_none_or(|r| r.check(&camera).is_err()) {
            *rays = Some(RayList::new(&camera)?);
        }
        let rays = rays
            .as_ref()
            .ok_or_else(|| Error::Unsupported("no ray list".into()))?;
        let frame = self.caster.cast(
            rays,
            &camera,
            &CastParams {
                radius: self.radius,
                traversal: self.traversal,
                primitive: self.primitive,
            },
        )?;
        Ok(Output {
            visible: frame.visible,
            rays: frame.rays,
            pixels: Some(PixelChoice {
                width: camera.width,
                height: camera.height,
                point: frame.pixel_point,
            }),
            reported_seconds: None,
            detail: Vec::new(),
            score: None,
        })
    }

    fn reported_build_seconds(&self) -> Option<f64> {
        Some(self.build_seconds)
    }
}

/// The point radius the parameters ask for on `points`.
pub fn radius(points: &[cloud::glam::DVec3], params: &Params) -> Result<f64> {
    let factor: f64 = params.get("radius_factor", raycast::auto::RADIUS_FACTOR)?;
    let given: Option<String> = params.get_opt("radius")?;
    let factor = match given.as_deref() {
        Some("auto") => {
            if params.get_opt::<f64>("radius_factor")?.is_some() {
                return Err(Error::Unsupported(
                    "parameter radius=auto is raycast::auto's radius factor; drop radius_factor"
                        .into(),
                ));
            }
            raycast::auto::RADIUS_FACTOR
        }
        Some(_) => return params.get("radius", 0.0),
        None => factor,
    };
    Ok(factor * cloud::spacing::density_spacing(points, 8, 20_000, 1)?)
}

impl Method for RaycastMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
        crate::Scale::PerPoint(155)
    }
    fn name(&self) -> &'static str {
        "raycast"
    }

    fn summary(&self) -> &'static str {
        "ray-cast point filtering (Jensen 2012): one ray per pixel through a point k-d tree (seed 001)"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>> {
        let traversal = match params.get("traversal", "exact".to_owned())?.as_str() {
            "exact" => Traversal::Exact,
            "seed" => Traversal::Seed,
            other => {
                return Err(Error::BadValue {
                    key: "traversal".into(),
                    value: other.to_owned(),
                    reason: "expected exact or seed".into(),
                });
            }
        };
        let primitive = match params.get("primitive", "sphere".to_owned())?.as_str() {
            "sphere" => Primitive::Sphere,
            "disc" if traversal == Traversal::Exact => Primitive::Disc,
            "disc" => {
                return Err(Error::BadValue {
                    key: "primitive".into(),
                    value: "disc".into(),
                    reason: "discs take traversal=exact (the seed's S1..S9 tests spheres)".into(),
                });
            }
            other => {
                return Err(Error::BadValue {
                    key: "primitive".into(),
                    value: other.to_owned(),
                    reason: "expected sphere or disc".into(),
                });
            }
        };
        let positions = &input.cloud.positions;
        let normals = match primitive {
            // The normals an external disc caster is sent, so the pairing compares like with like.
            Primitive::Disc => Some(crate::external::cloud_normals(input.cloud)?.0),
            Primitive::Sphere => None,
        };
        // The structure's build alone (the normals and the density spacing are inputs an
        // external caster is sent too), as a peer reports its BVH's.
        let start = std::time::Instant::now();
        let mut caster = RayCaster::new(positions)?;
        if let Some(normals) = &normals {
            caster = caster.with_normals(normals)?;
        }
        let build_seconds = start.elapsed().as_secs_f64();
        Ok(Box::new(Prep {
            caster,
            radius: radius(positions, params)?,
            traversal,
            primitive,
            width: params.get_opt("width")?,
            height: params.get_opt("height")?,
            rays: Mutex::new(None),
            build_seconds,
        }))
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::synth::sphere_scene;

    use super::*;

    fn run(set: &[&str], normals: bool) -> Result<Output> {
        let mut scene = sphere_scene(4_000);
        if !normals {
            scene.cloud.normals = None;
        }
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let params = Params::parse(set)?;
        let camera = Camera::new(
            DVec3::new(0.3, 0.2, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            45.0,
            96,
            72,
        )?;
        crate::kernel::prepare(&RaycastMethod, input, &params)?.visible(&camera)
    }

    #[test]
    fn discs_run_with_the_clouds_normals_or_estimated_ones() {
        let spheres = run(&[], true).unwrap();
        let given = run(&["primitive=disc"], true).unwrap();
        let estimated = run(&["primitive=disc"], false).unwrap();
        for out in [&given, &estimated] {
            // A sphere seen from outside: discs and spheres see about the same points.
            let ratio = out.visible.len() as f64 / spheres.visible.len() as f64;
            assert!((0.7..1.3).contains(&ratio), "{ratio}");
        }
        assert_ne!(given.visible, spheres.visible);
    }

    #[test]
    fn bad_primitives_are_errors() {
        for (set, needle) in [
            (&["primitive=cube"][..], "sphere or disc"),
            (&["primitive=disc", "traversal=seed"], "traversal=exact"),
        ] {
            let err = run(set, true).unwrap_err().to_string();
            assert!(err.contains(needle), "{set:?}: {err}");
        }
    }
}
