//! The k nearest neighbours of every point of a set at once, from a uniform grid: the same
//! answers as [`crate::knn::Knn::canonical_knn`] (by squared distance, ties by global index,
//! the point itself first), for the normals of a whole cloud or of a chunk with its halo. On a
//! shared 2-core machine its queries took about half the k-d tree's time on a 10^6-point
//! sphere, and the 10^7-point out-of-core QSplat build of dragon samples about 0.8× the user
//! time. The per-query selection is the cost (at k = 16 on 10^6 dragon samples, 127
//! candidates a query, 44 of them within the previous query's bound): selecting by integer keys
//! took about 7 % off one thread's query time; keeping the best in a sorted array as they come,
//! or cells of 0.4 k instead of 0.6 k (85 candidates), measured no faster on this machine.
//! Gathering the candidates within the bound without a branch on each (a third of them pass,
//! so the branch was mispredicted often) took about 8 % off the queries of 2·10^6 points of a
//! wavy sheet at k = 16 (whole-process CPU time, 12 pairs: median ratio 0.92, spread 0.82 to
//! 1.11); sorting all the candidates within the bound instead of selecting the k best, or
//! 64-bit keys of truncated distances, measured no faster. Leaving the candidates' buffer
//! uncleared between queries (it only grows; a slot is written before it counts) took 3.9 %
//! off `benches/normals.rs` (criterion, 2·10^6 torus points at k = 16, interval −6.0 % to
//! −1.7 %).
//!
//! Method: the cell-list (linked-cell) neighbour search of molecular dynamics (Allen &
//! Tildesley, *Computer Simulation of Liquids*, 1987, §5.3.2), as PotreeConverter 2 and
//! point-cloud libraries bin points for neighbour queries: the points are binned in cubic
//! cells (sorted by cell, so a row of cells is one slice, found from a table of rows where it
//! is small), and a query scans the 3 × 3 × 3 cells around its own, gathered once for all the
//! queries of a cell into flat columns, and selects the k best (a fixed k, no tree) by
//! integer keys (distance bits, then the global index among ties at the k-th distance).
//! [`GridKnn::nearest`] answers any position the same way (the orientation's guide asks it
//! for a point's nearest guide points), reusing a block while the queries stay in one cell.
//! The answer is exact when the k-th distance is below the distance from the query to the
//! scanned block's faces (less a margin for the rounding of the binning); otherwise the
//! 5 × 5 × 5 block is scanned, and if that does not suffice either (an isolated point) the
//! query goes to [`crate::knn::Knn`] (built once, on the first such query, on the calling
//! thread: [`crate::knn::Knn::new_sequential`]). Squared distances are summed as `kiddo` sums them (`((dx² + dy²) + dz²)`), so
//! both give the very same numbers.
//!
//! The cell size is chosen so that an occupied cell holds about `0.6 k` distinct positions,
//! measured rather than assumed (the median occupied cell, in a large set over one occupied
//! cell in sixteen by a hash of its key; a surface's cells fill as the square of their size);
//! it changes only the speed, never an answer.
//!
//! Coincident points keep [`crate::knn`]'s bound: each cell lists distinct positions, each with
//! its copies by global index; a block takes at most k copies of a position (the later ones, at
//! the same distance and of larger index, can never be among the k best), and the points at
//! one position share one query.
//! [`GridKnn::examined`] counts the candidates tried, for the tests' bound.

use std::borrow::Cow;
use std::cell::{Cell, RefCell};
use std::num::NonZero;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::knn::Knn;

/// Cells per axis at most (21 bits of a key each).
const MAX_CELLS: u64 = (1 << 21) - 1;
/// Rings of cells scanned around a query before the k-d tree answers it.
const MAX_RING: i64 = 2;

/// A grid over a set of points (a whole cloud, or a chunk with its halo) answering canonical
/// k-nearest-neighbour queries for its own points.
#[derive(Debug)]
pub struct GridKnn<'a> {
    positions: Cow<'a, [DVec3]>,
    /// Global index of each point (by local index).
    global: Vec<u64>,
    origin: DVec3,
    cell: f64,
    inv: f64,
    dims: [i64; 3],
    /// Distances below this far from the faces of a block are not trusted.
    margin: f64,
    /// The occupied cells' keys, ascending; cell `c` holds distinct positions
    /// `cstart[c]..cstart[c + 1]`.
    cells: Vec<u64>,
    cstart: Vec<u32>,
    /// Where each row of cells (a `(y, z)`, by `z · dims[1] + y`) starts in `cells`, one more
    /// for the end: a block's rows found without a search; `None` where the rows would
    /// outnumber the occupied cells by far (then each row is a binary search in `cells`).
    rows: Option<Vec<u32>>,
    /// Distinct positions; position `d` has copies `members[dstart[d]..dstart[d + 1]]`.
    dpos: Vec<[f64; 3]>,
    dstart: Vec<u32>,
    /// (global index, local index), by global index within a position.
    members: Vec<(u64, u32)>,
    fallback: OnceLock<Option<Knn>>,
    examined: AtomicU64,
    fell_back: AtomicU64,
}

fn cell_key(c: [i64; 3]) -> u64 {
    ((c[2] as u64) << 42) | ((c[1] as u64) << 21) | c[0] as u64
}

/// The bits positions are grouped by (`-0.0` and `0.0` are one position).
fn pos_key(p: DVec3) -> [u64; 3] {
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

/// Points below which [`median_run`] counts every cell rather than a sample of them.
const SAMPLE_CELLS_FROM: usize = 1 << 16;
/// Sampled cells below which [`median_run`] counts every cell after all.
const SAMPLE_CELLS_AT_LEAST: usize = 32;

/// The median, over the occupied cells, of the points a cell holds (a few cells of many
/// copies do not sway it). In a large set, over the occupied cells whose key hashes to one in
/// sixteen: a sample of the occupied cells (each cell's points all in or all out, so its count
/// is whole), sorted instead of every key. It only sizes the cells: an answer never depends on
/// it.
fn median_run(keys: &[u64]) -> f64 {
    if keys.len() >= SAMPLE_CELLS_FROM {
        let mut sampled: Vec<u64> = keys
            .par_iter()
            .copied()
            .filter(|&key| crate::rng::splitmix64(key) >> 60 == 0)
            .collect();
        sampled.par_sort_unstable();
        let mut runs = runs_of(&sampled);
        if runs.len() >= SAMPLE_CELLS_AT_LEAST {
            return median(&mut runs);
        }
    }
    let mut sorted = keys.to_vec();
    sorted.par_sort_unstable();
    median(&mut runs_of(&sorted))
}

/// The lengths of the runs of equal keys in `sorted`.
fn runs_of(sorted: &[u64]) -> Vec<usize> {
    sorted.chunk_by(|a, b| a == b).map(<[u64]>::len).collect()
}

/// The median of `runs` (not empty: a set has points), as a float.
fn median(runs: &mut [usize]) -> f64 {
    let mid = runs.len() / 2;
    *runs.select_nth_unstable(mid).1 as f64
}

/// The squared distance as `kiddo`'s `SquaredEuclidean` sums it.
#[inline(always)]
fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    let dz = a[2] - b[2];
    dx * dx + dy * dy + dz * dz
}

impl<'a> GridKnn<'a> {
    /// The grid of `positions` (finite; the caller checks), point `i` having global index
    /// `global(i)`; cells sized for queries of about `k_hint` neighbours. Fails when there
    /// are no points or more than 2^32.
    pub fn new(
        positions: &'a [DVec3],
        global: impl Fn(u64) -> u64 + Sync,
        k_hint: usize,
    ) -> Result<Self> {
        Self::build(Cow::Borrowed(positions), global, k_hint)
    }

    /// [`GridKnn::new`] owning its points (a grid kept beside them, as
    /// [`crate::orient::Guide`] keeps its own).
    pub fn new_owned(
        positions: Vec<DVec3>,
        global: impl Fn(u64) -> u64 + Sync,
        k_hint: usize,
    ) -> Result<GridKnn<'static>> {
        GridKnn::build(Cow::Owned(positions), global, k_hint)
    }

    fn build(
        owned: Cow<'a, [DVec3]>,
        global: impl Fn(u64) -> u64 + Sync,
        k_hint: usize,
    ) -> Result<Self> {
        let positions: &[DVec3] = &owned;
        let n = positions.len();
        if n == 0 {
            return Err(Error::EmptyCloud);
        }
        if n as u64 > u64::from(u32::MAX) {
            return Err(Error::InvalidParameter {
                name: "positions",
                reason: format!("{n} points; a neighbour index holds at most 2^32"),
            });
        }
        let global: Vec<u64> = (0..n as u64).into_par_iter().map(&global).collect();
        let (lo, hi) = positions
            .par_iter()
            .fold(
                || (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            )
            .reduce(
                || (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        let extent = (hi - lo).max_element();
        let smallest = extent / MAX_CELLS as f64;
        let target = (0.6 * k_hint.max(1) as f64).max(2.0);
        let keys_at = |cell: f64| -> Vec<u64> {
            let inv = 1.0 / cell;
            positions
                .par_iter()
                .map(|p| cell_key(Self::cell_of_raw(*p, lo, inv, hi, cell)))
                .collect()
        };
        let mut cell = if extent > 0.0 {
            // As if the points filled the box's largest face.
            let e = hi - lo;
            let mut a = [e.x * e.y, e.y * e.z, e.x * e.z];
            a.sort_by(f64::total_cmp);
            (a[2] * target / n as f64).sqrt().max(smallest)
        } else {
            1.0
        };
        // A few corrections by the measured occupancy (a surface's cells fill as the square
        // of their size).
        let mut keys = keys_at(cell);
        if extent > 0.0 {
            for _ in 0..3 {
                let occupancy = median_run(&keys);
                if (0.6 * target..=1.6 * target).contains(&occupancy) {
                    break;
                }
                let next = (cell * (target / occupancy).sqrt()).clamp(smallest, extent);
                if next == cell {
                    break;
                }
                cell = next;
                keys = keys_at(cell);
            }
        }
        let inv = 1.0 / cell;
        let dims = if extent > 0.0 {
            let d = Self::cell_of_raw(hi, lo, inv, hi, cell);
            [d[0] + 1, d[1] + 1, d[2] + 1]
        } else {
            [1, 1, 1]
        };
        // Points by cell, then global index; then, within each cell, by position (a stable
        // sort: a position's copies stay by global index; each key read once, as the points'
        // positions lie scattered in memory).
        let mut order: Vec<(u64, u64, u32)> = (0..n)
            .into_par_iter()
            .map(|i| (keys[i], global[i], i as u32))
            .collect();
        drop(keys);
        order.par_sort_unstable();
        order
            .par_chunk_by_mut(|a, b| a.0 == b.0)
            .for_each(|cell| cell.sort_by_cached_key(|e| pos_key(positions[e.2 as usize])));
        let mut cells = Vec::new();
        let mut cstart = Vec::new();
        let mut dpos = Vec::new();
        let mut dstart = Vec::new();
        let mut members = Vec::with_capacity(n);
        for (j, e) in order.iter().enumerate() {
            let new_cell = j == 0 || order[j - 1].0 != e.0;
            if new_cell {
                cells.push(e.0);
                cstart.push(dpos.len() as u32);
            }
            let p = positions[e.2 as usize];
            if new_cell || pos_key(positions[order[j - 1].2 as usize]) != pos_key(p) {
                dpos.push(p.to_array());
                dstart.push(members.len() as u32);
            }
            members.push((e.1, e.2));
        }
        cstart.push(dpos.len() as u32);
        dstart.push(members.len() as u32);
        let row_count = (dims[1] as u64).saturating_mul(dims[2] as u64);
        let rows = (row_count <= 4 * cells.len() as u64 + 1024).then(|| {
            let mut rows = Vec::with_capacity(row_count as usize + 1);
            let mut at = 0usize;
            for r in 0..=row_count {
                // The first cell of row r or later (the row is the key's upper 42 bits).
                let first = cell_key([0, (r % dims[1] as u64) as i64, (r / dims[1] as u64) as i64]);
                while at < cells.len() && (r == row_count || cells[at] < first) {
                    at += 1;
                }
                rows.push(at as u32);
            }
            rows
        });
        let scale = lo.abs().max(hi.abs()).max_element() + extent;
        Ok(Self {
            positions: owned,
            global,
            origin: lo,
            cell,
            inv,
            dims,
            margin: 1e-6 * cell + 1e-12 * scale,
            cells,
            cstart,
            rows,
            dpos,
            dstart,
            members,
            fallback: OnceLock::new(),
            examined: AtomicU64::new(0),
            fell_back: AtomicU64::new(0),
        })
    }

    fn cell_of_raw(p: DVec3, lo: DVec3, inv: f64, hi: DVec3, cell: f64) -> [i64; 3] {
        let max = |a: usize| (((hi[a] - lo[a]) / cell).floor() as i64).clamp(0, MAX_CELLS as i64);
        let c = |a: usize| (((p[a] - lo[a]) * inv).floor() as i64).clamp(0, max(a));
        [c(0), c(1), c(2)]
    }

    fn cell_of(&self, p: &[f64; 3]) -> [i64; 3] {
        let c = |a: usize| {
            (((p[a] - self.origin[a]) * self.inv).floor() as i64).clamp(0, self.dims[a] - 1)
        };
        [c(0), c(1), c(2)]
    }

    /// Points in the grid.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the grid is empty (never: [`GridKnn::new`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Candidates tried so far (positions scanned plus copies taken).
    pub fn examined(&self) -> u64 {
        self.examined.load(Ordering::Relaxed)
    }

    /// Queries the k-d tree answered so far.
    pub fn fell_back(&self) -> u64 {
        self.fell_back.load(Ordering::Relaxed)
    }

    /// The cell size chosen.
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Fills `block` with the candidates of the block of `2r + 1` cells a side around `c`: each
    /// distinct position's first `k` copies (later copies, at the same distance and of larger
    /// global index, are never among the k best).
    fn fill(&self, c: [i64; 3], r: i64, k: usize, block: &mut Block) {
        block.clear();
        block.cell = c;
        block.ring = r;
        let x0 = (c[0] - r).max(0);
        let x1 = (c[0] + r).min(self.dims[0] - 1);
        for z in (c[2] - r).max(0)..=(c[2] + r).min(self.dims[2] - 1) {
            for y in (c[1] - r).max(0)..=(c[1] + r).min(self.dims[1] - 1) {
                let (lo, hi) = match &self.rows {
                    Some(rows) => {
                        let r = (z * self.dims[1] + y) as usize;
                        (rows[r] as usize, rows[r + 1] as usize)
                    }
                    None => (0, self.cells.len()),
                };
                let row = &self.cells[lo..hi];
                let a = lo + row.partition_point(|&key| key < cell_key([x0, y, z]));
                let b = a + self.cells[a..hi].partition_point(|&key| key <= cell_key([x1, y, z]));
                for d in self.cstart[a] as usize..self.cstart[b] as usize {
                    let (s, e) = (self.dstart[d] as usize, self.dstart[d + 1] as usize);
                    let p = self.dpos[d];
                    for &(g, l) in &self.members[s..e.min(s + k)] {
                        block.x.push(p[0]);
                        block.y.push(p[1]);
                        block.z.push(p[2]);
                        block.g.push(g);
                        block.l.push(l);
                    }
                }
            }
        }
    }

    /// The `k` best of `q` among `block`'s candidates into `out` ((squared distance, global,
    /// index in the block), in canonical order); returns whether they are the k nearest of all
    /// points. `out` comes in holding the previous selection from this block.
    fn select(
        &self,
        q: &[f64; 3],
        k: usize,
        block: &Block,
        out: &mut Vec<(f64, u64, u32)>,
        examined: &mut u64,
    ) -> bool {
        let n = block.x.len();
        *examined += n as u64;
        let d2: &mut Vec<f64> = &mut block.d2.borrow_mut();
        d2.clear();
        // (Zipped columns: no bounds checks, so the loop vectorises.)
        d2.extend(
            block
                .x
                .iter()
                .zip(&block.y)
                .zip(&block.z)
                .map(|((&x, &y), &z)| dist2(q, &[x, y, z])),
        );
        // The previous query of this block bounds this one's k-th distance: its k nearest
        // (still in `out`, as block indices) are k candidates, so this query's k-th nearest
        // is no farther than the farthest of them (distances summed alike: the bound is exact,
        // and at least k candidates lie within it).
        let bound = if block.last_full.get() && out.len() == k {
            out.iter().map(|e| d2[e.2 as usize]).fold(0.0, f64::max)
        } else {
            f64::INFINITY
        };
        // The candidates within the bound as keys (distance bits, block index): squared
        // distances are never negative, so their bits order as they do, and a key is one
        // integer to compare. The k best by key are the k best by (distance, global index)
        // except among ties at the k-th distance, settled by global index below.
        let cand: &mut Vec<u128> = &mut block.cand.borrow_mut();
        let want = k.min(n);
        let mut kept = 0;
        for threshold in [bound, f64::INFINITY] {
            // Branch-free: every candidate is written, the length advances past those within
            // the threshold (about a third pass: a branch on each mispredicted often). The
            // buffer grows and is never cleared: every slot below `len` is written first.
            if cand.len() < n {
                cand.resize(n, 0);
            }
            let mut len = 0;
            for (i, &d) in d2.iter().enumerate() {
                cand[len] = (u128::from(d.to_bits()) << 64) | i as u128;
                len += usize::from(d <= threshold);
            }
            kept = len;
            if kept >= want {
                break;
            }
        }
        let cand = &mut cand[..kept];
        let dist = |key: u128| (key >> 64) as u64;
        let index = |key: u128| key as u32;
        if cand.len() > want && want > 0 {
            cand.select_nth_unstable(want - 1);
            let last = dist(cand[want - 1]);
            if cand[want..].iter().any(|&key| dist(key) == last) {
                // Ties at the k-th distance: those of least global index. (Every key nearer
                // than the k-th is among the first k after the selection.)
                let mut best: Vec<u128> = cand[..want]
                    .iter()
                    .filter(|&&key| dist(key) < last)
                    .copied()
                    .collect();
                let mut tied: Vec<u128> = cand
                    .iter()
                    .filter(|&&key| dist(key) == last)
                    .copied()
                    .collect();
                tied.sort_unstable_by_key(|&key| block.g[index(key) as usize]);
                let room = want - best.len();
                best.extend(tied.into_iter().take(room));
                cand[..want].copy_from_slice(&best);
            }
        }
        let cand = &cand[..cand.len().min(want)];
        out.clear();
        out.extend(cand.iter().map(|&key| {
            let i = index(key);
            (f64::from_bits(dist(key)), block.g[i as usize], i)
        }));
        out.sort_unstable_by_key(|e| (e.0.to_bits(), e.1));
        block.last_full.set(out.len() == k);
        let (c, r) = (block.cell, block.ring);
        let covers_all = (0..3).all(|a| c[a] - r <= 0 && c[a] + r >= self.dims[a] - 1);
        if covers_all {
            return true;
        }
        if out.len() < k {
            return false;
        }
        let mut b = f64::INFINITY;
        for a in 0..3 {
            let lo = self.origin[a] + (c[a] - r) as f64 * self.cell;
            let hi = self.origin[a] + (c[a] + r + 1) as f64 * self.cell;
            // Faces at the grid's border have nothing beyond them.
            if c[a] - r > 0 {
                b = b.min(q[a] - lo);
            }
            if c[a] + r < self.dims[a] - 1 {
                b = b.min(hi - q[a]);
            }
        }
        let b = b - self.margin;
        b > 0.0 && out[k - 1].0 < b * b
    }

    /// The `k` nearest of `q` in canonical order as (squared distance, local index), into
    /// `res`; `block` holds the 3 × 3 × 3 block around `q`'s cell when it is filled for it.
    fn query(&self, q: &[f64; 3], k: usize, s: &mut Scratch, examined: &mut u64) -> Result<()> {
        s.res.clear();
        let c = self.cell_of(q);
        for r in 1..=MAX_RING {
            if s.block.cell != c || s.block.ring != r || s.block.k != k {
                self.fill(c, r, k, &mut s.block);
                s.block.k = k;
            }
            if self.select(q, k, &s.block, &mut s.sel, examined) {
                let l = &s.block.l;
                s.res
                    .extend(s.sel.iter().map(|e| (e.0, u64::from(l[e.2 as usize]))));
                return Ok(());
            }
        }
        self.fell_back.fetch_add(1, Ordering::Relaxed);
        let knn = self
            .fallback
            .get_or_init(|| Knn::new_sequential(&self.positions, |i| self.global[i as usize]).ok())
            .as_ref()
            .ok_or(Error::EmptyCloud)?;
        let kk = NonZero::new(k).ok_or(Error::InvalidParameter {
            name: "k",
            reason: "zero".into(),
        })?;
        let mut e = 0;
        s.res
            .extend(knn.canonical_knn_counted(DVec3::from_array(*q), kk, &mut e));
        *examined += e;
        Ok(())
    }

    /// The `k` nearest neighbours of `p` as (squared distance, local index) in canonical
    /// order (as [`Knn::canonical_knn`]).
    pub fn canonical_knn(&self, p: DVec3, k: NonZero<usize>) -> Result<Vec<(f64, u64)>> {
        let (mut s, mut e) = (Scratch::default(), 0);
        self.query(&p.to_array(), k.get(), &mut s, &mut e)?;
        self.examined.fetch_add(e, Ordering::Relaxed);
        Ok(s.res)
    }

    /// The `k` nearest neighbours of any position `p` as (squared distance, local index) in
    /// canonical order, as [`GridKnn::canonical_knn`] gives them, with `scratch`'s buffers:
    /// successive queries near one another (in one cell) share its block of candidates, as
    /// [`GridKnn::for_each_point`]'s do (the candidates tried are counted in the scratch,
    /// [`Queries::examined`], not in [`GridKnn::examined`]). A scratch serves one grid:
    /// [`Queries::default`] for another.
    pub fn nearest<'s>(
        &self,
        p: DVec3,
        k: NonZero<usize>,
        scratch: &'s mut Queries,
    ) -> Result<&'s [(f64, u64)]> {
        self.query(
            &p.to_array(),
            k.get(),
            &mut scratch.scratch,
            &mut scratch.examined,
        )?;
        Ok(&scratch.scratch.res)
    }

    /// `f(i, neighbours)` for every point `i` of the grid with `want(i)`, its `k` nearest
    /// neighbours (the point itself first) as [`GridKnn::canonical_knn`] gives them, in
    /// parallel cell by cell (a cell's queries share its block of candidates); the points at
    /// one position share one query. Returns the values by local index (`T::default()` where
    /// not wanted).
    pub fn for_each_point<T: Send + Clone + Default>(
        &self,
        k: NonZero<usize>,
        want: impl Fn(usize) -> bool + Sync,
        f: impl Fn(usize, &[(f64, u64)]) -> T + Sync,
    ) -> Result<Vec<T>> {
        let k = k.get();
        let parts: Vec<Result<Vec<(u32, T)>>> = (0..self.cells.len())
            .into_par_iter()
            .with_min_len(16)
            .fold(
                || (Ok(Vec::new()), Scratch::default()),
                |(acc, mut s): (Result<Vec<(u32, T)>>, Scratch), c| {
                    let Ok(mut acc) = acc else {
                        return (acc, s);
                    };
                    let mut examined = 0;
                    for d in self.cstart[c] as usize..self.cstart[c + 1] as usize {
                        let copies =
                            &self.members[self.dstart[d] as usize..self.dstart[d + 1] as usize];
                        if !copies.iter().any(|&(_, l)| want(l as usize)) {
                            continue;
                        }
                        if let Err(e) = self.query(&self.dpos[d], k, &mut s, &mut examined) {
                            return (Err(e), s);
                        }
                        for &(_, l) in copies {
                            if want(l as usize) {
                                acc.push((l, f(l as usize, &s.res)));
                            }
                        }
                    }
                    self.examined.fetch_add(examined, Ordering::Relaxed);
                    (Ok(acc), s)
                },
            )
            .map(|(acc, _)| acc)
            .collect();
        let mut out = vec![T::default(); self.positions.len()];
        for part in parts {
            for (l, v) in part? {
                out[l as usize] = v;
            }
        }
        Ok(out)
    }
}

/// The candidates of a block of cells, as columns.
#[derive(Debug, Default)]
struct Block {
    cell: [i64; 3],
    ring: i64,
    k: usize,
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    g: Vec<u64>,
    l: Vec<u32>,
    /// The candidates' squared distances to the current query.
    d2: RefCell<Vec<f64>>,
    /// The selection's keys (distance bits, block index).
    cand: RefCell<Vec<u128>>,
    /// Whether the last selection from this block found k candidates (then kept in
    /// [`Scratch::sel`]).
    last_full: Cell<bool>,
}

impl Block {
    fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
        self.g.clear();
        self.l.clear();
        self.last_full.set(false);
    }
}

/// A caller's buffers for [`GridKnn::nearest`] (one grid's: its block of candidates is the
/// last query's).
#[derive(Debug, Default)]
pub struct Queries {
    scratch: Scratch,
    examined: u64,
}

impl Queries {
    /// Candidates the queries with this scratch tried.
    pub fn examined(&self) -> u64 {
        self.examined
    }
}

/// A thread's buffers: the block, the selection, the answer.
#[derive(Debug)]
struct Scratch {
    block: Block,
    sel: Vec<(f64, u64, u32)>,
    res: Vec<(f64, u64)>,
}

impl Default for Scratch {
    fn default() -> Self {
        Scratch {
            // No cell is at -1: the first query fills the block.
            block: Block {
                cell: [-1; 3],
                ..Block::default()
            },
            sel: Vec::new(),
            res: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests;
