//! The point k-d tree of seed 001 ("Data Structure", "Traversing the tree").
//!
//! One point per node (n points, n nodes); the splitting axis cycles X, Y, Z with depth; the
//! tree is balanced at build time by splitting at the median (the node's own point is the
//! median, the points before it go left, after it right). Each node keeps, as the seed asks,
//! the bounds of its range ("we shall ... assume the k-d node has maximum and minimum values as
//! a part of this structure") and whether a point on its splitting plane went to the child in
//! back (−, left) or in front (+, right) "relative to Cartesian axis directions".
//!
//! Layout (PERF): nodes are stored in depth-first preorder, 64 bytes each (the point in f64,
//! the bounds in f32 rounded outward, the index, the right child's position, a flag word); the
//! left child is the next node. A subtree is a contiguous range, so the top levels are built in
//! parallel into disjoint slices.

use cloud::glam::DVec3;

/// "No child".
pub const NONE: u32 = u32::MAX;

const HAS_LEFT: u32 = 1 << 2;
const EQ_LEFT: u32 = 1 << 3;
const EQ_RIGHT: u32 = 1 << 4;

/// A node: its point, its subtree's bounds, its children and flags.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct Node {
    /// The point (the median of the node's range on its axis).
    pub p: [f64; 3],
    /// Lower corner of the subtree's bounding box (f32, rounded down).
    pub lo: [f32; 3],
    /// Upper corner of the subtree's bounding box (f32, rounded up).
    pub hi: [f32; 3],
    /// The point's index in the input.
    pub index: u32,
    /// Position of the right child, or [`NONE`].
    pub right: u32,
    /// Axis in bits 0–1, then has-left, equal-plane point in the left child, in the right.
    pub meta: u32,
}

impl Node {
    /// Splitting axis (0 = X, 1 = Y, 2 = Z).
    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.meta & 3) as usize
    }

    /// The splitting value: the node point's coordinate on its axis.
    #[inline(always)]
    pub fn split(&self) -> f64 {
        self.p[self.axis()]
    }

    /// Position of the left child (the next node), if any.
    #[inline(always)]
    pub fn left(&self, at: u32) -> u32 {
        if self.meta & HAS_LEFT != 0 {
            at + 1
        } else {
            NONE
        }
    }

    /// True when a point of the left (back, −) child lies on the splitting plane.
    #[inline(always)]
    pub fn equal_in_back(&self) -> bool {
        self.meta & EQ_LEFT != 0
    }

    /// True when a point of the right (front, +) child lies on the splitting plane.
    #[inline(always)]
    pub fn equal_in_front(&self) -> bool {
        self.meta & EQ_RIGHT != 0
    }
}

/// The tree.
#[derive(Debug, Clone)]
pub struct KdTree {
    /// Nodes in preorder; the root is node 0.
    pub nodes: Vec<Node>,
}

/// Subtrees smaller than this are built on the current thread.
const PARALLEL_BUILD: usize = 32_768;

impl KdTree {
    /// `values` (one per input point) in node order: entry `at` is node `at`'s point's.
    pub fn in_node_order<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.nodes
            .iter()
            .map(|n| values[n.index as usize])
            .collect()
    }

    /// Builds the tree over `points` (finite; the caller checks).
    pub fn build(points: &[DVec3]) -> Self {
        let mut items: Vec<(DVec3, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, &p)| (p, i as u32))
            .collect();
        let mut nodes = vec![
            Node {
                p: [0.0; 3],
                lo: [0.0; 3],
                hi: [0.0; 3],
                index: 0,
                right: NONE,
                meta: 0
            };
            points.len()
        ];
        if !points.is_empty() {
            build_into(&mut items, &mut nodes, 0, 0);
        }
        Self { nodes }
    }

    /// Depth of the tree (longest root-to-leaf path, in nodes).
    pub fn depth(&self) -> usize {
        fn go(nodes: &[Node], at: u32) -> usize {
            if at == NONE {
                return 0;
            }
            let n = &nodes[at as usize];
            1 + go(nodes, n.left(at)).max(go(nodes, n.right))
        }
        if self.nodes.is_empty() {
            0
        } else {
            go(&self.nodes, 0)
        }
    }
}

/// `v` as `f32`, rounded down.
pub(crate) fn down(v: f64) -> f32 {
    let f = v as f32;
    if f as f64 > v { f.next_down() } else { f }
}

/// `v` as `f32`, rounded up.
pub(crate) fn up(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v { f.next_up() } else { f }
}

/// Builds the subtree of `items` into `out` (same length), whose first slot is at global
/// position `base`; returns the subtree's bounds.
fn build_into(
    items: &mut [(DVec3, u32)],
    out: &mut [Node],
    base: u32,
    depth: usize,
) -> ([f32; 3], [f32; 3]) {
    let n = items.len();
    let axis = depth % 3;
    let m = n / 2;
    // Median on the axis, ties broken by index so that the tree is deterministic.
    items.select_nth_unstable_by(m, |a, b| {
        a.0[axis].total_cmp(&b.0[axis]).then(a.1.cmp(&b.1))
    });
    let (p, index) = items[m];
    let split = p[axis];
    let (left, rest) = items.split_at_mut(m);
    let right = &mut rest[1..];
    let mut meta = axis as u32;
    if !left.is_empty() {
        meta |= HAS_LEFT;
    }
    if left.iter().any(|q| q.0[axis] == split) {
        meta |= EQ_LEFT;
    }
    if right.iter().any(|q| q.0[axis] == split) {
        meta |= EQ_RIGHT;
    }
    let (node_slot, children) = out.split_at_mut(1);
    let (left_out, right_out) = children.split_at_mut(left.len());
    let right_pos = if right.is_empty() {
        NONE
    } else {
        base + 1 + left.len() as u32
    };
    let build_left = |l: &mut [(DVec3, u32)], o: &mut [Node]| {
        (!l.is_empty()).then(|| build_into(l, o, base + 1, depth + 1))
    };
    let build_right = |r: &mut [(DVec3, u32)], o: &mut [Node]| {
        (!r.is_empty()).then(|| build_into(r, o, right_pos, depth + 1))
    };
    let (lb, rb) = if n >= PARALLEL_BUILD {
        rayon::join(
            || build_left(left, left_out),
            || build_right(right, right_out),
        )
    } else {
        (build_left(left, left_out), build_right(right, right_out))
    };
    let mut lo = [down(p.x), down(p.y), down(p.z)];
    let mut hi = [up(p.x), up(p.y), up(p.z)];
    for (clo, chi) in [lb, rb].into_iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(clo[k]);
            hi[k] = hi[k].max(chi[k]);
        }
    }
    node_slot[0] = Node {
        p: p.to_array(),
        lo,
        hi,
        index,
        right: right_pos,
        meta,
    };
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_invariants(points: &[DVec3], tree: &KdTree) {
        // Every point once; ranges contiguous; split invariant; bounds enclose; flags right.
        let mut seen = vec![false; points.len()];
        fn walk(
            nodes: &[Node],
            at: u32,
            depth: usize,
            seen: &mut [bool],
            points: &[DVec3],
        ) -> Vec<u32> {
            if at == NONE {
                return Vec::new();
            }
            let n = nodes[at as usize];
            assert_eq!(n.axis(), depth % 3, "axes cycle X, Y, Z");
            assert!(!seen[n.index as usize]);
            seen[n.index as usize] = true;
            assert_eq!(n.p, points[n.index as usize].to_array());
            let left = walk(nodes, n.left(at), depth + 1, seen, points);
            let right = walk(nodes, n.right, depth + 1, seen, points);
            let a = n.axis();
            for &i in &left {
                assert!(points[i as usize][a] <= n.split());
            }
            for &i in &right {
                assert!(points[i as usize][a] >= n.split());
            }
            assert_eq!(
                n.equal_in_back(),
                left.iter().any(|&i| points[i as usize][a] == n.split())
            );
            assert_eq!(
                n.equal_in_front(),
                right.iter().any(|&i| points[i as usize][a] == n.split())
            );
            let mut all = left;
            all.extend(right);
            all.push(n.index);
            for &i in &all {
                for k in 0..3 {
                    let c = points[i as usize][k];
                    assert!(n.lo[k] as f64 <= c && c <= n.hi[k] as f64);
                }
            }
            all
        }
        walk(&tree.nodes, 0, 0, &mut seen, points);
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn balanced_with_equal_coordinates() {
        // A grid: many points share coordinates on every axis.
        let mut pts = Vec::new();
        for x in 0..7 {
            for y in 0..5 {
                for z in 0..3 {
                    pts.push(DVec3::new(x as f64, y as f64 * 0.5, z as f64 + 1000.0));
                }
            }
        }
        let tree = KdTree::build(&pts);
        check_invariants(&pts, &tree);
        assert!(tree.depth() <= (pts.len() as f64).log2().ceil() as usize + 1);
    }

    #[test]
    fn large_tree_built_in_parallel_is_the_same_shape() {
        let pts: Vec<DVec3> = cloud::synth::fibonacci_sphere(100_000);
        let tree = KdTree::build(&pts);
        check_invariants(&pts, &tree);
        assert_eq!(tree.depth(), 17);
    }
}
