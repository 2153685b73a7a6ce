//! `raycast`: point cloud filtering by ray casting (Eric Jensen, "Point Cloud Filtering using
//! Ray Casting", 2012; seed 001).
//!
//! One ray per pixel ([`rays::RayList`]: built once, re-aimed when the camera moves) finds the
//! point it hits; a frame's visible set is the set of points hit by some ray. Two traversals
//! ([`Traversal`]):
//! - [`Traversal::Seed`]: the seed's, as printed: a point k-d tree ([`kdtree`]: one point per
//!   node, axes cycling X, Y, Z, bounds per node, equal-plane flags, median split) walked by
//!   the steps S1–S9 ([`traverse`]) with its circular-prism / sphere hit test ([`hit`]); the
//!   first hit ends the search, so a ray gets *a* hit, not always the nearest.
//! - [`Traversal::Exact`] (default, beyond the seed): the nearest hit (smallest entry parameter,
//!   ties by lowest index), equal to the brute force of [`brute`] ray for ray, from a bounding
//!   volume hierarchy over buckets of points ([`bvh`]) cast an 8 × 8 pixel tile at a time,
//!   with `f32` culling and `f64` decisions ([`packet`]).
//!
//! Seed 001's concurrent update and render is [`concurrent`], on `cloud::double_buffer`.
//!
//! Points are spheres of radius R (world units), given or derived from the cloud's density
//! ([`auto::auto_radius`]); beyond the seed, they can be oriented discs of radius R instead
//! ([`Primitive::Disc`], with the cloud's normals: the surfels of splatting and of
//! point-cloud-utils' `RaySurfelIntersector`, so that the peer can be compared primitive for
//! primitive), with the exact traversal.
//!
//! PERF: tiles are cast in parallel (rayon), a band of tile rows per task. The seed's tree is
//! built when the seed traversal first needs it ([`RayCaster::tree`]), from the hierarchy's
//! points.

pub mod auto;
pub mod brute;
pub mod bvh;
pub mod concurrent;
pub mod error;
pub mod hit;
pub mod kdtree;
pub mod packet;
pub mod rays;
mod simd;
pub mod traverse;

use std::sync::OnceLock;

use cloud::glam::DVec3;
use cloud::{Camera, Model};
use rayon::prelude::*;

pub use bvh::Bvh;
pub use error::{Error, Result};
pub use kdtree::{KdTree, NONE};
pub use rays::{RayList, memory_estimate};
pub use traverse::{Ray, Scratch, Traversal};

/// What a point is to a ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Primitive {
    /// Seed 001's sphere of radius R.
    #[default]
    Sphere,
    /// An oriented disc of radius R around the point, perpendicular to its normal
    /// ([`RayCaster::with_normals`]); exact traversal only.
    Disc,
}

/// How to cast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CastParams {
    /// Point radius, world units.
    pub radius: f64,
    /// Traversal.
    pub traversal: Traversal,
    /// The points' primitive.
    pub primitive: Primitive,
}

/// One frame's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Per pixel (row-major): the point hit, or [`NONE`].
    pub pixel_point: Vec<u32>,
    /// Points hit by some ray, ascending.
    pub visible: Vec<u32>,
    /// Rays cast.
    pub rays: u64,
}

/// A cloud prepared for casting.
#[derive(Debug, Clone)]
pub struct RayCaster {
    bvh: Bvh,
    /// The seed traversal's tree, built on first use.
    seed: OnceLock<KdTree>,
    n_points: usize,
    /// Unit normals by slot of the hierarchy, for [`Primitive::Disc`].
    normals: Option<Vec<[f64; 3]>>,
}

const TILE: u32 = 8;

impl RayCaster {
    /// Builds the hierarchy of `points` for the exact traversal.
    pub fn new(points: &[DVec3]) -> Result<Self> {
        if points.is_empty() {
            return Err(Error::EmptyCloud);
        }
        if points.len() >= u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                reason: "more than 2^32 - 1 points".into(),
            });
        }
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return Err(Error::NonFinite(i));
        }
        Ok(Self {
            bvh: Bvh::build(points),
            seed: OnceLock::new(),
            n_points: points.len(),
            normals: None,
        })
    }

    /// Gives the points normals (one per point, any length but zero; `f64` or a cloud's `f32`),
    /// for [`Primitive::Disc`].
    pub fn with_normals<N: Copy + Into<DVec3>>(mut self, normals: &[N]) -> Result<Self> {
        if normals.len() != self.n_points {
            return Err(Error::InvalidParameter {
                name: "normals",
                reason: format!("{} normals for {} points", normals.len(), self.n_points),
            });
        }
        let mut unit = Vec::with_capacity(normals.len());
        for (i, nrm) in normals.iter().enumerate() {
            let nrm: DVec3 = (*nrm).into();
            let len = nrm.length();
            if !(len > 0.0) || !len.is_finite() {
                return Err(Error::InvalidParameter {
                    name: "normals",
                    reason: format!("normal {i} is {nrm}: not a direction"),
                });
            }
            unit.push((nrm / len).to_array());
        }
        self.normals = Some(self.bvh.in_slot_order(&unit, [f64::NAN; 3]));
        Ok(self)
    }

    /// The exact traversal's hierarchy.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The seed traversal's k-d tree, built from the points on the first call.
    pub fn tree(&self) -> &KdTree {
        self.seed.get_or_init(|| KdTree::build(&self.bvh.points()))
    }

    /// Casts every ray of `rays`, aimed for `camera`.
    pub fn cast(&self, rays: &RayList, camera: &Camera, params: &CastParams) -> Result<Frame> {
        rays.check(camera)?;
        if !(params.radius > 0.0) || !params.radius.is_finite() {
            return Err(Error::InvalidParameter {
                name: "radius",
                reason: format!("must be positive and finite, got {}", params.radius),
            });
        }
        match params.primitive {
            Primitive::Sphere => Ok(self.cast_with(rays, camera, params, packet::Sphere)),
            Primitive::Disc => {
                let Some(normals) = &self.normals else {
                    return Err(Error::InvalidParameter {
                        name: "primitive",
                        reason: "discs need the points' normals (RayCaster::with_normals)".into(),
                    });
                };
                if params.traversal != Traversal::Exact {
                    return Err(Error::InvalidParameter {
                        name: "primitive",
                        reason: "discs take the exact traversal (the seed's S1-S9 tests spheres)"
                            .into(),
                    });
                }
                Ok(self.cast_with(rays, camera, params, packet::Disc(normals)))
            }
        }
    }

    /// [`RayCaster::cast`] for points of `shape` (the seed traversal: spheres).
    fn cast_with(
        &self,
        rays: &RayList,
        camera: &Camera,
        params: &CastParams,
        shape: impl packet::SlotShape + Sync,
    ) -> Frame {
        let w = rays.width;
        let mut pixel_point = vec![NONE; rays.len()];
        let seed = (params.traversal == Traversal::Seed).then(|| self.tree());
        let window = self.window(camera, params.radius);
        // Bands of tile rows in parallel; within a band, tile by tile.
        pixel_point
            .par_chunks_mut((w * TILE) as usize)
            .enumerate()
            .for_each_init(Scratch::default, |scratch, (band, out)| {
                let y0 = band as u32 * TILE;
                let rows = out.len() as u32 / w;
                if window.is_some_and(|win| !win.meets(0..w, y0..y0 + rows)) {
                    return;
                }
                for x0 in (0..w).step_by(TILE as usize) {
                    let xs = x0..(x0 + TILE).min(w);
                    if window.is_some_and(|win| !win.meets(xs.clone(), y0..y0 + rows)) {
                        continue;
                    }
                    if let Some(tree) = seed {
                        for dy in 0..rows {
                            for x in xs.clone() {
                                let (o, d) = rays.aim(camera, ((y0 + dy) * w + x) as usize);
                                out[(dy * w + x) as usize] = traverse::cast_seed(
                                    tree,
                                    &Ray::new(o, d),
                                    params.radius,
                                    scratch,
                                )
                                .unwrap_or(NONE);
                            }
                        }
                        continue;
                    }
                    let p = &mut scratch.packet;
                    p.clear();
                    for dy in 0..rows {
                        let row = ((y0 + dy) * w) as usize;
                        for x in xs.clone() {
                            let (o, d) = rays.aim(camera, row + x as usize);
                            p.push(o, d);
                        }
                    }
                    packet::cast(&self.bvh, p, params.radius, shape, &mut scratch.stack);
                    let mut i = 0;
                    for dy in 0..rows {
                        let row = (dy * w) as usize;
                        for x in xs.clone() {
                            out[row + x as usize] = p.index(i);
                            i += 1;
                        }
                    }
                }
            });
        let visible = visible_set(&pixel_point, self.n_points);
        Frame {
            pixel_point,
            visible,
            rays: rays.len() as u64,
        }
    }
}

impl RayCaster {
    /// The pixels whose rays can meet the cloud's box enlarged by `radius`: the box's corners
    /// projected, for a pinhole or orthographic camera with the box wholly in front of it (the
    /// projection of a convex body in front of the eye is the convex hull of its corners'
    /// projections); `None` otherwise. The box is enlarged by the traversal's margin too, and
    /// the window by a pixel, beyond the rounding of rays and projections.
    fn window(&self, camera: &Camera, radius: f64) -> Option<Window> {
        if !matches!(
            camera.model(),
            Model::Pinhole { .. } | Model::Orthographic { .. }
        ) {
            return None;
        }
        let root = self.bvh.node(0);
        let c = self.bvh.centre;
        let pad = radius * 1.001 + (self.bvh.half_extent + radius) * 1e-5;
        let lo: [f64; 3] = std::array::from_fn(|k| root.lo[k] as f64 + c[k] - pad);
        let hi: [f64; 3] = std::array::from_fn(|k| root.hi[k] as f64 + c[k] + pad);
        let mut win = Window {
            x: (f64::INFINITY, f64::NEG_INFINITY),
            y: (f64::INFINITY, f64::NEG_INFINITY),
        };
        for corner in 0..8 {
            let pick = |k: usize| if corner >> k & 1 == 0 { lo[k] } else { hi[k] };
            let q = camera.project(DVec3::new(pick(0), pick(1), pick(2)))?;
            win.x = (win.x.0.min(q.x - 1.0), win.x.1.max(q.x + 1.0));
            win.y = (win.y.0.min(q.y - 1.0), win.y.1.max(q.y + 1.0));
        }
        (win.x.0.is_finite() && win.x.1.is_finite() && win.y.0.is_finite() && win.y.1.is_finite())
            .then_some(win)
    }
}

/// A rectangle of the image, in pixel coordinates, outside which no ray meets the cloud.
#[derive(Debug, Clone, Copy)]
struct Window {
    x: (f64, f64),
    y: (f64, f64),
}

impl Window {
    /// True when the centre of some pixel of `xs` × `ys` lies in the window.
    fn meets(&self, xs: std::ops::Range<u32>, ys: std::ops::Range<u32>) -> bool {
        let (x0, x1) = (xs.start as f64 + 0.5, xs.end as f64 - 0.5);
        let (y0, y1) = (ys.start as f64 + 0.5, ys.end as f64 - 0.5);
        x1 >= self.x.0 && x0 <= self.x.1 && y1 >= self.y.0 && y0 <= self.y.1
    }
}

/// The points named by some pixel, ascending.
pub fn visible_set(pixel_point: &[u32], n_points: usize) -> Vec<u32> {
    let mut bits = vec![0u64; n_points.div_ceil(64)];
    for &p in pixel_point {
        if p != NONE {
            bits[(p >> 6) as usize] |= 1 << (p & 63);
        }
    }
    let count = bits.iter().map(|b| b.count_ones() as usize).sum();
    let mut out = Vec::with_capacity(count);
    for (w, &b) in bits.iter().enumerate() {
        let mut b = b;
        while b != 0 {
            out.push((w * 64) as u32 + b.trailing_zeros());
            b &= b - 1;
        }
    }
    out
}

#[cfg(test)]
mod tests;
