//! Deterministic viewpoint sets around an object.
//!
//! View k of n looks at the centre c of the object's bounding box from
//! `eye_k = c + distance · d_k`, where d_k is the k-th point of a Fibonacci lattice on the unit
//! sphere with its pole on +z (view 0 is nearly frontal for models facing +z):
//! z_k = 1 − (2k + 1)/n, φ_k = k · π(3 − √5), d_k = (√(1 − z_k²) cos φ_k, √(1 − z_k²) sin φ_k, z_k).
//! The distance is `distance_factor` × the box diagonal; the vertical field of view is the angle
//! under which the bounding sphere of the box (radius = half the diagonal) is seen, times
//! `1 + margin`, so the whole object is inside the frustum of every view (the image is at least
//! as wide as it is tall). Up is +y, or +z when the view direction is within 1° of ±y.

use glam::DVec3;

use crate::bbox::Aabb;
use crate::camera::Camera;
use crate::error::{Error, Result};

/// How a viewpoint set is laid out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSpec {
    /// Number of views.
    pub n_views: usize,
    /// Eye distance from the box centre, in box diagonals.
    pub distance_factor: f64,
    /// Image width in pixels (≥ height).
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Relative margin added to the field of view.
    pub margin: f64,
}

impl Default for ViewSpec {
    fn default() -> Self {
        Self {
            n_views: 16,
            distance_factor: 1.5,
            width: 1280,
            height: 720,
            margin: 0.05,
        }
    }
}

/// The k-th of n unit directions of the Fibonacci lattice (pole on +z).
pub fn fibonacci_direction(k: usize, n: usize) -> DVec3 {
    let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = k as f64 * golden_angle;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The viewpoint set of `spec` around `bbox`.
pub fn fibonacci_views(bbox: &Aabb, spec: &ViewSpec) -> Result<Vec<Camera>> {
    let diagonal = bbox.diagonal();
    if !(diagonal > 0.0) {
        return Err(Error::InvalidParameter {
            name: "bbox",
            reason: "the object has zero extent".into(),
        });
    }
    if spec.n_views == 0 || !(spec.distance_factor > 0.5) || spec.width < spec.height {
        return Err(Error::InvalidParameter {
            name: "view spec",
            reason: format!(
                "need n_views > 0, distance_factor > 0.5 (eye outside the bounding sphere) and \
                 width >= height; got {spec:?}"
            ),
        });
    }
    let center = bbox.center();
    let distance = spec.distance_factor * diagonal;
    let half_angle = (0.5 * diagonal / distance).asin();
    let fov_y_deg = (2.0 * half_angle).to_degrees() * (1.0 + spec.margin);
    (0..spec.n_views)
        .map(|k| {
            let d = fibonacci_direction(k, spec.n_views);
            let up = if d.y.abs() > 1f64.to_radians().cos() {
                DVec3::Z
            } else {
                DVec3::Y
            };
            Camera::new(
                center + distance * d,
                center,
                up,
                fov_y_deg,
                spec.width,
                spec.height,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::fibonacci_sphere;

    #[test]
    fn whole_object_inside_every_view() {
        let bbox = Aabb {
            min: DVec3::new(-3.0, 10.0, 100.0),
            max: DVec3::new(1.0, 12.0, 101.0),
        };
        let views = fibonacci_views(&bbox, &ViewSpec::default()).unwrap();
        assert_eq!(views.len(), 16);
        for cam in &views {
            for i in 0..8 {
                let corner = DVec3::new(
                    if i & 1 == 0 { bbox.min.x } else { bbox.max.x },
                    if i & 2 == 0 { bbox.min.y } else { bbox.max.y },
                    if i & 4 == 0 { bbox.min.z } else { bbox.max.z },
                );
                let p = cam.project(corner).unwrap();
                assert!(p.pixel(cam.width, cam.height).is_some(), "{cam:?} {p:?}");
            }
        }
    }

    #[test]
    fn deterministic_and_spread() {
        let bbox = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        let a = fibonacci_views(&bbox, &ViewSpec::default()).unwrap();
        let b = fibonacci_views(&bbox, &ViewSpec::default()).unwrap();
        assert_eq!(a, b);
        let dirs = fibonacci_sphere(16);
        for (cam, d) in a.iter().zip(dirs) {
            assert!((cam.eye.normalize() - d).length() < 1e-12);
        }
    }
}
