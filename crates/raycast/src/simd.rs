//! Four `f32` lanes for the packet traversal's box and point tests, written lane by lane so
//! that the compiler makes each operation one 4-wide instruction (SSE on x86-64, NEON on
//! AArch64) without `unsafe`: each operation is one IEEE-754 operation per lane, and
//! [`F4::min`] and [`F4::max`] return the second operand where the comparison fails (as
//! SSE's do).

/// Four lanes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(16))]
pub struct F4(pub [f32; 4]);

impl F4 {
    /// The lanes of `a`.
    #[inline(always)]
    pub fn load(a: &[f32; 4]) -> Self {
        Self(*a)
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f32) -> Self {
        Self([v; 4])
    }

    #[inline(always)]
    fn map2(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Self([
            f(self.0[0], o.0[0]),
            f(self.0[1], o.0[1]),
            f(self.0[2], o.0[2]),
            f(self.0[3], o.0[3]),
        ])
    }

    /// Lane-wise sum.
    #[inline(always)]
    pub fn add(self, o: Self) -> Self {
        self.map2(o, |a, b| a + b)
    }

    /// Lane-wise difference.
    #[inline(always)]
    pub fn sub(self, o: Self) -> Self {
        self.map2(o, |a, b| a - b)
    }

    /// Lane-wise product.
    #[inline(always)]
    pub fn mul(self, o: Self) -> Self {
        self.map2(o, |a, b| a * b)
    }

    /// Lane-wise `if self < o { self } else { o }`.
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        self.map2(o, |a, b| if a < b { a } else { b })
    }

    /// Lane-wise `if self > o { self } else { o }`.
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        self.map2(o, |a, b| if a > b { a } else { b })
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        Self(self.0.map(f32::sqrt))
    }

    /// Bit `j` set where lane `j` of `self` ≤ that of `o`.
    #[inline(always)]
    pub fn le(self, o: Self) -> u32 {
        (0..4).fold(0, |m, j| m | (u32::from(self.0[j] <= o.0[j]) << j))
    }

    /// Bit `j` set where lane `j` of `self` ≤ that of `a` and of `b`.
    #[inline(always)]
    pub fn le_both(self, a: Self, b: Self) -> u32 {
        self.le(a) & self.le(b)
    }
}
