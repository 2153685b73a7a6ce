//! Consistent orientation of estimated normals: Hoppe et al.'s minimum-spanning-tree
//! propagation over a *guide*, a subset of the cloud chosen by position alone, so that the
//! rule gives every point the same sign whether the cloud is in memory or read chunk by chunk.
//!
//! Method (Hoppe, DeRose, Duchamp, McDonald, Stuetzle, "Surface reconstruction from
//! unorganized points", SIGGRAPH 1992, §3.3): covariance analysis gives each normal a line, not
//! a direction. On the Riemannian graph (each point joined to its k nearest neighbours, made
//! symmetric) with edge cost 1 − |n_i · n_j|, a minimum spanning tree joins points of nearly
//! parallel normals first; the root is the point of largest z, its normal made to point +z,
//! and the tree is walked flipping each child to agree with its parent (n_child · n_parent ≥
//! 0). Each connected component is rooted the same way. Deviations: Prim's algorithm with a
//! binary heap, ties broken by (cost, point, parent) so the tree is unique; Hoppe's graph also
//! joins the tangent planes of a Euclidean MST, which the k-nearest-neighbour graph covers for
//! the sampled surfaces here (components are oriented separately instead).
//!
//! The guide, for clouds beyond memory: the points whose position hash lies below 2^(64 − s),
//! with s the least shift leaving at most [`GUIDE_MAX`] of the n points expected
//! (n ≤ GUIDE_MAX · 2^s): all points when n ≤ GUIDE_MAX. The set depends on the positions and n
//! only, never on the input order or a memory limit, and [`GuideSampler`] finds it in one pass
//! over a stream (the shift only grows, and the set kept is always a superset of the final one).
//! The guide's points are sorted by position, their normals estimated among themselves (the
//! cloud's own k) and oriented by the tree. A point of the cloud then takes the sign of one
//! guide normal: among its [`CANDIDATES`] nearest distinct guide positions (by distance, ties
//! by position order: [`crate::knn`]'s canonical order over the sorted distinct positions,
//! found by a [`GridKnn`] over them), the one whose tangent plane passes closest to it
//! (|(p − g) · n_g| least, the first on ties), which keeps two close sheets of opposite normals
//! apart (4 candidates agreed with the dragon's mesh as often as 8, and took half the time).
//! The grid replaced a k-d tree query per point (the tree's own order on ties), which took as
//! long as the point's 16 nearest neighbours in the cloud. When the guide is the whole
//! cloud, a point's own entry (distance 0, plane distance 0) decides, and the rule is exactly
//! the tree's on the whole cloud.

use std::cell::RefCell;
use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;
use std::num::NonZero;
use std::sync::atomic::{AtomicU64, Ordering as AtomicOrdering};

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::knn_grid::{GridKnn, Queries};

/// Guide points at most (expected; the hash makes the count vary by a few hundred).
pub const GUIDE_MAX: usize = 1 << 16;
/// The guide limit the builds use: [`GUIDE_MAX`]; in this crate's own tests 10,000, so that
/// their clouds of tens of thousands of points meet a guide smaller than themselves in memory
/// and out of core alike.
pub const fn guide_max() -> usize {
    if cfg!(test) { 10_000 } else { GUIDE_MAX }
}

/// Nearest guide points among which a point picks the one whose plane passes closest.
pub const CANDIDATES: usize = 4;
/// Bytes a guide point needs while the guide is built (the neighbour lists, the graph, the
/// heap, the grid): what a memory limit must leave beside the reserve.
pub const BUILD_BYTES_PER_POINT: u64 = 320;

/// The 64-bit hash of a position (`-0.0` and `0.0` are one position): SplitMix64's finaliser
/// over the three coordinates' bits.
pub fn position_hash(p: DVec3) -> u64 {
    let mix = crate::rng::splitmix64;
    let [x, y, z] = [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits);
    mix(mix(mix(x ^ 0x9e37_79b9_7f4a_7c15) ^ y) ^ z)
}

/// The least shift s with `n ≤ max · 2^s`.
pub fn guide_shift(n: u64, max: usize) -> u32 {
    let max = (max.max(1)) as u128;
    let mut s = 0;
    while s < 64 && u128::from(n) > max << s {
        s += 1;
    }
    s
}

/// Whether a point of hash `h` is in the guide at shift `s`.
pub fn in_guide(h: u64, s: u32) -> bool {
    s == 0 || (s < 64 && h >> (64 - s) == 0)
}

/// The guide's points of `positions` (those [`in_guide`] at [`guide_shift`]`(n, max)`).
pub fn select_guide(positions: &[DVec3], max: usize) -> Vec<DVec3> {
    let s = guide_shift(positions.len() as u64, max);
    positions
        .iter()
        .copied()
        .filter(|&p| in_guide(position_hash(p), s))
        .collect()
}

/// The guide of a stream of points, found in one pass: the same set [`select_guide`] gives
/// for the whole stream.
#[derive(Debug, Clone)]
pub struct GuideSampler {
    seen: u64,
    shift: u32,
    /// The most points `shift` holds for (`max · 2^shift`, [`guide_shift`]).
    until: u128,
    kept: Vec<(u64, DVec3)>,
}

impl GuideSampler {
    /// A sampler keeping at most `max` points expected.
    pub fn new(max: usize) -> Self {
        GuideSampler {
            seen: 0,
            shift: 0,
            until: max.max(1) as u128,
            kept: Vec::new(),
        }
    }

    /// Takes the next point of the stream.
    pub fn push(&mut self, p: DVec3) {
        self.seen += 1;
        // `seen` passes `until` one at a time: the shift grows by one (`guide_shift`).
        if u128::from(self.seen) > self.until {
            self.shift += 1;
            self.until <<= 1;
            let s = self.shift;
            self.kept.retain(|e| in_guide(e.0, s));
        }
        let h = position_hash(p);
        if in_guide(h, self.shift) {
            self.kept.push((h, p));
        }
    }

    /// Points kept so far.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    /// Whether none is kept.
    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }

    /// The guide's points.
    pub fn finish(self) -> Vec<DVec3> {
        self.kept.into_iter().map(|e| e.1).collect()
    }
}

/// The total order guide points are sorted by (`-0.0` as `0.0`).
fn by_position(a: &DVec3, b: &DVec3) -> Ordering {
    let key = |p: &DVec3| [p.x + 0.0, p.y + 0.0, p.z + 0.0];
    let (ka, kb) = (key(a), key(b));
    ka[0]
        .total_cmp(&kb[0])
        .then(ka[1].total_cmp(&kb[1]))
        .then(ka[2].total_cmp(&kb[2]))
}

/// Oriented normals of a guide, and the search for a point's nearest guide points.
#[derive(Debug)]
pub struct Guide {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    /// The distinct positions (the first of each run of copies, by index into `positions`).
    distinct: Vec<u32>,
    /// A grid over the distinct positions (local index: into `distinct`).
    grid: Option<GridKnn<'static>>,
    /// Which guide a thread's query buffers belong to.
    id: u64,
}

/// Guides made so far (each gets its own id).
static GUIDES: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// A thread's buffers for guide queries: the id of the guide they belong to and the
    /// grid's scratch (its last block of candidates).
    static QUERIES: RefCell<(u64, Queries)> = RefCell::new((0, Queries::default()));
}

impl Guide {
    /// The guide of `points` (in any order: they are sorted by position), its normals from
    /// `k` neighbours among themselves, oriented by the minimum spanning tree. A guide without
    /// a surface (fewer than 3 points, or all at one position) orients by +z alone.
    pub fn new(mut points: Vec<DVec3>, k: usize) -> Result<Guide> {
        points.sort_by(by_position);
        let first = points.first().copied().unwrap_or_default();
        if points.len() < 3 || points.iter().all(|&p| p == first) {
            return Ok(Guide {
                positions: Vec::new(),
                normals: Vec::new(),
                distinct: Vec::new(),
                grid: None,
                id: GUIDES.fetch_add(1, AtomicOrdering::Relaxed),
            });
        }
        let k = k.clamp(3, points.len());
        let grid = GridKnn::new(&points, |i| i, k)?;
        let kk = NonZero::new(k).ok_or(Error::InvalidParameter {
            name: "k",
            reason: "zero".into(),
        })?;
        let found: Vec<(DVec3, Vec<u32>)> = grid.for_each_point(
            kk,
            |_| true,
            |_, nb| {
                let n = crate::eigen3::covariance_normal(nb.iter().map(|x| points[x.1 as usize]));
                (n, nb.iter().skip(1).map(|x| x.1 as u32).collect())
            },
        )?;
        drop(grid);
        let (mut normals, neighbours): (Vec<DVec3>, Vec<Vec<u32>>) = found.into_iter().unzip();
        mst_orient(&points, &mut normals, &neighbours);
        drop(neighbours);
        let distinct: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| {
                i == 0 || by_position(&points[i as usize - 1], &points[i as usize]).is_ne()
            })
            .collect();
        let entries: Vec<DVec3> = distinct.iter().map(|&i| points[i as usize]).collect();
        let grid = GridKnn::new_owned(entries, |i| i, CANDIDATES)?;
        Ok(Guide {
            positions: points,
            normals,
            distinct,
            grid: Some(grid),
            id: GUIDES.fetch_add(1, AtomicOrdering::Relaxed),
        })
    }

    /// Points of the guide.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the guide is empty (it then orients by +z).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The guide's oriented normal that decides the sign at `p` (module doc).
    pub fn reference(&self, p: DVec3) -> DVec3 {
        let Some(grid) = &self.grid else {
            return DVec3::Z;
        };
        let m = NonZero::new(CANDIDATES.min(self.distinct.len())).unwrap_or(NonZero::<usize>::MIN);
        let answer = |queries: &mut Queries| match grid.nearest(p, m, queries) {
            Ok(found) => self.closest_plane(p, found.iter().map(|x| x.1)),
            // (The grid fails only where it cannot build its k-d tree for a far query, which a
            // guide of at least two positions always can; the same answer by brute force.)
            Err(_) => self.closest_plane(p, self.brute_nearest(p, m.get()).into_iter()),
        };
        QUERIES.with(|cell| match cell.try_borrow_mut() {
            Ok(mut held) => {
                let (id, queries) = &mut *held;
                if *id != self.id {
                    // Another guide's block of candidates.
                    *queries = Queries::default();
                    *id = self.id;
                }
                answer(queries)
            }
            // (Never re-entered, as no query runs parallel work; fresh buffers if it were.)
            Err(_) => answer(&mut Queries::default()),
        })
    }

    /// Among the distinct guide positions `candidates` (in canonical order), the normal of the
    /// one whose tangent plane passes closest to `p`, the first on ties.
    fn closest_plane(&self, p: DVec3, candidates: impl Iterator<Item = u64>) -> DVec3 {
        let mut best = (f64::INFINITY, DVec3::Z);
        for d in candidates {
            let g = self.distinct[d as usize] as usize;
            let dist = (p - self.positions[g]).dot(self.normals[g]).abs();
            if dist < best.0 {
                best = (dist, self.normals[g]);
            }
        }
        best.1
    }

    /// The `m` nearest distinct guide positions of `p` in canonical order (by squared
    /// distance summed as the grid sums it, ties by index), by brute force.
    fn brute_nearest(&self, p: DVec3, m: usize) -> Vec<u64> {
        let mut all: Vec<(f64, u64)> = self
            .distinct
            .iter()
            .enumerate()
            .map(|(d, &g)| {
                let v = p - self.positions[g as usize];
                ((v.x * v.x + v.y * v.y) + v.z * v.z, d as u64)
            })
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all.into_iter().take(m).map(|x| x.1).collect()
    }

    /// `n` (unoriented, at `p`) with the guide's sign (flipped when n · reference < 0, as
    /// `crate::normals::orient` flips).
    pub fn orient(&self, p: DVec3, n: DVec3) -> Vec3 {
        if n.dot(self.reference(p)) < 0.0 {
            (-n).as_vec3()
        } else {
            n.as_vec3()
        }
    }
}

/// Orients `normals` (of `positions`, with each point's nearest neighbours `neighbours`, by
/// index) by Hoppe's minimum spanning tree over the symmetric neighbour graph (module doc).
pub fn mst_orient(positions: &[DVec3], normals: &mut [DVec3], neighbours: &[Vec<u32>]) {
    let n = positions.len();
    // The symmetric graph, as adjacency lists in one array.
    let mut degree = vec![0u32; n + 1];
    for (i, nb) in neighbours.iter().enumerate() {
        for &j in nb {
            if j as usize != i {
                degree[i] += 1;
                degree[j as usize] += 1;
            }
        }
    }
    let mut start = vec![0usize; n + 1];
    for i in 0..n {
        start[i + 1] = start[i] + degree[i] as usize;
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n]];
    for (i, nb) in neighbours.iter().enumerate() {
        for &j in nb {
            if j as usize != i {
                adj[fill[i]] = j;
                fill[i] += 1;
                adj[fill[j as usize]] = i as u32;
                fill[j as usize] += 1;
            }
        }
    }
    drop(fill);
    // Roots: by z descending, then index.
    let mut roots: Vec<u32> = (0..n as u32).collect();
    roots.sort_by(|&a, &b| {
        positions[b as usize]
            .z
            .total_cmp(&positions[a as usize].z)
            .then(a.cmp(&b))
    });
    let mut done = vec![false; n];
    let mut heap: BinaryHeap<Reverse<(u64, u32, u32)>> = BinaryHeap::new();
    let cost = |a: DVec3, b: DVec3| (1.0 - a.dot(b).abs()).max(0.0).to_bits();
    for &root in &roots {
        let r = root as usize;
        if done[r] {
            continue;
        }
        if normals[r].z < 0.0 {
            normals[r] = -normals[r];
        }
        done[r] = true;
        for &j in &adj[start[r]..start[r + 1]] {
            if !done[j as usize] {
                heap.push(Reverse((cost(normals[r], normals[j as usize]), j, root)));
            }
        }
        while let Some(Reverse((_, v, parent))) = heap.pop() {
            let v = v as usize;
            if done[v] {
                continue;
            }
            done[v] = true;
            if normals[v].dot(normals[parent as usize]) < 0.0 {
                normals[v] = -normals[v];
            }
            for &j in &adj[start[v]..start[v + 1]] {
                if !done[j as usize] {
                    heap.push(Reverse((
                        cost(normals[v], normals[j as usize]),
                        j,
                        v as u32,
                    )));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
