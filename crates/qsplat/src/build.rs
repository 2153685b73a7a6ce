//! Building QSplat's bounding-sphere hierarchy (Rusinkiewicz and Levoy 2000, §3.1; seed 002
//! §5.2.1), before quantisation.
//!
//! Leaves are the input points, each a sphere of the leaf radius. A set of points is split at
//! the midpoint of its bounding box's longest axis, and each half with more than one point is
//! split again the same way, giving two to four children (the original's "up to 4 children").
//! If every point of a set lies on one side of the midpoint (coincident points), the set is
//! split in halves by position in the list; the split is a stable partition, so every set lists
//! its points in input order (which the out-of-core build relies on). A parent's sphere encloses its children's spheres
//! (centre: the middle of their bounding box; radius: the largest distance to a child's far
//! side); its normal is the normalised sum of its children's normals weighted by their leaf
//! counts; its normal-cone half-angle the largest, over children, of the angle between the
//! child's normal and the parent's plus the child's own half-angle; its colour the leaf-count
//! weighted mean.
//!
//! Parallel build (the same tree, node for node, as the sequential recursion): the upper
//! levels are split in parallel down to subtrees of fewer than 16,384 points, those are
//! built side by side each into its own vector, the few parents above them are made from their
//! roots, and everything is moved once, in parallel, into the post-order arena.

use cloud::glam::{DVec3, Vec3};

/// A node of the (unquantised) hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Sphere centre.
    pub center: DVec3,
    /// Sphere radius.
    pub radius: f64,
    /// Unit normal.
    pub normal: DVec3,
    /// Normal-cone half-angle, radians.
    pub cone: f64,
    /// Mean colour, RGB in [0, 255].
    pub color: Vec3,
    /// Leaves below (1 for a leaf).
    pub leaves: u32,
    /// Children (arena indices), the first `n_children` used.
    pub kids: [u32; 4],
    /// Number of children (0 for a leaf).
    pub n_children: u8,
    /// The input point, for a leaf.
    pub point: Option<u32>,
}

impl Node {
    /// Children (arena indices); empty for a leaf.
    pub fn children(&self) -> &[u32] {
        &self.kids[..self.n_children as usize]
    }
}

/// The hierarchy: an arena whose last node is the root. Every subtree is contiguous and ends
/// with its root, so the subtree of child k of a node spans from just after child k − 1 (or
/// the node's own first index) to child k.
#[derive(Debug, Clone, PartialEq)]
pub struct Hierarchy {
    /// Nodes; children come before their parent.
    pub nodes: Vec<Node>,
}

impl Hierarchy {
    /// The root's index.
    pub fn root(&self) -> usize {
        self.nodes.len() - 1
    }
}

/// The inputs of a build.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// Positions.
    pub positions: &'a [DVec3],
    /// Unit normals.
    pub normals: &'a [Vec3],
    /// Colours, if any.
    pub colors: Option<&'a [[u8; 3]]>,
    /// Leaf sphere radius.
    pub leaf_radius: f64,
}

/// Subtrees smaller than this are built by one thread.
const PARALLEL: usize = 16_384;

/// Builds the hierarchy over all points.
pub fn build(input: &Input<'_>) -> Hierarchy {
    let mut items = items_of(input);
    let nodes = build_sub(input, &mut items);
    Hierarchy { nodes }
}

/// The input points as the build sorts them.
fn items_of(input: &Input<'_>) -> Vec<Item> {
    input
        .positions
        .iter()
        .zip(input.normals)
        .enumerate()
        .map(|(i, (p, n))| Item {
            p: *p,
            n: *n,
            i: i as u32,
        })
        .collect()
}

/// The root of the hierarchy [`build`] makes, the very node (bit for bit, its children's arena
/// indices included), without the other nodes: the same splits and the same [`parent_from`] of
/// the same children, each subtree's nodes counted instead of stored (no arena, no copy into
/// it). The out-of-core build needs a chunk's root before it can encode the chunk.
pub fn build_root(input: &Input<'_>) -> Node {
    let mut items = items_of(input);
    root_of(input, &mut items).0
}

/// A node to overwrite.
pub(crate) const BLANK: Node = Node {
    center: DVec3::ZERO,
    radius: 0.0,
    normal: DVec3::Z,
    cone: 0.0,
    color: Vec3::ZERO,
    leaves: 0,
    kids: [0; 4],
    n_children: 0,
    point: None,
};

/// The root of the subtree of `items` and its number of nodes, its children's indices relative
/// to the subtree's first node (the arena's post order: child k's subtree follows child k - 1's
/// and ends with its root); the children of a subtree of [`PARALLEL`] points or more are made
/// in parallel, as [`build_sub`] makes them.
fn root_of(input: &Input<'_>, items: &mut [Item]) -> (Node, u32) {
    if items.len() == 1 {
        return (leaf(input, &items[0]), 1);
    }
    let large = items.len() >= PARALLEL;
    let groups = groups(items);
    let n = groups.len();
    let mut kids = [BLANK, BLANK, BLANK, BLANK];
    let mut counts = [0u32; 4];
    if large {
        use rayon::prelude::*;
        let made: Vec<(Node, u32)> = groups.into_par_iter().map(|g| root_of(input, g)).collect();
        for (k, (node, count)) in made.into_iter().enumerate() {
            kids[k] = node;
            counts[k] = count;
        }
    } else {
        for (k, g) in groups.into_iter().enumerate() {
            (kids[k], counts[k]) = root_of(input, g);
        }
    }
    let mut ids = [0u32; 4];
    let mut total = 0u32;
    for k in 0..n {
        total += counts[k];
        ids[k] = total - 1;
    }
    let [a, b, c, d] = &kids;
    let refs = [a, b, c, d];
    (parent_from(&refs[..n], &ids[..n]), total + 1)
}

fn leaf(input: &Input<'_>, item: &Item) -> Node {
    let i = item.i;
    let c = input.colors.map_or(Vec3::splat(200.0), |c| {
        let c = c[i as usize];
        Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
    });
    Node {
        center: item.p,
        radius: input.leaf_radius,
        normal: item.n.as_dvec3().normalize_or(DVec3::Z),
        cone: 0.0,
        color: c,
        leaves: 1,
        kids: [0; 4],
        n_children: 0,
        point: Some(i),
    }
}

/// A point being sorted into the tree: its position and normal (carried along, so that the
/// partitions and the leaves read memory in order) and its index.
#[derive(Debug, Clone, Copy)]
struct Item {
    p: DVec3,
    n: Vec3,
    i: u32,
}

thread_local! {
    /// The right-hand points of a split, while the left ones move down.
    static RIGHT: std::cell::RefCell<Vec<Item>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Items a thread's [`RIGHT`] buffer keeps between splits (a larger one is freed).
const KEEP: usize = 4 * PARALLEL;

/// Splits `items` at the midpoint of their bounding box's longest axis (in place); returns the
/// size of the first part (never 0 nor the whole, for two or more items).
fn split(items: &mut [Item]) -> usize {
    let fold = |(lo, hi): (DVec3, DVec3), it: &Item| (lo.min(it.p), hi.max(it.p));
    let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (lo, hi) = if items.len() >= 4 * PARALLEL {
        use rayon::prelude::*;
        items
            .par_iter()
            .fold(|| empty, fold)
            .reduce(|| empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
    } else {
        items.iter().fold(empty, fold)
    };
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = 0.5 * (lo[axis] + hi[axis]);
    // A stable partition (the points below the midpoint first, each side in the order it
    // had), so that every set stays in input order: the out-of-core build, which streams the
    // points to their chunks in input order, then has each chunk in the order this build
    // gives it, whatever way the points reached the chunk. (The order decides how coincident
    // points are halved.) The right points wait in a buffer of the thread's while the left
    // ones move down.
    let k = RIGHT.with_borrow_mut(|right| {
        // Branch-free: every item is written to both places and only the side it belongs to
        // advances (a midpoint split is a coin toss for a branch predictor).
        let n = items.len();
        let Some(&first) = items.first() else {
            return 0;
        };
        if right.len() < n {
            right.resize(n, first);
        }
        let (mut k, mut r) = (0, 0);
        for j in 0..n {
            let it = items[j];
            let left = usize::from(it.p[axis] < mid);
            items[k] = it;
            right[r] = it;
            k += left;
            r += 1 - left;
        }
        items[k..].copy_from_slice(&right[..r]);
        if right.len() > KEEP {
            *right = Vec::new();
        }
        k
    });
    if k == 0 || k == items.len() {
        items.len() / 2
    } else {
        k
    }
}

/// Splits `items` into two to four groups (the two halves, each halved again when it has two
/// or more points).
fn groups(items: &mut [Item]) -> Vec<&mut [Item]> {
    let k = split(items);
    let large = items.len() >= 4 * PARALLEL;
    let (a, b) = items.split_at_mut(k);
    let halve = |half: &mut [Item]| {
        if half.len() >= 2 {
            split(half)
        } else {
            half.len()
        }
    };
    // The two halves are split side by side when large.
    let (ka, kb) = if large {
        rayon::join(|| halve(a), || halve(b))
    } else {
        (halve(a), halve(b))
    };
    let mut groups: Vec<&mut [Item]> = Vec::with_capacity(4);
    for (half, k2) in [(a, ka), (b, kb)] {
        let (c, d) = half.split_at_mut(k2);
        groups.push(c);
        if !d.is_empty() {
            groups.push(d);
        }
    }
    groups
}

/// The upper tree of a parallel build: subtrees small enough for one thread, and the parents
/// above them.
enum Piece<'a> {
    /// A subtree of fewer than [`PARALLEL`] points, built by [`build_into`].
    Sub(&'a mut [Item]),
    /// A parent of two to four pieces.
    Parent(Vec<Piece<'a>>),
}

/// Splits `items` (in parallel) down to subtrees of fewer than [`PARALLEL`] points.
fn plan(items: &mut [Item]) -> Piece<'_> {
    if items.len() < PARALLEL {
        return Piece::Sub(items);
    }
    use rayon::prelude::*;
    Piece::Parent(groups(items).into_par_iter().map(plan).collect())
}

/// One step of the arena's post order: the next small subtree, or a parent of the last `n`
/// roots.
enum Step {
    Sub,
    Parent(usize),
}

/// Lists the pieces in post order: the subtrees in `subs`, every piece's kind in `steps`.
fn flatten<'a>(piece: Piece<'a>, subs: &mut Vec<&'a mut [Item]>, steps: &mut Vec<Step>) {
    match piece {
        Piece::Sub(items) => {
            subs.push(items);
            steps.push(Step::Sub);
        }
        Piece::Parent(kids) => {
            let n = kids.len();
            for k in kids {
                flatten(k, subs, steps);
            }
            steps.push(Step::Parent(n));
        }
    }
}

/// Builds the tree of `items`: the upper levels are split in parallel, the small subtrees are
/// built in parallel each into its own vector, the parents above them are made from the
/// subtrees' roots, and everything is moved once into the arena (in parallel, in place).
fn build_sub(input: &Input<'_>, items: &mut [Item]) -> Vec<Node> {
    use rayon::prelude::*;
    let mut subs = Vec::new();
    let mut steps = Vec::new();
    flatten(plan(items), &mut subs, &mut steps);
    let built: Vec<Vec<Node>> = subs
        .into_par_iter()
        .map(|items| {
            let mut nodes = Vec::with_capacity(2 * items.len());
            build_into(input, items, &mut nodes);
            nodes
        })
        .collect();
    // Arena positions: every piece's first index (subtrees and parents in post order), and
    // what the piece is: subtree k (its nodes' children shifted by its start) or parent p.
    let mut starts = Vec::with_capacity(steps.len() + 1);
    let mut which = Vec::with_capacity(steps.len());
    let mut parents = Vec::new();
    // The roots not yet given a parent (copies: a few hundred at most).
    let mut roots: Vec<(u32, Node)> = Vec::new();
    let (mut len, mut k) = (0usize, 0usize);
    for step in &steps {
        starts.push(len);
        match *step {
            Step::Sub => {
                which.push((true, k));
                len += built[k].len();
                roots.push(((len - 1) as u32, built[k][built[k].len() - 1].clone()));
                k += 1;
            }
            Step::Parent(n) => {
                let kids = roots.split_off(roots.len() - n);
                let ids: Vec<u32> = kids.iter().map(|k| k.0).collect();
                let refs: Vec<&Node> = kids.iter().map(|k| &k.1).collect();
                let parent = parent_from(&refs, &ids);
                which.push((false, parents.len()));
                roots.push((len as u32, parent.clone()));
                parents.push(parent);
                len += 1;
            }
        }
    }
    starts.push(len);
    (0..len)
        .into_par_iter()
        .with_min_len(4_096)
        .map(|i| {
            let piece = starts.partition_point(|&s| s <= i) - 1;
            match which[piece] {
                (true, k) => {
                    let mut node = built[k][i - starts[piece]].clone();
                    let offset = starts[piece] as u32;
                    for c in &mut node.kids[..node.n_children as usize] {
                        *c += offset;
                    }
                    node
                }
                (false, p) => parents[p].clone(),
            }
        })
        .collect()
}

/// Appends the subtree of `items` to `nodes` (children first); returns its root's index.
fn build_into(input: &Input<'_>, items: &mut [Item], nodes: &mut Vec<Node>) -> u32 {
    if items.len() == 1 {
        nodes.push(leaf(input, &items[0]));
    } else {
        let mut children = [0u32; 4];
        let mut n = 0;
        for g in groups(items) {
            children[n] = build_into(input, g, nodes);
            n += 1;
        }
        let parent = parent_of(nodes, &children[..n]);
        nodes.push(parent);
    }
    (nodes.len() - 1) as u32
}

/// The parent of `children` (arena indices into `nodes`).
fn parent_of(nodes: &[Node], children: &[u32]) -> Node {
    let mut kids = [&nodes[children[0] as usize]; 4];
    for (k, &c) in kids.iter_mut().zip(children) {
        *k = &nodes[c as usize];
    }
    parent_from(&kids[..children.len()], children)
}

/// The parent of the nodes `kids`, whose arena indices are `children`.
pub(crate) fn parent_from(nodes: &[&Node], children: &[u32]) -> Node {
    let kids = || nodes.iter().copied();
    let (lo, hi) = kids().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), k| {
        (
            lo.min(k.center - DVec3::splat(k.radius)),
            hi.max(k.center + DVec3::splat(k.radius)),
        )
    });
    let center = 0.5 * (lo + hi);
    // A hair of slack so that rounding never leaves a child poking out of its parent.
    let radius = kids()
        .map(|k| (k.center - center).length() + k.radius)
        .fold(0.0, f64::max)
        * (1.0 + 1e-9);
    let leaves: u32 = kids().map(|k| k.leaves).sum();
    let sum: DVec3 = kids().map(|k| k.normal * k.leaves as f64).sum();
    let normal = sum.normalize_or(nodes[0].normal);
    let cone = kids()
        .map(|k| normal.dot(k.normal).clamp(-1.0, 1.0).acos() + k.cone)
        .fold(0.0, f64::max)
        .min(std::f64::consts::PI);
    let color = kids().map(|k| k.color * k.leaves as f32).sum::<Vec3>() / leaves as f32;
    let mut ids = [0u32; 4];
    ids[..children.len()].copy_from_slice(children);
    Node {
        center,
        radius,
        normal,
        cone,
        color,
        leaves,
        kids: ids,
        n_children: children.len() as u8,
        point: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_to_four_children_and_every_point_once() {
        let pts = cloud::synth::fibonacci_sphere(1_000);
        let normals: Vec<Vec3> = pts.iter().map(|p| p.as_vec3()).collect();
        let h = build(&Input {
            positions: &pts,
            normals: &normals,
            colors: None,
            leaf_radius: 0.01,
        });
        let mut seen = vec![0; pts.len()];
        for n in &h.nodes {
            match n.point {
                Some(p) => {
                    seen[p as usize] += 1;
                    assert!(n.children().is_empty());
                }
                None => assert!(
                    (2..=4).contains(&n.children().len()),
                    "{}",
                    n.children().len()
                ),
            }
            for &c in n.children() {
                let k = &h.nodes[c as usize];
                assert!((k.center - n.center).length() + k.radius <= n.radius);
                let needed = n.normal.dot(k.normal).clamp(-1.0, 1.0).acos() + k.cone;
                assert!(needed <= n.cone + 1e-9 || n.cone >= std::f64::consts::PI);
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        assert_eq!(h.nodes[h.root()].leaves, 1_000);
    }

    #[test]
    fn the_root_alone_is_the_full_builds_root() {
        // Small and parallel (more than 4 × PARALLEL points) builds, with colours, copies of
        // points (halved by position) and a clump of one position.
        let mut pts = cloud::synth::torus_scene(90_000, 3)
            .unwrap()
            .cloud
            .positions;
        let copies: Vec<DVec3> = pts.iter().step_by(7).copied().collect();
        pts.extend(copies);
        pts.extend(std::iter::repeat_n(pts[5], 300));
        let normals: Vec<Vec3> = pts
            .iter()
            .map(|p| p.as_vec3().normalize_or_zero())
            .collect();
        let colors: Vec<[u8; 3]> = (0..pts.len())
            .map(|i| [(i % 251) as u8, (i % 13) as u8 * 19, 7])
            .collect();
        for n in [1, 2, 5, 1_000, 20_000, pts.len()] {
            for with_colors in [false, true] {
                let input = Input {
                    positions: &pts[..n],
                    normals: &normals[..n],
                    colors: with_colors.then_some(&colors[..n]),
                    leaf_radius: 0.003,
                };
                let h = build(&input);
                assert_eq!(build_root(&input), h.nodes[h.root()], "{n} points");
            }
        }
    }

    /// The leaves in arena order, by a plain recursion over index lists (a stable partition by
    /// filtering; halves by position when every point is on one side).
    fn reference_leaves(pts: &[DVec3], set: Vec<u32>, out: &mut Vec<u32>) {
        if set.len() == 1 {
            out.push(set[0]);
            return;
        }
        let halves = |set: Vec<u32>| -> (Vec<u32>, Vec<u32>) {
            let (lo, hi) = set
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
                    (lo.min(pts[i as usize]), hi.max(pts[i as usize]))
                });
            let ext = hi - lo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = 0.5 * (lo[axis] + hi[axis]);
            let (a, b): (Vec<u32>, Vec<u32>) =
                set.iter().partition(|&&i| pts[i as usize][axis] < mid);
            if a.is_empty() || b.is_empty() {
                let h = set.len() / 2;
                (set[..h].to_vec(), set[h..].to_vec())
            } else {
                (a, b)
            }
        };
        let (a, b) = halves(set);
        for half in [a, b] {
            if half.len() >= 2 {
                let (c, d) = halves(half);
                reference_leaves(pts, c, out);
                reference_leaves(pts, d, out);
            } else {
                reference_leaves(pts, half, out);
            }
        }
    }

    #[test]
    fn the_split_is_a_stable_partition() {
        // Clumps of copies (halved by position) among scattered points, small and parallel.
        let mut pts = cloud::synth::fibonacci_sphere(70_000);
        for i in (0..70_000).step_by(97) {
            let p = pts[i];
            pts.extend(std::iter::repeat_n(p, 1 + i % 7));
        }
        pts.extend(std::iter::repeat_n(pts[3], 500));
        let normals: Vec<Vec3> = pts.iter().map(|p| p.as_vec3()).collect();
        for n in [2, 9, 1_000, pts.len()] {
            let h = build(&Input {
                positions: &pts[..n],
                normals: &normals[..n],
                colors: None,
                leaf_radius: 0.01,
            });
            let got: Vec<u32> = h.nodes.iter().filter_map(|n| n.point).collect();
            let mut want = Vec::new();
            reference_leaves(&pts[..n], (0..n as u32).collect(), &mut want);
            assert_eq!(got, want, "{n} points");
        }
    }

    #[test]
    fn coincident_points_still_split() {
        let pts = vec![DVec3::ONE; 9];
        let normals = vec![Vec3::Z; 9];
        let h = build(&Input {
            positions: &pts,
            normals: &normals,
            colors: None,
            leaf_radius: 0.5,
        });
        assert_eq!(h.nodes.iter().filter(|n| n.point.is_some()).count(), 9);
    }
}
