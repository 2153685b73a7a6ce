//! `hpr`: the Hidden Point Removal operator of Katz, Tal and Basri ("Direct Visibility of
//! Point Sets", SIGGRAPH 2007) as studied for real time in seed 000.
//!
//! Given points P and a viewpoint C, HPR (seed 000 §3, §6):
//! 1. translates so that C is the origin and transforms every point p along its ray from C
//!    ([`transform`]): *spherical flipping* (§3.1) p̂ = p + 2(R − ‖p‖) p/‖p‖, i.e. the
//!    linear kernel of Katz and Tal ("On the visibility of point clouds", ICCV 2015) with
//!    magnitude 2R − ‖p‖; or their *exponential kernel*, magnitude ‖p‖^γ with γ < 0, which is
//!    scale invariant;
//! 2. optionally perturbs the transformed points (seed 000 §4): uniform noise in [−k·R, k·R]
//!    on each coordinate, seeded, k = 0.01 in the paper;
//! 3. computes the convex hull of the transformed points plus C itself (§3.2: without C,
//!    points on the back of the object may lie on the hull) with any [`hull::ConvexHull`];
//! 4. maps back (§6 step 3): the transformed array keeps the input order and C is appended
//!    last, so the visible points are the hull vertices other than C, by index.
//!
//! The radius R is absolute, or Katz's parameterisation R = max‖p − C‖ · 10^γ ([`Radius`]).
//! R ≤ max‖p − C‖, a viewpoint on a point, an empty cloud and non-finite input are errors.
//! Coincident input points flip to coincident points, so all of them lie on the hull when one
//! does; a hull reports one index of each such group (the lowest, with `own`), and the mapping
//! step adds the others ([`with_duplicates`]): every copy of a visible point is visible, as
//! Katz's criterion (p̂ on the hull) says. (With a perturbation the copies are moved apart and
//! each is classified on its own.) A hull that knows its input has no coincident points
//! ([`ConvexHull::vertices_distinct`]: `own` does) spares that step.
//!
//! Beyond seed 000: [`properties`] (Katz and Tal 2015's three properties of a kernel, two
//! more kernels that have them), [`confidence`] (their visibility-confidence score) and
//! [`approx`] (HPR over an approximate hull, Machado e Silva et al. 2012/2014).
//!
//! Seed 000 §5's front/back buffer with an auxiliary thread is the reusable
//! [`cloud::double_buffer::DoubleBuffer`] (the ray caster uses it too); [`background`] runs HPR
//! in it.

pub mod approx;
pub mod auto;
pub mod background;
pub mod confidence;
pub mod properties;
pub mod transform;

use std::time::Instant;

use cloud::glam::DVec3;
use hull::{ConvexHull, HullError};

pub use transform::{Kernel, Radius, Transformed};

/// Why HPR could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HprError {
    /// No points.
    #[error("the point cloud is empty")]
    EmptyCloud,
    /// A non-finite coordinate (point index, or the viewpoint when `None`).
    #[error("non-finite coordinate in {}", .0.map_or("the viewpoint".to_owned(), |i| format!("point {i}")))]
    NonFinite(Option<usize>),
    /// The viewpoint coincides with a point.
    #[error("the viewpoint coincides with point {0}: its direction is undefined")]
    EyeOnPoint(usize),
    /// The flipping sphere does not contain every point.
    #[error(
        "radius {radius} does not exceed the farthest point's distance {max_distance}: spherical flipping needs R > max ‖p − C‖"
    )]
    RadiusTooSmall {
        /// The radius asked for.
        radius: f64,
        /// The farthest point's distance from the viewpoint.
        max_distance: f64,
    },
    /// A parameter is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The hull failed.
    #[error("convex hull: {0}")]
    Hull(#[from] HullError),
}

/// HPR's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HprParams {
    /// The transform.
    pub kernel: Kernel,
    /// Perturbation k: uniform noise in [−k·scale, k·scale] per coordinate (0: none).
    pub perturb: f64,
    /// Seed of the perturbation.
    pub seed: u64,
}

impl Default for HprParams {
    fn default() -> Self {
        Self {
            kernel: Kernel::Linear(Radius::Gamma(3.0)),
            perturb: 0.0,
            seed: 0,
        }
    }
}

/// Time spent in each step, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timings {
    /// Transform (and perturbation).
    pub transform: f64,
    /// Convex hull.
    pub hull: f64,
    /// Mapping hull vertices back to input indices.
    pub map: f64,
}

impl Timings {
    /// Total.
    pub fn total(&self) -> f64 {
        self.transform + self.hull + self.map
    }
}

/// The outcome of one HPR call.
#[derive(Debug, Clone, PartialEq)]
pub struct Visibility {
    /// Indices of the visible points, ascending.
    pub visible: Vec<u32>,
    /// The scale R of the transform (see [`Transformed::scale`]).
    pub scale: f64,
    /// Step timings.
    pub timings: Timings,
}

/// Runs HPR for `points` seen from `eye` with hull implementation `hull`.
pub fn visible(
    points: &[DVec3],
    eye: DVec3,
    params: &HprParams,
    hull: &dyn ConvexHull,
) -> Result<Visibility, HprError> {
    if let Some((scaled, eye, kernel)) = rescaled(points, eye, params.kernel)? {
        let p = HprParams { kernel, ..*params };
        return visible(&scaled, eye, &p, hull);
    }
    let start = Instant::now();
    let transformed = transform::transform(points, eye, params.kernel)?;
    let transformed = if params.perturb > 0.0 {
        transform::perturb(transformed, params.perturb, params.seed)?
    } else if params.perturb < 0.0 || !params.perturb.is_finite() {
        return Err(HprError::InvalidParameter {
            name: "perturb",
            reason: format!("must be >= 0, got {}", params.perturb),
        });
    } else {
        transformed
    };
    let t_transform = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let (vertices, distinct) = hull.vertices_distinct(&transformed.points)?;
    let t_hull = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let eye_index = points.len() as u32;
    let visible: Vec<u32> = vertices.into_iter().filter(|&v| v != eye_index).collect();
    // Coincident input points flip to coincident points: when the hull knows the flipped set
    // has none, there are no copies to add.
    let visible = if params.perturb > 0.0 || distinct {
        visible
    } else {
        with_duplicates(points, visible)
    };
    let t_map = start.elapsed().as_secs_f64();
    Ok(Visibility {
        visible,
        scale: transformed.scale,
        timings: Timings {
            transform: t_transform,
            hull: t_hull,
            map: t_map,
        },
    })
}

/// Coordinates far outside [2^-100, 2^100] would overflow the flip's norms (squares) or
/// underflow them: such a cloud is run on an exact power-of-two copy instead, returned here
/// with the eye and the kernel scaled alike (`None`: no rescaling needed). Flipping commutes
/// with such a scaling (the radius scales with the cloud; an absolute radius is scaled too;
/// the other kernels' results are scaled uniformly), so the visible set is unchanged.
pub(crate) fn rescaled(
    points: &[DVec3],
    eye: DVec3,
    kernel: Kernel,
) -> Result<Option<(Vec<DVec3>, DVec3, Kernel)>, HprError> {
    let coords = points
        .iter()
        .chain(std::iter::once(&eye))
        .flat_map(|p| p.to_array());
    let max = {
        use rayon::prelude::*;
        let abs_max = |p: &DVec3| p.abs().max_element();
        points
            .par_iter()
            .map(abs_max)
            .reduce(|| 0.0, f64::max)
            .max(abs_max(&eye))
    };
    // One parallel pass decides the common case; the sequential check runs only when
    // rescaling (a non-finite coordinate is left to the transform, which reports it).
    let Some((f1, f2)) = hull::rescale_needed(max)
        .then(|| hull::exact_rescale(coords))
        .transpose()?
        .flatten()
    else {
        return Ok(None);
    };
    let scale = |v: DVec3| v * f1 * f2;
    let scaled: Vec<DVec3> = points.iter().map(|&p| scale(p)).collect();
    let kernel = match kernel {
        Kernel::Linear(Radius::Absolute(r)) => Kernel::Linear(Radius::Absolute(r * f1 * f2)),
        k => k,
    };
    Ok(Some((scaled, scale(eye), kernel)))
}

/// `visible` (ascending indices into `points`) with every point that coincides with one of
/// them added, ascending: one parallel pass over the cloud with a hash set of the visible
/// positions' bit patterns (−0.0 and 0.0 differ in bits; they flip alike only when the other
/// coordinates do, and such pairs are left as the hull reports them).
pub fn with_duplicates(points: &[DVec3], visible: Vec<u32>) -> Vec<u32> {
    use rayon::prelude::*;
    use rustc_hash::FxHashSet;
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let set: FxHashSet<[u64; 3]> = visible.iter().map(|&i| key(points[i as usize])).collect();
    if set.len() == points.len() {
        return visible;
    }
    let all: Vec<u32> = points
        .par_iter()
        .enumerate()
        .filter(|(_, p)| set.contains(&key(**p)))
        .map(|(i, _)| i as u32)
        .collect();
    if all.len() == visible.len() {
        visible
    } else {
        all
    }
}

#[cfg(test)]
mod tests {
    use cloud::synth::{sphere_point_visible, sphere_scene};

    use super::*;

    fn own() -> Box<dyn ConvexHull> {
        hull::by_name("own").unwrap()
    }

    /// `own` that does not say whether the input is distinct (the trait's default), so that
    /// HPR always looks for copies.
    struct Unsure;
    impl ConvexHull for Unsure {
        fn name(&self) -> &'static str {
            "unsure"
        }
        fn vertices(&self, points: &[[f64; 3]]) -> Result<Vec<u32>, HullError> {
            hull::incremental::hull_vertices(points).map(|h| h.vertices)
        }
    }

    #[test]
    fn skipping_the_copy_search_on_distinct_clouds_changes_nothing() {
        let scene = sphere_scene(4_000);
        let mut points = scene.cloud.positions.clone();
        let eye = DVec3::new(0.3, 0.2, 3.0);
        for copies in [false, true] {
            if copies {
                let extra: Vec<DVec3> = points.iter().step_by(5).copied().collect();
                points.extend(extra);
            }
            let fast = visible(&points, eye, &HprParams::default(), own().as_ref()).unwrap();
            let slow = visible(&points, eye, &HprParams::default(), &Unsure).unwrap();
            assert_eq!(fast.visible, slow.visible, "copies: {copies}");
            assert!(fast.visible.len() > 500);
        }
    }

    #[test]
    fn every_copy_of_a_visible_point_is_visible() {
        let scene = sphere_scene(3_000);
        let mut points = scene.cloud.positions.clone();
        // Every 7th point again, at the end.
        let copies: Vec<usize> = (0..points.len()).step_by(7).collect();
        let extra: Vec<DVec3> = copies.iter().map(|&i| points[i]).collect();
        points.extend(extra);
        let eye = DVec3::new(0.3, 0.2, 3.0);
        let v = visible(&points, eye, &HprParams::default(), own().as_ref()).unwrap();
        let seen: std::collections::HashSet<u32> = v.visible.iter().copied().collect();
        assert!(v.visible.windows(2).all(|w| w[0] < w[1]), "ascending");
        let n = scene.cloud.len();
        let mut visible_copies = 0;
        for (k, &i) in copies.iter().enumerate() {
            let copy = (n + k) as u32;
            assert_eq!(
                seen.contains(&(i as u32)),
                seen.contains(&copy),
                "point {i}"
            );
            visible_copies += usize::from(seen.contains(&copy));
        }
        assert!(visible_copies > 50, "{visible_copies}");
        // The same visible set as without the copies, on the original points.
        let plain = visible(
            &scene.cloud.positions,
            eye,
            &HprParams::default(),
            own().as_ref(),
        )
        .unwrap();
        let original: Vec<u32> = v
            .visible
            .iter()
            .copied()
            .filter(|&i| (i as usize) < n)
            .collect();
        assert_eq!(original, plain.visible);
    }

    /// Misclassified points of the unit sphere seen from `eye` at `gamma`, with the largest
    /// |cos| between a misclassified point's normal and its direction to the eye.
    fn sphere_errors(gamma: f64) -> (usize, usize, f64) {
        let scene = sphere_scene(4_000);
        let eye = DVec3::new(0.3, 0.2, 3.0);
        let params = HprParams {
            kernel: Kernel::Linear(Radius::Gamma(gamma)),
            ..HprParams::default()
        };
        let v = visible(&scene.cloud.positions, eye, &params, own().as_ref()).unwrap();
        let mut flags = vec![false; scene.cloud.len()];
        for &i in &v.visible {
            flags[i as usize] = true;
        }
        let (mut false_pos, mut false_neg, mut worst) = (0, 0, 0.0f64);
        for (&p, &f) in scene.cloud.positions.iter().zip(&flags) {
            let truth = sphere_point_visible(DVec3::ZERO, p, eye);
            if truth != f {
                if f {
                    false_pos += 1
                } else {
                    false_neg += 1
                }
                worst = worst.max(p.normalize().dot((eye - p).normalize()).abs());
            }
        }
        (false_pos, false_neg, worst)
    }

    /// Clouds at 1e200 and 1e-200 give the visible set of the same cloud at unit size (an
    /// unscaled flip overflows or underflows its norms).
    #[test]
    fn extreme_magnitudes_give_the_unit_answer() {
        let scene = sphere_scene(3_000);
        let eye = DVec3::new(0.3, 0.2, 3.0);
        for params in [
            HprParams::default(),
            HprParams {
                kernel: Kernel::Linear(Radius::Absolute(500.0)),
                ..HprParams::default()
            },
        ] {
            let unit = visible(&scene.cloud.positions, eye, &params, own().as_ref())
                .unwrap()
                .visible;
            for k in [664, -664] {
                let f = 2f64.powi(k);
                let pts: Vec<DVec3> = scene.cloud.positions.iter().map(|p| *p * f).collect();
                let mut p = params;
                if let Kernel::Linear(Radius::Absolute(r)) = params.kernel {
                    p.kernel = Kernel::Linear(Radius::Absolute(r * f));
                }
                let v = visible(&pts, eye * f, &p, own().as_ref()).unwrap().visible;
                assert_eq!(v, unit, "2^{k}, {params:?}");
            }
        }
    }

    #[test]
    fn convex_object_errors_are_at_the_silhouette_until_r_outgrows_the_density() {
        // Katz et al. 2007 §3: on a densely sampled convex object the visible set is the
        // front-facing points up to a band at the silhouette. Seed 000 §6: for an R too large
        // for the sampling density, occluded points "pass the threshold" and become visible.
        for gamma in [1.0, 2.0, 3.0] {
            let (false_pos, false_neg, worst) = sphere_errors(gamma);
            assert!(
                worst < 0.1,
                "gamma {gamma}: an error away from the silhouette (|cos| {worst})"
            );
            assert!(
                false_pos + false_neg < 4_000 * 3 / 100,
                "gamma {gamma}: {false_pos} + {false_neg}"
            );
        }
        let (fp2, _, _) = sphere_errors(2.0);
        let (fp4, _, worst4) = sphere_errors(4.0);
        assert!(
            fp4 > 10 * fp2 && worst4 > 0.5,
            "gamma 4 on 4,000 points: {fp4} false positives"
        );
    }

    #[test]
    fn hull_implementations_agree_on_a_small_cloud() {
        let scene = sphere_scene(500);
        let eye = DVec3::new(0.0, 0.0, 3.0);
        let a = visible(
            &scene.cloud.positions,
            eye,
            &HprParams::default(),
            own().as_ref(),
        )
        .unwrap();
        let b = visible(
            &scene.cloud.positions,
            eye,
            &HprParams::default(),
            hull::by_name("qhull").unwrap().as_ref(),
        )
        .unwrap();
        assert_eq!(a.visible, b.visible);
    }

    #[test]
    fn errors() {
        let pts = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        let h = own();
        assert_eq!(
            visible(&[], DVec3::ZERO, &HprParams::default(), h.as_ref()),
            Err(HprError::EmptyCloud)
        );
        assert_eq!(
            visible(&pts, DVec3::Y, &HprParams::default(), h.as_ref()),
            Err(HprError::EyeOnPoint(1))
        );
        assert_eq!(
            visible(&pts, DVec3::NAN, &HprParams::default(), h.as_ref()),
            Err(HprError::NonFinite(None))
        );
        let small = HprParams {
            kernel: Kernel::Linear(Radius::Absolute(1.0)),
            ..HprParams::default()
        };
        assert!(matches!(
            visible(&pts, DVec3::new(0.0, 0.0, -1.0), &small, h.as_ref()),
            Err(HprError::RadiusTooSmall { .. })
        ));
        let bad = HprParams {
            perturb: -1.0,
            ..HprParams::default()
        };
        assert!(matches!(
            visible(&pts, DVec3::new(0.0, 0.0, -5.0), &bad, h.as_ref()),
            Err(HprError::InvalidParameter {
                name: "perturb",
                ..
            })
        ));
        // Two points and the eye: too few for a 3-d hull.
        assert!(matches!(
            visible(
                &pts[..2],
                DVec3::new(0.0, 0.0, -5.0),
                &HprParams::default(),
                h.as_ref()
            ),
            Err(HprError::Hull(HullError::TooFewPoints(3)))
        ));
    }
}
