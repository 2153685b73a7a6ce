//! A built file read on demand: selection from a tree that is not loaded (the `lod_file`
//! method), so that memory follows what a view draws, not the file's size.
//!
//! [`PagedTree::open`] reads and checks the header ([`crate::file`]'s layout: the magic, the
//! version, the counts against the file's length), the root's colour and the table of page
//! checksums, and checks the header's checksum over them; each page read later is checked
//! against its checksum ([`Error::Checksum`] naming the page and its bytes). Words and colours are then read in
//! pages of [`PAGE_WORDS`] words through a cache of at most the given bytes, evicted first in,
//! first out; the file is breadth first, so the children of neighbouring nodes share pages and
//! a view's cut touches few of them. The traversal ([`crate::traverse::traverse_nodes`],
//! [`crate::traverse::leaves`]) is the in-memory one on this source: the same splats, bit for
//! bit (a test compares).
//!
//! Deviation from the "memory-mapped": positional reads (`pread`) into the cache
//! instead, because mapping a file needs `unsafe`, which the workspace denies; the operating
//! system's page cache still keeps hot pages, and the process's own memory stays bounded by
//! the cache.
//!
//! Trust: the structure is not validated up front (that would read the whole file). The
//! checksums catch damage done after the file was written; beyond them, every
//! word is checked as the traversal decodes it (tree bits, sphere index, offsets inside the
//! file and after their group, at most one visit per word), and a failure is
//! [`Error::Corrupt`] with the byte offset.

use std::collections::VecDeque;
use std::path::Path;

use cloud::lod_file::FileReader;

use crate::file::{self, Header};
use crate::traverse::{Nodes, Root};
use crate::{Error, Result};

/// Words per page (64 KiB of words; a colour page holds as many colours, 32 KiB): the unit a
/// checksum covers.
pub const PAGE_WORDS: usize = file::PAGE_WORDS;
/// The smallest cache (two word pages and two colour pages).
pub const MIN_CACHE: u64 = 2 * (4 + 2) * PAGE_WORDS as u64;

/// A QSplat file opened for selection.
#[derive(Debug)]
pub struct PagedTree {
    file: FileReader,
    header: Header,
    root_color: u16,
    /// The page checksums (word pages, then colour pages).
    sums: Vec<u32>,
    cache: Cache,
    /// Pages read from the file so far.
    pub pages_read: u64,
}

/// Cached pages, first in, first out, indexed by page number (a file of 10^9 points has
/// about 10^5 pages: the index is small beside the pages).
#[derive(Debug)]
struct Cache {
    words: Vec<Option<Vec<u32>>>,
    colors: Vec<Option<Vec<u16>>>,
    /// (is a colour page, page) in the order they were read.
    order: VecDeque<(bool, usize)>,
    bytes: u64,
    limit: u64,
}

impl PagedTree {
    /// Opens `path`, keeping at most `cache_bytes` of pages (at least [`MIN_CACHE`]).
    pub fn open(path: &Path, cache_bytes: u64) -> Result<Self> {
        let mut file = FileReader::open(path)?;
        let len = file.len();
        let head = file.head(file::HEADER_BYTES)?;
        let header = file::parse_header(&head, len, file.path())?;
        // The counts fit the file's length; the index costs 24 bytes per 64 KiB page.
        let pages = (header.n_words as usize).div_ceil(PAGE_WORDS);
        let mut tree = Self {
            file,
            header,
            root_color: 0,
            sums: Vec::new(),
            cache: Cache {
                words: vec![None; pages],
                colors: if header.colored {
                    vec![None; pages]
                } else {
                    Vec::new()
                },
                order: VecDeque::new(),
                bytes: 0,
                limit: cache_bytes.max(MIN_CACHE),
            },
            pages_read: 0,
        };
        let mut c = [0u8; 2];
        let root_color: &[u8] = if header.colored {
            tree.read_at(&mut c, file::colors_offset(header.n_words))?;
            tree.root_color = u16::from_le_bytes(c);
            &c
        } else {
            &[]
        };
        // The counts fit the file's length, so the table is 8 bytes per 64 KiB page at most.
        let tail = file::trailer_offset(header.n_words, header.colored);
        let mut table = vec![0u8; (len - tail) as usize];
        tree.read_at(&mut table, tail)?;
        tree.sums = file::check_header_sum(&header, &head, root_color, &table, tree.file.path())?;
        Ok(tree)
    }

    /// Points (leaves) of the tree.
    pub fn n_points(&self) -> u64 {
        self.header.n_points
    }

    /// Words after the root.
    pub fn n_words(&self) -> u64 {
        self.header.n_words
    }

    /// The cache's limit, bytes.
    pub fn cache_limit(&self) -> u64 {
        self.cache.limit
    }

    /// Bytes of pages held now.
    pub fn cache_bytes(&self) -> u64 {
        self.cache.bytes
    }

    /// Bytes read from the file so far (header included).
    pub fn bytes_read(&self) -> u64 {
        self.file.bytes_read()
    }

    fn read_at(&mut self, buf: &mut [u8], offset: u64) -> Result<()> {
        self.file.read_at(buf, offset)
    }

    /// Page `page` of the words (or of the colours), read when not cached.
    fn page(&mut self, colors: bool, page: usize) -> Result<()> {
        let cached = if colors {
            self.cache.colors.get(page).is_some_and(Option::is_some)
        } else {
            self.cache.words.get(page).is_some_and(Option::is_some)
        };
        if cached {
            return Ok(());
        }
        let n = self.header.n_words as usize;
        let first = page * PAGE_WORDS;
        if first >= n {
            return Err(self.corrupt_error(first, "a position past the last word"));
        }
        let count = PAGE_WORDS.min(n - first);
        let width = if colors { 2 } else { 4 };
        let page_bytes = (count * width) as u64;
        while self.cache.bytes + page_bytes > self.cache.limit {
            let Some((c, p)) = self.cache.order.pop_front() else {
                break;
            };
            let freed = if c {
                self.cache
                    .colors
                    .get_mut(p)
                    .and_then(Option::take)
                    .map_or(0, |v| 2 * v.len())
            } else {
                self.cache
                    .words
                    .get_mut(p)
                    .and_then(Option::take)
                    .map_or(0, |v| 4 * v.len())
            };
            self.cache.bytes -= freed as u64;
        }
        let mut raw = vec![0u8; count * width];
        let offset = if colors {
            // Word k's colour is 2 (k + 1) bytes after the root's.
            file::colors_offset(self.header.n_words) + 2 * (first as u64 + 1)
        } else {
            file::word_offset(first as u64)
        };
        self.read_at(&mut raw, offset)?;
        file::check_page(
            &self.header,
            &self.sums,
            colors,
            page as u64,
            &raw,
            self.file.path(),
        )?;
        self.pages_read += 1;
        if colors {
            let v = raw
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect();
            if let Some(slot) = self.cache.colors.get_mut(page) {
                *slot = Some(v);
            }
        } else {
            let v = raw
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            if let Some(slot) = self.cache.words.get_mut(page) {
                *slot = Some(v);
            }
        }
        self.cache.order.push_back((colors, page));
        self.cache.bytes += page_bytes;
        Ok(())
    }
}

impl Nodes for PagedTree {
    type Error = Error;

    fn root(&self) -> Root {
        Root {
            center: self.header.root_center,
            radius: self.header.root_radius,
            word: self.header.root_word,
            color: self.root_color,
        }
    }

    fn word_count(&self) -> usize {
        self.header.n_words as usize
    }

    fn colored(&self) -> bool {
        self.header.colored
    }

    fn word(&mut self, at: usize) -> Result<u32> {
        let (page, k) = (at / PAGE_WORDS, at % PAGE_WORDS);
        if let Some(Some(p)) = self.cache.words.get(page)
            && let Some(&w) = p.get(k)
        {
            return Ok(w);
        }
        self.page(false, page)?;
        self.cache
            .words
            .get(page)
            .and_then(|p| p.as_ref()?.get(k).copied())
            .ok_or_else(|| self.corrupt_error(at, "word outside the file"))
    }

    fn color(&mut self, at: usize) -> Result<u16> {
        let (page, k) = (at / PAGE_WORDS, at % PAGE_WORDS);
        if let Some(Some(p)) = self.cache.colors.get(page)
            && let Some(&c) = p.get(k)
        {
            return Ok(c);
        }
        self.page(true, page)?;
        self.cache
            .colors
            .get(page)
            .and_then(|p| p.as_ref()?.get(k).copied())
            .ok_or_else(|| self.corrupt_error(at, "colour outside the file"))
    }

    fn corrupt(&self, at: usize, reason: &str) -> Option<Error> {
        Some(self.corrupt_error(at, reason))
    }
}

impl PagedTree {
    fn corrupt_error(&self, at: usize, reason: &str) -> Error {
        Error::Corrupt {
            format: file::FORMAT,
            path: self.file.path().to_owned(),
            offset: if at == usize::MAX {
                // The root's word, the header's last field.
                (file::HEADER_BYTES - 4) as u64
            } else {
                file::word_offset(at as u64)
            },
            reason: reason.to_owned(),
        }
    }
}

#[cfg(test)]
mod tests {
    use cloud::glam::DVec3;
    use cloud::rng::{RngExt, seeded};
    use cloud::{Camera, PointCloud};

    use super::*;
    use crate::traverse::{TraverseParams, leaves, traverse, traverse_nodes};
    use crate::tree::Word;
    use crate::{QTree, build_tree};

    /// A noisy sphere of `n` points with normals and colours.
    fn cloud(n: usize) -> PointCloud {
        let mut rng = seeded(7, "paged-test-cloud");
        let dirs = cloud::synth::fibonacci_sphere(n);
        PointCloud {
            positions: dirs
                .iter()
                .map(|d| *d * (2.0 + 0.05 * rng.random::<f64>()) + DVec3::new(1.0, 2.0, 3.0))
                .collect(),
            normals: Some(dirs.iter().map(|d| d.as_vec3()).collect()),
            colors: Some(
                (0..n)
                    .map(|i| [(i % 251) as u8, (i % 13) as u8 * 19, 7])
                    .collect(),
            ),
            ..PointCloud::default()
        }
    }

    fn cameras() -> Vec<Camera> {
        let target = DVec3::new(1.0, 2.0, 3.0);
        [
            (DVec3::new(0.0, 0.0, 9.0), 60.0),
            (DVec3::new(7.0, 1.0, -2.0), 30.0),
            (DVec3::new(-3.0, 6.0, 4.0), 75.0),
            (DVec3::new(1.5, 2.5, 4.2), 90.0),
        ]
        .into_iter()
        .map(|(e, fov)| Camera::new(target + e, target, DVec3::Y, fov, 160, 120).unwrap())
        .collect()
    }

    fn written(tree: &QTree) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        file::write(tree, &dir.path().join("t.qs")).unwrap();
        dir
    }

    #[test]
    fn selection_from_the_file_is_the_in_memory_selection() {
        for colored in [true, false] {
            let mut c = cloud(60_000);
            if !colored {
                c.colors = None;
            }
            let tree = build_tree(&c, 0.01).unwrap();
            let dir = written(&tree);
            // The smallest cache: pages are evicted and read again.
            let mut paged = PagedTree::open(&dir.path().join("t.qs"), 0).unwrap();
            assert_eq!(paged.n_points(), 60_000);
            for cam in cameras() {
                for threshold_px in [0.5, 2.0, 16.0] {
                    for (frustum_cull, backface_cull) in [(true, true), (false, false)] {
                        let params = TraverseParams {
                            threshold_px,
                            frustum_cull,
                            backface_cull,
                        };
                        let want = traverse(&tree, &cam, &params);
                        let got = traverse_nodes(&mut paged, &cam, &params).unwrap();
                        assert_eq!(got, want, "threshold {threshold_px}");
                        assert!(paged.cache_bytes() <= paged.cache_limit());
                    }
                }
            }
            let mut want = Vec::new();
            let n = leaves(&mut &tree, |s| want.push(s)).unwrap();
            let mut got = Vec::new();
            assert_eq!(leaves(&mut paged, |s| got.push(s)).unwrap(), n);
            assert_eq!(n, 60_000);
            assert_eq!(got, want);
            // The leaves are the points' spheres: every point is within a leaf's radius of
            // one (quantisation rounds outwards).
            assert!(paged.pages_read > 0);
        }
    }

    #[test]
    fn a_coarse_view_reads_a_small_part_of_the_file() {
        let tree = build_tree(&cloud(200_000), 0.005).unwrap();
        let dir = written(&tree);
        let path = dir.path().join("t.qs");
        let file_bytes = std::fs::metadata(&path).unwrap().len();
        let mut paged = PagedTree::open(&path, 1 << 30).unwrap();
        let far = Camera::new(
            DVec3::new(1.0, 2.0, 60.0),
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::Y,
            40.0,
            320,
            240,
        )
        .unwrap();
        let params = TraverseParams {
            threshold_px: 2.0,
            ..TraverseParams::default()
        };
        let got = traverse_nodes(&mut paged, &far, &params).unwrap();
        assert_eq!(got, traverse(&tree, &far, &params));
        assert!(
            paged.bytes_read() * 10 < file_bytes,
            "{} of {file_bytes} bytes read for {} splats",
            paged.bytes_read(),
            got.len()
        );
    }

    #[test]
    fn truncated_and_lying_files_are_errors_at_open() {
        let tree = build_tree(&cloud(5_000), 0.01).unwrap();
        let bytes = file::to_bytes(&tree);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.qs");
        for cut in [0, 7, 40, bytes.len() - 1] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let e = PagedTree::open(&path, 0).unwrap_err();
            assert!(matches!(e, Error::Corrupt { .. }), "{cut}: {e}");
        }
        let mut lying = bytes.clone();
        lying[24..32].copy_from_slice(&u64::MAX.to_le_bytes());
        std::fs::write(&path, &lying).unwrap();
        assert!(matches!(
            PagedTree::open(&path, 0).unwrap_err(),
            Error::Corrupt { .. }
        ));
        let missing = PagedTree::open(&dir.path().join("none.qs"), 0).unwrap_err();
        assert!(matches!(missing, Error::Io { .. }));
    }

    #[test]
    fn a_flipped_byte_anywhere_fails_a_checksum_in_both_readers() {
        let tree = build_tree(&cloud(60_000), 0.01).unwrap();
        let bytes = file::to_bytes(&tree);
        let n = tree.words.len() as u64;
        let pages = file::pages(n);
        assert!(pages >= 4, "{pages} pages");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.qs");
        let mid = file::page_range(n, false, pages / 2);
        let last = file::page_range(n, true, pages - 1);
        let tail = file::trailer_offset(n, true);
        // (byte, the block named, read at open by the paged reader)
        let cases = [
            (40, "the header", true),
            (file::colors_offset(n) + 1, "the header", true),
            (tail + 5, "the header", true),
            (bytes.len() as u64 - 1, "the header", true),
            ((mid.0 + mid.1) / 2, "word page", false),
            (last.1 - 1, "colour page", false),
        ];
        for (at, block, at_open) in cases {
            let mut b = bytes.clone();
            b[at as usize] ^= 0x04;
            std::fs::write(&path, &b).unwrap();
            let whole = file::read(&path).unwrap_err();
            let paged = PagedTree::open(&path, 0)
                .and_then(|mut t| leaves(&mut t, |_| {}).map(|_| t))
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
                assert!(
                    p.ends_with("t.qs") && b.starts_with(block),
                    "byte {at}: {e}"
                );
                if !at_open {
                    assert!((*offset..*end).contains(&at), "byte {at}: {e}");
                }
                assert!(e.to_string().contains("rebuild it"), "{e}");
            }
            assert_eq!(PagedTree::open(&path, 0).is_err(), at_open, "byte {at}");
        }
        // The middle page is named by number.
        let mut b = bytes.clone();
        b[mid.0 as usize] ^= 1;
        let e = file::from_bytes(&b, "t").unwrap_err();
        assert!(
            e.to_string().contains(&format!("word page {}", pages / 2)),
            "{e}"
        );
    }

    #[test]
    fn a_version_1_file_is_refused_with_rebuild_it() {
        let tree = build_tree(&cloud(2_000), 0.01).unwrap();
        let mut b = file::to_bytes(&tree);
        b[8..12].copy_from_slice(&1u32.to_le_bytes());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.qs");
        std::fs::write(&path, &b).unwrap();
        for e in [
            file::read(&path).unwrap_err(),
            PagedTree::open(&path, 0).unwrap_err(),
        ] {
            assert!(
                matches!(
                    e,
                    Error::OldVersion {
                        version: 1,
                        current: 2,
                        ..
                    }
                ),
                "{e}"
            );
            let m = e.to_string();
            assert!(
                m.contains("old.qs")
                    && m.contains("older pointsight")
                    && m.contains("rebuild it with `pointsight lod-build`"),
                "{m}"
            );
        }
    }

    #[test]
    fn damaged_words_are_errors_never_panics_or_loops() {
        let tree = build_tree(&cloud(3_000), 0.01).unwrap();
        let bytes = file::to_bytes(&tree);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.qs");
        let words = tree.words.len();
        let mut rng = seeded(11, "paged-test-damage");
        let cam = &cameras()[0];
        let params = TraverseParams {
            threshold_px: 0.0,
            frustum_cull: false,
            backface_cull: false,
        };
        let mut errors = 0;
        for _ in 0..300 {
            let mut b = bytes.clone();
            for _ in 0..3 {
                let k = rng.random_range(0..words);
                let o = file::word_offset(k as u64) as usize;
                let v: u32 = rng.random();
                b[o..o + 4].copy_from_slice(&v.to_le_bytes());
            }
            // Past the checksums, to reach the structural checks.
            file::reseal(&mut b);
            std::fs::write(&path, &b).unwrap();
            let mut paged = PagedTree::open(&path, 0).unwrap();
            let a = traverse_nodes(&mut paged, cam, &params);
            let l = leaves(&mut paged, |_| {});
            for r in [a.err(), l.err()].into_iter().flatten() {
                assert!(matches!(r, Error::Corrupt { .. }), "{r}");
                errors += 1;
            }
        }
        assert!(errors > 100, "only {errors} of 600 damaged walks failed");
        // An offset word pointing back at its own group.
        let mut b = bytes.clone();
        assert!(Word::unpack(tree.root_word).unwrap().grandchildren);
        b[file::word_offset(0) as usize..][..4].copy_from_slice(&0u32.to_le_bytes());
        file::reseal(&mut b);
        std::fs::write(&path, &b).unwrap();
        let mut paged = PagedTree::open(&path, 0).unwrap();
        let e = leaves(&mut paged, |_| {}).unwrap_err();
        assert!(e.to_string().contains("offset"), "{e}");
    }
}
