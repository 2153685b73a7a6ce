//! Steps 2 to 4 of the out-of-core build: the octree's cells counted ([`REFINE`] levels a
//! pass below the cells that hold more points than a chunk), the top of the tree planned as
//! [`hierarchy::build_cell`] would recurse ([`plan`]), the chunks numbered ([`mark_chunks`])
//! and the points distributed to their bins' files.

use cloud::glam::{DVec3, Vec3};
use cloud::spill::SpillFile;

use super::record::DREC;
use super::{Builder, Input, NONE, Point, REFINE, SMALL_BUFFER, Stage, Tally, internal};
use crate::hierarchy::{self, COLLAPSE};
use crate::{Error, Result};

/// A cell of the counted octree.
pub(super) struct Cell {
    pub(super) center: DVec3,
    pub(super) half: f64,
    pub(super) count: u64,
    /// Whether the children are known (all of the cell's points counted one level down).
    pub(super) counted: bool,
    pub(super) kids: [u32; 8],
    /// The chunk this cell is, if it is one.
    pub(super) chunk: u32,
}

impl Cell {
    pub(super) fn new(center: DVec3, half: f64) -> Self {
        Self {
            center,
            half,
            count: 0,
            counted: false,
            kids: [NONE; 8],
            chunk: NONE,
        }
    }
}

/// A bin in memory: its number, its points with their chunks, the next chunk's first point.
pub(super) type LoadedBin = (u32, Vec<(Point, u32)>, usize);

/// A planned node above or at the chunks, in arena order.
pub(super) enum Top {
    Chunk {
        center: DVec3,
        half: f64,
        budget: u32,
        count: u64,
    },
    Inner {
        kids: Vec<usize>,
    },
}

impl Builder {
    /// One counting pass: [`REFINE`] levels of counts below each of `targets`.
    /// With `tally`, every point is also added to it (the checks of prepared points).
    pub(super) fn count_pass(
        &self,
        input: &mut Input,
        cells: &mut Vec<Cell>,
        targets: &[u32],
        mut leaf_box: Option<(DVec3, f32, &mut (Vec3, Vec3))>,
        mut tally: Option<&mut Tally>,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<()> {
        let width = 1usize << (3 * REFINE);
        let mut slot = vec![NONE; cells.len()];
        for (t, &x) in targets.iter().enumerate() {
            slot[x as usize] = t as u32;
        }
        let mut counts = vec![vec![0u32; width]; targets.len()];
        progress(Stage::Count, 0);
        let mut seen = 0u64;
        self.for_each_point(input, false, |point| {
            if let Some(t) = tally.as_mut() {
                t.add(point)?;
            }
            let p = point.position;
            if let Some((origin, half, b)) = leaf_box.as_mut() {
                let c = (p - *origin).as_vec3();
                b.0 = b.0.min(c - *half);
                b.1 = b.1.max(c + *half);
            }
            let mut x = 0usize;
            loop {
                let cell = &cells[x];
                if slot[x] != NONE {
                    let (mut c, mut h) = (cell.center, cell.half);
                    let mut code = 0usize;
                    for _ in 0..REFINE {
                        let o = hierarchy::octant(p, c);
                        code = code * 8 + o;
                        c = hierarchy::octant_center(c, h, o);
                        h *= 0.5;
                    }
                    counts[slot[x] as usize][code] += 1;
                    break;
                }
                if !cell.counted {
                    break;
                }
                let k = cell.kids[hierarchy::octant(p, cell.center)];
                if k == NONE {
                    return Err(internal("a point outside the counted cells"));
                }
                x = k as usize;
            }
            seen += 1;
            if seen.is_multiple_of(1 << 20) {
                progress(Stage::Count, seen);
            }
            Ok(())
        })?;
        progress(Stage::Count, seen);
        for (t, &x) in targets.iter().enumerate() {
            for (code, &k) in counts[t].iter().enumerate() {
                if k == 0 {
                    continue;
                }
                let mut at = x as usize;
                for level in (0..REFINE).rev() {
                    let o = (code >> (3 * level)) & 7;
                    cells[at].counted = true;
                    let next = cells[at].kids[o];
                    at = if next == NONE {
                        let (c, h) = (cells[at].center, cells[at].half);
                        let id = cells.len() as u32;
                        cells.push(Cell::new(hierarchy::octant_center(c, h, o), 0.5 * h));
                        cells[at].kids[o] = id;
                        id as usize
                    } else {
                        next as usize
                    };
                    cells[at].count += u64::from(k);
                }
            }
        }
        Ok(())
    }

    /// Distributes the points to their bins' files (records tagged with their chunk).
    pub(super) fn distribute(
        &self,
        input: &mut Input,
        cells: &[Cell],
        chunks: &[(usize, u32)],
        bins: u32,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<Vec<SpillFile>> {
        let layout = self.drec;
        let mut writers = Vec::with_capacity(bins as usize);
        for _ in 0..bins {
            writers.push(
                self.scratch
                    .create_buffered(layout.len(), SMALL_BUFFER)
                    .map_err(|e| self.io(e))?,
            );
        }
        let mut buf = [0u8; DREC];
        let mut seen = 0u64;
        progress(Stage::Distribute, 0);
        self.for_each_point(input, true, |point| {
            let p = point.position;
            let mut x = 0usize;
            while cells[x].chunk == NONE {
                let k = cells[x].kids[hierarchy::octant(p, cells[x].center)];
                if k == NONE {
                    return Err(internal("a point outside the planned chunks"));
                }
                x = k as usize;
            }
            let c = cells[x].chunk;
            layout.pack(point, c, &mut buf).ok_or_else(|| {
                internal(&format!(
                    "point {} at {} is off the prepared points' grid or its index too large",
                    point.index, point.position
                ))
            })?;
            let bin = chunks[c as usize].1 as usize;
            writers[bin]
                .push(&buf[..layout.len()])
                .map_err(|e| self.io(e))?;
            seen += 1;
            if seen.is_multiple_of(1 << 20) {
                progress(Stage::Distribute, seen);
            }
            Ok(())
        })?;
        progress(Stage::Distribute, seen);
        writers
            .into_iter()
            .map(|w| w.finish().map_err(|e| self.io(e)))
            .collect()
    }
}

/// Plans the subtree of cell `x0` as [`hierarchy::build_cell`] recurses (see the module
/// documentation); cells whose children must be counted first go to `missing`.
pub(super) fn plan(
    cells: &[Cell],
    cap: u64,
    x0: usize,
    tops: &mut Vec<Top>,
    missing: &mut Vec<u32>,
) -> Result<Option<usize>> {
    let mut x = x0;
    let mut budget = COLLAPSE;
    loop {
        let cell = &cells[x];
        if cell.count <= cap {
            tops.push(Top::Chunk {
                center: cell.center,
                half: cell.half,
                budget,
                count: cell.count,
            });
            return Ok(Some(tops.len() - 1));
        }
        if !cell.counted {
            missing.push(x as u32);
            return Ok(None);
        }
        let kids: Vec<usize> = cell
            .kids
            .iter()
            .filter(|&&k| k != NONE)
            .map(|&k| k as usize)
            .collect();
        if kids.len() >= 2 {
            let mut planned = Vec::with_capacity(kids.len());
            for k in kids {
                if let Some(t) = plan(cells, cap, k, tops, missing)? {
                    planned.push(t);
                }
            }
            if !missing.is_empty() {
                return Ok(None);
            }
            tops.push(Top::Inner { kids: planned });
            return Ok(Some(tops.len() - 1));
        }
        budget -= 1;
        if budget == 0 || kids.is_empty() {
            return Err(Error::InvalidParameter {
                name: "memory_limit",
                reason: format!(
                    "{} points lie within a cell of {:e} (2^-64 of the cloud's cube): more \
                     coincident points than a chunk of {cap} holds; raise the limit",
                    cell.count,
                    2.0 * cell.half
                ),
            });
        }
        x = kids[0];
    }
}

/// Marks the chunk cells with their chunk numbers, in the order [`plan`] made them.
pub(super) fn mark_chunks(cells: &mut [Cell], cap: u64, x: usize, next: &mut u32) -> Result<()> {
    if cells[x].count <= cap {
        cells[x].chunk = *next;
        *next += 1;
        return Ok(());
    }
    let kids = cells[x].kids;
    for k in kids.into_iter().filter(|&k| k != NONE) {
        mark_chunks(cells, cap, k as usize, next)?;
    }
    Ok(())
}
