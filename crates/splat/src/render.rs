//! A software splat renderer: discs with a depth buffer and Lambert shading, tile-parallel.
//!
//! A splat is a centre, a world-space radius, a unit normal and an albedo. Each splat is drawn
//! as a screen-aligned disc of radius `radius · focal / depth` pixels (at least half a pixel, so
//! every splat in view covers its own pixel) at the depth of its centre; the nearest disc wins
//! each pixel. The colour is albedo · (ambient + (1 − ambient)·|n·l|) with a headlight l (the
//! direction from the point to the eye); `two_sided` lighting, so that normals need not be
//! oriented. Pixels no splat covers keep the background and are reported as uncovered (holes
//! are measured against that).
//!
//! Parallelism: splats are binned into 32 × 32 pixel tiles by their screen bounding box; tiles
//! are drawn independently with rayon. [`Canvas`] draws batch by batch into the same image, for
//! more splats than memory holds at once.

use cloud::Camera;
use cloud::glam::{DVec3, Vec3};
use rayon::prelude::*;

/// One splat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Splat {
    /// Centre.
    pub center: DVec3,
    /// World-space radius.
    pub radius: f32,
    /// Unit normal.
    pub normal: Vec3,
    /// Albedo, RGB in [0, 1].
    pub albedo: Vec3,
}

/// Rendering options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderParams {
    /// Background colour.
    pub background: [u8; 3],
    /// Ambient share of the light, in [0, 1].
    pub ambient: f32,
}

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            background: [255, 255, 255],
            ambient: 0.25,
        }
    }
}

/// A rendered image.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// RGB, row-major.
    pub rgb: Vec<u8>,
    /// Per pixel: covered by some splat.
    pub covered: Vec<bool>,
}

const TILE: u32 = 32;

struct Screen {
    x: f32,
    y: f32,
    r: f32,
    depth: f32,
    color: [u8; 3],
}

/// Renders `splats` as seen by `camera`.
pub fn render(splats: &[Splat], camera: &Camera, params: &RenderParams) -> Image {
    let mut canvas = Canvas::new(camera, params);
    canvas.draw(splats);
    canvas.finish()
}

/// An image drawn batch by batch: [`Canvas::draw`] any number of times, then
/// [`Canvas::finish`]; the image is [`render`]'s of all the batches' splats in order (the
/// nearer splat wins a pixel, the earlier one a tie), so a cloud larger than memory can be
/// rendered by streaming it (the `lod` experiment's reference for a built file). Memory: the
/// image's depth and colour, plus one batch.
#[derive(Debug, Clone)]
pub struct Canvas {
    camera: Camera,
    params: RenderParams,
    tiles_x: usize,
    /// Per tile: its depths and colours, row-major within the tile.
    tiles: Vec<(Vec<f32>, Vec<[u8; 3]>)>,
}

impl Canvas {
    /// An empty image (the background) for `camera`.
    pub fn new(camera: &Camera, params: &RenderParams) -> Self {
        let (w, h) = (camera.width, camera.height);
        let tiles_x = w.div_ceil(TILE) as usize;
        let tiles_y = h.div_ceil(TILE) as usize;
        let tiles = (0..tiles_x * tiles_y)
            .map(|t| {
                let (ox, oy) = ((t % tiles_x) as u32 * TILE, (t / tiles_x) as u32 * TILE);
                let size = (TILE.min(w - ox) * TILE.min(h - oy)) as usize;
                (vec![f32::INFINITY; size], vec![params.background; size])
            })
            .collect();
        Self {
            camera: *camera,
            params: *params,
            tiles_x,
            tiles,
        }
    }

    /// Draws `splats` over what is drawn.
    pub fn draw(&mut self, splats: &[Splat]) {
        let camera = &self.camera;
        let (w, h) = (camera.width, camera.height);
        let ambient = self.params.ambient.clamp(0.0, 1.0);
        let screen: Vec<Screen> = splats
            .par_iter()
            .filter_map(|s| {
                let p = camera.project(s.center)?;
                let r = (s.radius as f64 / camera.pixel_size_at(p.depth)).max(0.5) as f32;
                let (x, y) = (p.x as f32, p.y as f32);
                if x + r < 0.0 || y + r < 0.0 || x - r > w as f32 || y - r > h as f32 {
                    return None;
                }
                let to_eye = (camera.ray_origin_for(s.center) - s.center)
                    .normalize_or_zero()
                    .as_vec3();
                let shade = ambient + (1.0 - ambient) * s.normal.dot(to_eye).abs();
                let c = (s.albedo * shade).clamp(Vec3::ZERO, Vec3::ONE) * 255.0;
                Some(Screen {
                    x,
                    y,
                    r,
                    depth: p.depth as f32,
                    color: [c.x as u8, c.y as u8, c.z as u8],
                })
            })
            .collect();
        let tiles_x = self.tiles_x;
        let tiles_y = self.tiles.len() / tiles_x.max(1);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); self.tiles.len()];
        for (k, s) in screen.iter().enumerate() {
            let tx0 = ((s.x - s.r).max(0.0) as u32 / TILE) as usize;
            let ty0 = ((s.y - s.r).max(0.0) as u32 / TILE) as usize;
            let tx1 = (((s.x + s.r).min(w as f32 - 1.0)) as u32 / TILE) as usize;
            let ty1 = (((s.y + s.r).min(h as f32 - 1.0)) as u32 / TILE) as usize;
            for ty in ty0..=ty1.min(tiles_y - 1) {
                for tx in tx0..=tx1.min(tiles_x - 1) {
                    bins[ty * tiles_x + tx].push(k as u32);
                }
            }
        }
        self.tiles
            .par_iter_mut()
            .zip(bins.par_iter())
            .enumerate()
            .for_each(|(t, ((depth, color), list))| {
                let (ox, oy) = ((t % tiles_x) as u32 * TILE, (t / tiles_x) as u32 * TILE);
                let (tw, th) = (TILE.min(w - ox), TILE.min(h - oy));
                for &k in list {
                    let s = &screen[k as usize];
                    let x0 = (s.x - s.r).floor().max(ox as f32) as u32;
                    let y0 = (s.y - s.r).floor().max(oy as f32) as u32;
                    let x1 = ((s.x + s.r).ceil() as u32).min(ox + tw);
                    let y1 = ((s.y + s.r).ceil() as u32).min(oy + th);
                    let r2 = s.r * s.r;
                    for y in y0..y1 {
                        let dy = y as f32 + 0.5 - s.y;
                        for x in x0..x1 {
                            let dx = x as f32 + 0.5 - s.x;
                            if dx * dx + dy * dy > r2 {
                                continue;
                            }
                            let i = ((y - oy) * tw + (x - ox)) as usize;
                            if s.depth < depth[i] {
                                depth[i] = s.depth;
                                color[i] = s.color;
                            }
                        }
                    }
                }
            });
    }

    /// The image.
    pub fn finish(self) -> Image {
        let (w, h) = (self.camera.width, self.camera.height);
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        let mut covered = vec![false; (w * h) as usize];
        for (t, (depth, color)) in self.tiles.iter().enumerate() {
            let (ox, oy) = (
                (t % self.tiles_x) as u32 * TILE,
                (t / self.tiles_x) as u32 * TILE,
            );
            let tw = TILE.min(w - ox);
            for (i, (d, c)) in depth.iter().zip(color).enumerate() {
                let (x, y) = (ox + i as u32 % tw, oy + i as u32 / tw);
                let k = (y * w + x) as usize;
                rgb[3 * k..3 * k + 3].copy_from_slice(c);
                covered[k] = d.is_finite();
            }
        }
        Image {
            width: w,
            height: h,
            rgb,
            covered,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::ZERO,
            DVec3::Y,
            40.0,
            96,
            64,
        )
        .unwrap()
    }

    #[test]
    fn a_canvas_drawn_in_batches_is_the_whole_render() {
        // Many overlapping splats, ties included (equal depths: the earlier one wins).
        let splats: Vec<Splat> = (0..5_000)
            .map(|i| {
                let a = i as f64 * 0.37;
                Splat {
                    center: DVec3::new(a.cos() * 1.5, a.sin() * 1.0, (i % 7) as f64 * 0.1),
                    radius: 0.05 + (i % 5) as f32 * 0.03,
                    normal: Vec3::new(a.sin() as f32, 0.0, a.cos() as f32).normalize(),
                    albedo: Vec3::new((i % 3) as f32 / 2.0, (i % 11) as f32 / 10.0, 0.5),
                }
            })
            .collect();
        let whole = render(&splats, &cam(), &RenderParams::default());
        for batch in [1, 7, 1_000, 4_999] {
            let mut canvas = Canvas::new(&cam(), &RenderParams::default());
            for part in splats.chunks(batch) {
                canvas.draw(part);
            }
            assert_eq!(canvas.finish(), whole, "batches of {batch}");
        }
        assert!(whole.covered.iter().filter(|&&c| c).count() > 1_000);
    }

    #[test]
    fn nearer_splat_wins_and_is_lit_facing_the_eye() {
        let far = Splat {
            center: DVec3::ZERO,
            radius: 0.5,
            normal: Vec3::Z,
            albedo: Vec3::new(1.0, 0.0, 0.0),
        };
        let near = Splat {
            center: DVec3::new(0.0, 0.0, 1.0),
            radius: 0.1,
            normal: Vec3::Z,
            albedo: Vec3::new(0.0, 1.0, 0.0),
        };
        let img = render(&[far, near], &cam(), &RenderParams::default());
        let centre = (32 * 96 + 48) as usize;
        assert!(img.covered[centre]);
        assert_eq!(&img.rgb[3 * centre..3 * centre + 3], &[0, 255, 0]);
        // Off the near splat but on the far one: red, fully lit (normal faces the eye).
        let k = (32 * 96 + 56) as usize;
        assert!(img.rgb[3 * k] > 240 && img.rgb[3 * k + 1] == 0);
        // A corner: background, not covered.
        assert!(!img.covered[0]);
        assert_eq!(&img.rgb[0..3], &[255, 255, 255]);
    }

    #[test]
    fn grazing_splats_are_darker_and_tiles_agree_across_borders() {
        let lit = Splat {
            center: DVec3::ZERO,
            radius: 2.0,
            normal: Vec3::new(1.0, 0.0, 0.0),
            albedo: Vec3::ONE,
        };
        let img = render(&[lit], &cam(), &RenderParams::default());
        // Edge-on: only the ambient share.
        let k = (32 * 96 + 48) as usize;
        assert!(
            (img.rgb[3 * k] as f32 - 0.25 * 255.0).abs() < 2.0,
            "{}",
            img.rgb[3 * k]
        );
        // The disc spans several 32-pixel tiles and is covered without seams.
        let row: Vec<bool> = (20..76).map(|x| img.covered[32 * 96 + x]).collect();
        assert!(row.iter().all(|&c| c));
    }
}
