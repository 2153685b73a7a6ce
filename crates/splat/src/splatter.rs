//! What both z-buffer selection rules share ([`crate::visibility`]'s disc rule and
//! [`crate::sprite`]'s point sprites): the cloud prepared for splatting ([`Splatter`]: f32
//! positions relative to their centroid, in Morton order; its projection), the parameters and
//! the outcome, the buffers reused from view to view ([`SplatScratch`]) and the nearest item per
//! pixel without atomics ([`nearest_per_cell`]).

use cloud::glam::{DVec3, Vec3A};
use cloud::{Camera, Model};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Which z-buffer selection rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Rule {
    /// This module's: a disc of `radius_px` centred on the point's pixel, a relative tolerance
    /// at the point's own pixel.
    #[default]
    Disc,
    /// A GPU point renderer's ([`crate::sprite`]): a square sprite of 2 × `radius_px` pixels
    /// at the exact projection, one world tolerance along the view axis.
    Sprite,
}

/// Parameters of the splat baseline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplatParams {
    /// Splat radius in pixels (with [`Rule::Sprite`], half the sprite's side).
    pub radius_px: f64,
    /// Relative depth tolerance (with [`Rule::Sprite`], relative to the eye's distance to the
    /// cloud's centroid).
    pub depth_tolerance: f64,
    /// The selection rule.
    pub rule: Rule,
}

impl Default for SplatParams {
    fn default() -> Self {
        Self {
            radius_px: 2.0,
            depth_tolerance: 0.01,
            rule: Rule::Disc,
        }
    }
}

/// The outcome of one splat pass.
#[derive(Debug, Clone)]
pub struct SplatVisibility {
    /// Indices of the visible points, ascending.
    pub visible: Vec<u32>,
    /// Per pixel (row-major, camera resolution): the index of the point whose splat is nearest
    /// there, or `u32::MAX` where no splat reaches (empty when not asked for).
    pub pixel_point: Vec<u32>,
}

pub(crate) const EMPTY: u64 = u64::MAX;
pub(crate) const OFF: u16 = u16::MAX;

#[inline]
pub(crate) fn pack(depth: f32, index: u32) -> u64 {
    // Positive finite f32 values order like their bit patterns.
    (u64::from(depth.to_bits()) << 32) | u64::from(index)
}

#[inline]
pub(crate) fn unpack_depth(v: u64) -> f32 {
    f32::from_bits((v >> 32) as u32)
}

/// The nearest item per cell: `private[0]` becomes `cells` packed (depth, item index) minima,
/// `EMPTY` where no item lands (`cell_of`: an item's cell and depth, or `None`). PERF: no
/// atomics (x86 has no atomic minimum; a compare-and-swap loop per point cost 30 ms on 871k
/// points): each thread keeps its share of the items in a private buffer, and the buffers are
/// merged.
pub(crate) fn nearest_per_cell<T: Sync>(
    items: &[T],
    cells: usize,
    private: &mut Vec<Vec<u64>>,
    cell_of: impl Fn(usize, &T) -> Option<(usize, f32)> + Sync,
) {
    let threads = rayon::current_num_threads().max(1);
    let share = items.len().div_ceil(threads).max(1);
    private.resize_with(threads, Vec::new);
    private.par_iter_mut().enumerate().for_each(|(t, out)| {
        out.clear();
        out.resize(cells, EMPTY);
        let start = (t * share).min(items.len());
        let end = ((t + 1) * share).min(items.len());
        for (i, item) in items[start..end].iter().enumerate() {
            if let Some((k, z)) = cell_of(start + i, item) {
                out[k] = out[k].min(pack(z, (start + i) as u32));
            }
        }
    });
    let (nearest, rest) = private.split_at_mut(1);
    nearest[0]
        .par_chunks_mut(4096)
        .enumerate()
        .for_each(|(c, chunk)| {
            for other in rest.iter() {
                for (a, &b) in chunk.iter_mut().zip(&other[c * 4096..]) {
                    *a = (*a).min(b);
                }
            }
        });
}

/// Buffers reused from one view to the next (no page faults on the hot path).
#[derive(Debug, Default)]
pub struct SplatScratch {
    pub(crate) projected: Vec<(u16, u16, f32)>,
    pub(crate) private: Vec<Vec<u64>>,
    pub(crate) horizontal: Vec<Vec<u64>>,
    pub(crate) splatted: Vec<u64>,
    pub(crate) depth: Vec<f32>,
}

/// A cloud prepared for splatting.
#[derive(Debug, Clone)]
pub struct Splatter {
    pub(crate) origin: DVec3,
    /// Positions relative to `origin`, f32 (SIMD-aligned), in Morton order.
    pub(crate) pos: Vec<Vec3A>,
    /// Input index of each stored position.
    pub(crate) perm: Vec<u32>,
    /// The points' mean (f64).
    pub(crate) centroid: DVec3,
}

impl Splatter {
    /// Prepares `points` (finite).
    pub fn new(points: &[DVec3]) -> Result<Self> {
        if points.len() >= u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                reason: "more than 2^32 - 1 points".into(),
            });
        }
        cloud::points::check_finite(points)?;
        if points.is_empty() {
            return Ok(Self {
                origin: DVec3::ZERO,
                pos: Vec::new(),
                perm: Vec::new(),
                centroid: DVec3::ZERO,
            });
        }
        let bbox = cloud::Aabb::from_points(points).ok_or(cloud::Error::EmptyCloud)?;
        let origin = bbox.center();
        let extent = bbox.extent().max_element().max(f64::MIN_POSITIVE);
        let mut keyed: Vec<(u64, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let q = ((*p - bbox.min) / extent * 1_048_575.0).as_uvec3();
                (morton(q.x, q.y, q.z), i as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        let perm: Vec<u32> = keyed.iter().map(|k| k.1).collect();
        let pos = perm
            .par_iter()
            .map(|&i| Vec3A::from((points[i as usize] - origin).as_vec3()))
            .collect();
        // Summed in order, so that it is the same to the bit from run to run.
        let centroid = points.iter().copied().sum::<DVec3>() / points.len() as f64;
        Ok(Self {
            origin,
            pos,
            perm,
            centroid,
        })
    }

    /// Stored positions (relative to the bounding box's centre, f32, Morton order).
    pub(crate) fn positions(&self) -> &[Vec3A] {
        &self.pos
    }

    /// Input index of each stored position.
    pub(crate) fn permutation(&self) -> &[u32] {
        &self.perm
    }

    /// The points' mean.
    pub fn centroid(&self) -> DVec3 {
        self.centroid
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// The projection every splat uses: (pixel x, pixel y, depth) of stored point `k`, or
    /// `None` behind the eye or outside the image; the camera's model (`cloud::camera`) in f32.
    #[inline(always)]
    pub(crate) fn projector(
        &self,
        camera: &Camera,
    ) -> impl Fn(Vec3A) -> Option<(u16, u16, f32)> + Sync + use<> {
        let project = self.projector_f32(camera);
        move |p: Vec3A| project(p).map(|(x, y, z)| (x as u16, y as u16, z))
    }

    /// [`Self::projector`] with the sub-pixel position: (x, y, depth) in [0, w) × [0, h).
    #[inline(always)]
    pub(crate) fn projector_f32(
        &self,
        camera: &Camera,
    ) -> impl Fn(Vec3A) -> Option<(f32, f32, f32)> + Sync + use<> {
        let eye = Vec3A::from((camera.eye - self.origin).as_vec3());
        let (fwd, right, down) = (
            Vec3A::from(camera.forward().as_vec3()),
            Vec3A::from(camera.right().as_vec3()),
            Vec3A::from(camera.down().as_vec3()),
        );
        let (w, h) = (camera.width as f32, camera.height as f32);
        // (scale x, scale y, offset x, offset y) of the two planar models.
        #[derive(Clone, Copy)]
        enum P {
            Pinhole(f32, f32, f32, f32),
            Ortho(f32, f32),
            Sphere,
        }
        let model = match *camera.model() {
            Model::Pinhole { fx, fy, cx, cy } => {
                P::Pinhole(fx as f32, fy as f32, cx as f32, cy as f32)
            }
            Model::Orthographic {
                view_width,
                view_height,
            } => P::Ortho(w / view_width as f32, h / view_height as f32),
            Model::Spherical => P::Sphere,
        };
        move |p: Vec3A| {
            let v = p - eye;
            let (x, y, z) = match model {
                P::Pinhole(fx, fy, cx, cy) => {
                    let z = v.dot(fwd);
                    let k = 1.0 / z;
                    (cx + fx * v.dot(right) * k, cy + fy * v.dot(down) * k, z)
                }
                P::Ortho(sx, sy) => (
                    0.5 * w + v.dot(right) * sx,
                    0.5 * h + v.dot(down) * sy,
                    v.dot(fwd),
                ),
                P::Sphere => {
                    use std::f32::consts::PI;
                    let z = v.length();
                    let phi = v.dot(right).atan2(v.dot(fwd));
                    let theta = (-v.dot(down) / z).clamp(-1.0, 1.0).acos();
                    let x = w * (0.5 + phi / (2.0 * PI));
                    (if x >= w { x - w } else { x }, h * theta / PI, z)
                }
            };
            (z > 0.0 && x >= 0.0 && y >= 0.0 && x < w && y < h).then_some((x, y, z))
        }
    }

    /// An upper bound of the bytes one view allocates. Per pixel: a private nearest-point
    /// buffer per thread, the filtered and splatted buffers, the depth and the per-pixel output
    /// (8 B each but the last two, 4 B); per point: its projection (12 B) and the visible set.
    /// `tests/memory_estimates.rs` checks it against the measured peak.
    pub fn memory_estimate(&self, camera: &Camera) -> u128 {
        let threads = rayon::current_num_threads().max(1) as u64;
        cloud::memory::image_bytes(camera.width, camera.height, 8 * threads + 8 + 8 + 4 + 4, 1)
            + 17 * self.pos.len() as u128
            + (1 << 16)
    }
}

/// Interleaves the low 20 bits of x, y and z (Morton order).
fn morton(x: u32, y: u32, z: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = u64::from(v) & 0xf_ffff;
        v = (v | (v << 32)) & 0x000f_0000_0000_ffff;
        v = (v | (v << 16)) & 0x000f_0000_ff00_00ff;
        v = (v | (v << 8)) & 0x000f_00f0_0f00_f00f;
        v = (v | (v << 4)) & 0x00c3_0c30_c30c_30c3;
        v = (v | (v << 2)) & 0x0249_2492_4924_9249;
        v
    }
    (spread(x) << 2) | (spread(y) << 1) | spread(z)
}
