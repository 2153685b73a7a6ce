//! Choosing γ from the cloud alone (beyond the seeds: Katz et al. leave R to the user, seed 000
//! §6 sets it by hand).
//!
//! Why γ matters: flipping maps a point at distance d from the eye to distance 2R − d. A point
//! hidden a depth Δ behind a surface stays hidden only while it is below the chords between
//! that surface's flipped samples. Samples an angle δ apart (δ ≈ s/d for spacing s) have a
//! chord sag of about 2R·δ²/8 on the flipped sphere, so hidden points leak through when
//! R·s²/(4d²) > Δ, while a larger R keeps more truly visible points near silhouettes and in
//! concavities. The best R is therefore the largest that keeps the sag below the occlusion
//! depths of the object, R* = κ · T · d² / s² for a thickness scale T of the object, and
//!
//!   γ = log10(R* / max‖p − C‖) = log10(κ · D · d² / (s² · m)),
//!
//! with D the bounding-box diagonal (T ∝ D), d the eye's distance to the box centre, s the
//! spacing implied by the local density (`cloud::spacing::density_spacing`, k = 8: unlike the
//! nearest-neighbour distance it does not depend on whether the points are mesh vertices or
//! random samples) and m = max‖p − C‖.
//!
//! κ = 0.03 ([`KAPPA`]) was fitted on the synthetic torus and sphere-plane scenes: the centre of
//! the interval of log10 κ for which every view of both is within 0.02 of its best F1 over the
//! γ grid (−1.74 to −1.24, interpolating between grid points). The visibility experiment reports
//! how the rule does on every view of every dataset.

use cloud::glam::DVec3;

/// The rule's constant (see the module documentation).
pub const KAPPA: f64 = 0.03;

/// What the rule needs to know about a cloud (computed once per cloud).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudScale {
    /// Spacing implied by the density (1/sqrt(points per unit area)).
    pub spacing: f64,
    /// Bounding-box diagonal.
    pub diagonal: f64,
    /// Bounding-box centre.
    pub center: DVec3,
}

impl CloudScale {
    /// Measures `points` (density spacing from the 8 nearest neighbours, over a seeded sample
    /// of 20,000 points).
    pub fn of(points: &[DVec3]) -> cloud::Result<Self> {
        let bbox = cloud::Aabb::from_points(points).ok_or(cloud::Error::EmptyCloud)?;
        Ok(Self {
            spacing: cloud::spacing::density_spacing(points, 8, 20_000, 1)?,
            diagonal: bbox.diagonal(),
            center: bbox.center(),
        })
    }
}

/// Katz's γ for a view from `eye`, given the cloud's scale and the largest distance of a point
/// from the eye.
pub fn auto_gamma(scale: &CloudScale, eye: DVec3, max_distance: f64) -> f64 {
    let d = (eye - scale.center).length();
    let s = scale.spacing.max(f64::MIN_POSITIVE);
    (KAPPA * scale.diagonal * d * d / (s * s * max_distance)).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn denser_clouds_and_farther_eyes_get_larger_gamma() {
        let scale = CloudScale {
            spacing: 0.01,
            diagonal: 2.0,
            center: DVec3::ZERO,
        };
        let g = auto_gamma(&scale, DVec3::new(0.0, 0.0, 3.0), 4.0);
        let denser = CloudScale {
            spacing: 0.005,
            ..scale
        };
        assert!(
            (auto_gamma(&denser, DVec3::new(0.0, 0.0, 3.0), 4.0) - (g + 4f64.log10())).abs()
                < 1e-12
        );
        assert!(auto_gamma(&scale, DVec3::new(0.0, 0.0, 6.0), 7.0) > g);
    }
}
