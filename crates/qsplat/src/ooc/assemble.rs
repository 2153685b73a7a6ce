//! Step 6 of QSplat's out-of-core build: the file assembled breadth first through
//! `cloud::io::atomic` (whole or not at all): each level is, left to right, the top nodes'
//! groups and the chunks' encoded segments of that level, their offsets moved to their place.

use std::io;
use std::path::Path;

use cloud::ooc::PartKind;

use super::Stage;
use super::encode::{Builder, Encoded, WREC};
use crate::file::PAGE_WORDS;
use crate::tree;
use crate::{Error, Result};
use cloud::io::checksum::Summed;

impl Builder<'_> {
    /// Writes the file: breadth first, each level the top groups and chunk segments in order.
    pub(super) fn assemble(&mut self, root: usize, root_word: u32, out: &Path) -> Result<()> {
        #[derive(Clone, Copy)]
        enum Entry {
            Top(usize),
            Chunk(usize, usize),
        }
        let chunk_levels = |c: &Encoded| c.level_starts.len().saturating_sub(1);
        // The entries that start groups at the next level, in order.
        let children = |e: Entry| -> Vec<Entry> {
            match e {
                Entry::Top(p) => match &self.chunks.parts()[p].kind {
                    PartKind::Inner(kids) => {
                        kids.iter()
                            .filter_map(|&k| match self.chunks.parts()[k].kind {
                                PartKind::Inner(_) => Some(Entry::Top(k)),
                                PartKind::Chunk(c) => (chunk_levels(&self.encoded[c]) > 0)
                                    .then_some(Entry::Chunk(c, 0)),
                            })
                            .collect()
                    }
                    PartKind::Chunk(_) => Vec::new(),
                },
                Entry::Chunk(c, d) => {
                    if d + 1 < chunk_levels(&self.encoded[c]) {
                        vec![Entry::Chunk(c, d + 1)]
                    } else {
                        Vec::new()
                    }
                }
            }
        };
        let mut levels: Vec<Vec<Entry>> = vec![vec![Entry::Top(root)]];
        loop {
            let next: Vec<Entry> = levels
                .last()
                .into_iter()
                .flatten()
                .flat_map(|&e| children(e))
                .collect();
            if next.is_empty() {
                break;
            }
            levels.push(next);
        }
        let size = |e: Entry| -> usize {
            match e {
                Entry::Top(p) => match &self.chunks.parts()[p].kind {
                    PartKind::Inner(kids) => kids.len() + usize::from(self.grand(p)),
                    PartKind::Chunk(_) => 0,
                },
                Entry::Chunk(c, d) => {
                    let s = &self.encoded[c].level_starts;
                    s[d + 1] - s[d]
                }
            }
        };
        let mut starts: Vec<Vec<usize>> = Vec::with_capacity(levels.len());
        let mut total = 0usize;
        for l in &levels {
            starts.push(
                l.iter()
                    .map(|&e| {
                        let s = total;
                        total += size(e);
                        s
                    })
                    .collect(),
            );
        }
        if total > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                reason: format!("{total} words; offsets are 32-bit"),
            });
        }
        // Each entry's first child entry's start in the next level.
        let mut child_start: Vec<Vec<Option<usize>>> = Vec::with_capacity(levels.len());
        for (l, level) in levels.iter().enumerate() {
            let mut seen = 0usize;
            child_start.push(
                level
                    .iter()
                    .map(|&e| {
                        let n = children(e).len();
                        let s = (n > 0).then(|| starts[l + 1][seen]);
                        seen += n;
                        s
                    })
                    .collect(),
            );
        }
        let root_node = self.nodes[root].clone();
        let colors = self.opts.colors;
        let me = &*self;
        let mut written_levels = 0u64;
        let result = cloud::io::atomic::write_with(out, |o| {
            use std::io::Write;
            let head = crate::file::header_bytes(
                colors,
                u64::from(root_node.leaves),
                total as u64,
                root_node.center,
                root_node.radius,
                root_word,
            );
            o.write_all(&head)?;
            let root_color = tree::node_color(&root_node).to_le_bytes();
            // Each sweep's page checksums (crate::file's layout).
            let mut sums: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
            // Words first, then (after the root's) the colours: two sweeps.
            for sweep in 0..1 + usize::from(colors) {
                let want_color = sweep == 1;
                if want_color {
                    o.write_all(&root_color)?;
                }
                let mut o = Summed::new(&mut *o, PAGE_WORDS * if want_color { 2 } else { 4 });
                for (l, level) in levels.iter().enumerate() {
                    for (g, &e) in level.iter().enumerate() {
                        match e {
                            Entry::Top(p) => {
                                let PartKind::Inner(kids) = &me.chunks.parts()[p].kind else {
                                    continue;
                                };
                                if me.grand(p) {
                                    let s = child_start[l][g].ok_or_else(|| {
                                        io::Error::other("a top group lost its children")
                                    })?;
                                    if want_color {
                                        o.write_all(&0u16.to_le_bytes())?;
                                    } else {
                                        o.write_all(&(s as u32).to_le_bytes())?;
                                    }
                                }
                                for &k in kids {
                                    let (w, c) = me.child_word(k);
                                    if want_color {
                                        o.write_all(&c.to_le_bytes())?;
                                    } else {
                                        o.write_all(&w.to_le_bytes())?;
                                    }
                                }
                            }
                            Entry::Chunk(c, d) => {
                                let chunk = &me.encoded[c];
                                let s = &chunk.level_starts;
                                let Some(file) = &chunk.file else {
                                    return Err(io::Error::other("chunk not encoded"));
                                };
                                let mut r = file.reader(s[d] as u64, (s[d + 1] - s[d]) as u64)?;
                                // Offsets point into the chunk's words: its next level moves
                                // to the start of its next entry.
                                let shift = child_start[l][g].map(|n| n as i64 - s[d + 1] as i64);
                                let mut rec = [0u8; WREC];
                                while r.next_into(&mut rec)? {
                                    if want_color {
                                        o.write_all(&rec[4..6])?;
                                        continue;
                                    }
                                    let mut w =
                                        u32::from_le_bytes([rec[0], rec[1], rec[2], rec[3]]);
                                    if rec[6] == 1 {
                                        let shift = shift.ok_or_else(|| {
                                            io::Error::other("offset word without a next level")
                                        })?;
                                        w = u32::try_from(i64::from(w) + shift).map_err(|_| {
                                            io::Error::other("offset beyond 32 bits")
                                        })?;
                                    }
                                    o.write_all(&w.to_le_bytes())?;
                                }
                            }
                        }
                    }
                    written_levels += 1;
                }
                sums[sweep] = o.finish().1;
            }
            o.write_all(&crate::file::trailer(
                &head,
                if colors { &root_color } else { &[] },
                &sums[0],
                &sums[1],
            ))?;
            Ok(written_levels)
        });
        match result {
            Ok(levels) => {
                (self.progress)(Stage::Write, levels);
                Ok(())
            }
            Err(source) => Err(Error::Io {
                path: out.display().to_string(),
                source,
            }),
        }
    }
}
