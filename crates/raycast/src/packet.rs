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
use crate::simd::F4;
use wide::f64x4;

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

/// Four lanes.
type V = [f32; LANES];

/// Groups of four rays in a packet.
const GROUPS: usize = MAX_RAYS / LANES;

/// 2^`e` (|`e`| < 1023).
#[inline(always)]
fn pow2(e: i64) -> f64 {
    f64::from_bits(((1023 + e) as u64) << 52)
}

/// Rounding-up factor of the margins.
const UP: f64 = 1.0 + 1.0 / (1u64 << 20) as f64;

/// A ray's bounds for the point filter, in scaled units times |d|².
#[derive(Debug, Clone, Copy, Default)]
struct Filter {
    /// (radius + filter margin)² · |d|².
    rr_dd: f32,
    /// Filter margin · |d|.
    eta_dn: f32,
    /// |d|².
    dd: f32,
    /// The best hit so far (scaled, rounded up) · |d|², rounded up.
    best_dd: f32,
}

/// Rays of one packet with their best hits.
///
/// Each ray keeps its exact `f64` origin and direction, and for culling their `f32` forms in
/// scaled parameter units: the origin relative to the cloud's centre, the scaled direction
/// and its reciprocal, the box enlargement and the best hit as a box bound, four rays to a
/// group (structure of arrays, so that four rays test a box at once). Lanes past the
/// packet's rays and those of degenerate rays never enter a box. The point filter's bounds
/// are made when the ray first reaches a leaf.
#[derive(Debug, Clone)]
pub struct Packet {
    len: usize,
    /// Origins by axis (lanes past the rays: copies of the last ray).
    o: [[f64; MAX_RAYS]; 3],
    /// Directions by axis (likewise).
    d: [[f64; MAX_RAYS]; 3],
    /// Origins relative to the centre, by axis.
    o32: [[V; GROUPS]; 3],
    /// Reciprocal scaled directions (clamped to ±1e30), by axis.
    inv: [[V; GROUPS]; 3],
    /// Box enlargement: radius and margin.
    pad: [V; GROUPS],
    /// Best hit so far, scaled, rounded up: the box test's bound.
    best_box: [V; GROUPS],
    /// Scaled directions.
    d32: [[f32; 3]; MAX_RAYS],
    /// The filter margin, world units.
    eta: [f64; MAX_RAYS],
    /// The exact parameter's factor to scaled units (a power of two).
    to_scaled: [f64; MAX_RAYS],
    filter: [Filter; MAX_RAYS],
    /// Rays whose filter bounds are made, a bit each.
    ready: u64,
    best_t: [f64; MAX_RAYS],
    best: [u32; MAX_RAYS],
    /// Rays answered by the brute force (degenerate), a bit each.
    degenerate: u64,
}

impl Default for Packet {
    fn default() -> Self {
        let zero = [[0.0; LANES]; GROUPS];
        Self {
            len: 0,
            o: [[0.0; MAX_RAYS]; 3],
            d: [[0.0; MAX_RAYS]; 3],
            o32: [zero; 3],
            inv: [zero; 3],
            pad: zero,
            best_box: zero,
            d32: [[0.0; 3]; MAX_RAYS],
            eta: [0.0; MAX_RAYS],
            to_scaled: [0.0; MAX_RAYS],
            filter: [Filter::default(); MAX_RAYS],
            ready: 0,
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
        for k in 0..3 {
            self.o[k][i] = o[k];
            self.d[k][i] = d[k];
        }
        self.len += 1;
    }

    /// The index of the point ray `i` hits first, or [`NONE`].
    #[inline]
    pub fn index(&self, i: usize) -> u32 {
        self.best[i]
    }

    /// Ray `i`'s origin.
    #[inline(always)]
    fn ray_o(&self, i: usize) -> [f64; 3] {
        [self.o[0][i], self.o[1][i], self.o[2][i]]
    }

    /// Ray `i`'s direction.
    #[inline(always)]
    fn ray_d(&self, i: usize) -> [f64; 3] {
        [self.d[0][i], self.d[1][i], self.d[2][i]]
    }

    /// Ray `i`'s answer: (entry parameter, input index) of the point hit first.
    #[inline]
    pub fn hit(&self, i: usize) -> Option<(f64, u32)> {
        (self.best[i] != NONE).then_some((self.best_t[i], self.best[i]))
    }

    /// Lane `i` never enters a box: every entry parameter is at least 0, above its bound.
    fn shut(&mut self, i: usize) {
        let (g, j) = (i / LANES, i % LANES);
        for k in 0..3 {
            self.o32[k][g][j] = 0.0;
            self.inv[k][g][j] = 0.0;
        }
        self.pad[g][j] = 0.0;
        self.best_box[g][j] = f32::NEG_INFINITY;
    }

    /// Prepares the `f32` forms for `bvh` and `radius`, resets the best hits.
    fn prepare(&mut self, bvh: &Bvh, radius: f64) {
        let c = bvh.centre;
        self.ready = 0;
        self.degenerate = 0;
        // The origin's terms, made again only when the origin changes (a pinhole's rays
        // share it).
        let mut last = [f64::NAN; 3];
        let (mut o32, mut om, mut pad, mut eta) = ([0.0f32; 3], 0.0, 0.0f32, 0.0);
        for i in 0..self.len {
            self.best_t[i] = f64::INFINITY;
            self.best[i] = NONE;
            let (o, d) = (self.ray_o(i), self.ray_d(i));
            if o != last {
                last = o;
                let rel = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
                om = rel[0].abs().max(rel[1].abs()).max(rel[2].abs()) + bvh.half_extent;
                let size = om + radius;
                pad = ((radius + size * pow2(-19)) * UP) as f32;
                eta = size * pow2(-18);
                o32 = rel.map(|v| v as f32);
            }
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if !(1e-200..=1e200).contains(&dd) || !(om <= 1e100) {
                self.degenerate |= 1 << i;
                self.shut(i);
                continue;
            }
            // A power of two bringing the largest component into [1, 2) (the square's range
            // keeps its exponent within ±340).
            let big = d[0].abs().max(d[1].abs()).max(d[2].abs());
            let e = ((big.to_bits() >> 52) & 0x7ff) as i64 - 1023;
            let scale = pow2(-e);
            let (g, j) = (i / LANES, i % LANES);
            for k in 0..3 {
                let d32 = (d[k] * scale) as f32;
                self.o32[k][g][j] = o32[k];
                self.inv[k][g][j] = (1.0 / d32).clamp(-1e30, 1e30);
                self.d32[i][k] = d32;
            }
            self.pad[g][j] = pad;
            self.best_box[g][j] = f32::INFINITY;
            self.eta[i] = eta;
            self.to_scaled[i] = pow2(e);
        }
        for i in self.len..self.len.next_multiple_of(LANES) {
            self.shut(i);
        }
    }

    /// True when no ray of the packet meets the root's box enlarged by more than `radius`:
    /// the interval-arithmetic test of [`Interval::misses`] in `f64` on the rays as given,
    /// before their `f32` forms are made (most packets of a view around an object miss it).
    /// False when some ray is degenerate, or its direction's sign varies on every axis.
    fn misses_root(&mut self, bvh: &Bvh, radius: f64) -> bool {
        // The last group's spare lanes copy the last ray, which changes no bound.
        let last = self.len - 1;
        for i in self.len..self.len.next_multiple_of(LANES) {
            for k in 0..3 {
                self.o[k][i] = self.o[k][last];
                self.d[k][i] = self.d[k][last];
            }
        }
        let lanes = |a: &[f64; MAX_RAYS], g: usize| {
            f64x4::new([a[4 * g], a[4 * g + 1], a[4 * g + 2], a[4 * g + 3]])
        };
        let (mut o_lo, mut o_hi) = (
            [f64x4::splat(f64::INFINITY); 3],
            [f64x4::splat(f64::NEG_INFINITY); 3],
        );
        let (mut d_lo, mut d_hi) = (o_lo, o_hi);
        let mut fine = f64x4::splat(f64::from_bits(u64::MAX));
        for g in 0..self.len.div_ceil(LANES) {
            let d = [0, 1, 2].map(|k| lanes(&self.d[k], g));
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            fine &= dd.simd_ge(f64x4::splat(1e-200)) & dd.simd_le(f64x4::splat(1e200));
            for k in 0..3 {
                let o = lanes(&self.o[k], g);
                o_lo[k] = o_lo[k].fast_min(o);
                o_hi[k] = o_hi[k].fast_max(o);
                d_lo[k] = d_lo[k].fast_min(d[k]);
                d_hi[k] = d_hi[k].fast_max(d[k]);
            }
        }
        let lo = |v: f64x4| v.to_array().into_iter().fold(f64::INFINITY, f64::min);
        let hi = |v: f64x4| v.to_array().into_iter().fold(f64::NEG_INFINITY, f64::max);
        let (o_lo, o_hi) = (o_lo.map(lo), o_hi.map(hi));
        let (d_lo, d_hi) = (d_lo.map(lo), d_hi.map(hi));
        if fine.to_bitmask() != 0b1111 || (o_lo.iter().chain(&o_hi).any(|v| v.is_nan())) {
            return false;
        }
        let c = bvh.centre;
        let om = (0..3).fold(0.0f64, |m, k| {
            m.max((o_lo[k] - c[k]).abs()).max((o_hi[k] - c[k]).abs())
        });
        let size = om + bvh.half_extent + radius;
        if !(size <= 1e100) {
            return false;
        }
        let pad = radius + size * pow2(-19);
        let root = bvh.node(0);
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..3 {
            // The reciprocals' interval, where every direction has the same sign.
            let (i_lo, i_hi) = if d_lo[k] > 0.0 || d_hi[k] < 0.0 {
                (1.0 / d_hi[k], 1.0 / d_lo[k])
            } else {
                continue;
            };
            let lo = root.lo[k] as f64 + bvh.centre[k] - pad;
            let hi = root.hi[k] as f64 + bvh.centre[k] + pad;
            let a = lo - o_hi[k];
            let b = hi - o_lo[k];
            let (near, far) = if i_lo > 0.0 {
                ((a * i_lo).min(a * i_hi), (b * i_lo).max(b * i_hi))
            } else {
                let (a, b) = (hi - o_lo[k], lo - o_hi[k]);
                ((a * i_lo).min(a * i_hi), (b * i_lo).max(b * i_hi))
            };
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        t0 > t1 + t1.abs() * 1e-9
    }

    /// Ray `i`'s filter bounds, made on first use.
    #[inline(always)]
    fn filter(&mut self, i: usize, radius: f64) -> Filter {
        if self.ready & (1 << i) == 0 {
            self.ready |= 1 << i;
            let d = self.d32[i];
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let (dd64, eta) = (dd as f64, self.eta[i]);
            self.filter[i] = Filter {
                rr_dd: ((radius + eta) * (radius + eta) * dd64 * UP * UP) as f32,
                eta_dn: (eta * dd64.sqrt() * UP) as f32,
                dd,
                best_dd: f32::INFINITY,
            };
        }
        self.filter[i]
    }

    /// Ray `i` (its filter made) takes the hit (`t`, `index`) if it is nearer than its best,
    /// or as near with a lower index; returns whether it did.
    #[inline(always)]
    fn offer(&mut self, i: usize, t: f64, index: u32) -> bool {
        if t < self.best_t[i] || (t == self.best_t[i] && index < self.best[i]) {
            self.best_t[i] = t;
            self.best[i] = index;
            let scaled = t * self.to_scaled[i] * UP;
            self.best_box[i / LANES][i % LANES] = scaled as f32;
            let f = &mut self.filter[i];
            f.best_dd = (scaled * f.dd as f64 * UP) as f32;
            true
        } else {
            false
        }
    }

    /// The rays of group `g` that enter box `n`, enlarged by their pads, before their best
    /// hits: a bit each.
    #[inline(always)]
    fn enter(&self, g: usize, n: &Node) -> u32 {
        let pad = F4::load(&self.pad[g]);
        let mut t0 = F4::splat(0.0);
        let mut t1 = F4::splat(f32::INFINITY);
        for k in 0..3 {
            let o = F4::load(&self.o32[k][g]);
            let inv = F4::load(&self.inv[k][g]);
            let a = F4::splat(n.lo[k]).sub(pad).sub(o).mul(inv);
            let b = F4::splat(n.hi[k]).add(pad).sub(o).mul(inv);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        t0.le_both(t1, F4::load(&self.best_box[g]))
    }

    /// Degenerate ray `i`'s answer: the brute force over the slots.
    fn brute<S: SlotShape>(&mut self, i: usize, bvh: &Bvh, r2: f64, shape: S) {
        let (o, d) = (self.ray_o(i), self.ray_d(i));
        for (s, &index) in bvh.index.iter().enumerate() {
            if index != NONE
                && let Some(t) = shape.entry(bvh, &o, &d, s, r2)
                && (t < self.best_t[i] || (t == self.best_t[i] && index < self.best[i]))
            {
                self.best_t[i] = t;
                self.best[i] = index;
            }
        }
    }
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
            let (g, j) = (i / LANES, i % LANES);
            for k in 0..3 {
                iv.o_lo[k] = iv.o_lo[k].min(p.o32[k][g][j]);
                iv.o_hi[k] = iv.o_hi[k].max(p.o32[k][g][j]);
                iv.inv_lo[k] = iv.inv_lo[k].min(p.inv[k][g][j]);
                iv.inv_hi[k] = iv.inv_hi[k].max(p.inv[k][g][j]);
            }
            iv.pad = iv.pad.max(p.pad[g][j]);
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
                (min(a.0 * i_lo, a.0 * i_hi), max(b.1 * i_lo, b.1 * i_hi))
            } else if i_hi < 0.0 {
                (min(b.1 * i_lo, b.1 * i_hi), max(a.0 * i_lo, a.0 * i_hi))
            } else {
                // Directions of both signs: the products' extremes.
                let p = [a.0 * i_lo, a.0 * i_hi, a.1 * i_lo, a.1 * i_hi];
                let q = [b.0 * i_lo, b.0 * i_hi, b.1 * i_lo, b.1 * i_hi];
                let lo_all = p.iter().chain(&q).fold(f32::INFINITY, |m, &v| min(m, v));
                let hi_all = p
                    .iter()
                    .chain(&q)
                    .fold(f32::NEG_INFINITY, |m, &v| max(m, v));
                (lo_all, hi_all)
            };
            t0 = max(t0, near);
            t1 = min(t1, far);
        }
        t0 > t1 + t1.abs() * eps || t0 > self.best + self.best * eps
    }
}

/// The smaller of `a` and `b` (`b` when they do not compare).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// The larger of `a` and `b` (`b` when they do not compare).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
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
    let m = packet.len;
    if m == 0 || bvh.is_empty() || packet.misses_root(bvh, radius) {
        packet.best[..m].fill(NONE);
        return;
    }
    packet.prepare(bvh, radius);
    let r2 = radius * radius;
    if packet.degenerate != 0 {
        for i in 0..m {
            if packet.degenerate & (1 << i) != 0 {
                packet.brute(i, bvh, r2, shape);
            }
        }
    }
    let Some(mut iv) = Interval::of(packet) else {
        return;
    };
    let groups = m.div_ceil(LANES);
    let stack = &mut stack.0;
    stack.clear();
    stack.push((0, 0));
    while let Some((at, first)) = stack.pop() {
        let n = bvh.node(at);
        // The first ray, from `first`, that enters the node.
        let mut g = first as usize / LANES;
        let mut mask = packet.enter(g, n) & (!0 << (first as usize % LANES));
        if mask == 0 {
            if g + 1 == groups || iv.misses(n) {
                continue;
            }
            while mask == 0 && g + 1 < groups {
                g += 1;
                mask = packet.enter(g, n);
            }
            if mask == 0 {
                continue;
            }
        }
        let i = g * LANES + mask.trailing_zeros() as usize;
        if n.is_leaf() {
            // Every ray from there that enters it.
            let mut changed = false;
            loop {
                while mask != 0 {
                    let j = g * LANES + mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    changed |= leaf(bvh, packet, j, n, radius, shape);
                }
                g += 1;
                if g == groups {
                    break;
                }
                mask = packet.enter(g, n);
            }
            if changed {
                let most = packet.best_box[..groups]
                    .iter()
                    .fold(F4::splat(0.0), |b, v| b.max(F4::load(v)));
                iv.best = most
                    .lanes()
                    .into_iter()
                    .fold(0.0f32, |b, v| if v > b { v } else { b });
            }
            continue;
        }
        let [l, r] = bvh.children(n);
        let a = n.axis();
        let o = packet.o32[a][i / LANES][i % LANES];
        let mid = l.hi[a] + r.lo[a];
        let left_first = 2.0 * o < mid || (2.0 * o == mid && packet.d32[i][a] > 0.0);
        let (near, far) = if left_first {
            (n.first, n.first + 1)
        } else {
            (n.first + 1, n.first)
        };
        stack.push((far, i as u32));
        stack.push((near, i as u32));
    }
}

/// Ray `i` against leaf `n`'s points: the `f32` filter four at a time (the distance from the
/// point to the line against the radius, and a lower bound of the entry parameter against
/// the best hit), the exact test for those that pass; returns whether its best hit changed.
#[inline(always)]
fn leaf<S: SlotShape>(
    bvh: &Bvh,
    p: &mut Packet,
    i: usize,
    n: &Node,
    radius: f64,
    shape: S,
) -> bool {
    let f = p.filter(i, radius);
    let r2 = radius * radius;
    let first = n.first as usize;
    let (g, j) = (i / LANES, i % LANES);
    let o = [p.o32[0][g][j], p.o32[1][g][j], p.o32[2][g][j]].map(F4::splat);
    let d = p.d32[i].map(F4::splat);
    let (rr_dd, eta_dn) = (F4::splat(f.rr_dd), F4::splat(f.eta_dn));
    let mut best_dd = F4::splat(f.best_dd);
    let zero = F4::splat(0.0);
    let mut changed = false;
    for qi in 0..n.count().div_ceil(LANES) {
        let q = &bvh.quads[first / LANES + qi];
        let ex = o[0].sub(F4::load(&q.x));
        let ey = o[1].sub(F4::load(&q.y));
        let ez = o[2].sub(F4::load(&q.z));
        let cx = ey.mul(d[2]).sub(ez.mul(d[1]));
        let cy = ez.mul(d[0]).sub(ex.mul(d[2]));
        let cz = ex.mul(d[1]).sub(ey.mul(d[0]));
        let cr2 = cx.mul(cx).add(cy.mul(cy)).add(cz.mul(cz));
        let fd = ex.mul(d[0]).add(ey.mul(d[1])).add(ez.mul(d[2]));
        let h = rr_dd.sub(cr2).max(zero).sqrt();
        let lower = zero.sub(fd).sub(eta_dn).sub(h);
        let mut pass = cr2.le(rr_dd) & lower.le(best_dd);
        while pass != 0 {
            let s = first + qi * LANES + pass.trailing_zeros() as usize;
            pass &= pass - 1;
            if let Some(t) = shape.entry(bvh, &p.ray_o(i), &p.ray_d(i), s, r2)
                && p.offer(i, t, bvh.index[s])
            {
                changed = true;
                best_dd = F4::splat(p.filter[i].best_dd);
            }
        }
    }
    changed
}
