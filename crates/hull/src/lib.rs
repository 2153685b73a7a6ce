//! `hull`: the vertices of a 3-d convex hull, behind one trait, five implementations.
//!
//! [`ConvexHull::vertices`] takes f64 points and returns the indices of the points that are
//! vertices of their convex hull (ascending), or a typed [`HullError`]. Implementations,
//! selectable by name ([`by_name`], [`NAMES`]):
//!
//! | name | what | exact? |
//! |---|---|---|
//! | `own` | our randomised incremental hull with exact predicates ([`incremental`]) | yes |
//! | `qhull` | Qhull 2020.2 through the `qhull` crate, options `Qt` (default) or `QJ` ([`qhull_impl`]) | no: merges or joggles |
//! | `parry` | `parry3d-f64::try_convex_hull`, indices recovered ([`parry_impl`]) | no |
//! | `quickhull` | Jondolf's `quickhull` crate, f32 ([`quickhull_impl`]) | no |
//! | `chull` | the `chull` crate ([`chull_impl`]) | no |
//!
//! Every implementation validates its input first ([`validate`]): fewer than four points or a
//! non-finite coordinate are errors before any third-party code runs; all points collinear or
//! coplanar are errors from `own` and whatever the third-party crate says otherwise. Duplicates
//! are allowed: among coincident extreme points `own` reports the lowest index, the others one
//! of them. A panic inside a third-party crate is caught and returned as [`HullError::Panic`].
//!
//! [`check`] verifies a hull exactly (a certificate check with exact predicates, and a
//! brute-force extreme-point oracle for small inputs); the tests use it.

pub mod check;
pub mod chull_impl;
pub mod incremental;
pub mod parry_impl;
pub mod predicates;
pub mod qhull_impl;
pub mod quickhull_impl;

use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};

pub use predicates::P3;

/// Why a hull could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HullError {
    /// Fewer than four points.
    #[error("a 3-d hull needs at least 4 points, got {0}")]
    TooFewPoints(usize),
    /// A NaN or infinite coordinate.
    #[error("point {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// The points do not span 3-d space (coincident, collinear or coplanar).
    #[error("degenerate input: {0}")]
    Degenerate(String),
    /// An option the implementation does not accept.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// The implementation reported a failure.
    #[error("{implementation} failed: {message}")]
    Failed {
        /// Which implementation.
        implementation: &'static str,
        /// Its message.
        message: String,
    },
    /// The implementation panicked (caught).
    #[error("{implementation} panicked: {message}")]
    Panic {
        /// Which implementation.
        implementation: &'static str,
        /// The panic payload, if it was a string.
        message: String,
    },
    /// An internal invariant of `own` was violated (a bug: please report the input).
    #[error("internal error: {0}")]
    Internal(String),
}

/// One interface for every hull implementation.
pub trait ConvexHull: Send + Sync {
    /// Registry name.
    fn name(&self) -> &'static str;
    /// Indices of the hull's vertices, ascending, no repeats.
    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError>;
    /// [`ConvexHull::vertices`], and whether the input is known to hold no coincident points
    /// (`false`: it may; the default, for implementations that do not know). HPR uses it to
    /// skip looking for copies of visible points.
    fn vertices_distinct(&self, points: &[P3]) -> Result<(Vec<u32>, bool), HullError> {
        Ok((self.vertices(points)?, false))
    }
}

/// Names of the implementations, in listing order.
pub const NAMES: &[&str] = &["own", "qhull", "parry", "quickhull", "chull"];

/// The implementation called `name` with default options (`qhull`: `Qt`).
pub fn by_name(name: &str) -> Result<Box<dyn ConvexHull>, HullError> {
    Ok(match name {
        "own" => Box::new(incremental::Incremental),
        "qhull" => Box::new(qhull_impl::Qhull::new(qhull_impl::QhullOption::Qt)),
        "qhull-qj" => Box::new(qhull_impl::Qhull::new(qhull_impl::QhullOption::QJ)),
        "parry" => Box::new(parry_impl::Parry),
        "quickhull" => Box::new(quickhull_impl::QuickHull),
        "chull" => Box::new(chull_impl::Chull),
        _ => {
            return Err(HullError::InvalidOption(format!(
                "unknown hull {name:?}; known: {}, qhull-qj",
                NAMES.join(", ")
            )));
        }
    })
}

/// The power of two, as two factors to apply in turn, that brings the largest of `coords`
/// into [0.5, 1), when it lies outside [2^-100, 2^100], the range where the exact predicates
/// cannot overflow or underflow (Shewchuk's orient3d multiplies three differences: magnitudes
/// beyond about 2^300 overflow, below about 2^-300 underflow); `None` when no rescaling is
/// needed. Scaling by a power of two is exact and keeps every orientation's sign (and commutes
/// with HPR's flip), so answers do not change; an error when some coordinate would not survive
/// it (the input spans more magnitudes than a double holds).
pub fn exact_rescale(
    coords: impl Iterator<Item = f64> + Clone,
) -> Result<Option<(f64, f64)>, HullError> {
    let max = coords.clone().fold(0.0f64, |m, c| m.max(c.abs()));
    if !rescale_needed(max) {
        return Ok(None);
    }
    let exponent = max.log2().floor() as i32 + 1;
    // 2^-exponent may itself be out of range: apply it in two halves.
    let (h1, h2) = (exponent / 2, exponent - exponent / 2);
    let (f1, f2) = (2f64.powi(-h1), 2f64.powi(-h2));
    let exact = coords.into_iter().all(|c| {
        let s = c * f1 * f2;
        s / f2 / f1 == c && (c == 0.0 || s != 0.0)
    });
    if !exact {
        return Err(HullError::Degenerate(format!(
            "the coordinates span more magnitudes than a double can rescale exactly (largest \
             {max:e}); rescale or recentre the input"
        )));
    }
    Ok(Some((f1, f2)))
}

/// Whether coordinates whose largest magnitude is `max_abs` call for [`exact_rescale`]: finite,
/// non-zero and outside [2^-100, 2^100].
pub fn rescale_needed(max_abs: f64) -> bool {
    max_abs.is_finite() && max_abs != 0.0 && !(2f64.powi(-100)..=2f64.powi(100)).contains(&max_abs)
}

/// [`exact_rescale`] of every coordinate of `points`; the common case (no rescaling) is decided
/// by one parallel pass.
pub fn exact_rescale_points(points: &[P3]) -> Result<Option<(f64, f64)>, HullError> {
    use rayon::prelude::*;
    let max = points
        .par_iter()
        .map(|p| p[0].abs().max(p[1].abs()).max(p[2].abs()))
        .reduce(|| 0.0, f64::max);
    if !rescale_needed(max) {
        return Ok(None);
    }
    exact_rescale(points.iter().flatten().copied())
}

/// Checks what every implementation needs: at least 4 points, all coordinates finite.
pub fn validate(points: &[P3]) -> Result<(), HullError> {
    if points.len() < 4 {
        return Err(HullError::TooFewPoints(points.len()));
    }
    if points.len() >= u32::MAX as usize {
        return Err(HullError::Degenerate("more than 2^32 - 1 points".into()));
    }
    use rayon::prelude::*;
    match points
        .par_iter()
        .position_first(|p| !p.iter().all(|c| c.is_finite()))
    {
        Some(i) => Err(HullError::NonFinite(i)),
        None => Ok(()),
    }
}

/// Runs `f`, turning a panic into [`HullError::Panic`].
pub(crate) fn guarded<T>(
    implementation: &'static str,
    f: impl FnOnce() -> Result<T, HullError>,
) -> Result<T, HullError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "non-string panic payload".into());
            Err(HullError::Panic {
                implementation,
                message,
            })
        }
    }
}

/// Maps hull vertex coordinates returned by a crate that drops indices back to input indices
/// (bit-exact coordinates; coincident inputs map to their lowest index). Coordinates that
/// match no input point are an error naming the implementation.
pub(crate) fn recover_indices(
    implementation: &'static str,
    points: &[P3],
    hull_vertices: impl IntoIterator<Item = P3>,
) -> Result<Vec<u32>, HullError> {
    let key = |p: &P3| p.map(f64::to_bits);
    let mut index: HashMap<[u64; 3], u32> = HashMap::with_capacity(points.len());
    for (i, p) in points.iter().enumerate().rev() {
        index.insert(key(p), i as u32);
    }
    let mut out = Vec::new();
    for v in hull_vertices {
        match index.get(&key(&v)) {
            Some(&i) => out.push(i),
            None => {
                return Err(HullError::Failed {
                    implementation,
                    message: format!("returned a vertex {v:?} that is not an input point"),
                });
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_errors() {
        assert_eq!(validate(&[[0.0; 3]; 3]), Err(HullError::TooFewPoints(3)));
        let mut pts = vec![[0.0; 3]; 5];
        pts[4][1] = f64::NAN;
        assert_eq!(validate(&pts), Err(HullError::NonFinite(4)));
        pts[4][1] = f64::INFINITY;
        assert_eq!(validate(&pts), Err(HullError::NonFinite(4)));
        for name in NAMES {
            let h = by_name(name).unwrap();
            assert_eq!(h.vertices(&pts), Err(HullError::NonFinite(4)), "{name}");
            assert_eq!(
                h.vertices(&pts[..2]),
                Err(HullError::TooFewPoints(2)),
                "{name}"
            );
        }
        assert!(matches!(
            by_name("gift-wrap"),
            Err(HullError::InvalidOption(_))
        ));
    }

    #[test]
    fn panics_are_caught() {
        let r: Result<(), HullError> = guarded("test", || panic!("boom"));
        assert_eq!(
            r,
            Err(HullError::Panic {
                implementation: "test",
                message: "boom".into()
            })
        );
    }
}
