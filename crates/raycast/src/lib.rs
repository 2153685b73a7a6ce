//! `raycast`: point cloud filtering by ray casting (Eric Jensen, "Point Cloud Filtering using
//! Ray Casting", 2012; seed 001).
//!
//! One ray per pixel ([`rays::RayList`]: built once, re-aimed when the camera moves) is cast
//! through a point k-d tree ([`kdtree`]: one point per node, axes cycling X, Y, Z, bounds per
//! node, equal-plane flags, median split) with the seed's traversal S1–S9 ([`traverse`]) and
//! its circular-prism / sphere hit test ([`hit`]). The result per ray is the index of the point
//! it hits; a frame's visible set is the set of points hit by some ray. Seed 001's concurrent
//! update and render is [`concurrent`], on `cloud::double_buffer`.
//!
//! Points are spheres of radius R (world units), given or derived from the cloud's density
//! ([`auto::auto_radius`]); beyond the seed, they can be oriented discs of radius R instead
//! ([`Primitive::Disc`], with the cloud's normals: the surfels of splatting and of
//! point-cloud-utils' `RaySurfelIntersector`, so that the peer can be compared primitive for
//! primitive). The default traversal is exact (the nearest hit, equal to
//! the brute force of [`brute`] ray for ray); the seed's first-hit traversal is available as
//! [`Traversal::Seed`].
//!
//! PERF: rays are cast in parallel (rayon) in 8 × 8 pixel tiles, so neighbouring rays reuse
//! the same nodes; the tree is 64 bytes a node in preorder.

pub mod auto;
pub mod brute;
pub mod concurrent;
pub mod error;
pub mod hit;
pub mod kdtree;
pub mod rays;
pub mod traverse;

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

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
    tree: KdTree,
    n_points: usize,
    /// Unit normals in the tree's node order, for [`Primitive::Disc`].
    normals: Option<Vec<[f64; 3]>>,
}

const TILE: u32 = 8;

impl RayCaster {
    /// Builds the k-d tree of `points`.
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
            tree: KdTree::build(points),
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
        self.normals = Some(self.tree.in_node_order(&unit));
        Ok(self)
    }

    /// The tree.
    pub fn tree(&self) -> &KdTree {
        &self.tree
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
            Primitive::Sphere => self.cast_with(rays, camera, params, traverse::Sphere),
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
                self.cast_with(rays, camera, params, traverse::Disc(normals))
            }
        }
    }

    /// [`RayCaster::cast`] for points of `shape` (the seed traversal: spheres).
    fn cast_with(
        &self,
        rays: &RayList,
        camera: &Camera,
        params: &CastParams,
        shape: impl traverse::PointShape + Sync,
    ) -> Result<Frame> {
        let (w, h) = (rays.width, rays.height);
        let mut pixel_point = vec![NONE; rays.len()];
        // Rows of tiles in parallel; within a band, tile by tile.
        pixel_point
            .par_chunks_mut((w * TILE) as usize)
            .enumerate()
            .for_each_init(Scratch::default, |scratch, (band, out)| {
                let y0 = band as u32 * TILE;
                let rows = out.len() as u32 / w;
                for x0 in (0..w).step_by(TILE as usize) {
                    if params.traversal == Traversal::Exact {
                        let xs = x0..(x0 + TILE).min(w);
                        self.cast_packets(
                            rays,
                            camera,
                            (params.radius, shape),
                            (xs, y0, rows),
                            out,
                            scratch,
                        );
                        continue;
                    }
                    for dy in 0..rows {
                        for x in x0..(x0 + TILE).min(w) {
                            let k = ((y0 + dy) * w + x) as usize;
                            let (o, d) = rays.aim(camera, k);
                            let ray = Ray::new(o, d);
                            out[(dy * w + x) as usize] = traverse::cast(
                                &self.tree,
                                &ray,
                                params.radius,
                                params.traversal,
                                scratch,
                            )
                            .unwrap_or(NONE);
                        }
                    }
                }
            });
        let _ = h;
        let visible = visible_set(&pixel_point, self.n_points);
        Ok(Frame {
            pixel_point,
            visible,
            rays: rays.len() as u64,
        })
    }
}

impl RayCaster {
    /// The exact traversal over the pixels `xs` × `y0..y0 + rows` in 2 × 2 pixel packets
    /// ([`traverse::cast_exact_packet`]); `out` holds the band's rows from `y0`.
    fn cast_packets(
        &self,
        rays: &RayList,
        camera: &Camera,
        (radius, shape): (f64, impl traverse::PointShape),
        (xs, y0, rows): (std::ops::Range<u32>, u32, u32),
        out: &mut [u32],
        scratch: &mut Scratch,
    ) {
        let w = rays.width;
        for dy in (0..rows).step_by(2) {
            for x in xs.clone().step_by(2) {
                let mut at = [0usize; traverse::PACKET];
                let mut packet = [Ray::new([0.0; 3], [1.0; 3]); traverse::PACKET];
                let mut m = 0;
                for (ddy, ddx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    if dy + ddy >= rows || x + ddx >= xs.end {
                        continue;
                    }
                    let k = ((y0 + dy + ddy) * w + x + ddx) as usize;
                    let (o, d) = rays.aim(camera, k);
                    packet[m] = Ray::new(o, d);
                    at[m] = ((dy + ddy) * w + x + ddx) as usize;
                    m += 1;
                }
                let hits =
                    traverse::cast_exact_packet(&self.tree, &packet[..m], radius, shape, scratch);
                for i in 0..m {
                    out[at[i]] = hits[i].map_or(NONE, |h| h.1);
                }
            }
        }
    }
}

/// The points named by some pixel, ascending.
pub fn visible_set(pixel_point: &[u32], n_points: usize) -> Vec<u32> {
    let mut hit = vec![false; n_points];
    for &p in pixel_point {
        if p != NONE {
            hit[p as usize] = true;
        }
    }
    hit.iter()
        .enumerate()
        .filter_map(|(i, &h)| h.then_some(i as u32))
        .collect()
}

#[cfg(test)]
mod tests;
