//! Step 5 of the out-of-core build: each bin loaded, its points put back in input order, each
//! chunk built in memory, its nodes quantised on the global grid and numbered as in the whole
//! arena, and its sibling groups sorted as [`crate::list::SequentialList::new`] sorts them
//! (e_g² descending, then arena index, [`key_order`]) into a run file; the top nodes made
//! from the chunks' roots by [`hierarchy::parent_of_kids`].

use std::cmp::Ordering;

use cloud::glam::{DVec3, Vec3};
use cloud::spill::SpillFile;
use rayon::prelude::*;

use super::plan::{LoadedBin, Top};
use super::{Builder, Stage, internal};
use crate::Result;
use crate::file;
use crate::hierarchy::{self, Node};
use crate::list::{Entry, Grid, QBox};

impl Builder {
    /// Builds every chunk and top node in arena order, writing the sorted runs.
    pub(super) fn build_runs(
        &self,
        tops: &[Top],
        chunks: &[(usize, u32)],
        bin_files: Vec<SpillFile>,
        origin: DVec3,
        grid: &Grid,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<Runs> {
        progress(Stage::Build, 0);
        let mut runs = Runs::default();
        let mut batch = Batch::default();
        // Per top: its node (children cleared), box and error, arena index.
        let mut made: Vec<Option<(Node, QBox, f32, u64)>> = vec![None; tops.len()];
        let mut counter = 0u64;
        let mut bin_files: Vec<Option<SpillFile>> = bin_files.into_iter().map(Some).collect();
        // The bin in memory: its number, its points, the next chunk's first point.
        let mut loaded: Option<LoadedBin> = None;
        let mut chunk_id = 0usize;
        let mut done = 0u64;
        for (t, top) in tops.iter().enumerate() {
            match top {
                Top::Chunk {
                    center,
                    half,
                    budget,
                    count,
                } => {
                    let bin = chunks[chunk_id].1;
                    if loaded.as_ref().is_none_or(|l| l.0 != bin) {
                        if loaded.is_some() {
                            self.write_run(&mut batch, &mut runs)?;
                        }
                        let file = bin_files[bin as usize]
                            .take()
                            .ok_or(internal("a bin loaded twice"))?;
                        let pts = self.load(&file, 0, file.len())?;
                        drop(file);
                        loaded = Some((bin, pts, 0));
                    }
                    let (_, pts, at) = loaded.as_mut().ok_or(internal("no bin"))?;
                    let m = *count as usize;
                    let mine = &pts[*at..*at + m];
                    if mine.iter().any(|(_, c)| *c as usize != chunk_id) {
                        return Err(internal("a chunk's points out of place"));
                    }
                    *at += m;
                    let positions: Vec<DVec3> = mine.par_iter().map(|(p, _)| p.position).collect();
                    let normals: Vec<Vec3> = mine.par_iter().map(|(p, _)| p.normal).collect();
                    let colors: Vec<[u8; 3]> = if self.opts.colors {
                        mine.par_iter().map(|(p, _)| p.color).collect()
                    } else {
                        Vec::new()
                    };
                    let input = hierarchy::Input {
                        positions: &positions,
                        normals: &normals,
                        colors: self.opts.colors.then_some(&colors[..]),
                        leaf_diameter: self.leaf_diameter,
                    };
                    let mut items: Vec<u32> = (0..m as u32).collect();
                    let nodes =
                        hierarchy::build_cell(&input, origin, &mut items, *center, *half, *budget);
                    drop(items);
                    let boxes: Vec<QBox> = nodes.par_iter().map(|n| grid.qbox(n)).collect();
                    let e2: Vec<f32> = nodes.par_iter().map(|n| grid.e2(n)).collect();
                    batch.chunk(&nodes, &boxes, &e2, counter, self.opts.colors, grid);
                    let last = nodes.len() - 1;
                    let mut root = nodes[last].clone();
                    root.children = Vec::new();
                    made[t] = Some((root, boxes[last], e2[last], counter + last as u64));
                    counter += nodes.len() as u64;
                    chunk_id += 1;
                    done += *count;
                    progress(Stage::Build, done);
                }
                Top::Inner { kids } => {
                    let kid_nodes: Vec<&(Node, QBox, f32, u64)> = kids
                        .iter()
                        .map(|&k| {
                            made[k]
                                .as_ref()
                                .ok_or(internal("a top node before its child"))
                        })
                        .collect::<Result<_>>()?;
                    let refs: Vec<&Node> = kid_nodes.iter().map(|k| &k.0).collect();
                    let children = kid_nodes.iter().map(|k| k.3 as u32).collect();
                    let node = hierarchy::parent_of_kids(&refs, children);
                    let (b, e) = (grid.qbox(&node), grid.e2(&node));
                    batch.group(b, e, counter, kids.len());
                    for k in &kid_nodes {
                        batch.entry(&k.1, k.2, &k.0, self.opts.colors, grid);
                    }
                    let mut node = node;
                    node.children = Vec::new();
                    made[t] = Some((node, b, e, counter));
                    counter += 1;
                }
            }
        }
        self.write_run(&mut batch, &mut runs)?;
        let root = made.pop().flatten().ok_or(internal("no root"))?;
        let mut bytes = Vec::with_capacity(ENTRY_REC);
        push_entry_rec(&mut bytes, &root.1, root.2, &root.0, self.opts.colors, grid);
        runs.root = (root.1, bytes);
        runs.nodes = counter;
        Ok(runs)
    }

    /// Sorts the batch's groups and writes them as a run.
    pub(super) fn write_run(&self, batch: &mut Batch, runs: &mut Runs) -> Result<()> {
        if batch.groups.is_empty() {
            return Ok(());
        }
        // (The keys are distinct, arena indices: any sort gives the one order.)
        batch
            .groups
            .par_sort_unstable_by(|a, b| key_order(a.e2, a.gid, b.e2, b.gid));
        let mut g = self.scratch.create(GREC).map_err(|e| self.io(e))?;
        let mut e = self.scratch.create(ENTRY_REC).map_err(|e| self.io(e))?;
        // The groups' records and their entries in the sorted order, gathered in parallel a
        // window of groups at a time (each piece's bytes in order), then written.
        let entries = &batch.entries;
        for window in batch.groups.chunks(RUN_WINDOW) {
            let pieces: Vec<(Vec<u8>, Vec<u8>)> = window
                .par_chunks(RUN_PIECE)
                .map(|groups| {
                    let mut g = Vec::with_capacity(groups.len() * GREC);
                    let mut e = Vec::new();
                    for gr in groups {
                        file::push_box(&mut g, &gr.b);
                        g.extend_from_slice(&gr.e2.to_le_bytes());
                        g.extend_from_slice(&gr.gid.to_le_bytes());
                        g.push(gr.count as u8);
                        let s = gr.first * ENTRY_REC;
                        e.extend_from_slice(&entries[s..s + gr.count * ENTRY_REC]);
                    }
                    (g, e)
                })
                .collect();
            for (gp, ep) in &pieces {
                g.push_all(gp).map_err(|e| self.io(e))?;
                e.push_all(ep).map_err(|e| self.io(e))?;
            }
        }
        runs.groups += batch.groups.len() as u64;
        runs.runs.push((
            g.finish().map_err(|e| self.io(e))?,
            e.finish().map_err(|e| self.io(e))?,
        ));
        batch.groups.clear();
        batch.entries.clear();
        batch.groups.shrink_to(1 << 16);
        batch.entries.shrink_to(1 << 20);
        Ok(())
    }
}

/// Groups whose records [`Builder::write_run`] gathers at once (about 2 MB of groups and up to
/// eight entries each), and a thread's piece of them.
const RUN_WINDOW: usize = 1 << 13;
const RUN_PIECE: usize = 1 << 10;

/// Bytes of a group in a run: box, e_g², arena index, entries.
pub(super) const GREC: usize = 12 + 4 + 8 + 1;
/// Bytes of an entry in a run: the file's entry, splat and colour.
pub(super) const ENTRY_REC: usize = file::ENTRY + file::SPLAT + file::COLOR;

pub(super) fn push_entry_rec(
    b: &mut Vec<u8>,
    q: &QBox,
    e2: f32,
    n: &Node,
    colors: bool,
    grid: &Grid,
) {
    file::push_entry(b, &Entry { b: *q, e2 });
    crate::pack::push_splat(b, n, q, grid);
    if colors {
        crate::pack::push_color(b, n);
    } else {
        b.extend_from_slice(&[0; file::COLOR]);
    }
}

/// The list's order: e_g² descending, then arena index ascending.
pub(super) fn key_order(ea: f32, ga: u64, eb: f32, gb: u64) -> Ordering {
    eb.total_cmp(&ea).then(ga.cmp(&gb))
}

pub(super) struct GroupRec {
    pub(super) b: QBox,
    pub(super) e2: f32,
    pub(super) gid: u64,
    pub(super) first: usize,
    pub(super) count: usize,
}

#[derive(Default)]
pub(super) struct Batch {
    pub(super) groups: Vec<GroupRec>,
    pub(super) entries: Vec<u8>,
}

impl Batch {
    pub(super) fn group(&mut self, b: QBox, e2: f32, gid: u64, count: usize) {
        self.groups.push(GroupRec {
            b,
            e2,
            gid,
            first: self.entries.len() / ENTRY_REC,
            count,
        });
    }

    pub(super) fn entry(&mut self, q: &QBox, e2: f32, n: &Node, colors: bool, grid: &Grid) {
        push_entry_rec(&mut self.entries, q, e2, n, colors, grid);
    }

    /// A chunk's groups (its nodes with children, in arena order, numbered from `counter`)
    /// and their entries, as [`Batch::group`] and [`Batch::entry`] one by one would add them;
    /// the entries encoded in parallel, each group's into its own place.
    pub(super) fn chunk(
        &mut self,
        nodes: &[Node],
        boxes: &[QBox],
        e2: &[f32],
        counter: u64,
        colors: bool,
        grid: &Grid,
    ) {
        let start = self.entries.len();
        let first_group = self.groups.len();
        let mut at = start / ENTRY_REC;
        for (i, node) in nodes.iter().enumerate() {
            if !node.children.is_empty() {
                self.groups.push(GroupRec {
                    b: boxes[i],
                    e2: e2[i],
                    gid: counter + i as u64,
                    first: at,
                    count: node.children.len(),
                });
                at += node.children.len();
            }
        }
        self.entries.resize(at * ENTRY_REC, 0);
        // Each group's entries, a slice of its own.
        let mut parts: Vec<(&Node, &mut [u8])> =
            Vec::with_capacity(self.groups.len() - first_group);
        let mut rest = &mut self.entries[start..];
        for node in nodes.iter().filter(|n| !n.children.is_empty()) {
            let (head, tail) = rest.split_at_mut(node.children.len() * ENTRY_REC);
            parts.push((node, head));
            rest = tail;
        }
        parts.into_par_iter().with_min_len(256).for_each_init(
            || Vec::with_capacity(ENTRY_REC),
            |rec, (node, out)| {
                for (&k, slot) in node.children.iter().zip(out.chunks_exact_mut(ENTRY_REC)) {
                    let k = k as usize;
                    rec.clear();
                    push_entry_rec(rec, &boxes[k], e2[k], &nodes[k], colors, grid);
                    slot.copy_from_slice(rec);
                }
            },
        );
    }
}

#[derive(Default)]
pub(super) struct Runs {
    pub(super) runs: Vec<(SpillFile, SpillFile)>,
    pub(super) groups: u64,
    pub(super) nodes: u64,
    pub(super) root: (QBox, Vec<u8>),
}
