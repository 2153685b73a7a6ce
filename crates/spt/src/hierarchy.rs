//! The point hierarchy of a sequential point tree and its error metrics (seed 002 §5.3.1–5.3.2;
//! Dachsbacher, Vogelgsang and Stamminger, "Sequential Point Trees", SIGGRAPH 2003, §3).
//!
//! An octree over the points (seed 002 §5.3.1): a cell is split into its eight octants until one
//! point is left; chains of cells with a single occupied octant are collapsed, so every inner
//! node has two to eight children; coincident points are split by position in the list (the
//! octant partition is stable, so a cell's points keep the input order and the split depends on
//! the cell's points alone, which lets the out-of-core build, [`crate::ooc`], build a cell by
//! itself). Each node approximates its subtree by a disc:
//! - centre c: the mean of its points; normal n: the normalised mean of its points' normals;
//!   diameter d: that of the sphere around c enclosing its children's spheres (leaves: the
//!   leaf diameter given);
//! - perpendicular error (eq. 5.1, 5.2): e_p = max_i((c_i − c)·n + d_i) − min_i((c_i − c)·n −
//!   d_i) with d_i = r_i·sqrt(1 − (n_i·n)²), r_i the child's radius: the thickness of the slab
//!   parallel to the disc that holds the children's discs;
//! - tangential error: the children's discs projected onto the node's plane, measured between
//!   pairs of parallel lines in [`E_T_DIRECTIONS`] directions; e_t = d minus the narrowest such
//!   interval, clamped at 0 (seed 002 §5.3.2: "e_t is the parent disc's diameter minus the
//!   smallest interval between lines");
//! - geometric error (eq. 5.5): e_g = sqrt(e_p² + e_t²); leaves have e_g = 0.
//!
//! NOTE (as the original): errors are made monotone, e_g(parent) ≥ e_g(child), so that a node's
//! interval [r_min, r_max] lies below its parent's. NOTE (addition, for the exact equivalence
//! of the sequential and recursive cuts, see [`crate::list`]): each node also keeps the
//! axis-aligned box of its leaves' discs (leaf: point ± leaf radius; inner node: the union of
//! its children's boxes, computed with min/max and therefore exactly nested in f32).

use cloud::glam::{DVec3, Vec3};

/// Directions of the tangential-error lines (spread over half a turn).
pub const E_T_DIRECTIONS: usize = 16;

/// A node of the hierarchy (f32, as stored for rendering).
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Disc and bounding-sphere centre.
    pub center: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Diameter of the disc (= of the bounding sphere).
    pub diameter: f32,
    /// Perpendicular error.
    pub e_p: f32,
    /// Tangential error.
    pub e_t: f32,
    /// Geometric error, made monotone up the tree.
    pub e_g: f32,
    /// Mean colour in [0, 1].
    pub color: Vec3,
    /// Children (arena indices).
    pub children: Vec<u32>,
    /// Leaves below.
    pub leaves: u32,
    /// Lower corner of the box of the leaf discs below.
    pub lo: Vec3,
    /// Upper corner of that box.
    pub hi: Vec3,
}

impl Node {
    /// Bounding-sphere radius.
    pub fn radius(&self) -> f32 {
        0.5 * self.diameter
    }
}

/// The hierarchy: an arena whose last node is the root, positions relative to `origin`.
#[derive(Debug, Clone, PartialEq)]
pub struct Hierarchy {
    /// The world position of the local origin (node centres are relative to it, in f32).
    pub origin: DVec3,
    /// Nodes; children before parents.
    pub nodes: Vec<Node>,
}

impl Hierarchy {
    /// The root's index.
    pub fn root(&self) -> usize {
        self.nodes.len() - 1
    }
}

/// What the build needs.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// Positions.
    pub positions: &'a [DVec3],
    /// Unit normals.
    pub normals: &'a [Vec3],
    /// Colours in [0, 255], if any.
    pub colors: Option<&'a [[u8; 3]]>,
    /// Leaf disc diameter.
    pub leaf_diameter: f64,
}

const PARALLEL: usize = 16_384;

/// Builds the hierarchy.
pub fn build(input: &Input<'_>) -> Hierarchy {
    let bbox = cloud::Aabb::from_points(input.positions).unwrap_or(cloud::Aabb {
        min: DVec3::ZERO,
        max: DVec3::ZERO,
    });
    let origin = bbox.center();
    let mut items: Vec<u32> = (0..input.positions.len() as u32).collect();
    let (center, half) = root_cell(&bbox);
    let nodes = build_cell(input, origin, &mut items, center, half, COLLAPSE);
    Hierarchy { origin, nodes }
}

/// The root cube of the points' box: its centre and half side.
pub fn root_cell(bbox: &cloud::Aabb) -> (DVec3, f64) {
    let half = 0.5 * bbox.extent().max_element().max(1e-300);
    (bbox.center(), half * (1.0 + 1e-9))
}

/// Octant levels a cell's points may share before they count as coincident.
pub const COLLAPSE: u32 = 64;

/// The octant of `p` in the cube centred at `c`.
#[inline(always)]
pub fn octant(p: DVec3, c: DVec3) -> usize {
    usize::from(p.x >= c.x) | (usize::from(p.y >= c.y) << 1) | (usize::from(p.z >= c.z) << 2)
}

/// The centre of octant `o` of the cube (centre `c`, half side `h`); its half side is `h / 2`.
#[inline(always)]
pub fn octant_center(c: DVec3, h: f64, o: usize) -> DVec3 {
    c + DVec3::new(
        if o & 1 != 0 { 0.5 * h } else { -0.5 * h },
        if o & 2 != 0 { 0.5 * h } else { -0.5 * h },
        if o & 4 != 0 { 0.5 * h } else { -0.5 * h },
    )
}

/// A point as the octant partitions sort it: its index, and where it lies.
trait Item: Copy + Default + Send + Sync {
    fn position(self, input: &Input<'_>) -> DVec3;
}

impl Item for u32 {
    #[inline(always)]
    fn position(self, input: &Input<'_>) -> DVec3 {
        input.positions[self as usize]
    }
}

/// A point of a subtree built by one thread, its position carried along: the partitions of
/// its levels then read memory in order instead of the chunk's positions by index (an index's
/// position lies anywhere in them).
#[derive(Debug, Clone, Copy, Default)]
struct Local {
    p: DVec3,
    i: u32,
}

impl Item for Local {
    #[inline(always)]
    fn position(self, _: &Input<'_>) -> DVec3 {
        self.p
    }
}

/// Stable partition of `items` by octant (a counting sort); returns the counts.
fn partition_octants<T: Item>(
    input: &Input<'_>,
    items: &mut [T],
    c: DVec3,
    tmp: &mut Vec<T>,
) -> [usize; 8] {
    if items.len() >= 4 * PARALLEL {
        return partition_octants_parallel(input, items, c);
    }
    let mut counts = [0usize; 8];
    for &i in items.iter() {
        counts[octant(i.position(input), c)] += 1;
    }
    if counts.contains(&items.len()) {
        return counts;
    }
    let mut at = [0usize; 8];
    for o in 1..8 {
        at[o] = at[o - 1] + counts[o - 1];
    }
    tmp.clear();
    tmp.resize(items.len(), T::default());
    for &i in items.iter() {
        let o = octant(i.position(input), c);
        tmp[at[o]] = i;
        at[o] += 1;
    }
    items.copy_from_slice(tmp);
    counts
}

/// [`partition_octants`] of a large set: each piece's points by octant in parallel, then laid
/// out octant by octant, each octant's pieces in order (the same stable order).
fn partition_octants_parallel<T: Item>(input: &Input<'_>, items: &mut [T], c: DVec3) -> [usize; 8] {
    use rayon::prelude::*;
    let pieces: Vec<[Vec<T>; 8]> = items
        .par_chunks(PARALLEL)
        .map(|piece| {
            let mut by: [Vec<T>; 8] = Default::default();
            for &i in piece {
                by[octant(i.position(input), c)].push(i);
            }
            by
        })
        .collect();
    let counts: [usize; 8] = std::array::from_fn(|o| pieces.iter().map(|p| p[o].len()).sum());
    if !counts.contains(&items.len()) {
        let mut w = 0;
        for o in 0..8 {
            for p in &pieces {
                items[w..w + p[o].len()].copy_from_slice(&p[o]);
                w += p[o].len();
            }
        }
    }
    counts
}

/// The octant groups of a cell of two or more points: its points partitioned by octant, the
/// chains of single-octant cells collapsed (at most `budget` levels), coincident points halved
/// by list position. Returns the groups (start, end, centre of the child cell), how many, and
/// the half side of the cell the groups are octants of (doubled for halves, whose cells are
/// the cell itself).
fn octant_groups<T: Item>(
    input: &Input<'_>,
    items: &mut [T],
    center: DVec3,
    half: f64,
    budget: u32,
    tmp: &mut Vec<T>,
) -> ([(usize, usize, DVec3); 8], usize, f64) {
    let mut groups = [(0usize, 0usize, DVec3::ZERO); 8];
    let mut n_groups = 0;
    let (mut c, mut h) = (center, half);
    for _ in 0..budget.max(1) {
        let counts = partition_octants(input, items, c, tmp);
        n_groups = 0;
        let mut start = 0;
        for (o, &k) in counts.iter().enumerate() {
            if k > 0 {
                groups[n_groups] = (start, start + k, octant_center(c, h, o));
                n_groups += 1;
                start += k;
            }
        }
        if n_groups > 1 {
            break;
        }
        c = groups[0].2;
        h *= 0.5;
    }
    if n_groups == 1 {
        // Coincident points: halves by list position.
        let m = items.len() / 2;
        groups[0] = (0, m, c);
        groups[1] = (m, items.len(), c);
        n_groups = 2;
        h *= 2.0;
    }
    (groups, n_groups, h)
}

/// Builds the subtree of the points `items`, all inside the cube (centre, half side), in the
/// arena order of [`build`] (children before parents, the root last): the call [`build`] makes
/// for every cell with two or more occupied octants, `budget` the octant levels left before the
/// points count as coincident ([`COLLAPSE`] at such a cell; fewer when the out-of-core build
/// starts inside a chain of single-octant cells).
pub fn build_cell(
    input: &Input<'_>,
    origin: DVec3,
    items: &mut [u32],
    center: DVec3,
    half: f64,
    budget: u32,
) -> Vec<Node> {
    // Every inner node has two or more children: at most 2m - 1 nodes. A set built in parallel
    // reserves once its subtrees are built, for their nodes exactly (`build_into`).
    let mut nodes = if items.len() < PARALLEL {
        Vec::with_capacity((2 * items.len()).saturating_sub(1))
    } else {
        Vec::new()
    };
    let mut tmp = Vec::new();
    build_into(
        input, origin, items, center, half, budget, &mut nodes, &mut tmp,
    );
    nodes
}

/// [`build_cell`] appending the subtree's nodes to `nodes` (its indices absolute in it, as
/// [`build_cell`]'s relative ones shifted by where it starts); returns the subtree's root.
/// `tmp` is the octant partition's buffer for a set of [`PARALLEL`] points or more (a smaller
/// one, built by one thread, [`build_serial`], uses its thread's buffers). Subtrees of
/// [`PARALLEL`] points or more are built in parallel, each into a vector of its own appended in
/// order (a node is moved once per parallel level above it, not once per level, and by all
/// threads: on one thread, the moves took about 0.4 s of the 7.5 s chunk stage of a
/// 10^7-point out-of-core build).
#[allow(clippy::too_many_arguments)]
fn build_into(
    input: &Input<'_>,
    origin: DVec3,
    items: &mut [u32],
    center: DVec3,
    half: f64,
    budget: u32,
    nodes: &mut Vec<Node>,
    tmp: &mut Vec<u32>,
) -> u32 {
    if items.len() < PARALLEL {
        // One thread builds it: the points with their positions, in a buffer of the thread's.
        return LOCAL.with_borrow_mut(|(local, tmp)| {
            local.clear();
            local.extend(items.iter().map(|&i| Local {
                p: input.positions[i as usize],
                i,
            }));
            build_serial(input, origin, local, center, half, budget, nodes, tmp)
        });
    }
    let (groups, n_groups, h) = octant_groups(input, items, center, half, budget, tmp);
    let groups = &groups[..n_groups];
    let mut children = Vec::with_capacity(n_groups);
    use rayon::prelude::*;
    // (Reached only at the top of a `build_cell`, `nodes` empty; the subtrees have buffers of
    // their own.)
    *tmp = Vec::new();
    let mut slices: Vec<(&mut [u32], DVec3)> = Vec::with_capacity(n_groups);
    let mut rest: &mut [u32] = items;
    let mut consumed = 0;
    for &(_, e, oc) in groups {
        let (head, tail) = rest.split_at_mut(e - consumed);
        slices.push((head, oc));
        rest = tail;
        consumed = e;
    }
    let subtrees: Vec<Vec<Node>> = slices
        .into_par_iter()
        .map(|(s, oc)| build_cell(input, origin, s, oc, 0.5 * h, COLLAPSE))
        .collect();
    nodes.reserve_exact(subtrees.iter().map(Vec::len).sum::<usize>() + 1);
    for sub in subtrees {
        let offset = nodes.len() as u32;
        let n = sub.len() as u32;
        // Moved into place by all threads (one copy), their children's indices shifted on
        // the way.
        nodes.par_extend(sub.into_par_iter().with_min_len(4_096).map(|mut node| {
            for k in &mut node.children {
                *k += offset;
            }
            node
        }));
        children.push(offset + n - 1);
    }
    let parent = parent_of(nodes, children);
    nodes.push(parent);
    (nodes.len() - 1) as u32
}

thread_local! {
    /// A thread's points of the subtree it builds, and the partitions' buffer (kept between
    /// subtrees: fewer than 2 · [`PARALLEL`] points each, about 1 MB).
    static LOCAL: std::cell::RefCell<(Vec<Local>, Vec<Local>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// [`build_into`] for a subtree one thread builds, its points carried with their positions.
#[allow(clippy::too_many_arguments)]
fn build_serial(
    input: &Input<'_>,
    origin: DVec3,
    items: &mut [Local],
    center: DVec3,
    half: f64,
    budget: u32,
    nodes: &mut Vec<Node>,
    tmp: &mut Vec<Local>,
) -> u32 {
    if let [one] = items {
        nodes.push(leaf_at(input, origin, one.p, one.i));
        return (nodes.len() - 1) as u32;
    }
    let (groups, n_groups, h) = octant_groups(input, items, center, half, budget, tmp);
    let mut children = Vec::with_capacity(n_groups);
    for &(s, e, oc) in &groups[..n_groups] {
        let root = build_serial(
            input,
            origin,
            &mut items[s..e],
            oc,
            0.5 * h,
            COLLAPSE,
            nodes,
            tmp,
        );
        children.push(root);
    }
    let parent = parent_of(nodes, children);
    nodes.push(parent);
    (nodes.len() - 1) as u32
}

/// The leaf of point `i`, at `p` (its position).
fn leaf_at(input: &Input<'_>, origin: DVec3, p: DVec3, i: u32) -> Node {
    let color = input.colors.map_or(Vec3::splat(0.75), |c| {
        let c = c[i as usize];
        Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0
    });
    let center = (p - origin).as_vec3();
    let half = 0.5 * input.leaf_diameter as f32;
    Node {
        center,
        normal: input.normals[i as usize].normalize_or(Vec3::Z),
        diameter: input.leaf_diameter as f32,
        e_p: 0.0,
        e_t: 0.0,
        e_g: 0.0,
        color,
        children: Vec::new(),
        leaves: 1,
        lo: center - half,
        hi: center + half,
    }
}

fn parent_of(nodes: &[Node], children: Vec<u32>) -> Node {
    let kids: Vec<&Node> = children.iter().map(|&k| &nodes[k as usize]).collect();
    parent_of_kids(&kids, children)
}

/// The parent of the nodes `kids` (whose arena indices are `children`).
pub fn parent_of_kids(kids: &[&Node], children: Vec<u32>) -> Node {
    let leaves: u32 = kids.iter().map(|k| k.leaves).sum();
    let w = |k: &Node| k.leaves as f32 / leaves as f32;
    let center: Vec3 = kids.iter().map(|k| k.center * w(k)).sum();
    let normal = kids
        .iter()
        .map(|k| k.normal * w(k))
        .sum::<Vec3>()
        .normalize_or(kids[0].normal);
    let color: Vec3 = kids.iter().map(|k| k.color * w(k)).sum();
    // The sphere around c enclosing the children's spheres.
    let diameter = 2.0
        * kids
            .iter()
            .map(|k| (k.center - center).length() + k.radius())
            .fold(0.0f32, f32::max);
    let lo = kids.iter().fold(Vec3::INFINITY, |a, k| a.min(k.lo));
    let hi = kids.iter().fold(Vec3::NEG_INFINITY, |a, k| a.max(k.hi));
    let e_p = perpendicular_error(center, normal, kids);
    let e_t = tangential_error(center, normal, diameter, kids);
    let e_g = (e_p * e_p + e_t * e_t)
        .sqrt()
        .max(kids.iter().map(|k| k.e_g).fold(0.0, f32::max));
    Node {
        center,
        normal,
        diameter,
        e_p,
        e_t,
        e_g,
        color,
        children,
        leaves,
        lo,
        hi,
    }
}

/// Eq. 5.1–5.2: the thickness of the slab parallel to the disc (c, n) holding the children's
/// discs.
pub fn perpendicular_error(c: Vec3, n: Vec3, kids: &[&Node]) -> f32 {
    let (mut hi, mut lo) = (f32::NEG_INFINITY, f32::INFINITY);
    for k in kids {
        let d_i = k.radius() * (1.0 - k.normal.dot(n).powi(2)).max(0.0).sqrt();
        let h = (k.center - c).dot(n);
        hi = hi.max(h + d_i);
        lo = lo.min(h - d_i);
    }
    hi - lo
}

/// The cosine and sine of each of the [`E_T_DIRECTIONS`] angles `π k / E_T_DIRECTIONS`,
/// computed once (the very values computing them at each node gives).
fn directions() -> &'static [(f32, f32); E_T_DIRECTIONS] {
    static TABLE: std::sync::OnceLock<[(f32, f32); E_T_DIRECTIONS]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let angle = std::f32::consts::PI * k as f32 / E_T_DIRECTIONS as f32;
            (angle.cos(), angle.sin())
        })
    })
}

/// The tangential error: the disc's diameter minus the narrowest interval, over
/// [`E_T_DIRECTIONS`] directions in the disc's plane, holding the children's discs projected
/// onto the plane; at least 0.
pub fn tangential_error(c: Vec3, n: Vec3, diameter: f32, kids: &[&Node]) -> f32 {
    const D: usize = E_T_DIRECTIONS;
    let a = n.any_orthonormal_vector();
    let b = n.cross(a);
    // The directions u = a cos + b sin as columns, and each direction's interval; the children
    // in the outer loop so that the directions' arithmetic runs side by side (the very sums
    // `Vec3::dot` makes, so the same values as a direction at a time).
    let (mut ux, mut uy, mut uz) = ([0.0f32; D], [0.0f32; D], [0.0f32; D]);
    for (j, &(cos, sin)) in directions().iter().enumerate() {
        let u = a * cos + b * sin;
        (ux[j], uy[j], uz[j]) = (u.x, u.y, u.z);
    }
    let (mut hi, mut lo) = ([f32::NEG_INFINITY; D], [f32::INFINITY; D]);
    for kid in kids {
        // Support of a disc (radius r, normal m) in the in-plane direction u.
        let (r, m, d) = (kid.radius(), kid.normal, kid.center - c);
        for j in 0..D {
            let mu = (m.x * ux[j]) + (m.y * uy[j]) + (m.z * uz[j]);
            let h = r * (1.0 - mu * mu).max(0.0).sqrt();
            let x = (d.x * ux[j]) + (d.y * uy[j]) + (d.z * uz[j]);
            hi[j] = hi[j].max(x + h);
            lo[j] = lo[j].min(x - h);
        }
    }
    let narrowest = (0..D).map(|j| hi[j] - lo[j]).fold(f32::INFINITY, f32::min);
    (diameter - narrowest).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(center: Vec3, normal: Vec3, diameter: f32) -> Node {
        let h = Vec3::splat(0.5 * diameter);
        Node {
            center,
            normal,
            diameter,
            e_p: 0.0,
            e_t: 0.0,
            e_g: 0.0,
            color: Vec3::ONE,
            children: vec![],
            leaves: 1,
            lo: center - h,
            hi: center + h,
        }
    }

    #[test]
    fn flat_children_have_no_perpendicular_error() {
        let kids = [
            disc(Vec3::new(-1.0, 0.0, 0.0), Vec3::Z, 0.2),
            disc(Vec3::new(1.0, 0.0, 0.0), Vec3::Z, 0.2),
        ];
        let refs: Vec<&Node> = kids.iter().collect();
        assert_eq!(perpendicular_error(Vec3::ZERO, Vec3::Z, &refs), 0.0);
        // Tilted children: each contributes r·sin(tilt) on both sides.
        let t = Vec3::new(0.6, 0.0, 0.8);
        let kids = [
            disc(Vec3::ZERO, t, 1.0),
            disc(Vec3::new(0.0, 1.0, 0.5), Vec3::Z, 0.0),
        ];
        let refs: Vec<&Node> = kids.iter().collect();
        let e = perpendicular_error(Vec3::ZERO, Vec3::Z, &refs);
        assert!((e - (0.5 + 0.5 * 0.6)).abs() < 1e-6, "{e}");
    }

    #[test]
    fn a_long_row_wastes_the_disc_across_it() {
        // Children along x: the narrowest interval is across the row (about the children's
        // diameter), so a parent disc of diameter 2.2 wastes 2.0 of it.
        let kids: Vec<Node> = (0..5)
            .map(|i| disc(Vec3::new(-1.0 + 0.5 * i as f32, 0.0, 0.0), Vec3::Z, 0.2))
            .collect();
        let refs: Vec<&Node> = kids.iter().collect();
        let e = tangential_error(Vec3::ZERO, Vec3::Z, 2.2, &refs);
        assert!((e - 2.0).abs() < 0.05, "{e}");
    }

    #[test]
    fn the_parallel_octant_partition_is_the_counting_sort() {
        // Large enough for pieces of `PARALLEL` points, with a cell centre off the middle and
        // points on its planes (they go to the upper octant).
        let pts: Vec<DVec3> = (0..5 * PARALLEL as u32 + 123)
            .map(|i| {
                let h = |s: u32| {
                    f64::from(cloud::rng::splitmix64(u64::from(i) * 3 + u64::from(s)) as u32) / 4e9
                };
                let v = DVec3::new(h(0), h(1), h(2));
                if i % 97 == 0 {
                    DVec3::new(0.3, v.y, 0.4)
                } else {
                    v
                }
            })
            .collect();
        let normals = vec![Vec3::Z; pts.len()];
        let input = Input {
            positions: &pts,
            normals: &normals,
            colors: None,
            leaf_diameter: 0.01,
        };
        let c = DVec3::new(0.3, 0.55, 0.4);
        let mut serial: Vec<u32> = (0..pts.len() as u32).rev().collect();
        let mut parallel = serial.clone();
        let mut counts = [0usize; 8];
        let mut by: [Vec<u32>; 8] = Default::default();
        for &i in &serial {
            counts[octant(pts[i as usize], c)] += 1;
            by[octant(pts[i as usize], c)].push(i);
        }
        serial = by.concat();
        assert!(parallel.len() >= 4 * PARALLEL);
        assert_eq!(
            partition_octants(&input, &mut parallel, c, &mut Vec::new()),
            counts
        );
        assert_eq!(parallel, serial);
        // Every point in one octant: the order stays.
        let mut one: Vec<u32> = (0..pts.len() as u32).collect();
        let far = DVec3::splat(-1.0);
        let all = partition_octants(&input, &mut one, far, &mut Vec::new());
        assert_eq!(all[7], pts.len());
        assert!(one.iter().enumerate().all(|(k, &i)| i as usize == k));
    }

    #[test]
    fn hierarchy_is_sound() {
        let pts = cloud::synth::fibonacci_sphere(3_000);
        let normals: Vec<Vec3> = pts.iter().map(|p| p.as_vec3()).collect();
        let h = build(&Input {
            positions: &pts,
            normals: &normals,
            colors: None,
            leaf_diameter: 0.05,
        });
        assert_eq!(h.nodes[h.root()].leaves, 3_000);
        for n in &h.nodes {
            assert!(n.children.is_empty() || (2..=8).contains(&n.children.len()));
            for &k in &n.children {
                let kid = &h.nodes[k as usize];
                assert!(kid.e_g <= n.e_g, "monotone errors");
                assert!(
                    (kid.center - n.center).length() + kid.radius() <= n.radius() * (1.0 + 1e-6),
                    "nested spheres"
                );
                assert!(
                    kid.lo.cmpge(n.lo).all() && kid.hi.cmple(n.hi).all(),
                    "nested boxes"
                );
            }
        }
    }
}
