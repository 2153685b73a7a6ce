//! The k nearest neighbours of a point in a canonical order, in bounded work when points
//! coincide.
//!
//! The order: by distance, equal distances by the point's global index (its index in the whole
//! cloud, which a caller holding a part of the cloud gives), and when several points tie at the
//! k-th distance, those of smallest global index. It does not depend on how a tree was built,
//! so the same neighbourhood, summed in the same order, comes out of any index holding the
//! point's true neighbours: an out-of-core build's chunk and its halo give the very normals of
//! the whole cloud (`qsplat::ooc`'s byte-equality tests rely on it).
//!
//! Coincident points: a k-d tree over every point answers "the k nearest" with any k of the
//! points tied at the k-th distance, so resolving the tie by index needs every tied point; with
//! m copies of one position, each query near it fetched all m (10^4 identical points took 12 s,
//! 10^5 never ended). Here positions are grouped first (one sort): the tree holds each distinct
//! position once, with its copies listed by global index. A query fetches distinct positions
//! until their copies number k, and takes from the positions at the k-th distance only the
//! copies it needs, the smallest global indices first: the candidates examined are then at most
//! (k + 1) · the positions it fetched, whatever the copies. Only distinct positions exactly
//! equidistant from the query (the doubling below) can make a query fetch more than k + 1 of
//! them, which coincidence does not cause. Without any coincident points the index is the plain
//! tree (no groups, no cost beyond the sort that found none).
//!
//! [`Knn::examined`] counts the candidates (points the tree returned plus copies read from the
//! groups), which is how the tests bound the work without timing it.

use std::num::NonZero;

use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// A neighbour index over a set of points (a whole cloud, or a chunk with its halo).
#[derive(Debug)]
pub struct Knn {
    /// The distinct positions (every position when none coincide).
    tree: ImmutableKdTree<f64, 3>,
    /// Copies of each distinct position; `None` when no two points coincide.
    groups: Option<Groups>,
    /// Global index of each point (by its local index).
    global: Vec<u64>,
    /// Distinct positions in the tree.
    distinct: usize,
}

/// The points at each distinct position, as (global index, local index) sorted by global
/// index: group `g` is `members[start[g]..start[g + 1]]`.
#[derive(Debug)]
struct Groups {
    start: Vec<usize>,
    members: Vec<(u64, u64)>,
}

/// The bits of a coordinate as positions are grouped by (`-0.0` and `0.0` are one position:
/// every distance to them is the same).
fn key(p: DVec3) -> [u64; 3] {
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

impl Knn {
    /// The index of `positions` (finite; the caller checks), point `i` having global index
    /// `global(i)` (the identity for a whole cloud). Fails when there are no points.
    pub fn new(positions: &[DVec3], global: impl Fn(u64) -> u64 + Sync) -> Result<Self> {
        Self::build(positions, global, true)
    }

    /// [`Knn::new`] on the calling thread alone: for an index built lazily inside a parallel
    /// loop (as [`crate::knn_grid::GridKnn`]'s fallback is), where a parallel build would let
    /// the waiting thread take up another of the loop's queries and initialise the same index
    /// re-entrantly.
    pub fn new_sequential(positions: &[DVec3], global: impl Fn(u64) -> u64 + Sync) -> Result<Self> {
        Self::build(positions, global, false)
    }

    fn build(
        positions: &[DVec3],
        global: impl Fn(u64) -> u64 + Sync,
        parallel: bool,
    ) -> Result<Self> {
        if positions.is_empty() {
            return Err(Error::EmptyCloud);
        }
        let global: Vec<u64> = if parallel {
            (0..positions.len() as u64)
                .into_par_iter()
                .map(&global)
                .collect()
        } else {
            (0..positions.len() as u64).map(&global).collect()
        };
        let mut order: Vec<u32> = (0..positions.len() as u32).collect();
        if positions.len() > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "positions",
                reason: format!(
                    "{} points; a neighbour index holds at most 2^32",
                    positions.len()
                ),
            });
        }
        let by = |&i: &u32| (key(positions[i as usize]), global[i as usize]);
        if parallel {
            order.par_sort_unstable_by_key(by);
        } else {
            order.sort_unstable_by_key(by);
        }
        let coincide = order
            .windows(2)
            .any(|w| key(positions[w[0] as usize]) == key(positions[w[1] as usize]));
        let tree_error = |e| Error::InvalidParameter {
            name: "positions",
            reason: format!("cannot build a k-d tree: {e:?}"),
        };
        if !coincide {
            let entries: Vec<[f64; 3]> = positions.iter().map(|p| p.to_array()).collect();
            let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&entries).map_err(tree_error)?;
            return Ok(Self {
                tree,
                groups: None,
                distinct: positions.len(),
                global,
            });
        }
        let mut entries: Vec<[f64; 3]> = Vec::new();
        let mut start = Vec::new();
        let mut members = Vec::with_capacity(positions.len());
        for (j, &i) in order.iter().enumerate() {
            let p = positions[i as usize];
            if j == 0 || key(positions[order[j - 1] as usize]) != key(p) {
                entries.push(p.to_array());
                start.push(members.len());
            }
            members.push((global[i as usize], u64::from(i)));
        }
        start.push(members.len());
        let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&entries).map_err(tree_error)?;
        Ok(Self {
            tree,
            distinct: entries.len(),
            groups: Some(Groups { start, members }),
            global,
        })
    }

    /// Points in the index.
    pub fn len(&self) -> usize {
        self.global.len()
    }

    /// Whether the index is empty (never: [`Knn::new`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.global.is_empty()
    }

    /// Distinct positions among the points.
    pub fn distinct(&self) -> usize {
        self.distinct
    }

    /// Copies at distinct position `g` (as the tree numbers them).
    fn copies(&self, g: u64) -> usize {
        self.groups
            .as_ref()
            .map_or(1, |gr| gr.start[g as usize + 1] - gr.start[g as usize])
    }

    /// The nearest `want` distinct positions of `q`, as (squared distance, tree item), by
    /// distance.
    fn nearest(&self, q: &[f64; 3], want: usize, examined: &mut u64) -> Vec<(f64, u64)> {
        let want = NonZero::new(want.clamp(1, self.distinct)).unwrap_or(NonZero::<usize>::MIN);
        let got = self
            .tree
            .query(q)
            .nearest_n::<SquaredEuclidean<f64>>(want)
            .execute();
        *examined += got.len() as u64;
        got.iter()
            .map(|nb| (nb.distance, u64::from(nb.item)))
            .collect()
    }

    /// The `k` nearest neighbours of `p` (the point itself among them when it is in the index)
    /// as (squared distance, local index), in the canonical order (module doc).
    pub fn canonical_knn(&self, p: DVec3, k: NonZero<usize>) -> Vec<(f64, u64)> {
        self.canonical_knn_counted(p, k, &mut 0)
    }

    /// [`Knn::canonical_knn`], adding the candidates it examined to `examined`.
    pub fn canonical_knn_counted(
        &self,
        p: DVec3,
        k: NonZero<usize>,
        examined: &mut u64,
    ) -> Vec<(f64, u64)> {
        let q = p.to_array();
        let k = k.get();
        let mut want = k.saturating_add(1).min(self.distinct);
        loop {
            let got = self.nearest(&q, want, examined);
            // The k-th distance: where the copies of the positions so far reach k.
            let mut count = 0usize;
            let kth = got.iter().find_map(|&(d, g)| {
                count += self.copies(g);
                (count >= k).then_some(d)
            });
            // Complete when every position at the k-th distance is in the answer: the answer
            // holds every position, or its last is farther than the k-th.
            let complete = got.len() < want
                || want >= self.distinct
                || kth.is_none_or(|d| got.last().is_some_and(|l| l.0 > d));
            if complete {
                return self.take(&got, kth, k, examined);
            }
            want = want.saturating_mul(2).min(self.distinct);
        }
    }

    /// The first `k` in canonical order of the points at the positions `got` (by distance),
    /// the k-th distance being `kth` (`None`: fewer than k points in all).
    fn take(
        &self,
        got: &[(f64, u64)],
        kth: Option<f64>,
        k: usize,
        examined: &mut u64,
    ) -> Vec<(f64, u64)> {
        let within = got.iter().filter(|g| kth.is_none_or(|d| g.0 <= d));
        let mut nb: Vec<(f64, u64, u64)> = match &self.groups {
            None => within
                .map(|&(d, i)| (d, self.global[i as usize], i))
                .collect(),
            Some(groups) => {
                // Every copy of the positions nearer than the k-th distance (fewer than k in
                // all), and from each position at it the copies of smallest global index that
                // could be among the first k.
                let nearer: usize = got
                    .iter()
                    .filter(|g| kth.is_some_and(|d| g.0 < d))
                    .map(|g| self.copies(g.1))
                    .sum();
                let room = k.saturating_sub(nearer);
                let mut out = Vec::with_capacity(k + room);
                for &(d, g) in within {
                    let copies =
                        &groups.members[groups.start[g as usize]..groups.start[g as usize + 1]];
                    let take = if kth.is_some_and(|t| d < t) {
                        copies.len()
                    } else {
                        copies.len().min(room)
                    };
                    *examined += take as u64;
                    out.extend(copies[..take].iter().map(|&(gl, local)| (d, gl, local)));
                }
                out
            }
        };
        nb.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        nb.truncate(k);
        nb.into_iter().map(|(d, _, local)| (d, local)).collect()
    }

    /// The squared distance from `p` to its `k`-th nearest point, copies counted (the point
    /// itself when it is in the index is the first); the farthest point's when there are fewer
    /// than `k`.
    pub fn kth_distance2(&self, p: DVec3, k: NonZero<usize>) -> f64 {
        let q = p.to_array();
        let mut want = k.get().min(self.distinct);
        loop {
            let got = self.nearest(&q, want, &mut 0);
            let mut count = 0usize;
            if let Some(d) = got.iter().find_map(|&(d, g)| {
                count += self.copies(g);
                (count >= k.get()).then_some(d)
            }) {
                return d;
            }
            if want >= self.distinct {
                return got.last().map_or(0.0, |l| l.0);
            }
            want = want.saturating_mul(2).min(self.distinct);
        }
    }
}

/// How many positions of `positions` coincide: (distinct positions, points beyond the first
/// at each position, the most points at one position). `-0.0` and `0.0` are one position.
pub fn coincidence(positions: &[DVec3]) -> (usize, usize, usize) {
    if positions.is_empty() {
        return (0, 0, 0);
    }
    let mut keys: Vec<[u64; 3]> = positions.par_iter().map(|&p| key(p)).collect();
    keys.par_sort_unstable();
    let (mut distinct, mut most, mut run) = (1usize, 1usize, 1usize);
    for w in keys.windows(2) {
        if w[0] == w[1] {
            run += 1;
            most = most.max(run);
        } else {
            distinct += 1;
            run = 1;
        }
    }
    (distinct, positions.len() - distinct, most)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{RngExt, seeded};

    /// The canonical k nearest by brute force: every point sorted by (distance, global).
    fn brute(positions: &[DVec3], global: &[u64], p: DVec3, k: usize) -> Vec<(f64, u64)> {
        let mut all: Vec<(f64, u64, u64)> = positions
            .iter()
            .enumerate()
            .map(|(i, q)| (p.distance_squared(*q), global[i], i as u64))
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all.truncate(k);
        all.into_iter().map(|(d, _, i)| (d, i)).collect()
    }

    fn cloud_with_copies(clean: usize, copies: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = seeded(seed, "knn-test");
        let mut pts: Vec<DVec3> = (0..clean)
            .map(|_| DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.1))
            .collect();
        // Clusters of copies: of a clean point, of a grid corner, and of a new point.
        let a = pts[clean / 2];
        pts.extend(std::iter::repeat_n(a, copies));
        pts.extend(std::iter::repeat_n(
            DVec3::new(0.25, 0.25, 0.05),
            copies / 2,
        ));
        pts.extend(std::iter::repeat_n(DVec3::new(-0.0, 0.5, 0.0), 3));
        pts.extend(std::iter::repeat_n(DVec3::new(0.0, 0.5, -0.0), 3));
        pts
    }

    #[test]
    fn the_order_is_the_brute_force_one_with_and_without_copies() {
        for (clean, copies) in [(500, 0), (500, 40), (300, 700)] {
            let pts = cloud_with_copies(clean, copies, 7);
            // A permuted global numbering, as a chunk with a halo has.
            let global: Vec<u64> = (0..pts.len() as u64)
                .map(|i| (i * 7919) % 100_003)
                .collect();
            let knn = Knn::new(&pts, |i| global[i as usize]).unwrap();
            let sequential = Knn::new_sequential(&pts, |i| global[i as usize]).unwrap();
            for k in [1, 3, 16, 50] {
                let k_nz = NonZero::new(k).unwrap();
                for p in pts.iter().step_by(7) {
                    assert_eq!(
                        knn.canonical_knn(*p, k_nz),
                        brute(&pts, &global, *p, k),
                        "clean {clean}, copies {copies}, k {k}, at {p}"
                    );
                    assert_eq!(
                        sequential.canonical_knn(*p, k_nz),
                        knn.canonical_knn(*p, k_nz),
                        "sequential build"
                    );
                    let want = brute(&pts, &global, *p, k).last().unwrap().0;
                    assert_eq!(knn.kth_distance2(*p, k_nz), want);
                }
            }
        }
    }

    #[test]
    fn coincidence_counts_copies() {
        let pts = cloud_with_copies(100, 10, 1);
        // 100 clean, 10 copies of one of them, 5 of a new point, 6 at ±0.0.
        assert_eq!(coincidence(&pts), (102, 19, 11));
        assert_eq!(coincidence(&[]), (0, 0, 0));
    }

    #[test]
    fn ties_between_distinct_positions_are_by_global_index() {
        // A query at the centre of a square of points, each position doubled.
        let mut pts = vec![DVec3::ZERO];
        for _ in 0..2 {
            pts.extend([DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y]);
        }
        let global: Vec<u64> = vec![0, 8, 7, 6, 5, 4, 3, 2, 1];
        let knn = Knn::new(&pts, |i| global[i as usize]).unwrap();
        for k in 1..=9 {
            assert_eq!(
                knn.canonical_knn(DVec3::ZERO, NonZero::new(k).unwrap()),
                brute(&pts, &global, DVec3::ZERO, k)
            );
        }
    }

    /// The candidates examined over every point of `pts`, k = 16.
    fn examined_per_point(pts: &[DVec3]) -> f64 {
        let knn = Knn::new(pts, |i| i).unwrap();
        let k = NonZero::new(16).unwrap();
        let total: u64 = pts
            .par_iter()
            .map(|p| {
                let mut n = 0;
                knn.canonical_knn_counted(*p, k, &mut n);
                n
            })
            .sum();
        total as f64 / pts.len() as f64
    }

    #[test]
    fn copies_cost_a_small_constant_times_a_clean_cloud() {
        // 10^5 identical points beside a clean cloud of 20,000, and a clean cloud with 20,000
        // copies of one of its points (the bunny's case): the candidates per point stay within
        // 2x the clean cloud's (they were ~10^5 per point before the grouping).
        let mut rng = seeded(3, "knn-test");
        let clean: Vec<DVec3> = (0..20_000)
            .map(|_| DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.1))
            .collect();
        let base = examined_per_point(&clean);
        let mut many = clean.clone();
        many.extend(std::iter::repeat_n(DVec3::new(2.0, 2.0, 2.0), 100_000));
        let mut beside = clean.clone();
        beside.extend(std::iter::repeat_n(clean[1234], 20_000));
        for (name, pts) in [("10^5 identical", many), ("20,000 copies", beside)] {
            let e = examined_per_point(&pts);
            eprintln!("{name}: {e:.1} candidates a point (clean cloud: {base:.1})");
            assert!(
                e <= 3.0 * base,
                "{name}: {e} candidates a point, clean {base}"
            );
        }
        assert!(base <= 2.0 * 17.0, "clean: {base}");
    }
}
