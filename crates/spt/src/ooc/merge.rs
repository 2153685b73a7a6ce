//! Step 6 of the out-of-core build: the sorted runs merged (a heap of their heads, in the
//! list's order) into the file, written through `cloud::io::atomic` (whole or not at all), its
//! four sections at once.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use cloud::glam::DVec3;
use cloud::io::checksum::Summed;
use cloud::spill::SpillReader;

use super::runs::{ENTRY_REC, GREC, Runs, key_order};
use super::{Builder, SMALL_BUFFER, Stage, internal};
use crate::file::{self, Header};
use crate::list::{Grid, Group, QBox};
use crate::{Error, Result};

/// Bytes of each section writer's buffer, so of each write. ext4 gives a write a page-cache
/// folio as large as the write. On the 2-core VMs this project is measured on (free memory
/// handed back to the host in 8 MiB blocks), large folios were slow to get and 4 KiB ones
/// not (no compaction was counted either way; the large blocks the host took back are the
/// likely cause): at 10^7 points, 4 KiB writes took the merge from 2.5 to 4.4 s down to 1.3
/// to 1.9 s (4 alternated pairs). When large folios came cheap, the 4 KiB writes cost about
/// 0.35 s more (1.1 s against 1.5 s, 4 pairs on the same VM later).
const OUT_BUFFER: usize = 4 << 10;

impl Builder {
    /// Merges the runs into the file.
    pub(super) fn merge(
        &self,
        runs: Runs,
        n: u64,
        origin: DVec3,
        grid: &Grid,
        progress: &mut dyn FnMut(Stage, u64),
    ) -> Result<()> {
        let header = Header {
            colors: self.opts.colors,
            points: n,
            groups: runs.groups + 1,
            entries: runs.nodes,
            local: origin,
            grid_origin: grid.origin,
            cell: grid.cell,
            leaf_diameter: self.leaf_diameter,
            root: runs.root.0,
        };
        let sections = header.sections();
        let out = self.out.clone();
        let colors = self.opts.colors;
        let fill = |partial: &Path| -> Result<()> {
            let io = |source| Error::Io {
                path: out.display().to_string(),
                source,
            };
            let open = |at: u64| -> io::Result<BufWriter<File>> {
                let mut f = File::options().write(true).open(partial)?;
                f.seek(SeekFrom::Start(at))?;
                Ok(BufWriter::with_capacity(OUT_BUFFER, f))
            };
            // Each section summed in blocks of file::BLOCK_ITEMS items (file's layout).
            let summed = |at: u64, item: usize| -> io::Result<Summed<BufWriter<File>>> {
                Ok(Summed::new(open(at)?, file::BLOCK_ITEMS * item))
            };
            File::create(partial).map_err(io)?;
            let mut head = open(0).map_err(io)?;
            head.write_all(&header.to_bytes()).map_err(io)?;
            let mut gw = Summed::new(head, file::BLOCK_ITEMS * file::GROUP);
            let mut ew = summed(sections[1], file::ENTRY).map_err(io)?;
            let mut sw = summed(sections[2], file::SPLAT).map_err(io)?;
            let mut cw = if colors {
                Some(summed(sections[3], file::COLOR).map_err(io)?)
            } else {
                None
            };
            let mut bytes = Vec::with_capacity(file::GROUP);
            let put_entry = |rec: &[u8],
                             ew: &mut Summed<BufWriter<File>>,
                             sw: &mut Summed<BufWriter<File>>,
                             cw: &mut Option<Summed<BufWriter<File>>>|
             -> io::Result<()> {
                ew.write_all(&rec[..file::ENTRY])?;
                sw.write_all(&rec[file::ENTRY..file::ENTRY + file::SPLAT])?;
                if let Some(c) = cw {
                    c.write_all(&rec[file::ENTRY + file::SPLAT..])?;
                }
                Ok(())
            };
            file::push_group(
                &mut bytes,
                &Group {
                    b: runs.root.0,
                    e2: f32::INFINITY,
                    start: 0,
                    end: 1,
                },
            );
            gw.write_all(&bytes).map_err(io)?;
            put_entry(&runs.root.1, &mut ew, &mut sw, &mut cw).map_err(io)?;
            let mut next_entry = 1u32;
            let mut heads = BinaryHeap::new();
            let mut readers: Vec<(SpillReader, SpillReader)> = Vec::with_capacity(runs.runs.len());
            let mut grec = [0u8; GREC];
            for (i, (g, e)) in runs.runs.iter().enumerate() {
                let mut gr = g.reader_buffered(0, g.len(), SMALL_BUFFER).map_err(io)?;
                let er = e.reader_buffered(0, e.len(), SMALL_BUFFER).map_err(io)?;
                if gr.next_into(&mut grec).map_err(io)? {
                    heads.push(Head::of(&grec, i));
                }
                readers.push((gr, er));
            }
            let mut erec = vec![0u8; ENTRY_REC];
            let mut written = 0u64;
            while let Some(h) = heads.pop() {
                let (gr, er) = &mut readers[h.run];
                bytes.clear();
                file::push_group(
                    &mut bytes,
                    &Group {
                        b: h.b,
                        e2: h.e2,
                        start: next_entry,
                        end: next_entry + u32::from(h.count),
                    },
                );
                gw.write_all(&bytes).map_err(io)?;
                for _ in 0..h.count {
                    if !er.next_into(&mut erec).map_err(io)? {
                        return Err(internal("a run's entries end early"));
                    }
                    put_entry(&erec, &mut ew, &mut sw, &mut cw).map_err(io)?;
                }
                next_entry += u32::from(h.count);
                if gr.next_into(&mut grec).map_err(io)? {
                    heads.push(Head::of(&grec, h.run));
                }
                written += 1;
                if written.is_multiple_of(1 << 20) {
                    progress(Stage::Merge, written);
                }
            }
            if u64::from(next_entry) != header.entries {
                return Err(internal("the runs' entries do not add up"));
            }
            let mut tail = open(header.sums_offset()).map_err(io)?;
            for w in [Some(gw), Some(ew), Some(sw), cw].into_iter().flatten() {
                let (w, sums) = w.finish();
                for s in sums {
                    tail.write_all(&s.to_le_bytes()).map_err(io)?;
                }
                w.into_inner()
                    .map_err(|e| io(e.into_error()))?
                    .sync_all()
                    .map_err(io)?;
            }
            tail.into_inner()
                .map_err(|e| io(e.into_error()))?
                .sync_all()
                .map_err(io)?;
            progress(Stage::Merge, written);
            Ok(())
        };
        cloud::io::atomic::write_via(&self.out, fill, |source| Error::Io {
            path: self.out.display().to_string(),
            source,
        })
    }
}

/// The head of a run in the merge (a max-heap: the first in the list's order on top).
pub(super) struct Head {
    pub(super) b: QBox,
    pub(super) e2: f32,
    pub(super) gid: u64,
    pub(super) count: u8,
    pub(super) run: usize,
}

impl Head {
    pub(super) fn of(r: &[u8; GREC], run: usize) -> Self {
        Self {
            b: file::box_of(r),
            e2: f32::from_le_bytes([r[12], r[13], r[14], r[15]]),
            gid: u64::from_le_bytes(r[16..24].try_into().unwrap_or([0; 8])),
            count: r[24],
            run,
        }
    }
}

impl PartialEq for Head {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Head {}
impl PartialOrd for Head {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Head {
    fn cmp(&self, other: &Self) -> Ordering {
        key_order(other.e2, other.gid, self.e2, self.gid)
    }
}
