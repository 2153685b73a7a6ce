//! `srn`: Simplification by Random Numbers with a visual-masking importance map, after Qu,
//! Yuan, Nguyen and Meyer, "Perceptually guided rendering of textured point-based models",
//! Eurographics Symposium on Point-Based Graphics 2006 (seed 003 §5, §6).
//!
//! Pipeline: a [`texture::Texture`] → the CDF 9/7 wavelet transform ([`wavelet`]) → the
//! masking elevation of eq. 1 averaged over bands and scales ([`masking`]) → an importance in
//! [0, 1] per texel → per point, through its texture coordinates, a density I(x) → the test of
//! eq. 2: point i is drawn when r_i < I(x_i), r_i a random number in [0, 1) drawn once per
//! point from a seed ([`Srn::new`]).
//!
//! Density (NOTE: the paper gives no formula; this is ours): the paper sets the original
//! density to 1 and lowers it where masking is strong ("the textured area has fewer point
//! samples than the un-textured area"), so I(x) = clamp(s · (1 − importance(x)), I_min, 1) with
//! s the *density scale* (1 is the paper's setting; s < 1 thins everywhere, the sweep of the
//! LOD experiment) and I_min a floor (default 0.02) so no region vanishes.
//!
//! Splat growth (§6: "the size of each point is adjusted in inverse proportion to the local
//! density"): a kept point's radius is multiplied by 1 / sqrt(I(x)). Points of density I cover
//! 1/I times the area each, so the radius grows with the square root; this keeps a surface
//! covered on average ([`Srn::radius_factor`]).
//!
//! The selection is a branch-free scan over 8 bytes per point (r_i and the importance at the
//! point, both f32, interleaved), in parallel chunks; its output is ascending point indices.
//! Importance is looked up at the texel under each point's texture coordinate (nearest), once,
//! at build time.

pub mod error;
pub mod masking;
pub mod param;
pub mod texture;
pub mod wavelet;

use cloud::glam::Vec2;
use cloud::rng::{RngExt, seeded};
use rayon::prelude::*;

pub use error::{Error, Result};
pub use masking::{MaskingMap, MaskingParams, masking_map};
pub use texture::Texture;

/// Selection parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SrnParams {
    /// Density scale s: I = clamp(s (1 − importance), floor, 1).
    pub scale: f32,
    /// Density floor I_min.
    pub floor: f32,
}

impl Default for SrnParams {
    fn default() -> Self {
        SrnParams {
            scale: 1.0,
            floor: 0.02,
        }
    }
}

impl SrnParams {
    fn validate(&self) -> Result<()> {
        if !(self.scale >= 0.0 && self.scale.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "scale",
                reason: format!("{} is not a finite non-negative number", self.scale),
            });
        }
        if !(self.floor > 0.0 && self.floor <= 1.0) {
            return Err(Error::InvalidParameter {
                name: "floor",
                reason: format!("{} is not in (0, 1]", self.floor),
            });
        }
        Ok(())
    }

    /// The density of a point of importance `m`.
    #[inline]
    pub fn density(&self, m: f32) -> f32 {
        (self.scale * (1.0 - m)).clamp(self.floor, 1.0)
    }
}

/// Per-point state of SRN: the random number and the importance under the point.
#[derive(Debug, Clone, PartialEq)]
pub struct Srn {
    /// (r_i, importance_i) per point.
    points: Vec<[f32; 2]>,
}

const CHUNK: usize = 1 << 16;

impl Srn {
    /// Assigns each point its random number (seeded) and looks its importance up in `map`.
    pub fn new(uvs: &[Vec2], map: &MaskingMap, seed: u64) -> Result<Srn> {
        if let Some((index, uv)) = uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
            return Err(Error::NonFiniteUv {
                index,
                u: uv.x,
                v: uv.y,
            });
        }
        let mut rng = seeded(seed, "srn-random-numbers");
        let points = uvs
            .iter()
            .map(|&uv| {
                let x = ((uv.x.rem_euclid(1.0)) * map.width as f32) as usize;
                let y = ((1.0 - uv.y.rem_euclid(1.0)) * map.height as f32) as usize;
                let m = map.at(x.min(map.width - 1), y.min(map.height - 1));
                [rng.random::<f32>(), m]
            })
            .collect();
        Ok(Srn { points })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The random number r_i of point `i`.
    pub fn random(&self, i: usize) -> f32 {
        self.points[i][0]
    }

    /// The importance under point `i`.
    pub fn importance(&self, i: usize) -> f32 {
        self.points[i][1]
    }

    /// Density I at point `i`.
    pub fn density(&self, i: usize, params: &SrnParams) -> f32 {
        params.density(self.points[i][1])
    }

    /// Radius multiplier 1 / sqrt(I) of point `i`.
    pub fn radius_factor(&self, i: usize, params: &SrnParams) -> f32 {
        1.0 / self.density(i, params).sqrt()
    }

    /// Expected number of points kept (the sum of the densities).
    pub fn expected_kept(&self, params: &SrnParams) -> f64 {
        self.points
            .iter()
            .map(|p| f64::from(params.density(p[1])))
            .sum()
    }

    /// Eq. 2: the indices of the points with r_i < I(x_i), ascending, into `out` (cleared).
    ///
    /// `out` is grown to one slot per point (its capacity is kept from call to call, so a
    /// reused vector allocates nothing), each chunk of points writes its selection into its own
    /// part, and the parts are then moved together.
    pub fn select_into(&self, params: &SrnParams, out: &mut Vec<u32>) -> Result<()> {
        params.validate()?;
        out.clear();
        out.resize(self.points.len(), 0);
        let counts: Vec<usize> = out
            .par_chunks_mut(CHUNK)
            .zip(self.points.par_chunks(CHUNK))
            .enumerate()
            .map(|(c, (buf, chunk))| {
                let base = (c * CHUNK) as u32;
                let mut len = 0;
                for (i, p) in chunk.iter().enumerate() {
                    // PERF: unconditional write, conditional advance: no branch to mispredict.
                    buf[len] = base + i as u32;
                    len += usize::from(p[0] < params.density(p[1]));
                }
                len
            })
            .collect();
        cloud::compact::join_parts(out, 0, counts.into_iter().map(|kept| (kept, CHUNK)));
        Ok(())
    }

    /// Eq. 2 as a new vector.
    pub fn select(&self, params: &SrnParams) -> Result<Vec<u32>> {
        let mut out = Vec::new();
        self.select_into(params, &mut out)?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use texture::{flat, flower, half_textured};

    fn grid_uvs(n: usize) -> Vec<Vec2> {
        (0..n * n)
            .map(|i| {
                Vec2::new(
                    ((i % n) as f32 + 0.5) / n as f32,
                    ((i / n) as f32 + 0.5) / n as f32,
                )
            })
            .collect()
    }

    #[test]
    fn flat_texture_keeps_everything_at_scale_one() {
        let map = masking_map(&flat(32, [50, 60, 70]), &MaskingParams::default()).unwrap();
        let srn = Srn::new(&grid_uvs(100), &map, 1).unwrap();
        let kept = srn.select(&SrnParams::default()).unwrap();
        assert_eq!(kept.len(), 10_000);
        assert!(kept.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn kept_fraction_matches_the_density() {
        let map = masking_map(&flat(32, [50, 60, 70]), &MaskingParams::default()).unwrap();
        let srn = Srn::new(&grid_uvs(500), &map, 2).unwrap();
        for s in [0.9f32, 0.6, 0.3] {
            let p = SrnParams {
                scale: s,
                ..SrnParams::default()
            };
            let kept = srn.select(&p).unwrap().len() as f64 / 250_000.0;
            // Binomial: standard deviation below 0.001.
            assert!((kept - f64::from(s)).abs() < 0.005, "s {s}: kept {kept}");
            assert!((srn.radius_factor(0, &p) - 1.0 / s.sqrt()).abs() < 1e-6);
        }
    }

    #[test]
    fn chunked_selection_is_the_direct_filter() {
        // 90,000 points: two chunks, the second partial; a reused vector; a textured map so
        // that importance varies.
        let map = masking_map(&flower(128, 6), &MaskingParams::default()).unwrap();
        let srn = Srn::new(&grid_uvs(300), &map, 5).unwrap();
        let mut out = vec![7; 3];
        for s in [0.0f32, 0.05, 0.5, 1.0, 2.0] {
            let p = SrnParams {
                scale: s,
                ..SrnParams::default()
            };
            srn.select_into(&p, &mut out).unwrap();
            let direct: Vec<u32> = (0..srn.points.len())
                .filter(|&i| srn.points[i][0] < p.density(srn.points[i][1]))
                .map(|i| i as u32)
                .collect();
            assert_eq!(out, direct, "scale {s}");
        }
    }

    #[test]
    fn textured_half_keeps_fewer_points() {
        let map = masking_map(
            &half_textured(&flower(512, 8), [200; 3]),
            &MaskingParams::default(),
        )
        .unwrap();
        let uvs = grid_uvs(300);
        let srn = Srn::new(&uvs, &map, 3).unwrap();
        let kept = srn.select(&SrnParams::default()).unwrap();
        let textured = kept.iter().filter(|&&i| uvs[i as usize].x < 0.45).count() as f64;
        let plain = kept.iter().filter(|&&i| uvs[i as usize].x > 0.7).count() as f64;
        assert!(textured < 0.5 * plain, "textured {textured} plain {plain}");
        assert!(plain > 0.97 * 0.3 * 90_000.0, "{plain}");
        // The expected count is the sum of densities.
        let e = srn.expected_kept(&SrnParams::default());
        assert!(
            (kept.len() as f64 - e).abs() < 4.0 * e.sqrt(),
            "{} vs {e}",
            kept.len()
        );
    }

    #[test]
    fn bad_inputs_are_errors() {
        let map = masking_map(&flat(8, [0; 3]), &MaskingParams::default()).unwrap();
        assert!(matches!(
            Srn::new(&[Vec2::new(0.1, f32::NAN)], &map, 0),
            Err(Error::NonFiniteUv { index: 0, .. })
        ));
        let srn = Srn::new(&grid_uvs(4), &map, 0).unwrap();
        for p in [
            SrnParams {
                scale: -1.0,
                ..SrnParams::default()
            },
            SrnParams {
                scale: f32::NAN,
                ..SrnParams::default()
            },
            SrnParams {
                floor: 0.0,
                ..SrnParams::default()
            },
        ] {
            assert!(
                matches!(srn.select(&p), Err(Error::InvalidParameter { .. })),
                "{p:?}"
            );
        }
        assert!(
            Srn::new(&[], &map, 0)
                .unwrap()
                .select(&SrnParams::default())
                .unwrap()
                .is_empty()
        );
    }

    proptest! {
        #[test]
        fn selections_are_nested_and_seeded(seed in 0u64..1000, s1 in 0.0f32..1.2, s2 in 0.0f32..1.2) {
            let map = masking_map(&flower(64, 2), &MaskingParams::default()).unwrap();
            let uvs = grid_uvs(60);
            let srn = Srn::new(&uvs, &map, seed).unwrap();
            let (lo, hi) = if s1 < s2 { (s1, s2) } else { (s2, s1) };
            let a = srn.select(&SrnParams { scale: lo, ..SrnParams::default() }).unwrap();
            let b = srn.select(&SrnParams { scale: hi, ..SrnParams::default() }).unwrap();
            let bs: std::collections::HashSet<u32> = b.iter().copied().collect();
            prop_assert!(a.iter().all(|i| bs.contains(i)));
            prop_assert_eq!(&srn, &Srn::new(&uvs, &map, seed).unwrap());
            // Brute force of eq. 2.
            let brute: Vec<u32> = (0..srn.len() as u32)
                .filter(|&i| srn.random(i as usize) < srn.density(i as usize, &SrnParams { scale: hi, ..SrnParams::default() }))
                .collect();
            prop_assert_eq!(b, brute);
        }
    }
}
