//! The CDF 9/7 discrete wavelet transform of JPEG2000's lossy path, 1-d and 2-d multilevel.
//!
//! Seed 003 §5.1–5.2 computes masking on the coefficients of "the discrete wavelet transform"
//! of JPEG2000; the lossy (irreversible) path of JPEG2000 (ITU-T T.800 Annex F) uses the
//! Cohen–Daubechies–Feauveau 9/7 biorthogonal wavelet, implemented by lifting:
//!
//! 1. y(2n+1) += α (y(2n) + y(2n+2))
//! 2. y(2n)   += β (y(2n−1) + y(2n+1))
//! 3. y(2n+1) += γ (y(2n) + y(2n+2))
//! 4. y(2n)   += δ (y(2n−1) + y(2n+1))
//! 5. y(2n) ×= 1/K, y(2n+1) ×= K
//!
//! with α = −1.586134342059924, β = −0.052980118572961, γ = 0.882911075530934,
//! δ = 0.443506852043971, K = 1.230174104914001, and whole-sample symmetric extension at both
//! ends (x(−i) = x(i), x(n−1+i) = x(n−1−i)), so signals of any length, odd included, are
//! transformed without growing. With this normalisation the low-pass filter has DC gain 1 (a
//! constant signal stays itself in the base band) and the high-pass output of a constant is 0.
//! The inverse runs the steps backwards with opposite signs, so reconstruction is exact up to
//! floating-point rounding (tested to 1e-9 relative).
//!
//! The 2-d transform is separable (rows, then columns) and multilevel in the Mallat layout:
//! after level l the top-left ⌈w/2^l⌉ × ⌈h/2^l⌉ block holds the base band (LL), and the bands
//! HL (right), LH (below) and HH (diagonal) of that level sit beside it. [`Dwt2::band`] names
//! each band's rectangle.
//!
//! Complexity O(w·h) per level; the whole pyramid costs less than 4/3 of the first level.

const ALPHA: f64 = -1.586_134_342_059_924;
const BETA: f64 = -0.052_980_118_572_961;
const GAMMA: f64 = 0.882_911_075_530_934;
const DELTA: f64 = 0.443_506_852_043_971;
const K: f64 = 1.230_174_104_914_001;

/// Index `i` reflected into `0..n` by whole-sample symmetric extension (n ≥ 2, |overshoot| < n).
fn reflect(i: isize, n: usize) -> usize {
    let n = n as isize;
    let j = if i < 0 {
        -i
    } else if i >= n {
        2 * (n - 1) - i
    } else {
        i
    };
    j as usize
}

/// One lifting step: samples of `parity` get `c` times the sum of their two neighbours.
fn lift(x: &mut [f64], parity: usize, c: f64) {
    let n = x.len();
    let mut i = parity;
    while i < n {
        let l = x[reflect(i as isize - 1, n)];
        let r = x[reflect(i as isize + 1, n)];
        x[i] += c * (l + r);
        i += 2;
    }
}

/// Forward 1-d transform of `x` in place, interleaved (even = low, odd = high).
pub fn forward_1d_interleaved(x: &mut [f64]) {
    if x.len() < 2 {
        return;
    }
    lift(x, 1, ALPHA);
    lift(x, 0, BETA);
    lift(x, 1, GAMMA);
    lift(x, 0, DELTA);
    for (i, v) in x.iter_mut().enumerate() {
        *v *= if i % 2 == 0 { 1.0 / K } else { K };
    }
}

/// Inverse of [`forward_1d_interleaved`].
pub fn inverse_1d_interleaved(x: &mut [f64]) {
    if x.len() < 2 {
        return;
    }
    for (i, v) in x.iter_mut().enumerate() {
        *v *= if i % 2 == 0 { K } else { 1.0 / K };
    }
    lift(x, 0, -DELTA);
    lift(x, 1, -GAMMA);
    lift(x, 0, -BETA);
    lift(x, 1, -ALPHA);
}

/// Forward 1-d transform with the output de-interleaved: ⌈n/2⌉ low-pass then ⌊n/2⌋ high-pass.
pub fn forward_1d(x: &mut [f64], scratch: &mut Vec<f64>) {
    forward_1d_interleaved(x);
    deinterleave(x, scratch);
}

/// Inverse of [`forward_1d`].
pub fn inverse_1d(x: &mut [f64], scratch: &mut Vec<f64>) {
    interleave(x, scratch);
    inverse_1d_interleaved(x);
}

fn deinterleave(x: &mut [f64], scratch: &mut Vec<f64>) {
    let n = x.len();
    let n_low = n.div_ceil(2);
    scratch.clear();
    scratch.extend_from_slice(x);
    for i in 0..n {
        let dst = if i % 2 == 0 { i / 2 } else { n_low + i / 2 };
        x[dst] = scratch[i];
    }
}

fn interleave(x: &mut [f64], scratch: &mut Vec<f64>) {
    let n = x.len();
    let n_low = n.div_ceil(2);
    scratch.clear();
    scratch.extend_from_slice(x);
    for i in 0..n {
        let src = if i % 2 == 0 { i / 2 } else { n_low + i / 2 };
        x[i] = scratch[src];
    }
}

/// Which detail band of a level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Band {
    /// High-pass horizontally, low-pass vertically (right of the base band).
    Hl,
    /// Low-pass horizontally, high-pass vertically (below the base band).
    Lh,
    /// High-pass in both directions.
    Hh,
}

impl Band {
    /// The three detail bands.
    pub const ALL: [Band; 3] = [Band::Hl, Band::Lh, Band::Hh];
}

/// A rectangle of coefficients in the transformed array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// Width.
    pub w: usize,
    /// Height.
    pub h: usize,
}

/// A multilevel 2-d transform in the Mallat layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Dwt2 {
    /// Width of the image.
    pub width: usize,
    /// Height of the image.
    pub height: usize,
    /// Number of levels.
    pub levels: usize,
    /// Coefficients, row-major, `width × height`.
    pub coefficients: Vec<f64>,
}

/// Size of the region a level transforms: level 1 is the full image.
fn level_size(width: usize, height: usize, level: usize) -> (usize, usize) {
    let mut w = width;
    let mut h = height;
    for _ in 1..level {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
    }
    (w, h)
}

impl Dwt2 {
    /// Forward transform of a `width × height` row-major image over `levels` levels.
    pub fn forward(image: &[f64], width: usize, height: usize, levels: usize) -> Dwt2 {
        debug_assert_eq!(image.len(), width * height);
        let mut c = image.to_vec();
        let mut line = Vec::new();
        let mut scratch = Vec::new();
        for level in 1..=levels {
            let (w, h) = level_size(width, height, level);
            for y in 0..h {
                forward_1d(&mut c[y * width..y * width + w], &mut scratch);
            }
            for x in 0..w {
                line.clear();
                line.extend((0..h).map(|y| c[y * width + x]));
                forward_1d(&mut line, &mut scratch);
                for (y, v) in line.iter().enumerate() {
                    c[y * width + x] = *v;
                }
            }
        }
        Dwt2 {
            width,
            height,
            levels,
            coefficients: c,
        }
    }

    /// Inverse transform back to the image.
    pub fn inverse(&self) -> Vec<f64> {
        let width = self.width;
        let mut c = self.coefficients.clone();
        let mut line = Vec::new();
        let mut scratch = Vec::new();
        for level in (1..=self.levels).rev() {
            let (w, h) = level_size(self.width, self.height, level);
            for x in 0..w {
                line.clear();
                line.extend((0..h).map(|y| c[y * width + x]));
                inverse_1d(&mut line, &mut scratch);
                for (y, v) in line.iter().enumerate() {
                    c[y * width + x] = *v;
                }
            }
            for y in 0..h {
                inverse_1d(&mut c[y * width..y * width + w], &mut scratch);
            }
        }
        c
    }

    /// The rectangle of `band` at `level` (1 = finest).
    pub fn band(&self, level: usize, band: Band) -> Rect {
        let (w, h) = level_size(self.width, self.height, level);
        let (lw, lh) = (w.div_ceil(2), h.div_ceil(2));
        match band {
            Band::Hl => Rect {
                x0: lw,
                y0: 0,
                w: w - lw,
                h: lh,
            },
            Band::Lh => Rect {
                x0: 0,
                y0: lh,
                w: lw,
                h: h - lh,
            },
            Band::Hh => Rect {
                x0: lw,
                y0: lh,
                w: w - lw,
                h: h - lh,
            },
        }
    }

    /// The base band (LL) after the last level.
    pub fn base(&self) -> Rect {
        let (w, h) = level_size(self.width, self.height, self.levels + 1);
        Rect { x0: 0, y0: 0, w, h }
    }

    /// Coefficient at column `x`, row `y`.
    pub fn at(&self, x: usize, y: usize) -> f64 {
        self.coefficients[y * self.width + x]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn constant_signal_goes_to_the_base_band() {
        for n in [2usize, 3, 7, 8, 33] {
            let mut x = vec![5.0; n];
            let mut s = Vec::new();
            forward_1d(&mut x, &mut s);
            let n_low = n.div_ceil(2);
            assert!(x[..n_low].iter().all(|v| (v - 5.0).abs() < 1e-9), "{x:?}");
            assert!(x[n_low..].iter().all(|v| v.abs() < 1e-9), "{x:?}");
        }
    }

    #[test]
    fn linear_ramp_has_no_interior_detail() {
        // The 9/7 analysis high-pass has four vanishing moments: a ramp leaves no detail
        // away from the borders.
        let mut x: Vec<f64> = (0..64).map(|i| 3.0 * f64::from(i) - 7.0).collect();
        let mut s = Vec::new();
        forward_1d(&mut x, &mut s);
        assert!(x[32 + 3..64 - 3].iter().all(|v| v.abs() < 1e-9), "{x:?}");
    }

    #[test]
    fn two_d_bands_tile_the_image() {
        let d = Dwt2::forward(&vec![1.0; 37 * 21], 37, 21, 3);
        let mut area = d.base().w * d.base().h;
        for l in 1..=3 {
            for b in Band::ALL {
                let r = d.band(l, b);
                area += r.w * r.h;
            }
        }
        assert_eq!(area, 37 * 21);
        // A constant image: every detail coefficient is zero, the base band holds the constant.
        for l in 1..=3 {
            for b in Band::ALL {
                let r = d.band(l, b);
                for y in r.y0..r.y0 + r.h {
                    for x in r.x0..r.x0 + r.w {
                        assert!(d.at(x, y).abs() < 1e-9);
                    }
                }
            }
        }
        assert!((d.at(0, 0) - 1.0).abs() < 1e-9);
    }

    proptest! {
        #[test]
        fn one_d_reconstruction_is_perfect(x in prop::collection::vec(-300.0f64..300.0, 1..80)) {
            let mut y = x.clone();
            let mut s = Vec::new();
            forward_1d(&mut y, &mut s);
            inverse_1d(&mut y, &mut s);
            prop_assert!(max_abs_diff(&x, &y) < 1e-9);
        }

        #[test]
        fn two_d_reconstruction_is_perfect(
            w in 1usize..40,
            h in 1usize..40,
            levels in 0usize..5,
            seed in 0u64..1000,
        ) {
            let img: Vec<f64> = (0..w * h)
                .map(|i| {
                    let z = (i as u64 ^ seed).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                    (z >> 40) as f64 / 65536.0 * 255.0 - 128.0
                })
                .collect();
            let d = Dwt2::forward(&img, w, h, levels);
            let back = d.inverse();
            prop_assert!(max_abs_diff(&img, &back) < 1e-9);
        }
    }
}
