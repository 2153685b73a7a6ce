//! A texture parameterisation for clouds without texture coordinates.
//!
//! Seed 003 assumes textured models. The meshes of our data sets (bunny, dragon, armadillo)
//! carry no texture coordinates, so a cloud gets them from a spherical projection about a
//! centre: u = longitude / 2π (about the y axis), v = colatitude / π. This is a deliberate,
//! documented stand-in, not the paper's parameterisation: it is continuous except on the seam
//! u = 0 and stretched near the poles, which only changes where the texture's features land.

use cloud::glam::{DVec3, Vec2};

/// Spherical texture coordinates of `positions` about `center` (u around y, v from +y down).
pub fn spherical_uvs(positions: &[DVec3], center: DVec3) -> Vec<Vec2> {
    positions
        .iter()
        .map(|&p| {
            let d = p - center;
            let r = d.length();
            if r == 0.0 {
                return Vec2::new(0.5, 0.5);
            }
            let u = 0.5 + d.z.atan2(d.x) / std::f64::consts::TAU;
            let v = 1.0 - (d.y / r).clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
            Vec2::new(u as f32, v as f32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poles_equator_and_centre() {
        let uv = spherical_uvs(
            &[
                DVec3::new(0.0, 2.0, 0.0),
                DVec3::new(0.0, -2.0, 0.0),
                DVec3::new(-1.0, 0.0, 0.0),
                DVec3::ZERO,
            ],
            DVec3::ZERO,
        );
        assert!((uv[0].y - 1.0).abs() < 1e-6 && uv[1].y.abs() < 1e-6);
        assert!((uv[2].y - 0.5).abs() < 1e-6);
        assert!(uv[2].x == 1.0 || uv[2].x.abs() < 1e-6);
        assert_eq!(uv[3], Vec2::new(0.5, 0.5));
        assert!(
            uv.iter()
                .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y))
        );
    }
}
