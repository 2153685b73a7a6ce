//! The HPR transforms and the perturbation of seed 000 §4.
//!
//! Both kernels move each point along its ray from the viewpoint C (the origin after
//! translation) to magnitude f(‖p‖), f decreasing:
//! - linear (spherical flipping, Katz et al. 2007 §3, seed 000 §3.1): f(d) = 2R − d, which is
//!   p̂ = p + 2(R − ‖p‖)·p/‖p‖. R > max‖p‖ is required;
//! - exponential (Katz and Tal 2015): f(d) = d^γ with γ < 0; scale invariant;
//! - logarithmic (ours, a member of Katz and Tal's family, [`crate::properties`]):
//!   f(d) = ln(R/d) with R = max‖p‖·10^γ, γ > 0; scale invariant;
//! - exponential decay (ours, likewise): f(d) = exp(−γ·d/max‖p‖), γ > 0; scale invariant.
//!
//! [`crate::properties`] checks all four against Katz and Tal's three properties.
//!
//! The output keeps the input order and appends the viewpoint (the origin) last.

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use rayon::prelude::*;

use crate::HprError;

/// How the flipping radius is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Radius {
    /// R itself (Open3D's convention: R absolute, e.g. 100 × the diameter).
    Absolute(f64),
    /// Katz's parameterisation: R = max‖p − C‖ · 10^γ.
    Gamma(f64),
}

/// The transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// Spherical flipping with radius R.
    Linear(Radius),
    /// Exponential kernel with exponent γ < 0.
    Exponential(f64),
    /// Logarithmic kernel f(d) = ln(R/d), R = max‖p‖ · 10^γ, γ > 0 (limit γ → ∞).
    Log(f64),
    /// Exponential-decay kernel f(d) = exp(−γ·d/max‖p‖), 0 < γ < 700 (limit γ → 0).
    ExpDecay(f64),
}

/// The largest γ of [`Kernel::ExpDecay`]: beyond it exp(−γ) nears the smallest normal double.
pub const EXP_DECAY_MAX: f64 = 700.0;

/// Transformed points: input order, the viewpoint (origin) appended last.
#[derive(Debug, Clone, PartialEq)]
pub struct Transformed {
    /// n + 1 points, the last one the origin.
    pub points: Vec<[f64; 3]>,
    /// The transform's scale: R for the linear kernel, the largest magnitude for the
    /// exponential one. The perturbation is relative to it.
    pub scale: f64,
    /// The largest distance of an input point from the viewpoint.
    pub max_distance: f64,
}

/// Translates to the viewpoint and applies `kernel`.
pub fn transform(points: &[DVec3], eye: DVec3, kernel: Kernel) -> Result<Transformed, HprError> {
    if points.is_empty() {
        return Err(HprError::EmptyCloud);
    }
    if !eye.is_finite() {
        return Err(HprError::NonFinite(None));
    }
    // One pass for the checks and the distance range: (min, max, first bad index, its kind).
    let (min_distance, max_distance, bad) = points
        .par_iter()
        .enumerate()
        .fold(
            || (f64::INFINITY, 0.0f64, None::<(usize, bool)>),
            |(lo, hi, bad), (i, &p)| {
                let d = (p - eye).length();
                let this = if !p.is_finite() {
                    Some((i, true))
                } else if p == eye {
                    Some((i, false))
                } else {
                    None
                };
                let bad = match (bad, this) {
                    (Some(b), Some(t)) => Some(if t.0 < b.0 { t } else { b }),
                    (b, t) => b.or(t),
                };
                (lo.min(d), hi.max(d), bad)
            },
        )
        .reduce(
            || (f64::INFINITY, 0.0, None),
            |a, b| {
                let bad = match (a.2, b.2) {
                    (Some(x), Some(y)) => Some(if x.0 < y.0 { x } else { y }),
                    (x, y) => x.or(y),
                };
                (a.0.min(b.0), a.1.max(b.1), bad)
            },
        );
    match bad {
        Some((i, true)) => return Err(HprError::NonFinite(Some(i))),
        Some((i, false)) => return Err(HprError::EyeOnPoint(i)),
        None => {}
    }
    let mut out: Vec<[f64; 3]> = match kernel {
        Kernel::Linear(radius) => {
            let r = match radius {
                Radius::Absolute(r) => r,
                Radius::Gamma(g) => {
                    if !g.is_finite() {
                        return Err(HprError::InvalidParameter {
                            name: "gamma",
                            reason: format!("must be finite, got {g}"),
                        });
                    }
                    max_distance * 10f64.powf(g)
                }
            };
            if !(r > max_distance) || !r.is_finite() {
                return Err(HprError::RadiusTooSmall {
                    radius: r,
                    max_distance,
                });
            }
            flip_all(points, eye, |d| 2.0 * r - d)
        }
        Kernel::Exponential(g) => {
            if !(g < 0.0) || !g.is_finite() {
                return Err(HprError::InvalidParameter {
                    name: "gamma",
                    reason: format!("the exponential kernel needs gamma < 0, got {g}"),
                });
            }
            flip_all(points, eye, |d| d.powf(g))
        }
        Kernel::Log(g) => {
            if !(g > 0.0) || !g.is_finite() {
                return Err(HprError::InvalidParameter {
                    name: "gamma",
                    reason: format!("the log kernel needs gamma > 0, got {g}"),
                });
            }
            flip_all(points, eye, |d| log_magnitude(g, d, max_distance))
        }
        Kernel::ExpDecay(g) => {
            if !(g > 0.0 && g < EXP_DECAY_MAX) {
                return Err(HprError::InvalidParameter {
                    name: "gamma",
                    reason: format!(
                        "the expdecay kernel needs 0 < gamma < {EXP_DECAY_MAX}, got {g}"
                    ),
                });
            }
            flip_all(points, eye, |d| (-g * d / max_distance).exp())
        }
    };
    let scale = match kernel {
        Kernel::Linear(Radius::Absolute(r)) => r,
        Kernel::Linear(Radius::Gamma(g)) => max_distance * 10f64.powf(g),
        Kernel::Exponential(g) => min_distance.powf(g),
        Kernel::Log(g) => log_magnitude(g, min_distance, max_distance),
        Kernel::ExpDecay(g) => (-g * min_distance / max_distance).exp(),
    };
    out.push([0.0; 3]);
    Ok(Transformed {
        points: out,
        scale,
        max_distance,
    })
}

/// ln(R/d) with R = m·10^γ, written as γ·ln 10 + ln(m/d) so that no 10^γ overflows.
pub(crate) fn log_magnitude(gamma: f64, d: f64, max_distance: f64) -> f64 {
    gamma * std::f64::consts::LN_10 + (max_distance / d).ln()
}

/// Moves every point to magnitude `f(‖p − eye‖)` along its ray from the eye.
fn flip_all(points: &[DVec3], eye: DVec3, f: impl Fn(f64) -> f64 + Sync) -> Vec<[f64; 3]> {
    points
        .par_iter()
        .map(|&p| {
            let v = p - eye;
            let d = v.length();
            (v * (f(d) / d)).to_array()
        })
        .collect()
}

/// Points per independently seeded block of the perturbation (the noise does not depend on
/// the number of threads).
const BLOCK: usize = 4096;

/// Adds uniform noise in [−k·scale, k·scale] to each coordinate of every transformed point
/// (not to the viewpoint), reproducibly from `seed`.
pub fn perturb(mut t: Transformed, k: f64, seed: u64) -> Result<Transformed, HprError> {
    if !(k >= 0.0) || !k.is_finite() {
        return Err(HprError::InvalidParameter {
            name: "perturb",
            reason: format!("must be >= 0, got {k}"),
        });
    }
    let amplitude = k * t.scale;
    let n = t.points.len() - 1;
    t.points[..n]
        .par_chunks_mut(BLOCK)
        .enumerate()
        .for_each(|(block, chunk)| {
            let mut rng = seeded(seed.wrapping_add(block as u64), "hpr-perturb");
            for p in chunk {
                for c in p.iter_mut() {
                    *c += amplitude * (2.0 * rng.random::<f64>() - 1.0);
                }
            }
        });
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spherical_flipping_formula() {
        let eye = DVec3::new(1.0, 2.0, 3.0);
        let p = eye + DVec3::new(3.0, 4.0, 0.0);
        let t = transform(&[p], eye, Kernel::Linear(Radius::Absolute(10.0))).unwrap();
        // p̂ = p + 2(R − ‖p‖) p/‖p‖ with ‖p‖ = 5: magnitude 15 along (0.6, 0.8, 0).
        assert_eq!(t.points[0], [9.0, 12.0, 0.0]);
        assert_eq!(t.points[1], [0.0; 3]);
        assert_eq!(t.scale, 10.0);
    }

    #[test]
    fn gamma_radius_and_exponential_kernel() {
        let pts = [DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 4.0, 0.0)];
        let t = transform(&pts, DVec3::ZERO, Kernel::Linear(Radius::Gamma(2.0))).unwrap();
        assert_eq!(t.scale, 400.0);
        assert_eq!(t.points[0], [0.0, 0.0, 798.0]);
        let e = transform(&pts, DVec3::ZERO, Kernel::Exponential(-1.0)).unwrap();
        assert_eq!(e.points[0], [0.0, 0.0, 0.5]);
        assert_eq!(e.points[1], [0.0, 0.25, 0.0]);
        assert_eq!(e.scale, 0.5);
        assert!(transform(&pts, DVec3::ZERO, Kernel::Exponential(0.5)).is_err());
        // Log: ln(4·10/d): d = 2 → ln 20, d = 4 → ln 10.
        let l = transform(&pts, DVec3::ZERO, Kernel::Log(1.0)).unwrap();
        assert!((l.points[0][2] - 20f64.ln()).abs() < 1e-12);
        assert!((l.points[1][1] - 10f64.ln()).abs() < 1e-12);
        // Exp-decay: exp(−2·d/4): d = 2 → e^−1, d = 4 → e^−2.
        let x = transform(&pts, DVec3::ZERO, Kernel::ExpDecay(2.0)).unwrap();
        assert!((x.points[0][2] - (-1f64).exp()).abs() < 1e-15);
        assert!((x.points[1][1] - (-2f64).exp()).abs() < 1e-15);
        for bad in [
            Kernel::Log(0.0),
            Kernel::Log(f64::NAN),
            Kernel::ExpDecay(0.0),
            Kernel::ExpDecay(EXP_DECAY_MAX),
            Kernel::ExpDecay(f64::NAN),
        ] {
            assert!(
                matches!(
                    transform(&pts, DVec3::ZERO, bad),
                    Err(HprError::InvalidParameter { name: "gamma", .. })
                ),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn perturbation_is_bounded_seeded_and_leaves_the_eye() {
        let pts: Vec<DVec3> = (1..10_000)
            .map(|i| DVec3::new(i as f64, 1.0, 2.0))
            .collect();
        let t = transform(&pts, DVec3::ZERO, Kernel::Linear(Radius::Gamma(1.0))).unwrap();
        let a = perturb(t.clone(), 0.01, 5).unwrap();
        let b = perturb(t.clone(), 0.01, 5).unwrap();
        let c = perturb(t.clone(), 0.01, 6).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.points, c.points);
        assert_eq!(*a.points.last().unwrap(), [0.0; 3]);
        let bound = 0.01 * t.scale;
        for (p, q) in a.points.iter().zip(&t.points) {
            for k in 0..3 {
                assert!((p[k] - q[k]).abs() <= bound);
            }
        }
    }
}
