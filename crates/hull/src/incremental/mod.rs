//! `incremental` (the hull named `own`): an exact 3-d convex hull written for the HPR workload.
//!
//! **What.** The vertices of the convex hull of a set of f64 points, exactly: a point is
//! reported if and only if it is an extreme point of the input (not a convex combination of
//! other input points), every geometric decision being the sign of an exact determinant
//! ([`crate::predicates`]). Among coincident input points the lowest index is reported.
//!
//! **Why not QuickHull as Qhull does it.** Seed 000 §4 shows the spherically flipped cloud of
//! HPR is a worst case for QuickHull: a thin, nearly spherical cap whose points are almost all
//! on or within a hair of the hull. Qhull's floating-point precision handling merges nearly
//! coplanar facets there, and its outside sets are redistributed again and again as facets
//! are replaced. With exact predicates no merging is ever needed, and a randomised incremental
//! construction with point location by walking needs no outside sets at all.
//!
//! **Algorithm.** Randomised incremental construction (Clarkson and Shor, "Applications of
//! random sampling in computational geometry II", DCG 1989; de Berg et al., *Computational
//! Geometry*, ch. 11), with three changes that suit a hull whose output is a large share of
//! its input:
//! 1. *Insertion order*: BRIO rounds along a Morton curve ([`order`]); the points are copied
//!    into that order so consecutive insertions touch neighbouring memory.
//! 2. *Point location by walking* instead of a conflict graph: the facets, seen by central
//!    projection from a point O strictly inside the initial tetrahedron, tile the sphere of
//!    directions. A stochastic visibility walk (Devillers, Pion and Teillaud, "Walking in a
//!    triangulation", IJFCS 2002) from the last facet created finds the facet f whose cone
//!    contains the direction of the new point q (tests orient3d(O, a, b, q) across each edge
//!    a–b). If q is not strictly above f it lies in the current hull, and since the hull only
//!    grows, it is never a vertex: it is dropped for good.
//! 3. *Insertion*: the facets strictly visible from q form a disk around f (found by a
//!    breadth-first search with the exact test); they are replaced by the cone from q to the
//!    disk's boundary. Facets that q sees edge-on are kept, so the surface stays a consistent
//!    triangulation of the exact hull, possibly with coplanar neighbours.
//! 4. *Both cores*: each round of at least 16,384 points is first located in the hull of the
//!    previous rounds in parallel (read-only walks, rayon). Points inside that hull are
//!    inside the final one and are dropped there; the others are inserted in order, starting
//!    from the facet they were found above (no walk when it still exists). The construction
//!    is the same as the sequential one, point for point.
//!
//! A final pass keeps the vertices that are extreme: a vertex whose incident facets lie in
//! fewer than three distinct planes sits inside a face or an edge of the exact hull (this only
//! happens with coplanar input). Expected O(n log n) for points in general position.
//!
//! **Degenerate input.** Fewer than four points, non-finite coordinates, and all points
//! collinear or coplanar are typed errors ([`HullError`]); duplicates are allowed. The sort of
//! the insertion order also tells, for free, whether any two input points coincide
//! ([`OwnHull::distinct`]): HPR then skips its search for copies of visible points.
//!
//! **Cost** (dragon-871414 flipped at γ = 4, view 0; 871,415 points, 265,923 vertices): about
//! 0.05 s ordering (keys, parallel sort, the copy), 0.21 s construction (0.06 s of it the
//! parallel location of the rounds, the rest 295,291 sequential insertions creating 1.78 M
//! facets), 0.02 s collecting the vertices. The sequential insertions are the floor of this
//! design on two cores.

pub mod order;

use rayon::prelude::*;

use crate::predicates::{P3, collinear, orient3d_sign};
use crate::{HullError, validate};

const NONE: u32 = u32::MAX;

/// A triangular facet, counter-clockwise seen from outside; `adj[i]` is across the edge
/// `v[i] → v[(i + 1) % 3]`.
#[derive(Debug, Clone, Copy)]
struct Facet {
    v: [u32; 3],
    adj: [u32; 3],
    /// Visit stamp: `2k` visible from the k-th inserted point, `2k + 1` seen and not visible.
    mark: u32,
    alive: bool,
}

/// A computed hull: the vertex indices and the facets.
#[derive(Debug, Clone)]
pub struct OwnHull {
    /// Indices of the extreme points, ascending.
    pub vertices: Vec<u32>,
    /// The facets (vertex indices, counter-clockwise seen from outside); empty from
    /// [`hull_vertices`].
    pub facets: Vec<[u32; 3]>,
    /// True when no two input points coincide (known from the insertion order's sort keys,
    /// see [`order::Order::distinct`]); false when some may.
    pub distinct: bool,
}

/// Statistics of one construction, for benchmarks and the closing notes.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stats {
    /// Points inserted (found outside the hull at their turn).
    pub inserted: usize,
    /// Points dropped because they were inside at their turn.
    pub dropped: usize,
    /// Facets created over the whole construction.
    pub facets_created: usize,
    /// Walk steps over the whole construction.
    pub walk_steps: usize,
    /// Seconds spent ordering the points (BRIO rounds, curve keys, sort).
    pub order_seconds: f64,
    /// Seconds spent in the incremental construction.
    pub build_seconds: f64,
    /// Seconds spent collecting the vertices.
    pub finish_seconds: f64,
}

struct Builder<'a> {
    pts: &'a [P3],
    facets: Vec<Facet>,
    free: Vec<u32>,
    interior: P3,
    stamp: u32,
    last: u32,
    rng: u64,
    // Scratch, reused across insertions.
    stack: Vec<u32>,
    visible: Vec<u32>,
    horizon: Vec<(u32, u32)>,
    new_facets: Vec<u32>,
    /// True once some point was exactly coplanar with a horizon facet: only then can two
    /// adjacent facets be coplanar (see [`Builder::finish`]).
    coplanar_seen: bool,
    stats: Stats,
}

/// Computes the hull of `points`.
pub fn hull(points: &[P3]) -> Result<OwnHull, HullError> {
    hull_with_stats(points).map(|(h, _)| h)
}

/// Computes the hull's vertices only (`facets` is left empty, which saves collecting them).
pub fn hull_vertices(points: &[P3]) -> Result<OwnHull, HullError> {
    build(points, false).map(|(h, _)| h)
}

/// Computes the hull of `points` and reports construction statistics.
pub fn hull_with_stats(points: &[P3]) -> Result<(OwnHull, Stats), HullError> {
    build(points, true)
}

fn build(points: &[P3], with_facets: bool) -> Result<(OwnHull, Stats), HullError> {
    validate(points)?;
    if let Some((f1, f2)) = crate::exact_rescale_points(points)? {
        let scaled: Vec<P3> = points.iter().map(|p| p.map(|c| c * f1 * f2)).collect();
        return build(&scaled, with_facets);
    }
    let simplex = initial_simplex(points)?;
    let start = std::time::Instant::now();
    let order = order::insertion_order(points, &simplex);
    // PERF: the construction works on a copy of the points in insertion order (simplex
    // first). Consecutive insertions then touch neighbouring memory; indexing the input
    // directly costs a cache miss per point (about a third of the time on 871k points).
    let mut perm: Vec<u32> = Vec::with_capacity(points.len());
    perm.extend_from_slice(&simplex);
    perm.extend_from_slice(&order.indices);
    let local: Vec<P3> = perm.par_iter().map(|&i| points[i as usize]).collect();
    let order_seconds = start.elapsed().as_secs_f64();
    let mut b = Builder::new(&local, [0, 1, 2, 3])?;
    b.stats.order_seconds = order_seconds;
    let start = std::time::Instant::now();
    let mut hints: Vec<Hint> = Vec::new();
    for (k, &round_start) in order.rounds.iter().enumerate() {
        let round_end = order
            .rounds
            .get(k + 1)
            .copied()
            .unwrap_or(order.indices.len());
        // The round's points in the local (insertion-ordered) indexing: a range.
        let round = 4 + round_start..4 + round_end;
        if round.len() < PARALLEL_ROUND || rayon::current_num_threads() < 2 {
            for i in round {
                b.add(i as u32, None)?;
            }
            continue;
        }
        // Locate the whole round in the current hull in parallel (read-only walks). A point
        // inside the current hull is inside the final one: it is dropped here, exactly. The
        // others are inserted in order, starting from the facet they were found above.
        let (facets, pts, interior, last) = (&b.facets, b.pts, b.interior, b.last);
        let located: Vec<(Vec<Hint>, usize)> = (0..round.len().div_ceil(LOCATE_CHUNK))
            .into_par_iter()
            .map(|c| {
                let from = round.start + c * LOCATE_CHUNK;
                let chunk = from..(from + LOCATE_CHUNK).min(round.end);
                let mut rng =
                    (0x9e37_79b9_7f4a_7c15u64 ^ (c as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9)) | 1;
                let mut steps = 0;
                let mut start = last;
                let mut out = Vec::with_capacity(chunk.len());
                for i in chunk {
                    let q = &pts[i];
                    let f = walk(facets, pts, &interior, start, q, &mut rng, &mut steps)?;
                    start = f;
                    let v = facets[f as usize].v;
                    let p = |k: usize| &pts[v[k] as usize];
                    out.push((orient3d_sign(p(0), p(1), p(2), q) < 0).then_some((f, v)));
                }
                Ok((out, steps))
            })
            .collect::<Result<_, HullError>>()?;
        for (out, steps) in located {
            b.stats.walk_steps += steps;
            hints.extend(out);
        }
        for (i, &hint) in round.zip(&hints) {
            match hint {
                None => b.stats.dropped += 1,
                Some(h) => b.add(i as u32, Some(h))?,
            }
        }
        hints.clear();
    }
    b.stats.build_seconds = start.elapsed().as_secs_f64();
    let start = std::time::Instant::now();
    let (local_vertices, local_facets) = b.finish(with_facets);
    let mut vertices: Vec<u32> = local_vertices
        .par_iter()
        .map(|&v| perm[v as usize])
        .collect();
    vertices.par_sort_unstable();
    let facets = local_facets
        .iter()
        .map(|t| t.map(|v| perm[v as usize]))
        .collect();
    b.stats.finish_seconds = start.elapsed().as_secs_f64();
    let distinct = order.distinct;
    Ok((
        OwnHull {
            vertices,
            facets,
            distinct,
        },
        b.stats,
    ))
}

/// Four affinely independent points, chosen far apart: the extremes along the axes, the
/// point farthest from their line, the point farthest from that plane. Exact predicates
/// decide degeneracy.
fn initial_simplex(pts: &[P3]) -> Result<[u32; 4], HullError> {
    // The lowest index of each axis's minimum and maximum (rayon's reduce keeps the order of
    // its operands, and ties keep the left one).
    let extremes = (0..pts.len()).into_par_iter().map(|i| [i; 6]).reduce(
        || [0; 6],
        |a, b| {
            std::array::from_fn(|e| {
                let (k, max) = (e / 2, e % 2 == 1);
                let (pa, pb) = (pts[a[e]][k], pts[b[e]][k]);
                if (max && pb > pa) || (!max && pb < pa) {
                    b[e]
                } else {
                    a[e]
                }
            })
        },
    );
    let dist2 = |a: &P3, b: &P3| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
    let (mut i0, mut i1, mut best) = (0, 0, -1.0);
    for &a in &extremes {
        for &b in &extremes {
            let d = dist2(&pts[a], &pts[b]);
            if d > best {
                (i0, i1, best) = (a, b, d);
            }
        }
    }
    if pts[i0] == pts[i1] {
        return Err(HullError::Degenerate("all points coincide".into()));
    }
    // Farthest from the line i0–i1 (floating point to rank, exact to decide).
    let (a, b) = (pts[i0], pts[i1]);
    let ab = sub(&b, &a);
    let line_dist = |p: &P3| norm2(&cross(&ab, &sub(p, &a)));
    let i2 = argmax_first(pts.len(), |i| line_dist(&pts[i]));
    let i2 = if !collinear(&a, &b, &pts[i2]) {
        i2
    } else {
        (0..pts.len())
            .find(|&i| !collinear(&a, &b, &pts[i]))
            .ok_or_else(|| HullError::Degenerate("all points are collinear".into()))?
    };
    let c = pts[i2];
    let n = cross(&ab, &sub(&c, &a));
    let plane_dist = |p: &P3| dot(&n, &sub(p, &a)).abs();
    let i3 = argmax_first(pts.len(), |i| plane_dist(&pts[i]));
    let i3 = if orient3d_sign(&a, &b, &c, &pts[i3]) != 0 {
        i3
    } else {
        (0..pts.len())
            .find(|&i| orient3d_sign(&a, &b, &c, &pts[i]) != 0)
            .ok_or_else(|| HullError::Degenerate("all points are coplanar".into()))?
    };
    Ok([i0 as u32, i1 as u32, i2 as u32, i3 as u32])
}

/// The lowest index with the largest key (ties go to the lowest index, so that among
/// coincident points the lowest index enters the initial simplex).
fn argmax_first(n: usize, key: impl Fn(usize) -> f64 + Sync) -> usize {
    (0..n)
        .into_par_iter()
        .map(|i| (key(i), i))
        .reduce(
            || (f64::NEG_INFINITY, 0),
            |a, b| if b.0 > a.0 { b } else { a },
        )
        .1
}

impl<'a> Builder<'a> {
    fn new(pts: &'a [P3], s: [u32; 4]) -> Result<Self, HullError> {
        let p = |i: u32| &pts[i as usize];
        // Orient the tetrahedron so that facet (0, 1, 2) has vertex 3 below it.
        let [mut a, mut b, c, d] = s;
        if orient3d_sign(p(a), p(b), p(c), p(d)) < 0 {
            std::mem::swap(&mut a, &mut b);
        }
        // Facets CCW from outside: (a, c, b) has d below? Check the convention: with
        // orient3d(a, b, c, d) > 0, d is below (a, b, c), i.e. (a, b, c) is CCW seen from the
        // side away from d: outward. The other three facets follow the same orientation.
        let tris = [[a, b, c], [a, d, b], [b, d, c], [c, d, a]];
        let mut facets: Vec<Facet> = tris
            .iter()
            .map(|&v| Facet {
                v,
                adj: [NONE; 3],
                mark: u32::MAX,
                alive: true,
            })
            .collect();
        // Link by shared edges (each directed edge u→v matches the facet with v→u).
        for f in 0..4 {
            for e in 0..3 {
                let (u, v) = (facets[f].v[e], facets[f].v[(e + 1) % 3]);
                for g in 0..4 {
                    for e2 in 0..3 {
                        if facets[g].v[e2] == v && facets[g].v[(e2 + 1) % 3] == u {
                            facets[f].adj[e] = g as u32;
                        }
                    }
                }
            }
        }
        let corners = [p(a), p(b), p(c), p(d)];
        let interior: P3 = std::array::from_fn(|k| corners.iter().map(|q| q[k]).sum::<f64>() / 4.0);
        let builder = Self {
            pts,
            facets,
            free: Vec::new(),
            interior,
            stamp: 0,
            last: 0,
            rng: 0x2545_f491_4f6c_dd1d,
            stack: Vec::new(),
            visible: Vec::new(),
            horizon: Vec::new(),
            new_facets: Vec::new(),
            coplanar_seen: false,
            stats: Stats {
                inserted: 4,
                facets_created: 4,
                ..Stats::default()
            },
        };
        // The interior point must be strictly below every facet for the walk.
        for f in &builder.facets {
            if builder.orient(f.v, &interior) <= 0 {
                return Err(HullError::Degenerate(
                    "the initial tetrahedron is too flat to hold an interior point".into(),
                ));
            }
        }
        Ok(builder)
    }

    #[inline]
    fn p(&self, i: u32) -> &P3 {
        &self.pts[i as usize]
    }

    /// orient3d of a facet's corners and q (negative: q strictly outside the facet).
    #[inline]
    fn orient(&self, v: [u32; 3], q: &P3) -> i32 {
        orient3d_sign(self.p(v[0]), self.p(v[1]), self.p(v[2]), q)
    }

    /// The facet whose cone from the interior point contains q's direction, walking from
    /// `start`.
    fn locate(&mut self, q: &P3, start: u32) -> Result<u32, HullError> {
        let mut rng = self.rng;
        let mut steps = 0;
        let f = walk(
            &self.facets,
            self.pts,
            &self.interior,
            start,
            q,
            &mut rng,
            &mut steps,
        );
        self.rng = rng;
        self.stats.walk_steps += steps;
        f
    }

    /// Inserts point i if it is outside the current hull. `hint`: a facet the point was found
    /// strictly above earlier, with its corners then. If that facet still exists (same slot,
    /// same corners, alive) it is still visible and no walk is needed; otherwise the walk
    /// starts there if the slot is alive, else at the last facet created.
    fn add(&mut self, i: u32, hint: Hint) -> Result<(), HullError> {
        let q = *self.p(i);
        let f = match hint {
            Some((f, v)) if self.facets[f as usize].alive && self.facets[f as usize].v == v => f,
            _ => {
                let start = hint
                    .map(|h| h.0)
                    .filter(|&f| self.facets[f as usize].alive)
                    .unwrap_or(self.last);
                let f = self.locate(&q, start)?;
                if self.orient(self.facets[f as usize].v, &q) >= 0 {
                    self.stats.dropped += 1;
                    return Ok(());
                }
                f
            }
        };
        self.stats.inserted += 1;
        self.stamp = self.stamp.wrapping_add(1);
        let (vis, seen) = (2 * self.stamp, 2 * self.stamp + 1);

        // The disk of facets strictly visible from q, and its boundary.
        self.visible.clear();
        self.horizon.clear();
        self.stack.clear();
        self.stack.push(f);
        self.facets[f as usize].mark = vis;
        while let Some(g) = self.stack.pop() {
            self.visible.push(g);
            for e in 0..3 {
                let h = self.facets[g as usize].adj[e];
                let mark = self.facets[h as usize].mark;
                if mark == vis {
                    continue;
                }
                let side = if mark == seen {
                    1
                } else {
                    self.orient(self.facets[h as usize].v, &q)
                };
                if side < 0 {
                    self.facets[h as usize].mark = vis;
                    self.stack.push(h);
                } else {
                    self.coplanar_seen |= side == 0;
                    self.facets[h as usize].mark = seen;
                    self.horizon.push((g, e as u32));
                }
            }
        }

        // The cone from q to the horizon. The horizon is a simple cycle of a few edges: a
        // linear search over it (in L1) links the new facets faster than any per-vertex table.
        self.new_facets.clear();
        for k in 0..self.horizon.len() {
            let (g, e) = self.horizon[k];
            let e = e as usize;
            let gv = self.facets[g as usize].v;
            let (a, b) = (gv[e], gv[(e + 1) % 3]);
            let outside = self.facets[g as usize].adj[e];
            let nf = self.alloc(Facet {
                v: [a, b, i],
                adj: [outside, NONE, NONE],
                mark: 0,
                alive: true,
            });
            // The outside facet's edge b→a now borders the new facet.
            let of = &mut self.facets[outside as usize];
            let slot = (0..3)
                .find(|&s| of.v[s] == b && of.v[(s + 1) % 3] == a)
                .ok_or_else(|| HullError::Internal("broken adjacency at the horizon".into()))?;
            of.adj[slot] = nf;
            self.new_facets.push(nf);
        }
        for k in 0..self.new_facets.len() {
            let nf = self.new_facets[k];
            let b = self.facets[nf as usize].v[1];
            // Edge b→q borders the new facet whose horizon edge starts at b.
            let mut found = NONE;
            for &other in &self.new_facets {
                if self.facets[other as usize].v[0] == b {
                    if found != NONE {
                        return Err(HullError::Internal(
                            "the horizon is not a simple cycle".into(),
                        ));
                    }
                    found = other;
                }
            }
            if found == NONE {
                return Err(HullError::Internal("the horizon is not closed".into()));
            }
            self.facets[nf as usize].adj[1] = found;
            self.facets[found as usize].adj[2] = nf;
        }
        for k in 0..self.visible.len() {
            let g = self.visible[k];
            self.facets[g as usize].alive = false;
            self.free.push(g);
        }
        self.last = self.new_facets[0];
        self.stats.facets_created += self.new_facets.len();
        Ok(())
    }

    fn alloc(&mut self, f: Facet) -> u32 {
        match self.free.pop() {
            Some(slot) => {
                self.facets[slot as usize] = f;
                slot
            }
            None => {
                self.facets.push(f);
                (self.facets.len() - 1) as u32
            }
        }
    }

    /// The extreme vertices (ascending local indices) and, if asked for, the live facets.
    fn finish(&self, with_facets: bool) -> (Vec<u32>, Vec<[u32; 3]>) {
        // One incident facet per vertex, then count distinct planes around each vertex.
        let mut incident = vec![NONE; self.pts.len()];
        for (f, facet) in self.facets.iter().enumerate() {
            if facet.alive {
                for &v in &facet.v {
                    incident[v as usize] = f as u32;
                }
            }
        }
        // Two adjacent facets can only be coplanar if, at some insertion, the new point was
        // exactly coplanar with a facet on the horizon: a coplanar pair on the new cone
        // (a, b, q), (b, c, q) needs a, b, c, q in a plane P supporting the old hull, and then
        // the old facet beyond (a, b) lies in P. Without such an event every corner is extreme.
        let vertices: Vec<u32> = (0..self.pts.len() as u32)
            .filter(|&v| {
                incident[v as usize] != NONE
                    && (!self.coplanar_seen || self.is_extreme(v, incident[v as usize]))
            })
            .collect();
        let facets = if with_facets {
            self.facets
                .iter()
                .filter(|f| f.alive)
                .map(|f| f.v)
                .collect()
        } else {
            Vec::new()
        };
        (vertices, facets)
    }

    /// True when the facets around vertex `v` span at least three distinct planes.
    fn is_extreme(&self, v: u32, start: u32) -> bool {
        let mut changes = 0;
        let mut f = start;
        loop {
            let facet = &self.facets[f as usize];
            let e = (0..3).position(|k| facet.v[k] == v).unwrap_or(0);
            // Rotate around v: the facet across the edge ending at v (v[e-1] → v[e]).
            let prev_edge = (e + 2) % 3;
            let g = facet.adj[prev_edge];
            // g's corner opposite the shared edge decides coplanarity.
            let gf = &self.facets[g as usize];
            let shared = [facet.v[prev_edge], facet.v[e]];
            let opposite =
                gf.v.iter()
                    .copied()
                    .find(|u| !shared.contains(u))
                    .unwrap_or(gf.v[0]);
            if self.orient(facet.v, self.p(opposite)) != 0 {
                changes += 1;
                if changes >= 3 {
                    return true;
                }
            }
            f = g;
            if f == start {
                return false;
            }
        }
    }
}

/// The stochastic visibility walk (read-only): from facet `start` to the facet whose cone from
/// `interior` contains the direction of q. The edge just crossed is not tested again; the
/// first edge tested rotates pseudo-randomly, which rules out cycles.
fn walk(
    facets: &[Facet],
    pts: &[P3],
    interior: &P3,
    start: u32,
    q: &P3,
    rng: &mut u64,
    steps: &mut usize,
) -> Result<u32, HullError> {
    let mut f = start;
    let mut from = NONE;
    let limit = 4 * facets.len() + 64;
    for _ in 0..limit {
        *steps += 1;
        let facet = &facets[f as usize];
        *rng ^= *rng << 13;
        *rng ^= *rng >> 7;
        *rng ^= *rng << 17;
        let first = ((*rng >> 32) % 3) as usize;
        let mut next = NONE;
        for k in 0..3 {
            let e = (first + k) % 3;
            if facet.adj[e] == from {
                continue;
            }
            let (a, b) = (facet.v[e], facet.v[(e + 1) % 3]);
            // The interior point, a and b span the plane of the edge's wedge; the facet's
            // third corner is on its non-positive side. Cross when q is strictly beyond.
            if orient3d_sign(interior, &pts[a as usize], &pts[b as usize], q) > 0 {
                next = facet.adj[e];
                break;
            }
        }
        if next == NONE {
            return Ok(f);
        }
        from = f;
        f = next;
    }
    Err(HullError::Internal(
        "point location did not terminate".into(),
    ))
}

/// A facet a point was found strictly above, with its corners at the time.
type Hint = Option<(u32, [u32; 3])>;

/// Rounds smaller than this are located sequentially.
const PARALLEL_ROUND: usize = 16_384;
/// Points per parallel location task.
const LOCATE_CHUNK: usize = 4_096;

#[inline]
fn sub(a: &P3, b: &P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn cross(a: &P3, b: &P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
fn dot(a: &P3, b: &P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn norm2(a: &P3) -> f64 {
    dot(a, a)
}

/// The `own` implementation behind [`crate::ConvexHull`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Incremental;

impl crate::ConvexHull for Incremental {
    fn name(&self) -> &'static str {
        "own"
    }

    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError> {
        hull_vertices(points).map(|h| h.vertices)
    }

    fn vertices_distinct(&self, points: &[P3]) -> Result<(Vec<u32>, bool), HullError> {
        hull_vertices(points).map(|h| (h.vertices, h.distinct))
    }
}

#[cfg(test)]
mod tests;
