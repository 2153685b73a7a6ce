//! The family of HPR transforms and the three properties a member must have, after Katz and
//! Tal, "On the Visibility of Point Clouds", ICCV 2015.
//!
//! Katz and Tal generalise spherical flipping to any transform that moves each point p (the
//! viewpoint at the origin) along its own ray to magnitude f(‖p‖; γ), p̂ = f(‖p‖; γ)·p/‖p‖,
//! and show (abstract; §3 of the paper) that three properties of the *kernel* f suffice for
//! the operator "p is visible iff p̂ is a vertex of conv(P̂ ∪ {C})" to be correct:
//! 1. **sign**: f(d; γ) > 0 on the distances of the cloud (p̂ stays on p's side of C);
//! 2. **monotonicity**: f(·; γ) is strictly decreasing (nearer points map farther out, so a
//!    point behind another on the same ray is inside the segment from C to the other's image);
//! 3. **the parameter condition**: as γ tends to its limit γ* the kernel's ratios tend to 1,
//!    lim f(d₁; γ)/f(d₂; γ) = 1 for all d₁, d₂ in the cloud's range (for spherical flipping,
//!    R → ∞; for the exponential kernel, γ → 0⁻), so the transformed cloud approaches a sphere
//!    about C and every visible point of a densely sampled surface ends on the hull.
//!
//! NOTE: we had the paper's abstract and first page but not the body; property 3 is written
//! here as we read it from the abstract and from the two kernels it names (linear, exponential),
//! for which the ratio form holds. Every kernel of [`Family`] satisfies all three, and
//! [`check`] verifies them numerically for any kernel given as a function (the tests also show
//! it rejecting kernels that break each one).
//!
//! Members beyond the paper's two ([`crate::transform`] implements all four):
//! - [`Family::Log`]: f(d) = ln(R/d), R = max‖p‖·10^γ, γ > 0, γ* = +∞ (ratio − 1 ∝ 1/γ, a slower
//!   approach than the linear kernel's ∝ 10^−γ);
//! - [`Family::ExpDecay`]: f(d) = exp(−γ·d/max‖p‖), γ > 0, γ* = 0⁺ (ratio − 1 ≤ e^γ − 1).
//!
//! Both are scale invariant (they depend on d/max‖p‖ only), like the exponential kernel.

use crate::transform::{EXP_DECAY_MAX, Kernel, Radius, log_magnitude};

/// A one-parameter family of kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// Spherical flipping, f(d) = 2R − d with R = max‖p‖·10^γ (Katz et al. 2007).
    Linear,
    /// f(d) = d^γ, γ < 0 (Katz and Tal 2015).
    Exponential,
    /// f(d) = ln(R/d), R = max‖p‖·10^γ, γ > 0 (ours).
    Log,
    /// f(d) = exp(−γ·d/max‖p‖), γ > 0 (ours).
    ExpDecay,
}

/// Every family, in listing order.
pub const FAMILIES: &[Family] = &[
    Family::Linear,
    Family::Exponential,
    Family::Log,
    Family::ExpDecay,
];

impl Family {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Family::Linear => "linear",
            Family::Exponential => "exp",
            Family::Log => "log",
            Family::ExpDecay => "expdecay",
        }
    }

    /// The family called `name`.
    pub fn by_name(name: &str) -> Option<Family> {
        FAMILIES.iter().copied().find(|f| f.name() == name)
    }

    /// The kernel of parameter `gamma`.
    pub fn kernel(self, gamma: f64) -> Kernel {
        match self {
            Family::Linear => Kernel::Linear(Radius::Gamma(gamma)),
            Family::Exponential => Kernel::Exponential(gamma),
            Family::Log => Kernel::Log(gamma),
            Family::ExpDecay => Kernel::ExpDecay(gamma),
        }
    }

    /// True when `gamma` is a valid parameter.
    pub fn valid(self, gamma: f64) -> bool {
        gamma.is_finite()
            && match self {
                Family::Linear => gamma > 0.0,
                Family::Exponential => gamma < 0.0,
                Family::Log => gamma > 0.0,
                Family::ExpDecay => gamma > 0.0 && gamma < EXP_DECAY_MAX,
            }
    }

    /// f(d; γ) for a cloud whose farthest point is at `max_distance` (the magnitude
    /// [`crate::transform::transform`] gives a point at distance d).
    pub fn magnitude(self, gamma: f64, d: f64, max_distance: f64) -> f64 {
        match self {
            Family::Linear => 2.0 * max_distance * 10f64.powf(gamma) - d,
            Family::Exponential => d.powf(gamma),
            Family::Log => log_magnitude(gamma, d, max_distance),
            Family::ExpDecay => (-gamma * d / max_distance).exp(),
        }
    }

    /// Whether moving γ up moves it toward the limit of property 3.
    pub fn limit_is_up(self) -> bool {
        match self {
            Family::Linear | Family::Log | Family::Exponential => true,
            Family::ExpDecay => false,
        }
    }

    /// A sequence of valid parameters approaching the limit of property 3 (for [`check`]).
    pub fn toward_limit(self) -> Vec<f64> {
        match self {
            Family::Linear => (0..=6).map(|g| f64::from(g) + 0.5).collect(),
            Family::Exponential => (0..=10).map(|j| -(10f64.powi(-j))).collect(),
            Family::Log => (0..=8).map(|j| 10f64.powi(j)).collect(),
            Family::ExpDecay => (0..=10).map(|j| 10f64.powi(1 - j)).collect(),
        }
    }
}

/// Which property failed, and where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Violation {
    /// Property 1: f(d; γ) ≤ 0 (or not finite).
    #[error("property 1 (sign): f({d}; {gamma}) = {value} is not positive")]
    Sign {
        /// Parameter.
        gamma: f64,
        /// Distance.
        d: f64,
        /// f there.
        value: f64,
    },
    /// Property 2: f(d₁) ≤ f(d₂) for d₁ < d₂.
    #[error("property 2 (monotonicity): f({d1}; {gamma}) <= f({d2}; {gamma}) with {d1} < {d2}")]
    Monotone {
        /// Parameter.
        gamma: f64,
        /// The nearer distance.
        d1: f64,
        /// The farther distance.
        d2: f64,
    },
    /// Property 3: the spread max f / min f − 1 does not go to 0 along the sequence.
    #[error(
        "property 3 (parameter): the kernel's ratio spread is {spread} at the last parameter {gamma} (needs < {tolerance}, shrinking)"
    )]
    Limit {
        /// The last parameter.
        gamma: f64,
        /// Its spread.
        spread: f64,
        /// The bound it had to meet.
        tolerance: f64,
    },
}

/// Checks the three properties for a kernel `f(γ, d)` on the distances `distances` (any
/// order; a cloud's distances from its viewpoint) at every parameter of `gammas`, a sequence
/// that approaches the limit of property 3: f positive, strictly decreasing in d, and the
/// spread max_d f / min_d f − 1 non-increasing along `gammas` and below `tolerance` at the end.
pub fn check(
    f: impl Fn(f64, f64) -> f64,
    distances: &[f64],
    gammas: &[f64],
    tolerance: f64,
) -> Result<(), Violation> {
    let mut d: Vec<f64> = distances.to_vec();
    d.sort_by(f64::total_cmp);
    d.dedup();
    let mut last_spread = f64::INFINITY;
    for &gamma in gammas {
        let values: Vec<f64> = d.iter().map(|&x| f(gamma, x)).collect();
        for (&x, &value) in d.iter().zip(&values) {
            if !(value > 0.0) || !value.is_finite() {
                return Err(Violation::Sign { gamma, d: x, value });
            }
        }
        for i in 1..d.len() {
            if !(values[i - 1] > values[i]) {
                return Err(Violation::Monotone {
                    gamma,
                    d1: d[i - 1],
                    d2: d[i],
                });
            }
        }
        let (lo, hi) = values.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
        let spread = hi / lo - 1.0;
        // Rounding may stall the spread at its floor: allow a relative 1e-9 of slack.
        if spread > last_spread * (1.0 + 1e-9) + 1e-15 {
            return Err(Violation::Limit {
                gamma,
                spread,
                tolerance,
            });
        }
        last_spread = spread;
    }
    match gammas.last() {
        Some(&gamma) if !(last_spread < tolerance) => Err(Violation::Limit {
            gamma,
            spread: last_spread,
            tolerance,
        }),
        _ => Ok(()),
    }
}

/// [`check`] for a member of [`Family`] on distances up to `max_distance`.
pub fn check_family(
    family: Family,
    distances: &[f64],
    max_distance: f64,
    tolerance: f64,
) -> Result<(), Violation> {
    check(
        |g, d| family.magnitude(g, d, max_distance),
        distances,
        &family.toward_limit(),
        tolerance,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distances from 10⁻³·m to m, geometrically spaced, and m = 7.
    fn distances() -> (Vec<f64>, f64) {
        let m = 7.0;
        (
            (0..=60)
                .map(|i| m * 10f64.powf(-3.0 * i as f64 / 60.0))
                .collect(),
            m,
        )
    }

    #[test]
    fn every_family_has_the_three_properties() {
        let (d, m) = distances();
        for &family in FAMILIES {
            assert_eq!(check_family(family, &d, m, 1e-6), Ok(()), "{family:?}");
            for g in family.toward_limit() {
                assert!(family.valid(g), "{family:?} {g}");
            }
            assert_eq!(Family::by_name(family.name()), Some(family));
        }
    }

    #[test]
    fn the_magnitudes_are_the_transforms() {
        use cloud::glam::DVec3;
        let pts = [DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 5.0, 0.0)];
        for (family, gamma) in [
            (Family::Linear, 1.3),
            (Family::Exponential, -0.2),
            (Family::Log, 0.7),
            (Family::ExpDecay, 3.0),
        ] {
            let t = crate::transform::transform(&pts, DVec3::ZERO, family.kernel(gamma)).unwrap();
            let expect = family.magnitude(gamma, 2.0, 5.0);
            assert!(
                (t.points[0][2] - expect).abs() <= 1e-12 * expect,
                "{family:?}"
            );
            let expect = family.magnitude(gamma, 5.0, 5.0);
            assert!(
                (t.points[1][1] - expect).abs() <= 1e-12 * expect,
                "{family:?}"
            );
        }
    }

    #[test]
    fn kernels_that_break_a_property_are_caught() {
        let (d, m) = distances();
        // Sign: spherical flipping with R < max‖p‖ (γ < 0 in Katz's parameterisation).
        let sign = check(|g, d| Family::Linear.magnitude(g, d, m), &d, &[-0.5], 1e-6);
        assert!(matches!(sign, Err(Violation::Sign { .. })), "{sign:?}");
        // Monotonicity: an increasing kernel (the identity) and a non-monotone one.
        let id = check(|_, d| d, &d, &[1.0], 1e-6);
        assert!(matches!(id, Err(Violation::Monotone { .. })), "{id:?}");
        let bump = check(|g, d| 1.0 + g * (d - m / 2.0).powi(2), &d, &[1.0], 1e-6);
        assert!(matches!(bump, Err(Violation::Monotone { .. })), "{bump:?}");
        // The parameter condition: d^γ with γ moving away from 0, and a kernel whose ratio
        // never depends on the parameter (c/d).
        let away: Vec<f64> = (0..5).map(|j| -(10f64.powi(j - 4))).collect();
        let exp_away = check(|g, d| d.powf(g), &d, &away, 1e-6);
        assert!(
            matches!(exp_away, Err(Violation::Limit { .. })),
            "{exp_away:?}"
        );
        let fixed = check(|g, d| g / d, &d, &[1.0, 10.0, 100.0], 1e-6);
        assert!(matches!(fixed, Err(Violation::Limit { .. })), "{fixed:?}");
    }
}
