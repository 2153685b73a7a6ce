//! The visual-masking importance map of seed 003 §5.2 (JPEG2000's masking nonlinearity, eq. 1).
//!
//! Qu, Yuan, Nguyen and Meyer, "Perceptually guided rendering of textured point-based
//! models", Eurographics Symposium on Point-Based Graphics 2006, §5.2, eq. (1):
//!
//! ```text
//! z_i = sign(x_i) |x_i|^α / m_i,   m_i = 1 + a Σ_{k near i} |x_k|^β / |φ_i|
//! ```
//!
//! x_i are the wavelet coefficients of the texture, m_i the masking elevation factor, φ_i the
//! neighbourhood of i, α = 0.7, β = 0.2, a = (10000 / 2^(bit_depth−1))^β (the JPEG2000
//! recommended values). As the paper does (and unlike JPEG2000's decoder, which only sees the
//! causal part) the neighbourhood is non-causal: the (2ρ+1)² window centred on i inside the same
//! band, clipped at the band's border (|φ_i| counts the coefficients actually inside; ρ = 2 by
//! default, a 5 × 5 window). m_i is computed for every band but the base band, at every level;
//! the map at a texel is the average of the m_i of the coefficients covering it over all
//! 3 × levels detail bands ("an average of the elevation factors at each band and each scale").
//!
//! Input: the texture's luma (BT.601), level-shifted by 2^(bit_depth−1) as JPEG2000 does, and
//! transformed by [`crate::wavelet`] (CDF 9/7) over `levels` levels (5 by default, JPEG2000's
//! default, fewer when the image is too small).
//!
//! NOTE (not in the paper): the paper shows the map but does not say how elevation becomes the
//! density I of eq. 2. Here the *importance* is the elevation's excess over 1 normalised by its
//! 99th percentile over the texture and clamped to [0, 1] (robust to a few extreme texels): 0
//! where nothing masks (flat regions, where every coefficient is 0 and m = 1), 1 where masking is
//! strongest. A flat texture has importance 0 everywhere. [`crate::Srn`] maps importance to
//! density.
//!
//! Complexity O(w·h) (summed-area tables make every window sum O(1)).

use crate::texture::Texture;
use crate::wavelet::{Band, Dwt2};
use crate::{Error, Result};

/// Coefficients smaller than this (in sample units) count as zero.
const DEAD_ZONE: f64 = 1e-6;

/// Parameters of eq. 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskingParams {
    /// Exponent α of the signal (0.7 in JPEG2000); only [`masked_coefficient`] uses it.
    pub alpha: f64,
    /// Exponent β of the neighbourhood (0.2).
    pub beta: f64,
    /// Bit depth of the samples (8 for PNG textures); gives a = (10000 / 2^(bd−1))^β.
    pub bit_depth: u32,
    /// Wavelet levels (5, JPEG2000's default); reduced for small images.
    pub levels: usize,
    /// Neighbourhood half-width ρ: the window is (2ρ+1)².
    pub radius: usize,
    /// Percentile of the elevation used to normalise the importance to [0, 1].
    pub percentile: f64,
}

impl Default for MaskingParams {
    fn default() -> Self {
        MaskingParams {
            alpha: 0.7,
            beta: 0.2,
            bit_depth: 8,
            levels: 5,
            radius: 2,
            percentile: 0.99,
        }
    }
}

impl MaskingParams {
    /// The constant a of eq. 1.
    pub fn a(&self) -> f64 {
        (10_000.0 / 2f64.powi(self.bit_depth as i32 - 1)).powf(self.beta)
    }

    fn validate(&self) -> Result<()> {
        let bad = |name, reason: &str| {
            Err(Error::InvalidParameter {
                name,
                reason: reason.to_owned(),
            })
        };
        if !(self.beta > 0.0 && self.beta.is_finite()) {
            return bad("beta", "must be positive");
        }
        if !(self.alpha > 0.0 && self.alpha.is_finite()) {
            return bad("alpha", "must be positive");
        }
        if !(1..=16).contains(&self.bit_depth) {
            return bad("bit_depth", "must be in 1..=16");
        }
        if self.levels == 0 {
            return bad("levels", "must be at least 1");
        }
        if !(self.percentile > 0.0 && self.percentile <= 1.0) {
            return bad("percentile", "must be in (0, 1]");
        }
        Ok(())
    }
}

/// Eq. 1's masked coefficient z_i for a coefficient `x` with elevation `m`.
pub fn masked_coefficient(x: f64, m: f64, alpha: f64) -> f64 {
    x.signum() * x.abs().powf(alpha) / m
}

/// The masking map of a texture, at the texture's resolution.
#[derive(Debug, Clone, PartialEq)]
pub struct MaskingMap {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Wavelet levels actually used.
    pub levels: usize,
    /// Mean elevation factor m over all detail bands, per texel (≥ 1), row-major, row 0 on top.
    pub elevation: Vec<f64>,
    /// Importance in [0, 1] per texel (see the module doc).
    pub importance: Vec<f32>,
}

impl MaskingMap {
    /// Importance of the texel (column, row).
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.importance[y * self.width + x]
    }

    /// Mean importance over the texture.
    pub fn mean_importance(&self) -> f64 {
        self.importance.iter().map(|&v| f64::from(v)).sum::<f64>() / self.importance.len() as f64
    }
}

/// Window means of |x|^β inside one band, by a summed-area table.
fn band_elevation(d: &Dwt2, level: usize, band: Band, p: &MaskingParams, a: f64) -> Vec<f64> {
    let r = d.band(level, band);
    let (w, h) = (r.w, r.h);
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            let c = d.at(r.x0 + x, r.y0 + y).abs();
            // NOTE: |x|^β with β = 0.2 turns round-off (1e-14) into 1e-3; coefficients below
            // DEAD_ZONE are exact zeros of the transform that rounding made non-zero.
            if c > DEAD_ZONE {
                row += c.powf(p.beta);
            }
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(p.radius), (y + p.radius + 1).min(h));
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(p.radius), (x + p.radius + 1).min(w));
            let sum = sat[y1 * (w + 1) + x1] - sat[y0 * (w + 1) + x1] - sat[y1 * (w + 1) + x0]
                + sat[y0 * (w + 1) + x0];
            let count = ((x1 - x0) * (y1 - y0)) as f64;
            out.push(1.0 + a * sum / count);
        }
    }
    out
}

/// Computes the masking map of `texture`.
pub fn masking_map(texture: &Texture, params: &MaskingParams) -> Result<MaskingMap> {
    params.validate()?;
    let (width, height) = (texture.width(), texture.height());
    // Enough levels that the coarsest detail band still has at least one coefficient.
    let max_levels = (usize::BITS - 1 - width.min(height).leading_zeros()) as usize;
    let levels = params.levels.min(max_levels);
    if levels == 0 {
        return Err(Error::InvalidImage {
            width,
            height,
            len: width * height,
        });
    }
    let shift = 2f64.powi(params.bit_depth as i32 - 1);
    let luma: Vec<f64> = texture.luma().iter().map(|v| v - shift).collect();
    let d = Dwt2::forward(&luma, width, height, levels);
    let a = params.a();
    let mut elevation = vec![0.0f64; width * height];
    let mut n_bands = 0usize;
    for level in 1..=levels {
        for band in Band::ALL {
            let r = d.band(level, band);
            if r.w == 0 || r.h == 0 {
                continue;
            }
            n_bands += 1;
            let m = band_elevation(&d, level, band, params, a);
            for y in 0..height {
                let by = (y >> level).min(r.h - 1);
                for x in 0..width {
                    let bx = (x >> level).min(r.w - 1);
                    elevation[y * width + x] += m[by * r.w + bx];
                }
            }
        }
    }
    for e in &mut elevation {
        *e /= n_bands as f64;
    }
    let mut sorted = elevation.clone();
    sorted.sort_by(f64::total_cmp);
    let q = sorted[((sorted.len() - 1) as f64 * params.percentile).round() as usize];
    let scale = q - 1.0;
    let importance = elevation
        .iter()
        .map(|&e| {
            if scale > 1e-9 {
                ((e - 1.0) / scale).clamp(0.0, 1.0) as f32
            } else {
                0.0
            }
        })
        .collect();
    Ok(MaskingMap {
        width,
        height,
        levels,
        elevation,
        importance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{flat, flower, half_textured, marble};

    #[test]
    fn jpeg2000_constant_for_8_bits() {
        let a = MaskingParams::default().a();
        assert!((a - (10_000f64 / 128.0).powf(0.2)).abs() < 1e-12);
        assert!((a - 2.391).abs() < 1e-3, "{a}");
        // Eq. 1: no masking (m = 1) leaves |x|^α with the sign.
        assert!((masked_coefficient(-32.0, 1.0, 0.7) + 32f64.powf(0.7)).abs() < 1e-12);
        assert!((masked_coefficient(32.0, 2.0, 0.7) - 32f64.powf(0.7) / 2.0).abs() < 1e-12);
    }

    #[test]
    fn flat_texture_masks_nothing() {
        let m = masking_map(&flat(64, [120, 80, 30]), &MaskingParams::default()).unwrap();
        assert!(m.elevation.iter().all(|&e| (e - 1.0).abs() < 1e-6));
        assert!(m.importance.iter().all(|&v| v == 0.0));
        assert_eq!(m.levels, 5);
    }

    #[test]
    fn textured_half_masks_more_than_flat_half() {
        let t = half_textured(&flower(512, 8), [200, 200, 200]);
        let m = masking_map(&t, &MaskingParams::default()).unwrap();
        let mean = |x0: usize, x1: usize| {
            let mut s = 0.0;
            for y in 0..512 {
                for x in x0..x1 {
                    s += f64::from(m.at(x, y));
                }
            }
            s / ((x1 - x0) * 512) as f64
        };
        // Away from the seam the flat half has (almost) no masking: the coarsest bands' 5 × 5
        // windows, 32 texels per coefficient, reach about 64 texels across it.
        let (textured, plain) = (mean(0, 256), mean(352, 512));
        assert!(textured > 0.5, "{textured}");
        assert!(plain < 0.02, "{plain}");
    }

    #[test]
    fn busier_textures_mask_more() {
        let p = MaskingParams::default();
        let f = masking_map(&flower(128, 4), &p).unwrap();
        let mm = masking_map(&marble(128, 1), &p).unwrap();
        let mean_e = |m: &MaskingMap| m.elevation.iter().sum::<f64>() / m.elevation.len() as f64;
        assert!(
            mean_e(&f) > 1.5 && mean_e(&mm) > 1.2,
            "{} {}",
            mean_e(&f),
            mean_e(&mm)
        );
    }

    #[test]
    fn tiny_images_use_fewer_levels_and_bad_params_are_errors() {
        let m = masking_map(&flower(6, 1), &MaskingParams::default()).unwrap();
        assert_eq!(m.levels, 2);
        let one = Texture::new(1, 1, vec![[0; 3]]).unwrap();
        assert!(matches!(
            masking_map(&one, &MaskingParams::default()),
            Err(Error::InvalidImage { .. })
        ));
        let p = MaskingParams {
            beta: -1.0,
            ..MaskingParams::default()
        };
        assert!(matches!(
            masking_map(&flower(8, 1), &p),
            Err(Error::InvalidParameter { name: "beta", .. })
        ));
    }
}
