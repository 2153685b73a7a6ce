//! The exact caster's tree (beyond the seed): a bounding volume hierarchy over buckets of up to
//! [`LEAF`] points, laid out for coherent rays.
//!
//! Built as a k-d tree is, top down: a node's points are split at their median on the longest
//! side of the node's cell (the cloud's box cut by the splits above) until at most [`LEAF`]
//! remain; each node keeps the bounding box of its
//! points, the union of its children's. Unlike the seed's tree
//! ([`crate::kdtree`]: a point in every node), the points live only in the leaves, several to a
//! leaf, so a ray walks about an eighth as many nodes and tests a leaf's points together
//! (bucketed leaves, as in Wald, Slusallek, Benthin and Wagner, "Interactive rendering with
//! coherent ray tracing", 2001; the median split on the longest axis is the cheap stand-in for a
//! surface-area split, whose cost model knows nothing of the radius chosen at cast time).
//!
//! Layout (PERF): nodes are 32 bytes (the box in `f32` relative to the cloud's centre, rounded
//! outward; the first child or first slot; the count and split axis); the two children of a node
//! are adjacent and share a 64-byte line. A leaf's points take consecutive *slots* from a
//! multiple of 4: their offsets from the centre in `f32`, four to a [`Quad`] in
//! structure-of-arrays form for 4-wide tests, and beside them, slot for slot, the exact `f64`
//! position and the input index (padding slots: NaN and [`NONE`]). Leaves follow one another
//! in depth-first order, so a subtree's points are contiguous.

use std::collections::HashMap;

use cloud::glam::DVec3;

use crate::kdtree::{NONE, down, up};

/// Most points in a leaf.
pub const LEAF: usize = 8;

/// Lanes of a [`Quad`].
pub const LANES: usize = 4;

/// Subtrees with more points than this are built in parallel.
const PARALLEL_BUILD: usize = 32_768;

const LEAF_FLAG: u32 = 1 << 31;

/// A node: the bounding box of its points and where its children or points are.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub struct Node {
    /// Lower corner, relative to [`Bvh::centre`], rounded down.
    pub lo: [f32; 3],
    /// Upper corner, relative to [`Bvh::centre`], rounded up.
    pub hi: [f32; 3],
    /// Inner node: the first child (the second is the next node). Leaf: the first slot.
    pub first: u32,
    /// Leaf: the flag bit 31 and the number of points; inner node: the split axis.
    meta: u32,
}

impl Node {
    /// True for a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.meta & LEAF_FLAG != 0
    }

    /// A leaf's number of points.
    #[inline(always)]
    pub fn count(&self) -> usize {
        (self.meta & !LEAF_FLAG) as usize
    }

    /// An inner node's split axis.
    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.meta & 3) as usize
    }
}

/// Four slots' offsets from the centre, structure of arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
pub struct Quad {
    /// x offsets.
    pub x: [f32; LANES],
    /// y offsets.
    pub y: [f32; LANES],
    /// z offsets.
    pub z: [f32; LANES],
}

const NAN_QUAD: Quad = Quad {
    x: [f32::NAN; LANES],
    y: [f32::NAN; LANES],
    z: [f32::NAN; LANES],
};

/// Two sibling nodes on one cache line.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct Pair([Node; 2]);

const EMPTY: Node = Node {
    lo: [0.0; 3],
    hi: [0.0; 3],
    first: 0,
    meta: 0,
};

/// The hierarchy.
#[derive(Debug, Clone)]
pub struct Bvh {
    /// Nodes by pairs: node `i` is `pairs[i / 2].0[i % 2]`; the root is node 0, node 1 unused.
    pairs: Vec<Pair>,
    /// Offsets from the centre, four slots a quad.
    pub quads: Vec<Quad>,
    /// Exact positions by slot (NaN in padding slots).
    pub exact: Vec<[f64; 3]>,
    /// Input index by slot ([`NONE`] in padding slots).
    pub index: Vec<u32>,
    /// The centre of the cloud's bounding box: the origin of the `f32` coordinates.
    pub centre: [f64; 3],
    /// The largest coordinate of a point relative to the centre (half the box's longest side,
    /// rounded up).
    pub half_extent: f64,
}

/// Pairs of descendant nodes and quads of a subtree of `n` points.
fn shape(n: usize, memo: &mut HashMap<usize, (usize, usize)>) -> (usize, usize) {
    if n <= LEAF {
        return (0, n.div_ceil(LANES));
    }
    if let Some(&s) = memo.get(&n) {
        return s;
    }
    let (l, r) = (shape(n / 2, memo), shape(n - n / 2, memo));
    let s = (1 + l.0 + r.0, l.1 + r.1);
    memo.insert(n, s);
    s
}

/// Where a subtree goes: its descendants' node pairs and its slots.
struct Out<'a> {
    pairs: &'a mut [Pair],
    pair_base: u32,
    quads: &'a mut [Quad],
    exact: &'a mut [[f64; 3]],
    index: &'a mut [u32],
    quad_base: u32,
}

impl Bvh {
    /// Builds the hierarchy over `points` (finite, at most 2^32 − 1; the caller checks).
    pub fn build(points: &[DVec3]) -> Self {
        let n = points.len();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let centre = if n == 0 { DVec3::ZERO } else { (lo + hi) * 0.5 };
        let half_extent = if n == 0 {
            0.0
        } else {
            ((hi - centre).max(centre - lo)).max_element() * (1.0 + 1e-15)
        };
        let mut memo = HashMap::new();
        let (desc, quads) = shape(n, &mut memo);
        let mut pairs = vec![Pair([EMPTY; 2]); 1 + desc];
        let mut quad_out = vec![NAN_QUAD; quads];
        let mut exact = vec![[f64::NAN; 3]; quads * LANES];
        let mut index = vec![NONE; quads * LANES];
        if n > 0 {
            let mut items: Vec<(DVec3, u32)> = points
                .iter()
                .enumerate()
                .map(|(i, &p)| (p, i as u32))
                .collect();
            let (root, rest) = pairs.split_at_mut(1);
            let out = Out {
                pairs: rest,
                pair_base: 1,
                quads: &mut quad_out,
                exact: &mut exact,
                index: &mut index,
                quad_base: 0,
            };
            root[0].0[0] = build_into(&mut items, (lo, hi), out, centre, &memo);
        }
        Self {
            pairs,
            quads: quad_out,
            exact,
            index,
            centre: centre.to_array(),
            half_extent,
        }
    }

    /// Node `i`.
    #[inline(always)]
    pub fn node(&self, i: u32) -> &Node {
        &self.pairs[(i >> 1) as usize].0[(i & 1) as usize]
    }

    /// The two children of inner node `n`.
    #[inline(always)]
    pub fn children(&self, n: &Node) -> &[Node; 2] {
        &self.pairs[(n.first >> 1) as usize].0
    }

    /// Number of nodes (the unused node 1 included).
    pub fn len(&self) -> usize {
        self.pairs.len() * 2
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.quads.is_empty()
    }

    /// `values` (one per input point) by slot; padding slots get `pad`.
    pub fn in_slot_order<T: Copy>(&self, values: &[T], pad: T) -> Vec<T> {
        self.index
            .iter()
            .map(|&i| if i == NONE { pad } else { values[i as usize] })
            .collect()
    }

    /// The points in input order, as given to [`Bvh::build`].
    pub fn points(&self) -> Vec<DVec3> {
        let n = self.index.iter().filter(|&&i| i != NONE).count();
        let mut out = vec![DVec3::ZERO; n];
        for (&i, p) in self.index.iter().zip(&self.exact) {
            if i != NONE {
                out[i as usize] = DVec3::from_array(*p);
            }
        }
        out
    }
}

/// Builds the subtree of `items` into `out`; returns its root node. `cell` is the box the
/// splits above leave the subtree (its points lie in it): its longest side is the split axis.
fn build_into(
    items: &mut [(DVec3, u32)],
    cell: (DVec3, DVec3),
    out: Out<'_>,
    centre: DVec3,
    memo: &HashMap<usize, (usize, usize)>,
) -> Node {
    let n = items.len();
    if n <= LEAF {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for (k, (p, i)) in items.iter().enumerate() {
            let q = &mut out.quads[k / LANES];
            let l = k % LANES;
            q.x[l] = (p.x - centre.x) as f32;
            q.y[l] = (p.y - centre.y) as f32;
            q.z[l] = (p.z - centre.z) as f32;
            out.exact[k] = p.to_array();
            out.index[k] = *i;
            for a in 0..3 {
                lo[a] = lo[a].min(down(p[a] - centre[a]));
                hi[a] = hi[a].max(up(p[a] - centre[a]));
            }
        }
        return Node {
            lo,
            hi,
            first: out.quad_base * LANES as u32,
            meta: LEAF_FLAG | n as u32,
        };
    }
    let axis = (cell.1 - cell.0).max_position();
    let m = n / 2;
    // The median; equal coordinates go either side (the selection is deterministic).
    match axis {
        0 => items.select_nth_unstable_by(m, |a, b| a.0.x.total_cmp(&b.0.x)),
        1 => items.select_nth_unstable_by(m, |a, b| a.0.y.total_cmp(&b.0.y)),
        _ => items.select_nth_unstable_by(m, |a, b| a.0.z.total_cmp(&b.0.z)),
    };
    let split = items[m].0[axis];
    let (mut l_cell, mut r_cell) = (cell, cell);
    l_cell.1[axis] = split;
    r_cell.0[axis] = split;
    let (left, right) = items.split_at_mut(m);
    let ((ld, lq), (rd, _)) = (shape_of(left.len(), memo), shape_of(right.len(), memo));
    let (pair, rest) = out.pairs.split_at_mut(1);
    let (l_pairs, r_pairs) = rest.split_at_mut(ld);
    debug_assert_eq!(r_pairs.len(), rd);
    let (l_quads, r_quads) = out.quads.split_at_mut(lq);
    let (l_exact, r_exact) = out.exact.split_at_mut(lq * LANES);
    let (l_index, r_index) = out.index.split_at_mut(lq * LANES);
    let l_out = Out {
        pairs: l_pairs,
        pair_base: out.pair_base + 1,
        quads: l_quads,
        exact: l_exact,
        index: l_index,
        quad_base: out.quad_base,
    };
    let r_out = Out {
        pairs: r_pairs,
        pair_base: out.pair_base + 1 + ld as u32,
        quads: r_quads,
        exact: r_exact,
        index: r_index,
        quad_base: out.quad_base + lq as u32,
    };
    let (l, r) = if n > PARALLEL_BUILD {
        rayon::join(
            || build_into(left, l_cell, l_out, centre, memo),
            || build_into(right, r_cell, r_out, centre, memo),
        )
    } else {
        (
            build_into(left, l_cell, l_out, centre, memo),
            build_into(right, r_cell, r_out, centre, memo),
        )
    };
    pair[0] = Pair([l, r]);
    // The union of the children's boxes (rounding is monotone: the rounded union).
    Node {
        lo: std::array::from_fn(|a| l.lo[a].min(r.lo[a])),
        hi: std::array::from_fn(|a| l.hi[a].max(r.hi[a])),
        first: 2 * out.pair_base,
        meta: axis as u32,
    }
}

/// [`shape`] of a size the top-level call has already seen.
fn shape_of(n: usize, memo: &HashMap<usize, (usize, usize)>) -> (usize, usize) {
    if n <= LEAF {
        (0, n.div_ceil(LANES))
    } else {
        memo[&n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point in one leaf slot, in its boxes; boxes nested; leaves in depth-first order.
    fn check(points: &[DVec3], bvh: &Bvh) {
        let c = DVec3::from_array(bvh.centre);
        let mut seen = vec![false; points.len()];
        let mut next_slot = 0;
        fn inside(p: DVec3, c: DVec3, n: &Node) -> bool {
            (0..3).all(|k| n.lo[k] as f64 <= p[k] - c[k] && p[k] - c[k] <= n.hi[k] as f64)
        }
        let mut stack = vec![(0u32, Vec::<usize>::new())];
        while let Some((at, ancestors)) = stack.pop() {
            let n = bvh.node(at);
            if n.is_leaf() {
                assert!((1..=LEAF).contains(&n.count()));
                assert_eq!(n.first as usize, next_slot, "leaves in depth-first order");
                assert_eq!(n.first as usize % LANES, 0);
                for s in n.first as usize..n.first as usize + n.count() {
                    let i = bvh.index[s] as usize;
                    assert!(!seen[i]);
                    seen[i] = true;
                    assert_eq!(bvh.exact[s], points[i].to_array());
                    let q = bvh.quads[s / LANES];
                    let l = s % LANES;
                    let off = [q.x[l], q.y[l], q.z[l]];
                    for k in 0..3 {
                        assert!(
                            (off[k] as f64 - (points[i][k] - c[k])).abs()
                                <= 1e-6 * (1.0 + bvh.half_extent)
                        );
                        assert!((points[i][k] - c[k]).abs() <= bvh.half_extent);
                    }
                    assert!(inside(points[i], c, n));
                    for &a in &ancestors {
                        assert!(inside(points[i], c, bvh.node(a as u32)));
                    }
                }
                for s in n.first as usize + n.count()
                    ..(n.first as usize + n.count()).next_multiple_of(LANES)
                {
                    assert_eq!(bvh.index[s], NONE);
                    assert!(bvh.exact[s][0].is_nan());
                }
                next_slot = (n.first as usize + n.count()).next_multiple_of(LANES);
            } else {
                assert_eq!(n.first % 2, 0, "siblings share a pair");
                let mut a = ancestors.clone();
                a.push(at as usize);
                stack.push((n.first + 1, a.clone()));
                stack.push((n.first, a));
            }
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(next_slot, bvh.index.len());
        assert_eq!(bvh.points(), points);
    }

    #[test]
    fn every_point_in_one_leaf_inside_every_box_above_it() {
        for n in [1, 2, 5, 8, 9, 17, 100, 1000] {
            let pts: Vec<DVec3> = (0..n)
                .map(|i| {
                    let t = i as f64;
                    DVec3::new((t * 0.37).sin(), (t * 0.11).cos() * 3.0, t * 1e-3 + 500.0)
                })
                .collect();
            check(&pts, &Bvh::build(&pts));
        }
        // Coincident points and a grid sharing coordinates.
        check(&vec![DVec3::ONE; 37], &Bvh::build(&vec![DVec3::ONE; 37]));
        let grid: Vec<DVec3> = (0..343)
            .map(|i| DVec3::new((i % 7) as f64, (i / 7 % 7) as f64, (i / 49) as f64))
            .collect();
        check(&grid, &Bvh::build(&grid));
    }

    #[test]
    fn large_tree_built_in_parallel_is_the_sequential_one() {
        let pts = cloud::synth::fibonacci_sphere(100_000);
        let bvh = Bvh::build(&pts);
        check(&pts, &bvh);
        // The same tree from the same points, whatever the threads did.
        let again = Bvh::build(&pts);
        assert_eq!(bvh.pairs, again.pairs);
        assert_eq!(bvh.index, again.index);
    }
}
