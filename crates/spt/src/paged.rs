//! A sequential point tree cut from its file ([`crate::file`]) without loading it: the list is
//! sorted so that a view needs only a prefix of it (Dachsbacher et al. 2003, §4: "only a
//! prefix of the list has to be processed"), so a cut reads the groups and entries of that
//! prefix in blocks, scans each block as [`crate::list::SequentialList`] scans (the same test,
//! [`crate::list::scan_block`]) and keeps nothing of it, then reads the splats of the entries
//! it selected. Memory: one block and the selection, whatever the file's size.
//!
//! Every read covers whole checksummed blocks ([`crate::file::BLOCK_ITEMS`] items) and checks
//! each against its checksum before using it ([`Error::Checksum`] names the block and its
//! bytes): a flipped byte that leaves values finite and in range is caught so.
//!
//! The header is checked when the file is opened ([`crate::file::parse_header`], its checksum
//! included); every group
//! and entry is checked as it is read (the groups tile the entries in order, one to eight
//! each, errors sorted and finite, boxes ordered) and every splat read has a finite radius; a
//! damaged file is [`Error::Corrupt`] with its byte offset.

use std::path::Path;

use cloud::glam::{DVec3, Vec3};
use cloud::lod_file::FileReader;

use crate::file::{self, Header};
use crate::list::{Entry, Group, QBox, dist2, scan_block};
use crate::{CutStats, Splat, check};
use crate::{Error, Result};

/// Groups read at a time (a multiple of [`file::BLOCK_ITEMS`]).
pub const BLOCK_GROUPS: usize = 1 << 14;
const _: () = assert!(BLOCK_GROUPS.is_multiple_of(file::BLOCK_ITEMS));

/// An open tree file.
#[derive(Debug)]
pub struct PagedTree {
    file: FileReader,
    header: Header,
    sections: [u64; 4],
    groups: Vec<Group>,
    entries: Vec<Entry>,
    raw: Vec<u8>,
}

impl PagedTree {
    /// Opens the file at `path` and checks its header.
    pub fn open(path: &Path) -> Result<Self> {
        let mut file = FileReader::open(path)?;
        let head = file.head(file::HEADER)?;
        let header = file::parse_header(&head, file.len(), file.path())?;
        Ok(Self {
            file,
            sections: header.sections(),
            header,
            groups: Vec::new(),
            entries: Vec::new(),
            raw: Vec::new(),
        })
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    fn corrupt(&self, offset: u64, reason: String) -> Error {
        Error::Corrupt {
            format: file::FORMAT,
            path: self.file.path().to_owned(),
            offset,
            reason,
        }
    }

    /// Bytes read from the file so far (header included).
    pub fn bytes_read(&self) -> u64 {
        self.file.bytes_read()
    }

    fn read_at(&mut self, at: u64, len: usize) -> Result<()> {
        self.raw.resize(len, 0);
        self.file.read_at(&mut self.raw, at)
    }

    /// Reads items `from..to` of section `section` (0 groups, 1 entries, 2 splats, 3 colours)
    /// into `self.raw`: the whole blocks that hold them are read and checked against their
    /// checksums.
    fn read_items(&mut self, section: usize, from: usize, to: usize) -> Result<()> {
        let size = [file::GROUP, file::ENTRY, file::SPLAT, file::COLOR][section];
        self.raw.clear();
        if from >= to {
            return Ok(());
        }
        let (b0, b1) = (from / file::BLOCK_ITEMS, (to - 1) / file::BLOCK_ITEMS + 1);
        if b1 as u64 > self.header.blocks()[section] {
            return Err(self.corrupt(
                self.sections[section] + (from * size) as u64,
                format!("items {from}..{to} past the end of their section"),
            ));
        }
        let (start, _) = self.header.block_range(section, b0 as u64);
        let (_, end) = self.header.block_range(section, b1 as u64 - 1);
        self.read_at(self.header.sum_offset(section, b0 as u64), 4 * (b1 - b0))?;
        let sums = std::mem::take(&mut self.raw);
        self.read_at(start, (end - start) as usize)?;
        self.header
            .check_blocks(section, b0 as u64, &self.raw, &sums, self.file.path())?;
        self.raw.drain(..(from - b0 * file::BLOCK_ITEMS) * size);
        self.raw.truncate((to - from) * size);
        Ok(())
    }

    /// Reads groups `from..from + k` into `self.groups`, checked.
    fn read_groups(&mut self, from: usize, k: usize, prev: Option<(f32, u32)>) -> Result<()> {
        let at = self.sections[0] + (from * file::GROUP) as u64;
        self.read_items(0, from, from + k)?;
        self.groups.clear();
        let (mut last_e2, mut next) = prev.unwrap_or((f32::INFINITY, 0));
        for j in 0..k {
            let r = &self.raw[j * file::GROUP..(j + 1) * file::GROUP];
            let g = Group {
                b: file::box_of(r),
                e2: f32::from_le_bytes([r[12], r[13], r[14], r[15]]),
                start: u32::from_le_bytes([r[16], r[17], r[18], r[19]]),
                end: u32::from_le_bytes([r[20], r[21], r[22], r[23]]),
            };
            let i = from + j;
            let size = g.end.wrapping_sub(g.start);
            let bad = g.start != next
                || g.end < g.start
                || u64::from(g.end) > self.header.entries
                || !ordered(&g.b)
                || if i == 0 {
                    size != 1 || g.e2 != f32::INFINITY
                } else {
                    !((1..=8).contains(&size) && g.e2 >= 0.0 && g.e2.is_finite())
                        || (i > 1 && g.e2 > last_e2)
                };
            if bad {
                return Err(self.corrupt(
                    at + (j * file::GROUP) as u64,
                    format!(
                        "group {i} (entries {}..{}, error {}) is not in order",
                        g.start, g.end, g.e2
                    ),
                ));
            }
            if i > 0 {
                last_e2 = g.e2;
            }
            next = g.end;
            self.groups.push(g);
        }
        if from + k == self.header.groups as usize && u64::from(next) != self.header.entries {
            return Err(self.corrupt(
                self.sections[0],
                format!("the groups cover {next} of {} entries", self.header.entries),
            ));
        }
        Ok(())
    }

    /// Reads entries `from..to` into `self.entries`, checked.
    fn read_entries(&mut self, from: usize, to: usize) -> Result<()> {
        let at = self.sections[1] + (from * file::ENTRY) as u64;
        self.read_items(1, from, to)?;
        self.entries.clear();
        for j in 0..to - from {
            let r = &self.raw[j * file::ENTRY..(j + 1) * file::ENTRY];
            let e = Entry {
                b: file::box_of(r),
                e2: f32::from_le_bytes([r[12], r[13], r[14], r[15]]),
            };
            if !(ordered(&e.b) && e.e2 >= 0.0 && e.e2.is_finite()) {
                return Err(self.corrupt(
                    at + (j * file::ENTRY) as u64,
                    format!("entry {}: box not ordered or error not finite", from + j),
                ));
            }
            self.entries.push(e);
        }
        Ok(())
    }

    /// The sequential cut for an eye and a threshold ε (radians), as [`crate::Spt::cut_into`]:
    /// the same entries, ascending, into `out` (cleared first); the prefix is read from the
    /// file block by block.
    pub fn cut_into(&mut self, eye: DVec3, epsilon: f64, out: &mut Vec<u32>) -> Result<CutStats> {
        let eps2 = check(eye, epsilon)?;
        out.clear();
        let eye = ((eye - self.header.grid_origin) / self.header.cell).as_vec3();
        let bound = dist2(&self.header.root, eye) * eps2;
        let total = self.header.groups as usize;
        let mut stats = CutStats::default();
        let mut from = 0usize;
        let mut prev = None;
        while from < total {
            let k = BLOCK_GROUPS.min(total - from);
            self.read_groups(from, k, prev)?;
            // The root's group is always scanned; after it, the prefix ends at the first group
            // whose parent cannot be refined anywhere on the object.
            let skip = usize::from(from == 0);
            let end = skip + self.groups[skip..].partition_point(|g| g.e2 > bound);
            let last = self.groups[k - 1];
            prev = Some((last.e2, last.end));
            let groups = std::mem::take(&mut self.groups);
            let scanned = &groups[..end];
            if let (Some(a), Some(b)) = (scanned.first(), scanned.last()) {
                let (s, e) = (a.start as usize, b.end as usize);
                self.read_entries(s, e)?;
                stats.groups += scanned.len();
                stats.entries = e;
                stats.tested += scan_block(scanned, &self.entries, s, eye, eps2, out);
            }
            self.groups = groups;
            if end < k {
                break;
            }
            from += k;
        }
        stats.selected = out.len();
        self.entries = Vec::new();
        self.groups = Vec::new();
        Ok(stats)
    }

    /// The splats of a cut's entries (ascending, as a cut gives them), read from the file a
    /// checksummed block at a time.
    pub fn splats(&mut self, entries: &[u32]) -> Result<Vec<Splat>> {
        let mut out = Vec::with_capacity(entries.len());
        let colors = self.header.colors;
        let not_ascending = || Error::InvalidParameter {
            name: "entries",
            reason: "not ascending entries of this tree".into(),
        };
        if entries.windows(2).any(|w| w[0] >= w[1]) {
            return Err(not_ascending());
        }
        let mut i = 0;
        while i < entries.len() {
            let a = entries[i] as usize;
            let mut j = i + 1;
            while j < entries.len()
                && entries[j] as usize / file::BLOCK_ITEMS == a / file::BLOCK_ITEMS
            {
                j += 1;
            }
            let b = entries[j - 1] as usize + 1;
            if b as u64 > self.header.entries {
                return Err(not_ascending());
            }
            let s0 = self.sections[2] + (a * file::SPLAT) as u64;
            // The entries' boxes: a splat's centre is stored within its entry's box.
            self.read_items(1, a, b)?;
            let boxes = std::mem::take(&mut self.raw);
            self.read_items(2, a, b)?;
            let raw = std::mem::take(&mut self.raw);
            let mut cols = Vec::new();
            if colors {
                self.read_items(3, a, b)?;
                cols = std::mem::take(&mut self.raw);
            }
            for &e in &entries[i..j] {
                let k = e as usize - a;
                let r = &raw[k * file::SPLAT..(k + 1) * file::SPLAT];
                let q = file::box_of(&boxes[k * file::ENTRY..(k + 1) * file::ENTRY]);
                let (center, radius, normal) =
                    crate::pack::splat_of(r, &q, self.header.grid_origin, self.header.cell);
                let color = if colors {
                    crate::pack::color_of(&cols[k * file::COLOR..(k + 1) * file::COLOR])
                } else {
                    Vec3::splat(0.75)
                };
                if !(ordered(&q) && radius >= 0.0 && radius.is_finite()) {
                    return Err(self.corrupt(
                        s0 + (k * file::SPLAT) as u64,
                        format!("splat {e}: radius not finite or its box not ordered"),
                    ));
                }
                out.push(Splat {
                    center,
                    radius: f64::from(radius),
                    normal,
                    color,
                });
            }
            self.raw = raw;
            i = j;
        }
        Ok(out)
    }

    /// Every leaf's splat (entries whose error is 0 and which are not refined: the leaves of the
    /// tree, as the cut at ε = 0 from inside the object gives them), `batch` at a time.
    pub fn leaves(&mut self, batch: usize, mut each: impl FnMut(&[Splat])) -> Result<u64> {
        // A cut with ε = 0 refines every inner node (d² · 0 < e_g² when e_g > 0) and draws
        // every node with e_g = 0: the leaves, and inner nodes of coincident points.
        let eye = self.header.grid_origin;
        let mut entries = Vec::new();
        self.cut_into(eye, 0.0, &mut entries)?;
        let mut n = 0;
        for part in entries.chunks(batch.max(1)) {
            let s = self.splats(part)?;
            n += s.len() as u64;
            each(&s);
        }
        Ok(n)
    }
}

fn ordered(q: &QBox) -> bool {
    (0..3).all(|k| q.lo[k] <= q.hi[k])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ooc::{Builder, Options, Point};
    use cloud::rng::{RngExt, seeded};

    fn tree_file(n: usize, colors: bool, dir: &Path) -> (crate::Spt, std::path::PathBuf) {
        let mut rng = seeded(3, "paged-spt");
        let dirs = cloud::synth::fibonacci_sphere(n);
        let pts: Vec<Point> = dirs
            .iter()
            .enumerate()
            .map(|(i, d)| Point {
                position: *d * (1.0 + 0.05 * (9.0 * d.x).sin()),
                normal: d.as_vec3(),
                color: [rng.random(), rng.random(), rng.random()],
                index: i as u64,
            })
            .collect();
        let spt = crate::ooc::in_memory(
            pts.iter().map(|p| p.position).collect(),
            pts.iter().map(|p| p.normal).collect(),
            colors.then(|| pts.iter().map(|p| p.color).collect()),
            0.01,
        )
        .unwrap();
        let out = dir.join(format!("t{colors}.spt"));
        let mut b = Builder::new(
            &Options {
                memory_limit: crate::ooc::RESERVE + 5_000 * crate::ooc::BYTES_PER_POINT,
                colors,
                fail_after_bytes: None,
            },
            &out,
        )
        .unwrap();
        b.push(&pts).unwrap();
        b.finish(0.01, &mut |_, _| {}).unwrap();
        (spt, out)
    }

    #[test]
    fn cuts_from_the_file_equal_the_tree() {
        let dir = tempfile::tempdir().unwrap();
        for colors in [true, false] {
            let (spt, path) = tree_file(40_000, colors, dir.path());
            let mut f = PagedTree::open(&path).unwrap();
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for eye in [
                DVec3::new(0.0, 0.0, 3.0),
                DVec3::new(20.0, 5.0, 1.0),
                DVec3::ZERO,
            ] {
                for eps in [0.0, 1e-4, 1e-3, 1e-2, 0.2] {
                    let sa = spt.cut_into(eye, eps, &mut a).unwrap();
                    let sb = f.cut_into(eye, eps, &mut b).unwrap();
                    assert_eq!(a, b, "{eye} {eps}");
                    assert_eq!(
                        (sa.groups, sa.entries, sa.tested, sa.selected),
                        (sb.groups, sb.entries, sb.tested, sb.selected)
                    );
                    let want = spt.file_splats(&a);
                    let got = f.splats(&b).unwrap();
                    assert_eq!(want, got);
                    // Within `pack`'s bounds of the tree's own splats.
                    for ((w, g), &e) in spt.splats(&a).iter().zip(&got).zip(&a) {
                        let q = spt.list.entries[e as usize].b;
                        let h = f.header();
                        for k in 0..3 {
                            let step = f64::from(q.hi[k] - q.lo[k]) * h.cell / 65_535.0;
                            let err = (w.center[k] - g.center[k]).abs();
                            let f32_rounding = (w.center[k] - h.local[k]).abs() * 1.2e-7;
                            assert!(err <= step / 2.0 + f32_rounding, "{e} {k}: {err} {step}");
                        }
                        assert_eq!(w.radius, g.radius);
                        let angle = w
                            .normal
                            .cross(g.normal)
                            .length()
                            .atan2(w.normal.dot(g.normal));
                        assert!(angle <= crate::pack::NORMAL_MAX_ERROR, "{e}: {angle}");
                        if colors {
                            let d = (w.color - g.color).abs().max_element();
                            assert!(d <= 1.0 / 510.0 + 1e-6, "{e}: {d}");
                        }
                    }
                }
            }
            let mut leaves = 0;
            f.leaves(1000, |s| leaves += s.len()).unwrap();
            assert_eq!(leaves, 40_000);
        }
    }

    #[test]
    fn a_far_view_reads_a_small_prefix() {
        let dir = tempfile::tempdir().unwrap();
        let (_, path) = tree_file(100_000, true, dir.path());
        let len = std::fs::metadata(&path).unwrap().len();
        let mut f = PagedTree::open(&path).unwrap();
        let mut out = Vec::new();
        f.cut_into(DVec3::new(0.0, 0.0, 60.0), 1e-3, &mut out)
            .unwrap();
        f.splats(&out).unwrap();
        assert!(f.bytes_read() * 10 < len, "{} of {len}", f.bytes_read());
    }

    #[test]
    fn a_flipped_byte_anywhere_fails_a_checksum_in_both_readers() {
        let dir = tempfile::tempdir().unwrap();
        let (_, path) = tree_file(40_000, true, dir.path());
        let bytes = std::fs::read(&path).unwrap();
        let h = file::verify(&path).unwrap();
        let blocks = h.blocks();
        assert!(blocks.iter().all(|&b| b >= 3), "{blocks:?}");
        let mid = |section: usize| {
            let (a, b) = h.block_range(section, blocks[section] / 2);
            ((a + b) / 2, format!("block {}", blocks[section] / 2))
        };
        let bad = dir.path().join("bad.spt");
        // (byte, the block named)
        let mut cases = vec![(40, "the header".to_string())];
        for (section, name) in ["group", "entry", "splat", "colour"].iter().enumerate() {
            let (at, block) = mid(section);
            cases.push((at, format!("{name} {block}")));
        }
        cases.push((
            h.sums_offset() - 1,
            format!("colour block {}", blocks[3] - 1),
        ));
        // A damaged checksum fails its block's check (here the first entry block's).
        cases.push((h.sum_offset(1, 0) + 2, "entry block 0".into()));
        for (at, block) in cases {
            let mut d = bytes.clone();
            d[at as usize] ^= 0x20;
            std::fs::write(&bad, &d).unwrap();
            let whole = file::verify(&bad).unwrap_err();
            let paged = PagedTree::open(&bad)
                .and_then(|mut f| f.leaves(1 << 20, |_| {}))
                .unwrap_err();
            for e in [&whole, &paged] {
                let Error::Checksum {
                    path: p,
                    block: b,
                    offset,
                    end,
                } = e
                else {
                    panic!("byte {at}: {e}");
                };
                assert!(p.ends_with("bad.spt") && *b == block, "byte {at}: {e}");
                if at < h.sums_offset() {
                    assert!((*offset..*end).contains(&at), "byte {at}: {e}");
                }
                assert!(e.to_string().contains("rebuild it"), "{e}");
            }
        }
    }

    #[test]
    fn files_of_versions_1_and_2_are_refused_with_rebuild_it() {
        let dir = tempfile::tempdir().unwrap();
        let (_, path) = tree_file(2_000, false, dir.path());
        for version in [1u32, 2] {
            let mut b = std::fs::read(&path).unwrap();
            b[8..12].copy_from_slice(&version.to_le_bytes());
            let old = dir.path().join("old.spt");
            std::fs::write(&old, &b).unwrap();
            for e in [
                file::verify(&old).unwrap_err(),
                PagedTree::open(&old).unwrap_err(),
            ] {
                assert!(
                    matches!(e, Error::OldVersion { version: v, current: 3, .. } if v == version),
                    "{e}"
                );
                let m = e.to_string();
                assert!(
                    m.contains("old.spt")
                        && m.contains("older pointsight")
                        && m.contains("rebuild it with `pointsight lod-build`"),
                    "{m}"
                );
            }
        }
        // A version from the future is a damaged file, not an old one.
        let mut b = std::fs::read(&path).unwrap();
        b[8..12].copy_from_slice(&4u32.to_le_bytes());
        let new = dir.path().join("new.spt");
        std::fs::write(&new, &b).unwrap();
        assert!(matches!(PagedTree::open(&new), Err(Error::Corrupt { .. })));
    }

    #[test]
    fn damaged_files_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        let (_, path) = tree_file(8_000, true, dir.path());
        let bytes = std::fs::read(&path).unwrap();
        let bad = dir.path().join("bad.spt");
        std::fs::write(&bad, &bytes[..bytes.len() - 3]).unwrap();
        assert!(matches!(PagedTree::open(&bad), Err(Error::Corrupt { .. })));
        let mut rng = seeded(4, "damage");
        let mut caught = 0;
        let sums = file::check(&bytes, "t").unwrap().sums_offset() as usize;
        for trial in 0..200 {
            let mut d = bytes.clone();
            for _ in 0..6 {
                let at = rng.random_range(file::HEADER..sums);
                d[at] = rng.random();
            }
            // Half the trials past the checksums, to reach the checks of values.
            if trial % 2 == 0 {
                file::reseal(&mut d, true);
            }
            std::fs::write(&bad, &d).unwrap();
            let mut f = PagedTree::open(&bad).unwrap();
            let mut out = Vec::new();
            let r = f
                .cut_into(DVec3::new(0.0, 0.0, 3.0), 0.0, &mut out)
                .and_then(|_| f.splats(&out));
            caught += usize::from(r.is_err());
        }
        assert!(caught > 0);
    }
}
