//! `hpr-approx`: HPR over an approximate hull (`hpr::approx`, Machado e Silva et al. 2012 and
//! 2014): the transformed points' directions binned into `sectors` cells of a cube map around
//! the eye, the farthest per cell kept, the exact hull of those.
//!
//! `sectors=auto`: one cell per pixel, i.e. a cube-map edge of ⌈(π/2)·f⌉ cells for the camera's
//! focal length f in pixels (the angle of a pixel at the image centre; spherical cameras: the
//! equirectangular pixel), after the CGF paper's image-space framing. The kernel keys are
//! `hpr`'s (`gamma=auto` included).

use cloud::Camera;
use cloud::glam::DVec3;
use hpr::approx::{ApproxParams, visible};
use hull::ConvexHull;

use super::hpr::{
    GAMMA, HULL, KERNEL, KernelChoice, KernelRule, RADIUS, read_hull, read_kernel,
    refuse_orthographic,
};
use crate::card::{Card, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::params::{Param, Reader};
use crate::visibility::{Input, Method, Output, Prepared, Setup};

/// The card.
pub static CARD: Card = Card::new(
    "hpr-approx",
    "HPR over an approximate hull (Machado e Silva et al. 2012/2014): farthest flipped point per direction sector, hull of those",
    Kind::Visibility(&HprApprox),
    &[SECTORS, GAMMA, RADIUS, KERNEL, HULL],
    // 1.25 times the peak per point measured at 10^7 points, less the cloud's 48.
    Memory::PerPoint(59),
)
.with_parallel_views()
.with_made_for(Metric::Pixels);

const SECTORS: Param = Param::value(
    "sectors",
    "auto",
    "k, the cells of the direction cube map (rounded to 6 m^2), or auto: one per pixel of the view",
);

/// `sectors=auto` for `camera`: 6 m² with m = ⌈(π/2) / pixel angle⌉.
pub fn auto_sectors(camera: &Camera) -> u64 {
    let m = (std::f64::consts::FRAC_PI_2 * camera.focal_px())
        .ceil()
        .max(1.0) as u64;
    6 * m * m
}

/// The method.
struct HprApprox;

/// Its setting.
struct Args {
    kernel: KernelChoice,
    /// `None`: auto.
    sectors: Option<u64>,
    hull: Box<dyn ConvexHull>,
}

impl Method for HprApprox {
    fn parse(&self, r: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        let kernel = read_kernel(r)?;
        let text: String = r.get(&SECTORS)?;
        let sectors = match text.as_str() {
            "auto" => None,
            _ => {
                let k = text
                    .parse::<u64>()
                    .map_err(|e| r.bad(&SECTORS, &text, e.to_string()))?;
                hpr::approx::edge_for(k).map_err(Error::method)?;
                Some(k)
            }
        };
        Ok(Box::new(Args {
            kernel,
            sectors,
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
        refuse_orthographic("hpr-approx", camera)?;
        let mut detail = Vec::new();
        let kernel = self.kernel.for_view(self.points, camera.eye, &mut detail)?;
        let sectors = self.args.sectors.unwrap_or_else(|| auto_sectors(camera));
        let v = visible(
            self.points,
            camera.eye,
            &ApproxParams { kernel, sectors },
            self.args.hull.as_ref(),
        )
        .map_err(Error::method)?;
        detail.push(("sectors_used".to_owned(), v.sectors.to_string()));
        detail.push(("representatives".to_owned(), v.representatives.to_string()));
        Ok(Output {
            visible: v.visible,
            detail,
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

    fn camera(model: Model, w: u32, h: u32) -> Camera {
        Camera::look_at(
            DVec3::new(0.3, 0.2, 3.0),
            DVec3::ZERO,
            DVec3::Y,
            model,
            w,
            h,
        )
        .unwrap()
    }

    fn pinhole() -> Camera {
        camera(Model::pinhole_fov(50.0, 320, 240).unwrap(), 320, 240)
    }

    #[test]
    fn many_sectors_give_exact_hpr_and_few_give_fewer_points() {
        let scene = sphere_scene(3_000);
        let input = Input {
            cloud: &scene.cloud,
            mesh: None,
        };
        let (hpr, _) = super::super::hpr::CARD
            .setup(&Params::parse(&["gamma=2"]).unwrap())
            .unwrap();
        let exact = hpr.prepare(input).unwrap().visible(&pinhole()).unwrap();
        let fine = run(&["gamma=2", "sectors=600000000"], &pinhole()).unwrap();
        assert_eq!(fine.visible, exact.visible);
        let coarse = run(&["gamma=2", "sectors=600"], &pinhole()).unwrap();
        assert!(coarse.visible.len() * 2 < exact.visible.len());
        assert!(
            coarse
                .detail
                .iter()
                .any(|(k, v)| k == "sectors_used" && v == "600")
        );
    }

    #[test]
    fn auto_sectors_follow_the_pixel_angle_and_every_eye_camera_runs() {
        let small = pinhole();
        let big = camera(Model::pinhole_fov(50.0, 1280, 960).unwrap(), 1280, 960);
        assert!(auto_sectors(&big) > 10 * auto_sectors(&small));
        let sph = camera(Model::Spherical, 512, 256);
        for cam in [small, sph] {
            let out = run(&["gamma=auto"], &cam).unwrap();
            assert!(out.visible.len() > 500, "{}", out.visible.len());
            assert!(out.detail.iter().any(|(k, _)| k == "gamma_value"));
        }
        let ortho = camera(
            Model::Orthographic {
                view_width: 3.0,
                view_height: 3.0,
            },
            100,
            100,
        );
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
            (&["sectors=0"][..], "sectors"),
            (&["sectors=-3"], "sectors"),
            (&["sectors=lots"], "sectors"),
            (&["kernel=cubic"], "kernel=cubic"),
            (&["kernel=exp", "gamma=0.5"], "gamma"),
            (&["kernel=log", "radius=3"], "radius"),
            (&["gamma=NaN"], "gamma"),
            (&["perturb=0.01"], "perturb"),
        ] {
            let err = run(set, &cam).unwrap_err().to_string();
            assert!(err.contains(needle), "{set:?}: {err}");
        }
    }
}
