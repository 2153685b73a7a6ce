//! Four `f32` lanes for the packet traversal's box and point tests: `wide`'s `f32x4` (SSE on
//! x86-64, NEON on AArch64, plain arrays elsewhere), behind the few operations the tests use.
//! Each is one IEEE-754 operation per lane. [`F4::min`] and [`F4::max`] are the instructions'
//! own (no NaN fix-up): where a lane is NaN their result is unspecified, so the traversal
//! never feeds them one that matters (box tests see no NaN; a padding slot's NaN reaches them
//! in the point filter, whose comparisons then reject it whatever they return).

use wide::f32x4;

/// Four lanes.
#[derive(Debug, Clone, Copy)]
pub struct F4(f32x4);

impl F4 {
    /// The lanes of `a`.
    #[inline(always)]
    pub fn load(a: &[f32; 4]) -> Self {
        Self(f32x4::new(*a))
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f32) -> Self {
        Self(f32x4::splat(v))
    }

    /// The lanes.
    #[inline(always)]
    pub fn lanes(self) -> [f32; 4] {
        self.0.to_array()
    }

    /// Lane-wise sum.
    #[inline(always)]
    pub fn add(self, o: Self) -> Self {
        Self(self.0 + o.0)
    }

    /// Lane-wise difference.
    #[inline(always)]
    pub fn sub(self, o: Self) -> Self {
        Self(self.0 - o.0)
    }

    /// Lane-wise product.
    #[inline(always)]
    pub fn mul(self, o: Self) -> Self {
        Self(self.0 * o.0)
    }

    /// Lane-wise minimum (NaN: unspecified).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        Self(self.0.fast_min(o.0))
    }

    /// Lane-wise maximum (NaN: unspecified).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        Self(self.0.fast_max(o.0))
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        Self(self.0.sqrt())
    }

    /// Bit `j` set where lane `j` of `self` ≤ that of `o` (false for NaN).
    #[inline(always)]
    pub fn le(self, o: Self) -> u32 {
        self.0.simd_le(o.0).to_bitmask()
    }

    /// Bit `j` set where lane `j` of `self` ≤ that of `a` and of `b`.
    #[inline(always)]
    pub fn le_both(self, a: Self, b: Self) -> u32 {
        (self.0.simd_le(a.0) & self.0.simd_le(b.0)).to_bitmask()
    }
}

#[cfg(test)]
mod tests {
    use super::F4;

    #[test]
    fn lanes_are_ieee_operations_and_masks_bits() {
        let a = F4::load(&[1.0, -2.0, 9.0, f32::NAN]);
        let b = F4::load(&[1.5, -2.0, 4.0, 0.0]);
        assert_eq!(a.le(b), 0b0011);
        assert_eq!(b.le(a), 0b0110);
        assert_eq!(a.le_both(b, F4::splat(0.0)), 0b0010);
        let bits = |v: F4| v.lanes().map(f32::to_bits);
        let third = 1.0f32 / 3.0;
        let (xs, ys) = ([1.0, 2.0, -3.0, 1e-40f32], [third, 1e30, 0.5, 1e-40f32]);
        let (x, y) = (F4::load(&xs), F4::load(&ys));
        let each = |f: fn(f32, f32) -> f32| {
            std::array::from_fn::<u32, 4, _>(|j| f(xs[j], ys[j]).to_bits())
        };
        assert_eq!(bits(x.add(y)), each(|a, b| a + b));
        assert_eq!(bits(x.sub(y)), each(|a, b| a - b));
        assert_eq!(bits(x.mul(y)), each(|a, b| a * b));
        assert_eq!(bits(x.min(y)), each(|a, b| if a < b { a } else { b }));
        assert_eq!(bits(x.max(y)), each(|a, b| if a > b { a } else { b }));
        assert_eq!(bits(x.sqrt()), xs.map(|v| v.sqrt().to_bits()));
        // min and max of numbers; NaN lanes are left unspecified.
        assert_eq!(a.min(b).lanes()[..3], [1.0, -2.0, 4.0]);
        assert_eq!(a.max(b).lanes()[..3], [1.5, -2.0, 9.0]);
    }
}
