//! The sequential list (seed 002 §5.3.4; Dachsbacher et al. 2003, §4): the hierarchy flattened
//! into one array that a view cuts with a sequential scan instead of a recursive traversal.
//!
//! For a threshold ε the recursive test "refine N while ẽ_g = e_g / r < ε fails", i.e. while
//! r < r_min = e_g / ε, becomes per node the interval test r_min(N) ≤ r < r_max(N) with r_max
//! the parent's r_min: a node is drawn when its parent is refined and it is not. Because r_max
//! is the parent's e_g / ε, sorting the list by the parent's e_g in descending order is sorting
//! by r_max in descending order for every ε; a view scans only the prefix whose r_max exceeds
//! the object's nearest distance (a binary search), everything after it is too coarse to be
//! refined from anywhere on the object.
//!
//! NOTE (deviation, so that the sequential cut selects *exactly* the recursive one, which the
//! seed only claims): r is the distance from the eye to the node's box (the leaf discs' bounding
//! box, quantised outwards to a 16-bit grid over the object), not to its centre. With the
//! centre the child's r can be smaller than its parent's, and the original accepts the few
//! overlaps and holes this gives; with nested boxes every ingredient of the test is monotone
//! down the tree *in floating point* (nested integer boxes, monotone rounding of `lo − x`,
//! `x − hi`, squares, sums and the product by ε²; e_g monotone by construction), so "parent
//! refined" implies "every ancestor refined", which is what makes the two cuts identical. The
//! test is evaluated squared, d² · ε² < e_g², in grid units, by one function, [`refined`],
//! shared with the recursive traversal.
//!
//! Layout for the scan: groups of siblings (one header per parent: its box, its e_g², the
//! range of its children) followed by 16-byte entries (box as 6 × u16, e_g² as f32); the splat
//! attributes live in separate arrays in the same order and are only read for selected entries.
//! The root is the single entry of a first group whose "parent" is always refined.

use cloud::glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::hierarchy::Hierarchy;

/// The largest grid coordinate of the quantised boxes.
pub const GRID: f64 = 65_535.0;

/// A box on the 16-bit grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C)]
pub struct QBox {
    /// Lower corner (rounded down).
    pub lo: [u16; 3],
    /// Upper corner (rounded up).
    pub hi: [u16; 3],
}

/// Squared distance from `eye` (grid coordinates) to the box; 0 inside.
#[inline(always)]
pub fn dist2(b: &QBox, eye: Vec3) -> f32 {
    let axis = |lo: u16, hi: u16, x: f32| {
        let d = (lo as f32 - x).max(x - hi as f32).max(0.0);
        d * d
    };
    axis(b.lo[0], b.hi[0], eye.x) + axis(b.lo[1], b.hi[1], eye.y) + axis(b.lo[2], b.hi[2], eye.z)
}

/// The SPT test: is a node with box `b` and squared error `e2` refined (its image-space error
/// e_g / r at least ε) for the eye at `eye` and squared threshold `eps2`? Leaves (e_g = 0) never
/// are.
#[inline(always)]
pub fn refined(b: &QBox, e2: f32, eye: Vec3, eps2: f32) -> bool {
    dist2(b, eye) * eps2 < e2
}

/// Per-node quantised boxes and squared errors on the grid, shared by both traversals.
#[derive(Debug, Clone, PartialEq)]
pub struct Quantized {
    /// World position of the grid's origin.
    pub origin: DVec3,
    /// World size of one grid step.
    pub cell: f64,
    /// The boxes, by hierarchy node.
    pub boxes: Vec<QBox>,
    /// e_g² in grid units, by hierarchy node.
    pub e2: Vec<f32>,
}

/// The 16-bit grid over an object: the world position of its origin and its step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// The hierarchy's local origin (node positions are relative to it).
    pub local: DVec3,
    /// World position of the grid's origin.
    pub origin: DVec3,
    /// World size of one grid step.
    pub cell: f64,
}

impl Grid {
    /// The grid over the root's box `lo..hi` (local, f32) of a hierarchy with origin `local`.
    pub fn new(local: DVec3, lo: Vec3, hi: Vec3) -> Self {
        let extent = (hi - lo).as_dvec3().max_element();
        Self {
            local,
            origin: local + lo.as_dvec3(),
            cell: (extent / GRID).max(f64::MIN_POSITIVE),
        }
    }

    /// A node's box on the grid (rounded outwards).
    pub fn qbox(&self, n: &crate::hierarchy::Node) -> QBox {
        let q = |x: f64, up: bool| {
            let g = (x / self.cell).clamp(0.0, GRID);
            (if up { g.ceil() } else { g.floor() }) as u16
        };
        let a = self.local + n.lo.as_dvec3() - self.origin;
        let b = self.local + n.hi.as_dvec3() - self.origin;
        QBox {
            lo: [q(a.x, false), q(a.y, false), q(a.z, false)],
            hi: [q(b.x, true), q(b.y, true), q(b.z, true)],
        }
    }

    /// A node's e_g² in grid units.
    pub fn e2(&self, n: &crate::hierarchy::Node) -> f32 {
        (f64::from(n.e_g) / self.cell).powi(2) as f32
    }
}

impl Quantized {
    /// Quantises the hierarchy's boxes and errors.
    pub fn new(h: &Hierarchy) -> Self {
        let root = &h.nodes[h.root()];
        let grid = Grid::new(h.origin, root.lo, root.hi);
        Self {
            origin: grid.origin,
            cell: grid.cell,
            boxes: h.nodes.iter().map(|n| grid.qbox(n)).collect(),
            e2: h.nodes.iter().map(|n| grid.e2(n)).collect(),
        }
    }

    /// The eye in grid coordinates.
    pub fn eye(&self, eye: DVec3) -> Vec3 {
        ((eye - self.origin) / self.cell).as_vec3()
    }
}

/// One entry of the list: a node's box and squared error (16 bytes).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Entry {
    /// The node's box.
    pub b: QBox,
    /// e_g² in grid units.
    pub e2: f32,
}

/// The header of a group of siblings: their parent's box and error, their range.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Group {
    /// The parent's box.
    pub b: QBox,
    /// The parent's e_g² (its r_min · ε, squared, is the children's r_max · ε).
    pub e2: f32,
    /// First entry.
    pub start: u32,
    /// One past the last entry.
    pub end: u32,
}

/// The scan of [`SequentialList::cut_into`] over a block of consecutive groups read from
/// elsewhere (a file, [`crate::paged`]): `entries` holds the groups' entries, the first of them
/// list entry `first`; the selected entries' list indices are appended to `out`. Returns the
/// entries tested.
pub fn scan_block(
    groups: &[Group],
    entries: &[Entry],
    first: usize,
    eye: Vec3,
    eps2: f32,
    out: &mut Vec<u32>,
) -> usize {
    let base = out.len();
    out.resize(base + entries.len(), 0);
    let (len, tested) = scan_groups(groups, entries, first, eye, eps2, &mut out[base..]);
    out.truncate(base + len);
    tested
}

/// The sequential scan of consecutive groups whose entries are `entries` (the first of them
/// list entry `first`) into `buf` (one slot per entry); returns the entries selected (at the
/// front of `buf`) and tested.
///
/// Branch-free per entry: within a group whose parent is refined, each entry's index is
/// written at the selection's end and the end moves on only when the entry is not refined
/// itself. Groups whose parent is not refined are skipped with a branch: measured on the
/// dragon (view 0), reading their entries too was 15 % slower for a 4 px cut and the branch
/// per entry of the first version 27 % slower for a 1 px cut.
fn scan_groups(
    groups: &[Group],
    entries: &[Entry],
    first: usize,
    eye: Vec3,
    eps2: f32,
    buf: &mut [u32],
) -> (usize, usize) {
    let (mut len, mut tested) = (0usize, 0usize);
    for g in groups {
        if !refined(&g.b, g.e2, eye, eps2) {
            continue;
        }
        let (s, e) = (g.start as usize, g.end as usize);
        tested += e - s;
        for (i, entry) in entries[s - first..e - first].iter().enumerate() {
            buf[len] = (s + i) as u32;
            len += usize::from(!refined(&entry.b, entry.e2, eye, eps2));
        }
    }
    (len, tested)
}

/// What one cut did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CutStats {
    /// Groups in the scanned prefix.
    pub groups: usize,
    /// List entries in the scanned prefix.
    pub entries: usize,
    /// Entries whose own test ran (their parent was refined).
    pub tested: usize,
    /// Entries selected.
    pub selected: usize,
}

/// The sequential list.
#[derive(Debug, Clone, PartialEq)]
pub struct SequentialList {
    /// Group headers, sorted by the parent's e_g descending.
    pub groups: Vec<Group>,
    /// Entries, group after group.
    pub entries: Vec<Entry>,
    /// The hierarchy node of each entry.
    pub node: Vec<u32>,
}

const CHUNK_GROUPS: usize = 16_384;

impl SequentialList {
    /// Flattens the hierarchy.
    pub fn new(h: &Hierarchy, q: &Quantized) -> Self {
        let root = h.root();
        // (parent e2, parent id) per group; the root's pseudo-parent sorts first.
        let mut parents: Vec<(f32, usize)> = h
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| !n.children.is_empty())
            .map(|(i, _)| (q.e2[i], i))
            .collect();
        parents.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut groups = Vec::with_capacity(parents.len() + 1);
        let mut entries = Vec::with_capacity(h.nodes.len());
        let mut node = Vec::with_capacity(h.nodes.len());
        let mut push = |b: QBox, e2: f32, kids: &mut dyn Iterator<Item = usize>| {
            let start = entries.len() as u32;
            for k in kids {
                entries.push(Entry {
                    b: q.boxes[k],
                    e2: q.e2[k],
                });
                node.push(k as u32);
            }
            groups.push(Group {
                b,
                e2,
                start,
                end: entries.len() as u32,
            });
        };
        push(q.boxes[root], f32::INFINITY, &mut std::iter::once(root));
        for (e2, p) in parents {
            push(
                q.boxes[p],
                e2,
                &mut h.nodes[p].children.iter().map(|&k| k as usize),
            );
        }
        Self {
            groups,
            entries,
            node,
        }
    }

    /// The number of groups a cut must scan: those whose parent could be refined somewhere on
    /// the object, i.e. e_g² > d²(eye, root box) · ε².
    pub fn prefix(&self, root: &QBox, eye: Vec3, eps2: f32) -> usize {
        let bound = dist2(root, eye) * eps2;
        // The first group (the root's) is always scanned.
        1 + self.groups[1..].partition_point(|g| g.e2 > bound)
    }

    /// Appends the entries of the cut (ascending) to `out`; scans in parallel for long
    /// prefixes.
    ///
    /// `out` is first grown by the number of entries in the prefix (an upper bound of the
    /// selection; its capacity is kept from call to call, so a reused vector allocates
    /// nothing), each chunk of groups writes its selection into its own part of it, and the
    /// parts are then moved together.
    pub fn cut_into(&self, root: &QBox, eye: Vec3, eps2: f32, out: &mut Vec<u32>) -> CutStats {
        let n = self.prefix(root, eye, eps2);
        let groups = &self.groups[..n];
        let entries = groups.last().map_or(0, |g| g.end as usize);
        let mut stats = CutStats {
            groups: n,
            entries,
            ..CutStats::default()
        };
        let base = out.len();
        out.resize(base + entries, 0);
        let chunks: Vec<&[Group]> = groups.chunks(CHUNK_GROUPS).collect();
        let mut parts = Vec::with_capacity(chunks.len());
        let mut rest = &mut out[base..];
        for c in &chunks {
            let len = c.last().map_or(0, |g| g.end) - c.first().map_or(0, |g| g.start);
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(len as usize);
            parts.push((*c, part));
            rest = tail;
        }
        let counts: Vec<(usize, usize, usize)> = if parts.len() == 1 {
            parts
                .into_iter()
                .map(|(c, p)| self.scan(c, eye, eps2, p))
                .collect()
        } else {
            parts
                .into_par_iter()
                .map(|(c, p)| self.scan(c, eye, eps2, p))
                .collect()
        };
        stats.tested = counts.iter().map(|c| c.1).sum();
        stats.selected = cloud::compact::join_parts(out, base, counts.iter().map(|c| (c.0, c.2)));
        stats
    }

    /// [`scan_groups`] over some consecutive groups of the list; also returns the entries
    /// scanned.
    fn scan(
        &self,
        groups: &[Group],
        eye: Vec3,
        eps2: f32,
        buf: &mut [u32],
    ) -> (usize, usize, usize) {
        let (Some(first), Some(last)) = (groups.first(), groups.last()) else {
            return (0, 0, 0);
        };
        let (first, last) = (first.start as usize, last.end as usize);
        let (len, tested) = scan_groups(groups, &self.entries[first..last], first, eye, eps2, buf);
        (len, tested, last - first)
    }
}
