//! RGB textures: the procedural ones the experiments use and lookup by texture coordinates.
//!
//! Seed 003's figures use a high-contrast flower pattern (Figure 7, on a vase; Figure 8, on
//! one half of a torus) and a stone-like texture on the gargoyle. The paper's images are not
//! available, so [`flower`], [`marble`] and [`flat`] generate stand-ins in code, deterministic
//! from their parameters (the marble from a seed). Any other image comes in as an RGB buffer
//! through [`Texture::new`] (the harness decodes PNG files; this crate does no file I/O).
//!
//! Lookup ([`Texture::sample`]) wraps texture coordinates (repeat) and filters bilinearly;
//! v = 0 is the bottom row of the image, as in OpenGL.

use cloud::glam::{Vec2, Vec3};
use cloud::rng::{RngExt, seeded};

use crate::{Error, Result};

/// An RGB8 image, row-major, row 0 at the top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Texture {
    width: usize,
    height: usize,
    rgb: Vec<[u8; 3]>,
}

impl Texture {
    /// A texture from its pixels; errors when the size is zero or the buffer does not match.
    pub fn new(width: usize, height: usize, rgb: Vec<[u8; 3]>) -> Result<Texture> {
        if width == 0 || height == 0 || rgb.len() != width * height {
            return Err(Error::InvalidImage {
                width,
                height,
                len: rgb.len(),
            });
        }
        Ok(Texture { width, height, rgb })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixels, row-major, row 0 at the top.
    pub fn pixels(&self) -> &[[u8; 3]] {
        &self.rgb
    }

    /// Luma (ITU-R BT.601 weights) of every pixel, in 0..=255.
    pub fn luma(&self) -> Vec<f64> {
        self.rgb
            .iter()
            .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
            .collect()
    }

    /// The pixel (column, row) a texture coordinate falls in, wrapped.
    pub fn texel_of(&self, uv: Vec2) -> (usize, usize) {
        let x = (uv.x.rem_euclid(1.0) * self.width as f32) as usize;
        let y = ((1.0 - uv.y.rem_euclid(1.0)) * self.height as f32) as usize;
        (x.min(self.width - 1), y.min(self.height - 1))
    }

    /// Bilinear colour in [0, 1]³ at a texture coordinate (repeat wrapping).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let fx = uv.x.rem_euclid(1.0) * self.width as f32 - 0.5;
        let fy = (1.0 - uv.y.rem_euclid(1.0)) * self.height as f32 - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let wrap = |v: f32, n: usize| (v as i64).rem_euclid(n as i64) as usize;
        let px = |x: f32, y: f32| {
            let p = self.rgb[wrap(y, self.height) * self.width + wrap(x, self.width)];
            Vec3::new(f32::from(p[0]), f32::from(p[1]), f32::from(p[2])) / 255.0
        };
        let top = px(x0, y0).lerp(px(x0 + 1.0, y0), tx);
        let bottom = px(x0, y0 + 1.0).lerp(px(x0 + 1.0, y0 + 1.0), tx);
        top.lerp(bottom, ty)
    }
}

/// A high-contrast flower pattern: a `tiles × tiles` grid of five-petal flowers (saturated
/// petals with dark outlines and veins, a yellow heart) on a plain dark green ground,
/// `size × size` pixels; the flowers cover about 60 % of the area.
pub fn flower(size: usize, tiles: usize) -> Texture {
    let size = size.max(1);
    let tiles = tiles.max(1);
    let mut rgb = Vec::with_capacity(size * size);
    let tile = size as f64 / tiles as f64;
    for y in 0..size {
        for x in 0..size {
            let (tx, ty) = ((x as f64 + 0.5) / tile, (y as f64 + 0.5) / tile);
            // Position in the tile, in [-1, 1]², and which tile (colour varies per tile).
            let (cx, cy) = (2.0 * tx.fract() - 1.0, 2.0 * ty.fract() - 1.0);
            let which = (tx.floor() as usize + 3 * ty.floor() as usize) % 3;
            let r = (cx * cx + cy * cy).sqrt();
            let a = cy.atan2(cx);
            let petal = 0.55 + 0.35 * (2.5 * a).cos().abs();
            let pixel = if r < 0.22 {
                [250, 210, 40]
            } else if r < 0.26 {
                [90, 50, 10]
            } else if r < petal - 0.06 {
                // Veins: thin dark lines along each petal.
                if (5.0 * a).sin().abs() < 0.08 {
                    [60, 10, 30]
                } else {
                    [[220, 30, 60], [240, 240, 250], [140, 40, 200]][which]
                }
            } else if r < petal {
                [30, 10, 20]
            } else {
                [25, 70, 30]
            };
            rgb.push(pixel);
        }
    }
    Texture {
        width: size,
        height: size,
        rgb,
    }
}

/// A marble texture: veins sin(x + turbulence) over seeded value noise (five octaves), greys
/// with a warm tint, `size × size` pixels, periodic so it tiles.
pub fn marble(size: usize, seed: u64) -> Texture {
    let size = size.max(1);
    const LATTICE: usize = 16;
    let mut rng = seeded(seed, "marble-texture");
    let lattice: Vec<f64> = (0..LATTICE * LATTICE)
        .map(|_| rng.random::<f64>())
        .collect();
    let noise = |x: f64, y: f64, period: usize| {
        // Periodic value noise with smoothstep interpolation on a `period` lattice.
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let s = |t: f64| t * t * (3.0 - 2.0 * t);
        let at = |i: f64, j: f64| {
            let i = (i as i64).rem_euclid(period as i64) as usize % LATTICE;
            let j = (j as i64).rem_euclid(period as i64) as usize % LATTICE;
            lattice[j * LATTICE + i]
        };
        let top = at(x0, y0) + (at(x0 + 1.0, y0) - at(x0, y0)) * s(fx);
        let bottom = at(x0, y0 + 1.0) + (at(x0 + 1.0, y0 + 1.0) - at(x0, y0 + 1.0)) * s(fx);
        top + (bottom - top) * s(fy)
    };
    let mut rgb = Vec::with_capacity(size * size);
    for y in 0..size {
        for x in 0..size {
            let (u, v) = (x as f64 / size as f64, y as f64 / size as f64);
            let mut turbulence = 0.0;
            let mut amplitude = 1.0;
            let mut period = 2usize;
            for _ in 0..5 {
                turbulence += amplitude * noise(u * period as f64, v * period as f64, period);
                amplitude *= 0.5;
                period = (period * 2).min(LATTICE);
            }
            let t =
                0.5 + 0.5 * (std::f64::consts::TAU * (3.0 * u + 2.0 * v) + 6.0 * turbulence).sin();
            let t = t.powf(0.6);
            let g = 40.0 + 200.0 * t;
            rgb.push([(g + 15.0).min(255.0) as u8, g as u8, (g * 0.9) as u8]);
        }
    }
    Texture {
        width: size,
        height: size,
        rgb,
    }
}

/// A flat texture of one colour, `size × size` pixels.
pub fn flat(size: usize, color: [u8; 3]) -> Texture {
    let size = size.max(1);
    Texture {
        width: size,
        height: size,
        rgb: vec![color; size * size],
    }
}

/// `texture` on the half u < 0.5 and the flat `color` on the other half (seed 003 Figure 8).
pub fn half_textured(texture: &Texture, color: [u8; 3]) -> Texture {
    let mut out = texture.clone();
    for y in 0..out.height {
        for x in out.width / 2..out.width {
            out.rgb[y * out.width + x] = color;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_buffers_are_errors() {
        assert!(matches!(
            Texture::new(0, 4, vec![]),
            Err(Error::InvalidImage { .. })
        ));
        assert!(matches!(
            Texture::new(2, 2, vec![[0; 3]; 3]),
            Err(Error::InvalidImage { len: 3, .. })
        ));
    }

    #[test]
    fn sampling_wraps_and_hits_pixel_centres() {
        let t = Texture::new(2, 1, vec![[255, 0, 0], [0, 0, 255]]).unwrap();
        let left = t.sample(Vec2::new(0.25, 0.5));
        assert!((left - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-5, "{left}");
        let wrapped = t.sample(Vec2::new(1.75, -3.5));
        assert!(
            (wrapped - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-5,
            "{wrapped}"
        );
        assert_eq!(t.texel_of(Vec2::new(0.75, 0.0)), (1, 0));
    }

    #[test]
    fn procedural_textures_are_deterministic_and_differ() {
        assert_eq!(marble(64, 3), marble(64, 3));
        assert_ne!(marble(64, 3), marble(64, 4));
        let f = flower(64, 2);
        let distinct: std::collections::HashSet<_> = f.pixels().iter().collect();
        assert!(distinct.len() >= 5);
        assert_eq!(
            flat(8, [1, 2, 3])
                .pixels()
                .iter()
                .collect::<std::collections::HashSet<_>>()
                .len(),
            1
        );
        let h = half_textured(&f, [9, 9, 9]);
        assert_eq!(h.pixels()[63], [9, 9, 9]);
        assert_eq!(h.pixels()[0], f.pixels()[0]);
    }
}
