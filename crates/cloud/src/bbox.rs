//! Axis-aligned bounding boxes.

use glam::DVec3;

/// An axis-aligned box given by its two corners (`min <= max` componentwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest coordinates.
    pub min: DVec3,
    /// Largest coordinates.
    pub max: DVec3,
}

impl Aabb {
    /// The box of a set of points; `None` when there are none.
    pub fn from_points(points: &[DVec3]) -> Option<Self> {
        let first = *points.first()?;
        let (min, max) = points
            .iter()
            .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        Some(Self { min, max })
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// Edge lengths.
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// Grows the box to include `p`.
    pub fn include(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_of_points() {
        let b =
            Aabb::from_points(&[DVec3::new(1.0, -2.0, 0.0), DVec3::new(-1.0, 2.0, 3.0)]).unwrap();
        assert_eq!(b.min, DVec3::new(-1.0, -2.0, 0.0));
        assert_eq!(b.max, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.center(), DVec3::new(0.0, 0.0, 1.5));
        assert!(Aabb::from_points(&[]).is_none());
    }
}
