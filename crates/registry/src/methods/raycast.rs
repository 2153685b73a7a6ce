//! `raycast`: point filtering by ray casting (`raycast` crate, seed 001), one ray per pixel.
//!
//! `primitive=disc` (beyond the seed) makes every point an oriented disc of the same radius:
//! the cloud's normals, else the estimates external methods are sent
//! ([`super::external::points::cloud_normals`]), so that it meets point-cloud-utils' surfels on
//! their own terms.

use std::sync::Mutex;

use cloud::Camera;
use raycast::{CastParams, Primitive, RayCaster, RayList, Traversal};

use super::external::points::cloud_normals;
use crate::card::{Card, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{
    Input, Method, Output, PixelChoice, Prepared, Setup, camera_with_resolution,
};

/// The card.
pub static CARD: Card = Card::new(
    "raycast",
    "ray-cast point filtering (Jensen 2012): one ray per pixel through a point hierarchy (a bucketed BVH cast in 8x8 packets, or the seed's k-d tree; seed 001)",
    Kind::Visibility(&Raycast),
    &[RADIUS, RADIUS_FACTOR, WIDTH, HEIGHT, TRAVERSAL, PRIMITIVE],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(155),
)
.with_made_for(Metric::Pixels);

const RADIUS: Param = Param::value(
    "radius",
    "auto",
    "point radius in world units (overrides radius_factor), or auto: raycast::auto's rule (1.5 density spacings)",
);
const RADIUS_FACTOR: Param = Param::rule(
    "radius_factor",
    "auto's",
    "point radius in density spacings 1/sqrt(points per area) (raycast::auto), in place of radius",
);
const WIDTH: Param = Param::value(
    "width",
    "1280",
    "rays across (one per pixel; a view of another size is resampled, its vertical field kept)",
);
const HEIGHT: Param = Param::value("height", "720", "rays down");
const TRAVERSAL: Param = Param::implied(
    "traversal",
    "exact",
    "exact (nearest hit) or seed (S1..S9, first hit ends)",
);
const PRIMITIVE: Param = Param::implied(
    "primitive",
    "sphere",
    "sphere (seed 001) or disc: an oriented disc per point, the cloud's normals or estimated ones (exact traversal)",
);

/// The method.
struct Raycast;

/// The point radius: world units, or density spacings.
#[derive(Clone, Copy)]
enum RadiusRule {
    Absolute(f64),
    Spacings(f64),
}

/// Its setting.
struct Args {
    radius: RadiusRule,
    traversal: Traversal,
    primitive: Primitive,
    width: u32,
    height: u32,
}

impl Method for Raycast {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let factor: Option<f64> = r.given(&RADIUS_FACTOR)?;
        let radius = match (r.given_text(&RADIUS)?, factor) {
            (Some(auto), Some(_)) if auto == "auto" => {
                return Err(r.bad(
                    &RADIUS,
                    auto,
                    "is raycast::auto's radius factor; leave radius_factor out",
                ));
            }
            (Some(text), _) if text != "auto" => RadiusRule::Absolute(
                text.parse::<f64>()
                    .map_err(|e| r.bad(&RADIUS, &text, e.to_string()))?,
            ),
            (None, Some(f)) => RadiusRule::Spacings(f),
            // Auto, given or by default.
            _ => {
                r.text(&RADIUS)?;
                RadiusRule::Spacings(raycast::auto::RADIUS_FACTOR)
            }
        };
        let traversal = match r.get::<String>(&TRAVERSAL)?.as_str() {
            "exact" => Traversal::Exact,
            "seed" => Traversal::Seed,
            other => return Err(r.bad(&TRAVERSAL, other, "expected exact or seed")),
        };
        let primitive = match r.get::<String>(&PRIMITIVE)?.as_str() {
            "sphere" => Primitive::Sphere,
            "disc" if traversal == Traversal::Exact => Primitive::Disc,
            "disc" => {
                return Err(r.bad(
                    &PRIMITIVE,
                    "disc",
                    "discs take traversal=exact (the seed's S1..S9 tests spheres)",
                ));
            }
            other => return Err(r.bad(&PRIMITIVE, other, "expected sphere or disc")),
        };
        Ok(Box::new(Args {
            radius,
            traversal,
            primitive,
            width: r.get(&WIDTH)?,
            height: r.get(&HEIGHT)?,
        }))
    }
}

impl Setup for Args {
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
        let positions = &input.cloud.positions;
        let normals = match self.primitive {
            // The normals an external disc caster is sent, so the pairing compares like with like.
            Primitive::Disc => Some(cloud_normals(input.cloud)?.0),
            Primitive::Sphere => None,
        };
        // The structure's build alone (the normals and the density spacing are inputs an
        // external caster is sent too), as a peer reports its BVH's.
        let start = std::time::Instant::now();
        let mut caster = RayCaster::new(positions).map_err(Error::method)?;
        if let Some(normals) = &normals {
            caster = caster.with_normals(normals).map_err(Error::method)?;
        }
        if self.traversal == Traversal::Seed {
            // The seed traversal's k-d tree, otherwise built by the first view.
            caster.tree();
        }
        let build_seconds = start.elapsed().as_secs_f64();
        let radius = match self.radius {
            RadiusRule::Absolute(r) => r,
            RadiusRule::Spacings(f) => {
                f * cloud::spacing::density_spacing(positions, 8, 20_000, 1)?
            }
        };
        Ok(Box::new(Prep {
            caster,
            radius,
            args: self,
            rays: Mutex::new(None),
            build_seconds,
        }))
    }
}

struct Prep<'a> {
    caster: RayCaster,
    radius: f64,
    args: &'a Args,
    rays: Mutex<Option<RayList>>,
    /// The caster's build (its hierarchy with the normals attached; with `traversal=seed`, the
    /// seed's k-d tree too), seconds.
    build_seconds: f64,
}

impl Prepared for Prep<'_> {
    fn visible(&self, camera: &Camera) -> Result<Output> {
        let camera = camera_with_resolution(camera, Some(self.args.width), Some(self.args.height))?;
        let mut rays = self
            .rays
            .lock()
            .map_err(|_| Error::Unsupported("ray list poisoned".into()))?;
        // The ray list is built once per image size and field of view, then re-aimed.
        if rays.as_ref().is_none_or(|r| r.check(&camera).is_err()) {
            *rays = Some(RayList::new(&camera).map_err(Error::method)?);
        }
        let rays = rays
            .as_ref()
            .ok_or_else(|| Error::Unsupported("no ray list".into()))?;
        let frame = self
            .caster
            .cast(
                rays,
                &camera,
                &CastParams {
                    radius: self.radius,
                    traversal: self.args.traversal,
                    primitive: self.args.primitive,
                },
            )
            .map_err(Error::method)?;
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

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::synth::sphere_scene;

    use super::*;
    use crate::params::Params;

    fn run(set: &[&str], normals: bool) -> Result<Output> {
        let mut scene = sphere_scene(4_000);
        if !normals {
            scene.cloud.normals = None;
        }
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let (setup, _) = CARD.setup(&Params::parse(set)?)?;
        let camera = Camera::new(
            DVec3::new(0.3, 0.2, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            45.0,
            96,
            72,
        )?;
        setup.prepare(input)?.visible(&camera)
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
