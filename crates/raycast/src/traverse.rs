//! Casting one ray through the k-d tree: seed 001's steps S1–S9, iteratively.
//!
//! The seed's summary, for a node whose splitting plane is x_a = s:
//! - S1: test whether the ray is on the splitting plane; store.
//! - S2: if not, traverse the child closest to the origin; if it is, traverse the child that
//!   holds points on the plane (the "equal-axis child", recorded at build time).
//! - S3: if that child returned a point, return it.
//! - S4–S5: test the node's own point (the Boolean form of [`crate::hit`]); on a hit return it.
//! - S6: test whether the ray meets the node's splitting plane within the node's range.
//! - S7–S8: if so, traverse the remaining child and return its point.
//! - S9: return empty.
//!
//! Interpretation notes (NOTE): the printed S6 reads "If S1 is false, return empty", which
//! contradicts the prose above it ("If intersect occurs, traverse the child closest to the
//! origin, then traverse the other child"); we follow the prose: the far child is skipped only
//! when the ray lies in the plane (S1 true). "The ray is on the splitting plane" is read as the
//! ray lying in it (origin on the plane, direction parallel to it); an origin on the plane with
//! a direction leaving it takes the side the direction points to. The seed leaves the
//! "intersection testing" of S6 "to be written up later": we test the ray against the plane
//! within the node's bounds, enlarged by the point radius.
//!
//! Two traversals ([`Traversal`]):
//! - [`Traversal::Seed`]: this module, as printed: nearest child first and the *first hit ends
//!   the search*. Points are spheres of radius R, so a point in the near child can be hit after
//!   a point in the far child would have been, and a sphere straddling a plane can be missed;
//!   this mode returns *a* hit, not always the nearest.
//! - [`Traversal::Exact`] (default, beyond the seed): the hit with the smallest entry parameter
//!   (ties: lowest index), exactly what the brute force of [`crate::brute`] returns, from the
//!   bucketed hierarchy of [`crate::bvh`] cast a packet at a time by [`crate::packet`].

use crate::hit::hits;
use crate::kdtree::{KdTree, NONE, Node};
use crate::packet::{Packet, Stack};

/// Which traversal to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Traversal {
    /// Nearest hit, exact ([`crate::packet`]).
    #[default]
    Exact,
    /// Seed 001's S1–S9 with first hit ends.
    Seed,
}

/// A ray with its precomputed reciprocal direction.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub o: [f64; 3],
    /// Direction (need not be unit).
    pub d: [f64; 3],
    inv: [f64; 3],
}

impl Ray {
    /// A ray from `o` along `d`.
    #[inline(always)]
    pub fn new(o: [f64; 3], d: [f64; 3]) -> Self {
        Self {
            o,
            d,
            inv: [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]],
        }
    }
}

/// Node `at`'s children for `ray`, nearest first: the child on the origin's side of the
/// splitting plane (an origin on the plane takes the side its direction points to).
#[inline(always)]
fn near_far(ray: &Ray, n: &Node, at: u32) -> (u32, u32) {
    let (a, s) = (n.axis(), n.split());
    if ray.o[a] < s || (ray.o[a] == s && ray.d[a] < 0.0) {
        (n.left(at), n.right)
    } else {
        (n.right, n.left(at))
    }
}

/// Reusable traversal scratch (one per thread): the seed traversal's frames, the exact
/// traversal's packet and stack.
#[derive(Debug, Default)]
pub struct Scratch {
    frames: Vec<Frame>,
    /// A packet of rays ([`crate::packet`]).
    pub packet: Box<Packet>,
    /// The packet traversal's stack.
    pub stack: Stack,
}

#[derive(Debug, Clone, Copy)]
struct Frame {
    node: u32,
    /// 0: start (S1–S2); 1: near child done (S3–S7); 2: far child done (S8).
    stage: u8,
    on_plane: bool,
}

/// Seed 001's S1–S9 with an explicit stack: the first hit ends the search.
pub fn cast_seed(tree: &KdTree, ray: &Ray, radius: f64, scratch: &mut Scratch) -> Option<u32> {
    let nodes = &tree.nodes;
    if nodes.is_empty() {
        return None;
    }
    let r2 = radius * radius;
    let frames = &mut scratch.frames;
    frames.clear();
    frames.push(Frame {
        node: 0,
        stage: 0,
        on_plane: false,
    });
    // The answer of the call that just returned.
    let mut found: Option<u32> = None;
    while let Some(top) = frames.last_mut() {
        let at = top.node;
        let n = &nodes[at as usize];
        let a = n.axis();
        let s = n.split();
        match top.stage {
            0 => {
                // S1: does the ray lie in the splitting plane?
                let on_plane = ray.o[a] == s && ray.d[a] == 0.0;
                top.on_plane = on_plane;
                top.stage = 1;
                // S2: the child closest to the origin, or the child with points on the plane.
                let child = if !on_plane {
                    near_far(ray, n, at).0
                } else if n.equal_in_back() {
                    n.left(at)
                } else if n.equal_in_front() {
                    n.right
                } else {
                    NONE
                };
                found = None;
                if child != NONE {
                    frames.push(Frame {
                        node: child,
                        stage: 0,
                        on_plane: false,
                    });
                }
            }
            1 => {
                // S3: the near child's point.
                if found.is_some() {
                    frames.pop();
                    continue;
                }
                // S4–S5: this node's point.
                if hits(&ray.o, &ray.d, &n.p, r2) {
                    found = Some(n.index);
                    frames.pop();
                    continue;
                }
                // S6: a ray in the plane has nothing more to see; otherwise, does it meet the
                // plane within the node's (radius-enlarged) range, ahead of the origin?
                let far = near_far(ray, n, at).1;
                if top.on_plane || far == NONE || !crosses_plane_in_range(ray, n, radius) {
                    // S9.
                    found = None;
                    frames.pop();
                    continue;
                }
                // S7: the remaining child.
                top.stage = 2;
                found = None;
                frames.push(Frame {
                    node: far,
                    stage: 0,
                    on_plane: false,
                });
            }
            _ => {
                // S8: whatever the far child returned.
                frames.pop();
            }
        }
    }
    found
}

/// S6's test: the ray meets the node's splitting plane at a parameter ≥ 0, at a point inside
/// the node's bounds enlarged by `radius` on the other two axes.
#[inline(always)]
fn crosses_plane_in_range(ray: &Ray, n: &Node, radius: f64) -> bool {
    let a = n.axis();
    if ray.d[a] == 0.0 {
        return false;
    }
    let t = (n.split() - ray.o[a]) * ray.inv[a];
    if t < 0.0 {
        return false;
    }
    (0..3).filter(|&k| k != a).all(|k| {
        let x = ray.o[k] + t * ray.d[k];
        x >= n.lo[k] as f64 - radius && x <= n.hi[k] as f64 + radius
    })
}
