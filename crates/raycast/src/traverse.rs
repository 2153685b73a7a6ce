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
//! Two traversals share this skeleton ([`Traversal`]):
//! - [`Traversal::Seed`]: as printed: nearest child first and the *first hit ends the search*.
//!   Points are spheres of radius R, so a point in the near child can be hit after a point in
//!   the far child would have been, and a sphere straddling a plane can be missed; this mode
//!   returns *a* hit, not always the nearest.
//! - [`Traversal::Exact`] (default): the same near-first order, with each subtree entered only
//!   if the ray meets its bounds enlarged by R before the best hit so far; the first hit ends
//!   the search once nothing nearer can follow. It returns the hit with the smallest entry
//!   parameter (ties: lowest index), exactly what the brute force of [`crate::brute`] returns.
//!
//! The exact traversal takes the point's shape ([`PointShape`]): seed 001's [`Sphere`], or an
//! oriented [`Disc`] (beyond the seed, [`crate::hit::disc_entry`]); a disc lies inside its
//! sphere, so the same enlarged bounds prune both soundly.

use crate::hit::{disc_entry, entry, hits};
use crate::kdtree::{KdTree, NONE, Node};

/// Which traversal to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Traversal {
    /// Nearest hit, exact (pruned by subtree bounds).
    #[default]
    Exact,
    /// Seed 001's S1–S9 with first hit ends.
    Seed,
}

/// What a point is to a ray in the exact traversal: the ray parameter of its hit on node
/// `at`'s point. A generic parameter, so each primitive gets its own compiled traversal.
pub trait PointShape: Copy {
    /// The hit parameter of `ray` on node `at`'s point (radius² `r2`), or `None`.
    fn entry(&self, ray: &Ray, n: &Node, at: u32, r2: f64) -> Option<f64>;
}

/// Seed 001's sphere of radius R.
#[derive(Debug, Clone, Copy)]
pub struct Sphere;

impl PointShape for Sphere {
    #[inline(always)]
    fn entry(&self, ray: &Ray, n: &Node, _at: u32, r2: f64) -> Option<f64> {
        entry(&ray.o, &ray.d, &n.p, r2)
    }
}

/// An oriented disc of radius R; the unit normals in the tree's node order
/// ([`crate::KdTree::in_node_order`]).
#[derive(Debug, Clone, Copy)]
pub struct Disc<'a>(pub &'a [[f64; 3]]);

impl PointShape for Disc<'_> {
    #[inline(always)]
    fn entry(&self, ray: &Ray, n: &Node, at: u32, r2: f64) -> Option<f64> {
        disc_entry(&ray.o, &ray.d, &n.p, &self.0[at as usize], r2)
    }
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

/// How far the exact traversal enlarges node bounds for `ray`: the radius plus a relative
/// margin, so that rounding in the slab test never makes a subtree look farther than a sphere
/// inside it.
#[inline(always)]
fn bounds_pad(ray: &Ray, radius: f64) -> f64 {
    radius * (1.0 + 1e-9) + 1e-12 * (1.0 + ray.o.iter().fold(0.0f64, |m, c| m.max(c.abs())))
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

/// Reusable traversal scratch (one per thread).
#[derive(Debug, Default)]
pub struct Scratch {
    stack: Vec<u32>,
    frames: Vec<Frame>,
    packet: Vec<(u32, u8)>,
}

/// Entry parameter of the ray into the node's bounds enlarged by `pad`, or `None` on a miss.
#[inline(always)]
fn box_entry(ray: &Ray, n: &Node, pad: f64) -> Option<f64> {
    let mut t0 = 0.0f64;
    let mut t1 = f64::INFINITY;
    for k in 0..3 {
        let lo = n.lo[k] as f64 - pad;
        let hi = n.hi[k] as f64 + pad;
        if ray.d[k] == 0.0 {
            if ray.o[k] < lo || ray.o[k] > hi {
                return None;
            }
        } else {
            let a = (lo - ray.o[k]) * ray.inv[k];
            let b = (hi - ray.o[k]) * ray.inv[k];
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
    }
    (t0 <= t1).then_some(t0)
}

/// The exact traversal: the hit with the smallest entry parameter, ties by lowest index.
pub fn cast_exact(
    tree: &KdTree,
    ray: &Ray,
    radius: f64,
    scratch: &mut Scratch,
) -> Option<(f64, u32)> {
    cast_exact_with(tree, ray, radius, Sphere, scratch)
}

/// [`cast_exact`] for points of `shape`.
pub fn cast_exact_with(
    tree: &KdTree,
    ray: &Ray,
    radius: f64,
    shape: impl PointShape,
    scratch: &mut Scratch,
) -> Option<(f64, u32)> {
    let nodes = &tree.nodes;
    if nodes.is_empty() {
        return None;
    }
    let r2 = radius * radius;
    let pad = bounds_pad(ray, radius);
    let mut best_t = f64::INFINITY;
    let mut best = NONE;
    let stack = &mut scratch.stack;
    stack.clear();
    stack.push(0);
    while let Some(at) = stack.pop() {
        let n = &nodes[at as usize];
        match box_entry(ray, n, pad) {
            Some(t) if t <= best_t => {}
            _ => continue,
        }
        if let Some(t) = shape.entry(ray, n, at, r2)
            && (t < best_t || (t == best_t && n.index < best))
        {
            best_t = t;
            best = n.index;
        }
        // Near child last on the stack, so it is popped first.
        let (near, far) = near_far(ray, n, at);
        if far != NONE {
            stack.push(far);
        }
        if near != NONE {
            stack.push(near);
        }
    }
    (best != NONE).then_some((best_t, best))
}

/// Rays in a packet of [`cast_exact_packet`].
pub const PACKET: usize = 4;

/// [`cast_exact`] for up to [`PACKET`] rays at once (neighbouring pixels): one walk of the
/// tree, each node fetched and each stack step taken once for the packet, each ray testing
/// only the nodes whose enlarged bounds it enters before its own best hit (a mask carried
/// down the stack: bounds are nested, so a ray pruned at a node stays pruned below it).
///
/// Every ray gets exactly what [`cast_exact`] gives it: its answer is the smallest (entry
/// parameter, index) over the points it hits, and its own pruning is the same sound test;
/// the packet only changes the order in which nodes are visited (the first ray's near-first
/// order), which the minimum does not depend on.
pub fn cast_exact_packet(
    tree: &KdTree,
    rays: &[Ray],
    radius: f64,
    shape: impl PointShape,
    scratch: &mut Scratch,
) -> [Option<(f64, u32)>; PACKET] {
    let mut out = [None; PACKET];
    let nodes = &tree.nodes;
    let m = rays.len().min(PACKET);
    if nodes.is_empty() || m == 0 {
        return out;
    }
    let r2 = radius * radius;
    let mut pad = [0.0; PACKET];
    for (p, ray) in pad.iter_mut().zip(rays) {
        *p = bounds_pad(ray, radius);
    }
    let mut best_t = [f64::INFINITY; PACKET];
    let mut best = [NONE; PACKET];
    let stack = &mut scratch.packet;
    stack.clear();
    stack.push((0, (1u8 << m) - 1));
    let lead = &rays[0];
    while let Some((at, mask)) = stack.pop() {
        let n = &nodes[at as usize];
        let mut live = 0u8;
        for i in 0..m {
            if mask & (1 << i) == 0 {
                continue;
            }
            let ray = &rays[i];
            match box_entry(ray, n, pad[i]) {
                Some(t) if t <= best_t[i] => {}
                _ => continue,
            }
            live |= 1 << i;
            if let Some(t) = shape.entry(ray, n, at, r2)
                && (t < best_t[i] || (t == best_t[i] && n.index < best[i]))
            {
                best_t[i] = t;
                best[i] = n.index;
            }
        }
        if live == 0 {
            continue;
        }
        let (near, far) = near_far(lead, n, at);
        if far != NONE {
            stack.push((far, live));
        }
        if near != NONE {
            stack.push((near, live));
        }
    }
    for i in 0..m {
        out[i] = (best[i] != NONE).then_some((best_t[i], best[i]));
    }
    out
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

/// Casts with the chosen traversal; returns the index of the point hit.
#[inline]
pub fn cast(
    tree: &KdTree,
    ray: &Ray,
    radius: f64,
    traversal: Traversal,
    scratch: &mut Scratch,
) -> Option<u32> {
    match traversal {
        Traversal::Exact => cast_exact(tree, ray, radius, scratch).map(|(_, i)| i),
        Traversal::Seed => cast_seed(tree, ray, radius, scratch),
    }
}
