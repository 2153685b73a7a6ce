//! Recentring without loss, for georeferenced clouds (offsets of 10^5 to 10^6 m with millimetre
//! detail, as survey LAS files carry).
//!
//! The offset `c` is the bounding box's centre rounded to a multiple of 2^K, 2^K the smallest
//! power of two at least the box's longest side. Every coordinate and the offset are then
//! multiples of the coordinate's own unit in the last place, and the difference is smaller than
//! the coordinate, so `p − c` is exact in floating point; [`exact_offset`] checks this for every
//! coordinate with an error-free transformation (TwoSum) and returns zero — no recentring —
//! when any difference would round. Shifting a cloud by a multiple of 2^K shifts its offset by
//! the same amount, so the recentred coordinates (and every answer computed from them) do not
//! depend on where in the world the cloud lies.

use glam::DVec3;

use crate::bbox::Aabb;

/// True when `a − b` is exact in f64 (Knuth's TwoSum: the rounding error is zero).
#[inline]
pub fn difference_is_exact(a: f64, b: f64) -> bool {
    let nb = -b;
    let s = a + nb;
    let a2 = s - nb;
    let b2 = s - a2;
    (a - a2) + (nb - b2) == 0.0 && s.is_finite()
}

/// The lossless offset for `points` (zero when none is needed or none is exact).
pub fn exact_offset(points: &[DVec3]) -> DVec3 {
    let Some(bbox) = Aabb::from_points(points) else {
        return DVec3::ZERO;
    };
    let extent = bbox.extent().max_element();
    if !(extent > 0.0) || !extent.is_finite() {
        return DVec3::ZERO;
    }
    let unit = 2f64.powi(extent.log2().ceil() as i32);
    let c = (bbox.center() / unit).round() * unit;
    if c == DVec3::ZERO {
        return c;
    }
    if is_exact_for(points, c) {
        c
    } else {
        DVec3::ZERO
    }
}

/// True when subtracting `offset` from every point is exact.
pub fn is_exact_for(points: &[DVec3], offset: DVec3) -> bool {
    points.iter().all(|p| {
        difference_is_exact(p.x, offset.x)
            && difference_is_exact(p.y, offset.y)
            && difference_is_exact(p.z, offset.z)
    })
}

/// Subtracts `offset` from every point in place.
pub fn shift(points: &mut [DVec3], offset: DVec3) {
    if offset != DVec3::ZERO {
        for p in points {
            *p -= offset;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn georeferenced_points_recentre_exactly_and_independently_of_place() {
        // Millimetre detail around (512000, 4194304, 128): the world coordinates a survey
        // file gives, and the same cloud moved near the origin by a multiple of 2^K.
        let world: Vec<DVec3> = (0..1000)
            .map(|i| {
                let t = i as f64;
                let p = DVec3::new(
                    (t * 0.137).sin() * 20.0,
                    (t * 0.071).cos() * 15.0,
                    t * 0.001,
                );
                ((p + DVec3::new(512_000.0, 4_194_304.0, 128.0)) * 1000.0).round() / 1000.0
            })
            .collect();
        let moved_by = DVec3::new(512_000.0, 4_194_304.0, 128.0);
        let near: Vec<DVec3> = world.iter().map(|p| *p - moved_by).collect();
        for (p, q) in world.iter().zip(&near) {
            assert_eq!(*q + moved_by, *p, "the test's own move is exact");
        }
        let c = exact_offset(&world);
        assert_ne!(c, DVec3::ZERO);
        let mut a = world.clone();
        shift(&mut a, c);
        let mut b = near.clone();
        shift(&mut b, exact_offset(&near));
        assert_eq!(a, b);
        for (p, q) in a.iter().zip(&world) {
            assert_eq!(*p + c, *q, "the shift loses nothing");
        }
    }

    #[test]
    fn an_inexact_shift_is_refused() {
        // Extent 4, centre 2: the offset would be 4, and 1e-300 − 4 rounds.
        let pts = vec![DVec3::new(1e-300, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0)];
        assert_eq!(exact_offset(&pts), DVec3::ZERO);
        assert!(!difference_is_exact(1e-300, 4.0));
        assert!(difference_is_exact(4_000_000.001, 4_000_000.0));
        assert_eq!(exact_offset(&[]), DVec3::ZERO);
    }
}
