//! The quantised tree, laid out breadth first as in the original.
//!
//! A node is one 32-bit word: sphere index (13 bits, relative to the decoded parent), normal
//! code (14), cone code (2), tree bits (3: child count 0 or 2–4, and whether the node has
//! grandchildren); with colours, 16 bits more per node (kept in a parallel array). The children
//! of a node form a *sibling group*; groups are stored breadth first, and a group whose nodes
//! have children starts with one 32-bit word: the position of the group holding the first of
//! its nodes' children. The children groups of a group's nodes follow each other in order, so
//! one offset per group locates them all. The root's sphere is stored in full (f64).
//!
//! Encoding is top-down, each sphere relative to its parent's *decoded* sphere and rounded
//! outwards ([`crate::quant::encode_sphere`]), so that every decoded sphere encloses every
//! point below it.

use cloud::glam::DVec3;

use rayon::prelude::*;

use crate::build::{Hierarchy, Node};
use crate::quant;

/// Word layout.
const SPHERE_SHIFT: u32 = 19;
const NORMAL_SHIFT: u32 = 5;
const CONE_SHIFT: u32 = 3;
const GRAND_BIT: u32 = 1 << 2;

/// A quantised QSplat tree.
#[derive(Debug, Clone, PartialEq)]
pub struct QTree {
    /// Number of input points (leaves).
    pub n_points: u64,
    /// Root sphere centre.
    pub root_center: DVec3,
    /// Root sphere radius.
    pub root_radius: f64,
    /// The root's word (its sphere bits are zero: the sphere is stored in full).
    pub root_word: u32,
    /// Sibling groups, breadth first: an offset word (when the group's nodes have children)
    /// then one word per node.
    pub words: Vec<u32>,
    /// One colour per word (0 for offset words), when the tree has colours; the root's first.
    pub colors: Option<Vec<u16>>,
    /// The root's colour.
    pub root_color: u16,
}

/// The fields of a node word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Word {
    /// Sphere table index.
    pub sphere: u16,
    /// Normal code.
    pub normal: u16,
    /// Cone code.
    pub cone: u8,
    /// Children (0, 2, 3 or 4).
    pub children: u8,
    /// Whether some child has children.
    pub grandchildren: bool,
}

impl Word {
    /// Packs the fields.
    pub fn pack(&self) -> u32 {
        let count = match self.children {
            0 => 0,
            c => u32::from(c) - 1,
        };
        (u32::from(self.sphere) << SPHERE_SHIFT)
            | (u32::from(self.normal) << NORMAL_SHIFT)
            | (u32::from(self.cone) << CONE_SHIFT)
            | if self.grandchildren { GRAND_BIT } else { 0 }
            | count
    }

    /// Unpacks a word; `None` for impossible tree bits (grandchildren without children).
    pub fn unpack(w: u32) -> Option<Self> {
        let count = (w & 3) as u8;
        let grandchildren = w & GRAND_BIT != 0;
        let children = if count == 0 { 0 } else { count + 1 };
        if children == 0 && grandchildren {
            return None;
        }
        Some(Self {
            sphere: (w >> SPHERE_SHIFT) as u16,
            normal: ((w >> NORMAL_SHIFT) & 0x3fff) as u16,
            cone: ((w >> CONE_SHIFT) & 3) as u8,
            children,
            grandchildren,
        })
    }
}

fn word_of(h: &Hierarchy, id: usize, sphere: u16) -> Word {
    let n = &h.nodes[id];
    let grandchildren = n
        .children()
        .iter()
        .any(|&c| !h.nodes[c as usize].children().is_empty());
    word_for(n, sphere, grandchildren)
}

/// The word of node `n` with sphere index `sphere`; `grandchildren` when some child of it has
/// children.
pub(crate) fn word_for(n: &Node, sphere: u16, grandchildren: bool) -> Word {
    let normal = quant::encode_normal(n.normal);
    // Widen the cone by how far quantisation moved the normal.
    let cos_moved = quant::decode_normal(normal).dot(n.normal).clamp(-1.0, 1.0);
    // PERF: a narrow cone moved a little is code 0 (half-angle below 0.06 rad, whose
    // ⌊4·√sin⌋ is 0); cos(0.055) < 0.9985 leaves room for rounding. Most nodes are leaves
    // (cone 0) whose normal moves less than 0.03 rad, and skip the acos and sin.
    let cone = if n.cone <= 0.005 && cos_moved >= 0.9985 {
        0
    } else {
        quant::encode_cone(n.cone + cos_moved.acos())
    };
    Word {
        sphere,
        normal,
        cone,
        children: n.children().len() as u8,
        grandchildren,
    }
}

/// The sphere index of a node `(center, radius)` inside the decoded parent `(pc, pr)`, and its
/// own decoded sphere.
pub(crate) fn child_sphere(
    center: DVec3,
    radius: f64,
    parent: (DVec3, f64),
) -> (u16, (DVec3, f64)) {
    let (pc, pr) = parent;
    // The child is inside the (outward-rounded) parent: an entry always exists; the
    // parent's own cube (size 13) is the fallback.
    let sphere = quant::encode_sphere(center, radius, pc, pr)
        .unwrap_or_else(|| quant::sphere_table().1[(quant::N_GRID - 1) as usize]);
    let own = quant::decode_sphere(sphere, pc, pr).unwrap_or((pc, pr));
    (sphere, own)
}

fn color_of(h: &Hierarchy, id: usize) -> u16 {
    node_color(&h.nodes[id])
}

/// A node's RGB565 colour.
pub(crate) fn node_color(n: &Node) -> u16 {
    let c = n.color;
    quant::encode_rgb565([c.x.round() as u8, c.y.round() as u8, c.z.round() as u8])
}

/// Subtrees this large are encoded in parallel.
const PARALLEL: usize = 16_384;

/// Encodes the children of node `id` (decoded sphere `parent`) and their subtrees; `decoded`
/// and `words` cover the node's subtree without the node itself, nodes `start..id`.
fn encode_children(
    h: &Hierarchy,
    start: usize,
    id: usize,
    decoded: &mut [(DVec3, f64)],
    words: &mut [u32],
    parent: (DVec3, f64),
) {
    let mut tasks = Vec::with_capacity(4);
    let (mut dec, mut wor, mut s) = (decoded, words, start);
    for &c in h.nodes[id].children() {
        let c = c as usize;
        let (d_head, d_tail) = std::mem::take(&mut dec).split_at_mut(c + 1 - s);
        let (w_head, w_tail) = std::mem::take(&mut wor).split_at_mut(c + 1 - s);
        let node = &h.nodes[c];
        let (sphere, own) = child_sphere(node.center, node.radius, parent);
        let last = c - s;
        d_head[last] = own;
        w_head[last] = word_of(h, c, sphere).pack();
        tasks.push((s, c, &mut d_head[..last], &mut w_head[..last], own));
        (dec, wor, s) = (d_tail, w_tail, c + 1);
    }
    if id - start >= PARALLEL {
        tasks
            .into_par_iter()
            .for_each(|(s, c, d, w, own)| encode_children(h, s, c, d, w, own));
    } else {
        for (s, c, d, w, own) in tasks {
            encode_children(h, s, c, d, w, own);
        }
    }
}

impl QTree {
    /// Quantises `h`; `colors` keeps RGB565 colours.
    pub fn encode(h: &Hierarchy, colors: bool) -> Self {
        Self::encode_with_spheres(h, colors).0
    }

    /// Quantises `h` and also returns every hierarchy node's decoded sphere (for checks).
    pub fn encode_with_spheres(h: &Hierarchy, colors: bool) -> (Self, Vec<(DVec3, f64)>) {
        let root = h.root();
        let root_sphere = (h.nodes[root].center, h.nodes[root].radius);
        let (parts, decoded) = encode_parts(h, 0, root_sphere, colors, false);
        let tree = Self {
            n_points: u64::from(h.nodes[root].leaves),
            root_center: root_sphere.0,
            root_radius: root_sphere.1,
            root_word: parts.root_word,
            words: parts.words,
            colors: colors.then_some(parts.colors),
            root_color: parts.root_color,
        };
        (tree, decoded)
    }

    /// Size in bytes of the node data as the original counts it (4 bytes a node or offset,
    /// plus 2 bytes a node for colour), without the file header.
    pub fn payload_bytes(&self) -> usize {
        let nodes = 1 + self.words.len();
        4 * nodes + if self.colors.is_some() { 2 * nodes } else { 0 }
    }
}

/// The quantised form of a (sub)tree: its root's word and colour, and its sibling groups
/// breadth first.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Parts {
    /// The root's word.
    pub root_word: u32,
    /// The root's colour (0 without colours).
    pub root_color: u16,
    /// The words below the root, breadth first (offset words point into this array).
    pub words: Vec<u32>,
    /// One colour per word (empty without colours).
    pub colors: Vec<u16>,
    /// Word position at which each level of groups starts (the groups of the root's children
    /// first), then the total.
    pub level_starts: Vec<usize>,
    /// Positions of the offset words (filled only when asked for).
    pub offsets: Vec<usize>,
}

/// Quantises the tree `h` whose root has sphere index `root_sphere` (0 for the whole tree's
/// root, stored in full) and decodes to `root_decoded`; also returns every node's decoded
/// sphere. `want_offsets` lists the offset words' positions (for a subtree whose offsets are
/// moved when it is placed in a larger tree).
pub(crate) fn encode_parts(
    h: &Hierarchy,
    root_sphere: u16,
    root_decoded: (DVec3, f64),
    colors: bool,
    want_offsets: bool,
) -> (Parts, Vec<(DVec3, f64)>) {
    let root = h.root();
    let n = h.nodes.len();
    // Top-down over the contiguous subtrees, in parallel: every node's sphere relative to
    // its parent's decoded sphere, its decoded sphere and its word.
    let mut decoded: Vec<(DVec3, f64)> = vec![(DVec3::ZERO, 0.0); n];
    let mut node_words = vec![0u32; n];
    decoded[root] = root_decoded;
    node_words[root] = word_of(h, root, root_sphere).pack();
    encode_children(
        h,
        0,
        root,
        &mut decoded[..root],
        &mut node_words[..root],
        root_decoded,
    );

    // Sibling groups breadth first, one level at a time (in parallel: rayon's collect
    // keeps the order): the next level's groups are, in order, the children that have
    // children of this level's groups.
    // Child counts in one compact array (the nodes are 112 bytes; these lookups jump).
    let n_kids: Vec<u8> = h.nodes.par_iter().map(|n| n.n_children).collect();
    let has_kids = |c: u32| n_kids[c as usize] != 0;
    let mut levels: Vec<Vec<u32>> = Vec::new();
    if !h.nodes[root].children().is_empty() {
        levels.push(vec![root as u32]);
    }
    while let Some(last) = levels.last() {
        let next: Vec<u32> = last
            .par_iter()
            .flat_map_iter(|&p| {
                h.nodes[p as usize]
                    .children()
                    .iter()
                    .copied()
                    .filter(move |&c| has_kids(c))
            })
            .collect();
        if next.is_empty() {
            break;
        }
        levels.push(next);
    }
    // Per group: its words (an offset word when some child has children, then one per
    // child) and how many of its children start groups of the next level.
    let shape = |p: u32| {
        let kids = h.nodes[p as usize].children();
        let grand = kids.iter().filter(|&&c| has_kids(c)).count();
        (kids.len() + usize::from(grand > 0), grand)
    };
    let shapes: Vec<Vec<(usize, usize)>> = levels
        .iter()
        .map(|l| l.par_iter().map(|&p| shape(p)).collect())
        .collect();
    // Word position of every group, level by level.
    let mut pos: Vec<Vec<usize>> = Vec::with_capacity(levels.len());
    let mut level_starts = Vec::with_capacity(levels.len() + 1);
    let mut offset_at = Vec::new();
    let mut total = 0usize;
    for level in &shapes {
        level_starts.push(total);
        let mut at = Vec::with_capacity(level.len());
        for &(len, grand) in level {
            at.push(total);
            if want_offsets && grand > 0 {
                offset_at.push(total);
            }
            total += len;
        }
        pos.push(at);
    }
    level_starts.push(total);
    // A group's offset word: the position of the group of its first child with children,
    // which is the next level's group numbered by the grandparents counted before it.
    let mut offsets: Vec<Vec<u32>> = Vec::with_capacity(levels.len());
    for (l, level) in shapes.iter().enumerate() {
        let mut seen = 0usize;
        offsets.push(
            level
                .iter()
                .map(|&(_, grand)| {
                    let o = if grand > 0 {
                        pos[l + 1][seen] as u32
                    } else {
                        0
                    };
                    seen += grand;
                    o
                })
                .collect(),
        );
    }
    let group_words = |l: usize, g: usize| {
        let p = levels[l][g] as usize;
        let offset = (shapes[l][g].1 > 0).then_some((offsets[l][g], 0u16));
        offset
            .into_iter()
            .chain(h.nodes[p].children().iter().map(|&c| {
                let c = c as usize;
                (node_words[c], if colors { color_of(h, c) } else { 0 })
            }))
    };
    let (words, cols): (Vec<u32>, Vec<u16>) = (0..levels.len())
        .flat_map(|l| (0..levels[l].len()).map(move |g| (l, g)))
        .collect::<Vec<_>>()
        .into_par_iter()
        .flat_map_iter(|(l, g)| group_words(l, g))
        .unzip();
    debug_assert_eq!(words.len(), total);
    let parts = Parts {
        root_word: node_words[root],
        root_color: if colors { color_of(h, root) } else { 0 },
        words,
        colors: if colors { cols } else { Vec::new() },
        level_starts,
        offsets: offset_at,
    };
    (parts, decoded)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_narrow_cone_shortcut_is_what_encode_cone_gives() {
        for cone in [0.0, 0.001, 0.005] {
            for k in 0..=100_000 {
                let cos = 0.9985 + 0.0015 * f64::from(k) / 100_000.0;
                assert_eq!(quant::encode_cone(cone + cos.acos()), 0, "{cone} {cos}");
            }
        }
    }

    #[test]
    fn word_packing_round_trip() {
        for children in [0u8, 2, 3, 4] {
            for grandchildren in [false, true] {
                if children == 0 && grandchildren {
                    continue;
                }
                let w = Word {
                    sphere: 7_620,
                    normal: 16_223,
                    cone: 3,
                    children,
                    grandchildren,
                };
                assert_eq!(Word::unpack(w.pack()), Some(w));
            }
        }
        assert_eq!(Word::unpack(GRAND_BIT), None);
    }
}
