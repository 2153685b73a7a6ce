//! Step 3 of the preparation: each chunk's neighbourhoods completed by a *halo*, so that its
//! points' k nearest neighbours, normals and density-spacing distances are those of the whole
//! cloud, bit for bit.
//!
//! Every point of a chunk gets an upper bound of its k-th neighbour distance (from the chunk,
//! or from the input's strided sample for a chunk of fewer than k points); the chunk's halo
//! radius is the largest bound of the points whose ball leaves the chunk's box (balls inside it
//! hold no other chunk's point, the regions being separated by the split planes); one pass over
//! all chunks sends every point within a chunk's halo radius of its box to that chunk's halo
//! file. The k nearest neighbours over chunk + halo are then the true ones, taken in
//! `crate::knn`'s canonical order (which no index changes; `crate::knn_grid` finds them for
//! all the points of a chunk at once, as the in-memory normals do), so the normals and the
//! spacing sample's distances are the in-memory ones; when the normals' k is the halo's, the
//! first pass's query already gives the normal of every point whose ball lies inside its chunk
//! (the same neighbours in the same order), kept in a scratch file, as are the spacing
//! sample's distances of the points whose ball lies inside; the halo pass then searches only
//! the points near the borders, from a grid over the halo and the chunk's points within twice
//! the halo radius of its box's faces (all a border point's neighbours lie there).
//!
//! Where the normals are given, only the spacing sample needs neighbours: the first pass
//! searches only its points, a chunk's halo radius is the largest bound of those whose ball
//! leaves its box, and a chunk none of whose sample points is left for the halo pass gets no
//! halo and is not loaded again ([`Preparer::queries`] counts the searches).

use std::collections::HashMap;
use std::num::NonZero;

use glam::{DVec3, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};

use super::chunks::{NORMAL, PATCH, PartKind, Set, normal_bytes, normal_of};
use super::{HALO_BUFFER, NEIGHBOUR_BYTES_PER_POINT, Preparer, Stage};
use crate::lod_file::{Error, Result};
use crate::spill::{SpillFile, SpillWriter};

impl Preparer<'_> {
    /// Normals and the spacing sample's distances, chunk by chunk with halos (module doc,
    /// step 3); returns the largest halo.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn neighbourhoods(
        &mut self,
        root: usize,
        sample: &[(DVec3, u64)],
        k_halo: usize,
        estimate: Option<usize>,
        guide: Option<&crate::orient::Guide>,
        picks: Option<&(Vec<u64>, usize)>,
        spacing_d: &mut Vec<f64>,
    ) -> Result<u64> {
        let kk = NonZero::new(k_halo.max(1)).ok_or(Error::InvalidParameter {
            name: "k",
            reason: "zero".into(),
        })?;
        let sample_entries: Vec<[f64; 3]> = sample.iter().map(|s| s.0.to_array()).collect();
        let sample_tree = kd_tree(&sample_entries)?;
        // The normals' sign: the guide's (`crate::orient`), as the in-memory estimate has it.
        let sign = |p: DVec3, n: DVec3| match guide {
            Some(g) => g.orient(p, n),
            None => crate::normals::orient(n, DVec3::Z),
        };
        // (a) Every chunk's halo radius. When the normals' k is the halo's, the one query per
        // point also gives the normal of every point whose ball lies inside its chunk's box:
        // its neighbours are its true ones, in `canonical_knn`'s order, so the normal is the
        // one (c) would compute (bit for bit); it is kept in a scratch file (NaN: left to (c),
        // which then searches only the points near the borders).
        let single = estimate == Some(kk.get());
        let mut halo2 = vec![0.0f64; self.store.chunks.len()];
        // Per chunk: whether (c) has any search to make there (always, for estimated normals).
        let mut needed = vec![estimate.is_some(); self.store.chunks.len()];
        let mut early: Vec<Option<SpillFile>> =
            (0..self.store.chunks.len()).map(|_| None).collect();
        // Per chunk: whether (c) may search only the points near its box's faces (every query
        // left to (c) is then a point whose ball leaves the box), and the spacing picks (a)
        // answered (local indices).
        let mut border_only = vec![false; self.store.chunks.len()];
        let mut resolved: Vec<Vec<u32>> = vec![Vec::new(); self.store.chunks.len()];
        self.done = 0;
        (self.progress)(Stage::Neighbours, 0);
        for (c, r2) in halo2.iter_mut().enumerate() {
            let set = self.store.chunks[c].clone();
            let l = self.store.load_set(&set)?;
            let own = (l.positions.len() >= kk.get())
                .then(|| {
                    crate::knn_grid::GridKnn::new(
                        &l.positions,
                        |item| l.index[item as usize],
                        kk.get(),
                    )
                })
                .transpose()?;
            let bbox = set.bbox.unwrap_or((DVec3::ZERO, DVec3::ZERO));
            let overlap = set.overlap;
            let inside = |p: DVec3, d: f64| {
                !overlap && (0..3).all(|a| p[a] - bbox.0[a] > d && bbox.1[a] - p[a] > d)
            };
            if estimate.is_none() {
                // Given normals: only the spacing picks are searched.
                *r2 = 0.0;
                if let Some((picks, _)) = picks {
                    let times = pick_times(picks, &l.index);
                    let picked = |i: usize| times.get(i).is_some_and(|&t| t > 0);
                    self.queries += times.iter().filter(|&&t| t > 0).count() as u64;
                    let d2: Vec<f64> = match own.as_ref() {
                        Some(grid) => grid.for_each_point(kk, picked, |_, nb| {
                            nb.last().map_or(f64::INFINITY, |x| x.0)
                        })?,
                        None => (0..l.positions.len())
                            .map(|i| {
                                if !picked(i) {
                                    return 0.0;
                                }
                                sample_tree
                                    .query(&l.positions[i].to_array())
                                    .nearest_n::<SquaredEuclidean<f64>>(kk)
                                    .execute()
                                    .last()
                                    .map_or(f64::INFINITY, |x| x.distance)
                            })
                            .collect(),
                    };
                    for (i, &t) in times.iter().enumerate() {
                        if t == 0 {
                            continue;
                        }
                        let d = d2[i].sqrt();
                        if own.is_some() && inside(l.positions[i], d) {
                            spacing_d.extend(std::iter::repeat_n(d, t as usize));
                            resolved[c].push(i as u32);
                        } else {
                            needed[c] = true;
                            if !inside(l.positions[i], d) {
                                *r2 = r2.max(d2[i]);
                            }
                        }
                    }
                }
                border_only[c] = own.is_some() && !overlap;
                self.done += set.count;
                (self.progress)(Stage::Neighbours, self.done);
                continue;
            }
            self.queries += l.positions.len() as u64;
            let per_point: Vec<(f64, Option<Vec3>)> = match own.as_ref() {
                Some(grid) => grid.for_each_point(
                    kk,
                    |_| true,
                    |i, nb| {
                        let p = l.positions[i];
                        let d2 = nb.last().map_or(f64::INFINITY, |x| x.0);
                        if !inside(p, d2.sqrt()) {
                            (d2, None)
                        } else if single {
                            let n = crate::normals::covariance_normal(
                                nb.iter().map(|x| l.positions[x.1 as usize]),
                            );
                            (0.0, Some(sign(p, n)))
                        } else {
                            (0.0, None)
                        }
                    },
                )?,
                None => l
                    .positions
                    .iter()
                    .map(|p| {
                        let d2 = sample_tree
                            .query(&p.to_array())
                            .nearest_n::<SquaredEuclidean<f64>>(kk)
                            .execute()
                            .last()
                            .map_or(f64::INFINITY, |x| x.distance);
                        (if inside(*p, d2.sqrt()) { 0.0 } else { d2 }, None)
                    })
                    .collect(),
            };
            *r2 = per_point.iter().map(|x| x.0).fold(0.0, f64::max);
            // The spacing picks whose (ks + 1)-ball lies inside the box: their distances from
            // the chunk alone, exact as the normals above are.
            if let (Some((picks, ks)), Some(grid)) = (picks, own.as_ref())
                && !overlap
            {
                let times = pick_times(picks, &l.index);
                let k1 = NonZero::new(ks + 1).unwrap_or(kk);
                self.queries += times.iter().filter(|&&t| t > 0).count() as u64;
                let d2 = grid.for_each_point(
                    k1,
                    |i| times.get(i).is_some_and(|&t| t > 0),
                    |_, nb| nb.last().map_or(f64::INFINITY, |x| x.0),
                )?;
                for (i, &t) in times.iter().enumerate() {
                    let d = d2[i].sqrt();
                    if t > 0 && inside(l.positions[i], d) {
                        spacing_d.extend(std::iter::repeat_n(d, t as usize));
                        resolved[c].push(i as u32);
                    }
                }
            }
            border_only[c] = own.is_some() && !overlap && (estimate.is_none() || single);
            if single && own.is_some() {
                let mut w = self
                    .store
                    .scratch
                    .create(NORMAL)
                    .map_err(|e| self.store.io(e))?;
                for (_, n) in &per_point {
                    w.push(&normal_bytes(n.unwrap_or(Vec3::NAN)))
                        .map_err(|e| self.store.io(e))?;
                }
                early[c] = Some(w.finish().map_err(|e| self.store.io(e))?);
            }
            self.done += set.count;
            (self.progress)(Stage::Neighbours, self.done);
        }
        (self.progress)(Stage::Halos, 0);
        // Slack for the rounding of box distances against point distances.
        let slack = |r2: f64| r2 * (1.0 + 1e-9) + f64::MIN_POSITIVE;
        for t in 0..self.store.parts.len() {
            self.store.parts[t].halo2 = match &self.store.parts[t].kind {
                // No search left there: no halo (no distance is below -1).
                PartKind::Chunk(c) if !needed[*c] => -1.0,
                PartKind::Chunk(c) => slack(halo2[*c]),
                PartKind::Inner(kids) => kids
                    .iter()
                    .map(|&k| self.store.parts[k].halo2)
                    .fold(0.0, f64::max),
            };
        }
        // (b) One pass sending every point to the halos it lies in.
        let mut halos: Vec<Option<SpillWriter>> =
            (0..self.store.chunks.len()).map(|_| None).collect();
        // Each chunk's halo records, `len` bytes each (the vectors' spare room at most doubles
        // the bytes counted).
        let len = self.store.layout.len();
        let mut buffered: HashMap<usize, Vec<u8>> = HashMap::new();
        let mut buffered_bytes = 0usize;
        let mut stack = Vec::new();
        // No chunk wants a halo: no pass.
        let chunks_for_halos = if needed.iter().any(|&x| x) {
            self.store.chunks.len()
        } else {
            0
        };
        for d in 0..chunks_for_halos {
            let set = self.store.chunks[d].clone();
            self.store.for_each(&set, |r| {
                let p = self.store.layout.position_of(r);
                stack.clear();
                stack.push(root);
                while let Some(t) = stack.pop() {
                    let top = &self.store.parts[t];
                    if box_dist2(p, top.bbox) > top.halo2 {
                        continue;
                    }
                    match &top.kind {
                        PartKind::Inner(kids) => stack.extend(kids.iter().copied()),
                        PartKind::Chunk(c) if *c != d => {
                            buffered.entry(*c).or_default().extend_from_slice(&r[..len]);
                            buffered_bytes += len;
                        }
                        PartKind::Chunk(_) => {}
                    }
                }
                if buffered_bytes >= HALO_BUFFER {
                    self.flush_halos(&mut buffered, &mut halos)?;
                    buffered_bytes = 0;
                }
                Ok(())
            })?;
        }
        self.flush_halos(&mut buffered, &mut halos)?;
        // (c) Each chunk with its halo: normals and the spacing sample's distances.
        let budget = self.cap * self.opts.bytes_per_point / NEIGHBOUR_BYTES_PER_POINT;
        let mut largest = 0u64;
        self.done = 0;
        for (c, halo) in halos.into_iter().enumerate() {
            let set = self.store.chunks[c].clone();
            if !needed[c] {
                // Given normals and every spacing pick answered by (a): nothing to search.
                self.done += set.count;
                (self.progress)(Stage::Halos, self.done);
                continue;
            }
            let l = self.store.load_set(&set)?;
            let m = l.positions.len();
            let halo = match halo {
                Some(w) => Some(w.finish().map_err(|e| self.store.io(e))?),
                None => None,
            };
            let h = halo.as_ref().map_or(0, SpillFile::len);
            largest = largest.max(h);
            if (m as u64 + h) > budget {
                return Err(Error::InvalidParameter {
                    name: "memory_limit",
                    reason: format!(
                        "a chunk of {m} points needs a halo of {h} points for its neighbour \
                         searches, more than the limit holds ({budget} points); the cloud is \
                         too sparse around that chunk, or holds many copies of a point there, \
                         for this limit"
                    ),
                });
            }
            // The chunk's points that (c)'s searches can reach: when every query left is a
            // point within its ball's radius r <= R of a face of the box, its neighbours lie
            // within 2R of that face (distance to a plane is 1-Lipschitz); otherwise all.
            let sel: Vec<u32> = if border_only[c] {
                let (lo, hi) = set.bbox.unwrap_or((DVec3::ZERO, DVec3::ZERO));
                let magnitude = lo.abs().max(hi.abs()).max_element();
                let reach = 2.0 * halo2[c].sqrt() * (1.0 + 1e-6) + magnitude * 1e-12;
                (0..m as u32)
                    .filter(|&i| {
                        let p = l.positions[i as usize];
                        (0..3).any(|a| p[a] - lo[a] <= reach || hi[a] - p[a] <= reach)
                    })
                    .collect()
            } else {
                (0..m as u32).collect()
            };
            let mz = sel.len();
            let mut positions: Vec<DVec3> = sel.iter().map(|&i| l.positions[i as usize]).collect();
            let mut index: Vec<u64> = sel.iter().map(|&i| l.index[i as usize]).collect();
            if let Some(hf) = &halo {
                let hs = Set::whole(hf.clone());
                self.store.for_each(&hs, |r| {
                    let (p, i) = self.store.layout.unpack(r);
                    positions.push(p.position);
                    index.push(i);
                    Ok(())
                })?;
            }
            drop(halo);
            let grid =
                crate::knn_grid::GridKnn::new(&positions, |item| index[item as usize], kk.get())?;
            if let Some(k) = estimate {
                let k = NonZero::new(k).unwrap_or(kk);
                // The normals (a) found (NaN where it left them to this pass).
                let early = early[c].take();
                let known: Vec<bool> = match &early {
                    Some(f) => {
                        let mut r = f.reader(0, m as u64).map_err(|e| self.store.io(e))?;
                        let mut rec = [0u8; NORMAL];
                        let mut out = Vec::with_capacity(m);
                        while r.next_into(&mut rec).map_err(|e| self.store.io(e))? {
                            out.push(!normal_of(&rec).x.is_nan());
                        }
                        out
                    }
                    None => vec![false; m],
                };
                // By the grid's index (`sel` maps the chunk's part of it to the chunk's).
                let missing =
                    |j: usize| j < mz && !known.get(sel[j] as usize).copied().unwrap_or(false);
                self.queries += (0..positions.len()).filter(|&j| missing(j)).count() as u64;
                let found = grid.for_each_point(k, missing, |i, nb| {
                    let n = crate::normals::covariance_normal(
                        nb.iter().map(|x| positions[x.1 as usize]),
                    );
                    sign(positions[i], n)
                })?;
                // The chunk's normals: (a)'s file with the ones found here as a patch, or all
                // found here.
                let (normals, patch) = match early {
                    Some(f) => {
                        let mut w = self
                            .store
                            .scratch
                            .create(PATCH)
                            .map_err(|e| self.store.io(e))?;
                        let mut rec = [0u8; PATCH];
                        for (j, n) in found.iter().enumerate().take(mz) {
                            if missing(j) {
                                rec[..4].copy_from_slice(&sel[j].to_le_bytes());
                                rec[4..].copy_from_slice(&normal_bytes(*n));
                                w.push(&rec).map_err(|e| self.store.io(e))?;
                            }
                        }
                        (f, Some(w.finish().map_err(|e| self.store.io(e))?))
                    }
                    None => {
                        let mut w = self
                            .store
                            .scratch
                            .create(NORMAL)
                            .map_err(|e| self.store.io(e))?;
                        debug_assert_eq!(mz, m, "all normals are found from the whole chunk");
                        for n in found.iter().take(mz) {
                            w.push(&normal_bytes(*n)).map_err(|e| self.store.io(e))?;
                        }
                        (w.finish().map_err(|e| self.store.io(e))?, None)
                    }
                };
                self.store.chunks[c].normals = Some(normals);
                self.store.chunks[c].patch = patch;
            }
            if let Some((picks, ks)) = picks {
                let k1 = NonZero::new(ks + 1).unwrap_or(kk);
                // How often each point of the chunk is picked (counted once: the search asks
                // for every copy of every position), less the picks (a) answered.
                let mut times = pick_times(picks, &l.index);
                for &i in &resolved[c] {
                    times[i as usize] = 0;
                }
                let times: Vec<u32> = sel.iter().map(|&i| times[i as usize]).collect();
                self.queries += times.iter().filter(|&&t| t > 0).count() as u64;
                let d2 = grid.for_each_point(
                    k1,
                    |j| times.get(j).is_some_and(|&t| t > 0),
                    |_, nb| nb.last().map_or(0.0, |x| x.0),
                )?;
                for (j, d2) in d2.iter().enumerate().take(mz) {
                    let times = times[j] as usize;
                    if times > 0 {
                        spacing_d.extend(std::iter::repeat_n(d2.sqrt(), times));
                    }
                }
            }
            drop(grid);
            drop((positions, index));
            self.done += m as u64;
            (self.progress)(Stage::Halos, self.done);
        }
        Ok(largest)
    }

    fn flush_halos(
        &self,
        buffered: &mut HashMap<usize, Vec<u8>>,
        halos: &mut [Option<SpillWriter>],
    ) -> Result<()> {
        // Every chunk's halo file stays open until step (c) reaches it, so each writer's buffer
        // is one record: a 1 MiB buffer each held 1.2 GiB at 10^9 points (1,426 chunks) beside
        // the chunk, over the memory limit. Each chunk's records go to its file whole.
        let len = self.store.layout.len();
        for (c, bytes) in buffered.drain() {
            let w = match &mut halos[c] {
                Some(w) => w,
                None => halos[c].insert(
                    self.store
                        .scratch
                        .create_buffered(len, len)
                        .map_err(|e| self.store.io(e))?,
                ),
            };
            w.push_all(&bytes).map_err(|e| self.store.io(e))?;
            w.flush().map_err(|e| self.store.io(e))?;
        }
        Ok(())
    }
}

/// How often each of the points of global indices `index` is among the sorted `picks`.
fn pick_times(picks: &[u64], index: &[u64]) -> Vec<u32> {
    index
        .iter()
        .map(|&g| {
            let from = picks.partition_point(|&x| x < g);
            picks[from..].iter().take_while(|&&x| x == g).count() as u32
        })
        .collect()
}

/// Squared distance from `p` to the box `(lo, hi)`.
fn box_dist2(p: DVec3, (lo, hi): (DVec3, DVec3)) -> f64 {
    let d = (lo - p).max(DVec3::ZERO).max(p - hi);
    d.length_squared()
}

fn kd_tree(entries: &[[f64; 3]]) -> Result<ImmutableKdTree<f64, 3>> {
    ImmutableKdTree::<f64, 3>::new_from_slice(entries).map_err(|e| Error::InvalidParameter {
        name: "positions",
        reason: format!("cannot build a k-d tree: {e:?}"),
    })
}
