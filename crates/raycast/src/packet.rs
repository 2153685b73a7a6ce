//! The exact traversal of the bucketed hierarchy ([`crate::bvh`]), a packet of up to
//! [`MAX_RAYS`] rays (an 8 × 8 pixel tile) at a time: every ray gets the brute force's answer,
//! the smallest (entry parameter, index) over the points it hits.
//!
//! - Packets (Wald, Slusallek, Benthin and Wagner 2001; Wald, Boulos and Shirley, "Ray tracing
//!   deformable scenes using dynamic bounding volume hierarchies", 2007): one walk of the tree
//!   for the tile, near child first by the first active ray; at a node the walk goes on from
//!   the first ray that enters the node's box, enlarged by the radius, before its own best hit
//!   (boxes are nested and best hits only get nearer, so the rays before it stay out below it),
//!   and when that ray misses, an interval-arithmetic test of the whole packet (origins and
//!   reciprocal directions as intervals) can drop the node at once. At a leaf every ray from
//!   the first active one tests the box, then the leaf's points.
//! - `f32` culling, `f64` decisions: boxes, rays and point offsets are `f32` (4 points to a
//!   test), made conservative by margins that exceed every rounding error in them: boxes are
//!   enlarged by 2^-19 and the filter's radius by 2^-18 times the scale of the coordinates
//!   involved (origin and extent, relative to the cloud's centre), and the best hit is rounded
//!   up. A point that passes the filter and could beat the ray's best hit gets the exact `f64`
//!   test of [`crate::hit`] on its exact position, and the minimum is taken over those exact
//!   values. A point that the filter drops is one the exact test would not have hit or could
//!   not have won with, so the answer is the brute force's, ray for ray, ties included.
//! - Directions are scaled by a power of two (exact) to a largest component in [1, 2), so
//!   the margins hold whatever the rays' lengths. A ray whose direction's square is zero,
//!   below 10^-200 or above 10^200, or whose origin or cloud lies beyond 10^100 (where `f64`
//!   squares underflow or overflow and the exact test's values stop meaning distances) is
//!   answered by the brute force over the slots, whatever it says.

use crate::bvh::{Bvh, LANES, Node};
use crate::hit::{disc_entry, entry};
use crate::kdtree::NONE;

/// Most rays in a packet.
pub const MAX_RAYS: usize = 64;

/// The exact test of a point, by slot.
pub trait SlotShape: Copy {
    /// The hit parameter of the ray (`o`, `d`) on slot `s`'s point (radius² `r2`), or `None`.
    fn entry(&self, bvh: &Bvh, o: &[f64; 3], d: &[f64; 3], s: usize, r2: f64) -> Option<f64>;
}

/// Seed 001's sphere.
#[derive(Debug, Clone, Copy)]
pub struct Sphere;

impl SlotShape for Sphere {
    #[inline(always)]
    fn entry(&self, bvh: &Bvh, o: &[f64; 3], d: &[f64; 3], s: usize, r2: f64) -> Option<f64> {
        entry(o, d, &bvh.exact[s], r2)
    }
}

/// An oriented disc; the unit normals by slot ([`Bvh::in_slot_order`]).
#[derive(Debug, Clone, Copy)]
pub struct Disc<'a>(pub &'a [[f64; 3]]);

impl SlotShape for Disc<'_> {
    #[inline(always)]
    fn entry(&self, bvh: &Bvh, o: &[f64; 3], d: &[f64; 3], s: usize, r2: f64) -> Option<f64> {
        disc_entry(o, d, &bvh.exact[s], &self.0[s], r2)
    }
}

/// A ray's `f32` form for culling, in scaled parameter units.
#[derive(Debug, Clone, Copy, Default)]
struct Cull {
    /// Origin relative to the centre.
    o: [f32; 3],
    /// Scaled direction.
    d: [f32; 3],
    /// Its reciprocal (components clamped to ±1e30).
    inv: [f32; 3],
    /// Box enlargement: radius and margin.
    pad: f32,
    /// (radius + filter margin)² · |d|².
    rr_dd: f32,
    /// Filter margin · |d|.
    eta_dn: f32,
    /// |d|².
    dd: f32,
    /// The exact parameter's factor to scaled units (a power of two).
    to_scaled: f64,
    /// Best hit so far, scaled, rounded up: the box test's bound.
    best_box: f32,
    /// `best_box` · |d|², rounded up: the filter's bound.
    best_dd: f32,
}

/// Rays of one packet with their best hits.
#[derive(Debug, Clone)]
pub struct Packet {
    len: usize,
    o: [[f64; 3]; MAX_RAYS],
    d: [[f64; 3]; MAX_RAYS],
    cull: [Cull; MAX_RAYS],
    best_t: [f64; MAX_RAYS],
    best: [u32; MAX_RAYS],
    /// Rays answered by the brute force (degenerate), a bit each.
    degenerate: u64,
}

impl Default for Packet {
    fn default() -> Self {
        Self {
            len: 0,
            o: [[0.0; 3]; MAX_RAYS],
            d: [[0.0; 3]; MAX_RAYS],
            cull: [Cull::default(); MAX_RAYS],
            best_t: [f64::INFINITY; MAX_RAYS],
            best: [NONE; MAX_RAYS],
            degenerate: 0,
        }
    }
}

impl Packet {
    /// Empties the packet.
    pub fn clear(&mut self) {
        self.len = 0;
        self.degenerate = 0;
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Adds the ray (`o`, `d`); at most [`MAX_RAYS`].
    #[inline]
    pub fn push(&mut self, o: [f64; 3], d: [f64; 3]) {
        assert!(self.len < MAX_RAYS, "a packet holds {MAX_RAYS} rays");
        let i = self.len;
        self.o[i] = o;
        self.d[i] = d;
        self.len += 1;
    }

    /// Ray `i`'s answer: (entry parameter, input index) of the point hit first.
    #[inline]
    pub fn hit(&self, i: usize) -> Option<(f64, u32)> {
        (self.best[i] != NONE).then_some((self.best_t[i], self.best[i]))
    }

    /// Prepares the `f32` forms for `bvh` and `radius`, resets the best hits.
    fn prepare(&mut self, bvh: &Bvh, radius: f64) {
        let c = bvh.centre;
        for i in 0..self.len {
            self.best_t[i] = f64::INFINITY;
            self.best[i] = NONE;
            let (o, d) = (self.o[i], self.d[i]);
            let big = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let rel = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
            let om = rel.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if !(1e-200..=1e200).contains(&dd) || !(om + bvh.half_extent <= 1e100) {
                self.degenerate |= 1 << i;
                // Never enters a box: every entry parameter is 0, above this bound.
                self.cull[i] = Cull {
                    best_box: f32::NEG_INFINITY,
                    best_dd: f32::NEG_INFINITY,
                    ..Cull::default()
                };
                continue;
            }
            let scale = 2f64.powi(-(big.log2().floor() as i32));
            let ds = [d[0] * scale, d[1] * scale, d[2] * scale];
            let inv = ds.map(|v| (1.0 / v).clamp(-1e30, 1e30) as f32);
            let d32 = ds.map(|v| v as f32);
            let size = om + bvh.half_extent + radius;
            let delta = size * f64::powi(2.0, -19);
            let eta = size * f64::powi(2.0, -18);
            let dd32 = d32[0] * d32[0] + d32[1] * d32[1] + d32[2] * d32[2];
            let up = 1.0 + f64::powi(2.0, -20);
            let dd64 = dd32 as f64;
            self.cull[i] = Cull {
                o: rel.map(|v| v as f32),
                d: d32,
                inv,
                pad: ((radius + delta) * up) as f32,
                rr_dd: ((radius + eta) * (radius + eta) * dd64 * up * up) as f32,
                eta_dn: (eta * dd64.sqrt() * up) as f32,
                dd: dd32,
                to_scaled: 1.0 / scale,
                best_box: f32::INFINITY,
                best_dd: f32::INFINITY,
            };
        }
    }

    /// Ray `i` takes the hit (`t`, `index`) if it is nearer than its best, or as near with a
    /// lower index; returns whether it did.
    #[inline(always)]
    fn offer(&mut self, i: usize, t: f64, index: u32) -> bool {
        if t < self.best_t[i] || (t == self.best_t[i] && index < self.best[i]) {
            self.best_t[i] = t;
            self.best[i] = index;
            let c = &mut self.cull[i];
            let up = 1.0 + f64::powi(2.0, -20);
            let scaled = t * c.to_scaled * up;
            c.best_box = scaled as f32;
            c.best_dd = (scaled * c.dd as f64 * up) as f32;
            true
        } else {
            false
        }
    }
}

/// Entry of ray `c` into box `n` enlarged by its pad, if before its best hit.
#[inline(always)]
fn enters(c: &Cull, n: &Node) -> bool {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for k in 0..3 {
        let a = (n.lo[k] - c.pad - c.o[k]) * c.inv[k];
        let b = (n.hi[k] + c.pad - c.o[k]) * c.inv[k];
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        t0 = if near > t0 { near } else { t0 };
        t1 = if far < t1 { far } else { t1 };
    }
    t0 <= t1 && t0 <= c.best_box
}

/// The packet as intervals: origins, reciprocal directions and pads.
#[derive(Debug, Clone, Copy)]
struct Interval {
    o_lo: [f32; 3],
    o_hi: [f32; 3],
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    pad: f32,
    /// The largest best hit (scaled, rounded up).
    best: f32,
}

impl Interval {
    fn of(p: &Packet) -> Option<Self> {
        let mut iv = Self {
            o_lo: [f32::INFINITY; 3],
            o_hi: [f32::NEG_INFINITY; 3],
            inv_lo: [f32::INFINITY; 3],
            inv_hi: [f32::NEG_INFINITY; 3],
            pad: 0.0,
            best: f32::INFINITY,
        };
        let mut any = false;
        for i in 0..p.len {
            if p.degenerate & (1 << i) != 0 {
                continue;
            }
            any = true;
            let c = &p.cull[i];
            for k in 0..3 {
                iv.o_lo[k] = iv.o_lo[k].min(c.o[k]);
                iv.o_hi[k] = iv.o_hi[k].max(c.o[k]);
                iv.inv_lo[k] = iv.inv_lo[k].min(c.inv[k]);
                iv.inv_hi[k] = iv.inv_hi[k].max(c.inv[k]);
            }
            iv.pad = iv.pad.max(c.pad);
        }
        any.then_some(iv)
    }

    /// True when no ray of the packet can enter `n` (enlarged by the largest pad) before its
    /// best hit: for each axis, a lower bound over the packet of the ray's near slab parameter
    /// min((lo − o)·inv, (hi − o)·inv) and an upper bound of its far one, from the intervals
    /// of (lo − o), (hi − o) and inv.
    #[inline]
    fn misses(&self, n: &Node) -> bool {
        let eps = f32::powi(2.0, -18);
        let mut t0 = 0.0f32;
        let mut t1 = f32::INFINITY;
        for k in 0..3 {
            let lo = n.lo[k] - self.pad;
            let hi = n.hi[k] + self.pad;
            let a = (lo - self.o_hi[k], lo - self.o_lo[k]);
            let b = (hi - self.o_hi[k], hi - self.o_lo[k]);
            let (i_lo, i_hi) = (self.inv_lo[k], self.inv_hi[k]);
            let (near, far) = if i_lo > 0.0 {
                // Every ray enters through lo and leaves through hi.
                ((a.0 * i_lo).min(a.0 * i_hi), (b.1 * i_lo).max(b.1 * i_hi))
            } else if i_hi < 0.0 {
                ((b.1 * i_lo).min(b.1 * i_hi), (a.0 * i_lo).max(a.0 * i_hi))
            } else {
                // Directions of both signs: the products' extremes.
                let p = [a.0 * i_lo, a.0 * i_hi, a.1 * i_lo, a.1 * i_hi];
                let q = [b.0 * i_lo, b.0 * i_hi, b.1 * i_lo, b.1 * i_hi];
                let lo_all = p.iter().chain(&q).fold(f32::INFINITY, |m, &v| m.min(v));
                let hi_all = p.iter().chain(&q).fold(f32::NEG_INFINITY, |m, &v| m.max(v));
                (lo_all, hi_all)
            };
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        t0 > t1 + t1.abs() * eps || t0 > self.best + self.best * eps
    }
}

/// Traversal stack, reused between packets.
#[derive(Debug, Default)]
pub struct Stack(Vec<(u32, u32)>);

/// Casts every ray of `packet` through `bvh`: each ray's answer is then [`Packet::hit`].
pub fn cast<S: SlotShape>(
    bvh: &Bvh,
    packet: &mut Packet,
    radius: f64,
    shape: S,
    stack: &mut Stack,
) {
    packet.prepare(bvh, radius);
    let r2 = radius * radius;
    let m = packet.len;
    if m == 0 || bvh.is_empty() {
        return;
    }
    if packet.degenerate != 0 {
        for i in 0..m {
            if packet.degenerate & (1 << i) != 0 {
                let (o, d) = (packet.o[i], packet.d[i]);
                for s in 0..bvh.index.len() {
                    if bvh.index[s] != NONE
                        && let Some(t) = shape.entry(bvh, &o, &d, s, r2)
                    {
                        packet.offer(i, t, bvh.index[s]);
                    }
                }
            }
        }
    }
    let Some(mut iv) = Interval::of(packet) else {
        return;
    };
    let stack = &mut stack.0;
    stack.clear();
    stack.push((0, 0));
    while let Some((at, first)) = stack.pop() {
        let n = bvh.node(at);
        let mut i = first as usize;
        if !enters(&packet.cull[i], n) {
            if i + 1 == m || iv.misses(n) {
                continue;
            }
            i += 1;
            while i < m && !enters(&packet.cull[i], n) {
                i += 1;
            }
            if i == m {
                continue;
            }
        }
        if n.is_leaf() {
            let mut changed = leaf(bvh, packet, i, n, r2, shape);
            for j in i + 1..m {
                if enters(&packet.cull[j], n) {
                    changed |= leaf(bvh, packet, j, n, r2, shape);
                }
            }
            if changed {
                iv.best = (0..m).fold(0.0f32, |b, j| b.max(packet.cull[j].best_box));
            }
            continue;
        }
        let [l, r] = bvh.children(n);
        let a = n.axis();
        let c = &packet.cull[i];
        let mid = l.hi[a] + r.lo[a];
        let o2 = 2.0 * c.o[a];
        let left_first = o2 < mid || (o2 == mid && c.d[a] > 0.0);
        let (near, far) = if left_first {
            (n.first, n.first + 1)
        } else {
            (n.first + 1, n.first)
        };
        stack.push((far, i as u32));
        stack.push((near, i as u32));
    }
}

/// Ray `i` against leaf `n`'s points: the `f32` filter four at a time, the exact test for
/// those that pass; returns whether its best hit changed.
#[inline(always)]
fn leaf<S: SlotShape>(bvh: &Bvh, p: &mut Packet, i: usize, n: &Node, r2: f64, shape: S) -> bool {
    let first = n.first as usize;
    let quads = n.count().div_ceil(LANES);
    let mut changed = false;
    for qi in 0..quads {
        let q = &bvh.quads[first / LANES + qi];
        let c = &p.cull[i];
        let mut pass = [false; LANES];
        for l in 0..LANES {
            let ex = c.o[0] - q.x[l];
            let ey = c.o[1] - q.y[l];
            let ez = c.o[2] - q.z[l];
            let cx = ey * c.d[2] - ez * c.d[1];
            let cy = ez * c.d[0] - ex * c.d[2];
            let cz = ex * c.d[1] - ey * c.d[0];
            let cr2 = cx * cx + cy * cy + cz * cz;
            let f = ex * c.d[0] + ey * c.d[1] + ez * c.d[2];
            let room = c.rr_dd - cr2;
            let h = if room > 0.0 { room } else { 0.0 }.sqrt();
            let lower = -f - c.eta_dn - h;
            pass[l] = cr2 <= c.rr_dd && lower <= c.best_dd;
        }
        for (l, &ok) in pass.iter().enumerate() {
            if ok {
                let s = first + qi * LANES + l;
                if let Some(t) = shape.entry(bvh, &p.o[i], &p.d[i], s, r2) {
                    changed |= p.offer(i, t, bvh.index[s]);
                }
            }
        }
    }
    changed
}
