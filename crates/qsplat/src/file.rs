//! The compact file: a small header, then QSplat's node stream.
//!
//! Layout (little-endian): magic `PSQSPLAT`; version (u32, 2); flags (u32, bit 0: colours);
//! point count (u64); word count (u64); root centre (3 × f64) and radius (f64); root word
//! (u32); then the words (u32 each: offset words and node words, breadth first); then, with
//! colours, one u16 for the root and one per word (RGB565; 0 for offset words); then the
//! checksums ([`cloud::io::checksum`], CRC-32, u32 each): one per word page ([`PAGE_WORDS`]
//! words, 64 KiB; the last may be shorter), then with colours one per colour page (the
//! colours of a word page, 32 KiB, the root's not included); last, one CRC-32 over the bytes
//! outside every page: the header, the root's colour and the table of page checksums. The
//! original's node stream is the same 4 bytes a node (6 with colour) plus 4 per sibling group
//! with grandchildren; the checksums add 4 bytes per page (8 with colours) and 4 for the file.
//!
//! Version 1 (no checksums) is refused with [`Error::OldVersion`] ("rebuild it with
//! `pointsight lod-build`"); a page or header whose checksum fails is [`Error::Checksum`]
//! with its byte range. [`read`] and [`from_bytes`] check every checksum; [`crate::PagedTree`]
//! checks the header's when it opens the file and each page's as it reads it.
//!
//! Reading checks everything before trusting it: the magic and version, that the counts fit
//! the file's length (nothing is allocated from a count the file cannot back), the checksums,
//! every word's sphere and normal codes and tree bits, and the structure itself: walking the
//! tree from the root must visit every word exactly once and every offset must point at the
//! group that follows. Any other failure is [`Error::Corrupt`] with the byte offset.

use std::fs;
use std::path::Path;

use cloud::glam::DVec3;

use crate::quant;
use crate::tree::{QTree, Word};
use crate::{Error, Result};

const MAGIC: &[u8; 8] = b"PSQSPLAT";
const VERSION: u32 = 2;
/// The format's name in the errors that say a file is damaged or too old.
pub const FORMAT: &str = "QSplat";
/// What the versions before [`VERSION`] lacked, as the version error says it.
const CHANGES: &str = ", which adds checksums";
const HEADER: usize = 8 + 4 + 4 + 8 + 8 + 32 + 4;

/// Words per page: the unit [`crate::PagedTree`] reads and a checksum covers (64 KiB of words;
/// a colour page holds as many colours, 32 KiB).
pub const PAGE_WORDS: usize = 16_384;

/// Pages of `n_words` words.
pub(crate) fn pages(n_words: u64) -> u64 {
    n_words.div_ceil(PAGE_WORDS as u64)
}

/// Bytes of the checksums at the end of a file of `n_words` words.
fn trailer_bytes(n_words: u64, colored: bool) -> Option<u64> {
    pages(n_words)
        .checked_mul(4 * (1 + u64::from(colored)))?
        .checked_add(4)
}

/// Byte offset of the checksums (the page sums, then the header's).
pub(crate) fn trailer_offset(n_words: u64, colored: bool) -> u64 {
    colors_offset(n_words) + if colored { 2 * (n_words + 1) } else { 0 }
}

/// Byte range of word page `p` (`colors`: of its colours).
pub(crate) fn page_range(n_words: u64, colors: bool, p: u64) -> (u64, u64) {
    let first = p * PAGE_WORDS as u64;
    let last = (first + PAGE_WORDS as u64).min(n_words);
    if colors {
        let base = colors_offset(n_words) + 2;
        (base + 2 * first, base + 2 * last)
    } else {
        (word_offset(first), word_offset(last))
    }
}

/// Index of page `p`'s checksum in the table.
pub(crate) fn sum_index(n_words: u64, colors: bool, p: u64) -> usize {
    (p + if colors { pages(n_words) } else { 0 }) as usize
}

/// The name of page `p` in errors.
pub(crate) fn page_name(colors: bool, p: u64) -> String {
    format!("{} page {p}", if colors { "colour" } else { "word" })
}

/// The bytes that end a file: the page checksums (`word_sums`, then `color_sums`) and the
/// checksum over them, the header's bytes `header` and the root's colour `root_color` (empty
/// without colours).
pub(crate) fn trailer(
    header: &[u8],
    root_color: &[u8],
    word_sums: &[u32],
    color_sums: &[u32],
) -> Vec<u8> {
    let sums: Vec<u32> = word_sums.iter().chain(color_sums).copied().collect();
    cloud::io::checksum::trailer(&[header, root_color], &sums)
}

/// The header (everything before the words).
pub fn header_bytes(
    colors: bool,
    n_points: u64,
    n_words: u64,
    root_center: DVec3,
    root_radius: f64,
    root_word: u32,
) -> Vec<u8> {
    let mut b = Vec::with_capacity(HEADER);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.extend_from_slice(&u32::from(colors).to_le_bytes());
    b.extend_from_slice(&n_points.to_le_bytes());
    b.extend_from_slice(&n_words.to_le_bytes());
    for v in root_center.to_array() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&root_radius.to_le_bytes());
    b.extend_from_slice(&root_word.to_le_bytes());
    b
}

/// Serialises `tree`.
pub fn to_bytes(tree: &QTree) -> Vec<u8> {
    let n = tree.words.len() as u64;
    let colored = tree.colors.is_some();
    let mut b = Vec::with_capacity(HEADER + tree.payload_bytes() + 8);
    b.extend_from_slice(&header_bytes(
        colored,
        tree.n_points,
        n,
        tree.root_center,
        tree.root_radius,
        tree.root_word,
    ));
    for w in &tree.words {
        b.extend_from_slice(&w.to_le_bytes());
    }
    if let Some(colors) = &tree.colors {
        b.extend_from_slice(&tree.root_color.to_le_bytes());
        for c in colors {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    seal(&mut b, n);
    b
}

/// Appends the checksums to `b`, a file's bytes up to them, of `n` words.
pub(crate) fn seal(b: &mut Vec<u8>, n: u64) {
    use cloud::io::checksum::block_sums;
    let co = colors_offset(n) as usize;
    let words = &b[HEADER..co];
    let colors = &b[co..];
    let word_sums = block_sums(words, 4 * PAGE_WORDS);
    let color_sums = block_sums(colors.get(2..).unwrap_or(&[]), 2 * PAGE_WORDS);
    let t = trailer(
        &b[..HEADER],
        colors.get(..2).unwrap_or(&[]),
        &word_sums,
        &color_sums,
    );
    b.extend_from_slice(&t);
}

/// Recomputes the checksums of a file's bytes `b` after a test changed them on purpose (to
/// reach the checks behind the checksums).
#[cfg(test)]
pub(crate) fn reseal(b: &mut Vec<u8>) {
    let n = u64::from_le_bytes([b[24], b[25], b[26], b[27], b[28], b[29], b[30], b[31]]);
    b.truncate(trailer_offset(n, b[12] == 1) as usize);
    seal(b, n);
}

/// Writes `tree` to `path`.
pub fn write(tree: &QTree, path: &Path) -> Result<()> {
    cloud::io::atomic::write(path, &to_bytes(tree)).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Reads a tree from `path`.
pub fn read(path: &Path) -> Result<QTree> {
    let bytes = fs::read(path).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    from_bytes(&bytes, &path.display().to_string())
}

/// What the header says, checked against the file's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Header {
    pub colored: bool,
    pub n_points: u64,
    pub n_words: u64,
    pub root_center: DVec3,
    pub root_radius: f64,
    pub root_word: u32,
}

/// Byte offset of word `k`.
pub(crate) fn word_offset(k: u64) -> u64 {
    HEADER as u64 + 4 * k
}

/// Byte offset of the root's colour (the colours follow the words); word `k`'s is 2 (k + 1)
/// bytes after it.
pub(crate) fn colors_offset(n_words: u64) -> u64 {
    word_offset(n_words)
}

/// The header's bytes.
pub(crate) const HEADER_BYTES: usize = HEADER;

/// Parses the header at the start of `b` for a file of `file_len` bytes (the counts must fit
/// it exactly, so nothing is allocated from a count the file cannot back); `name` labels
/// errors.
pub(crate) fn parse_header(b: &[u8], file_len: u64, name: &str) -> Result<Header> {
    let corrupt = |offset: usize, reason: String| Error::Corrupt {
        format: FORMAT,
        path: name.to_owned(),
        offset: offset as u64,
        reason,
    };
    let u32_at = |o: usize| -> Result<u32> {
        b.get(o..o + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            .ok_or_else(|| corrupt(o, "truncated".into()))
    };
    let u64_at = |o: usize| -> Result<u64> {
        b.get(o..o + 8)
            .and_then(|s| s.try_into().ok())
            .map(u64::from_le_bytes)
            .ok_or_else(|| corrupt(o, "truncated".into()))
    };
    let f64_at = |o: usize| -> Result<f64> { u64_at(o).map(f64::from_bits) };
    if b.len() < 8 || &b[..8] != MAGIC {
        return Err(corrupt(
            0,
            "not a pointsight QSplat file (bad magic)".into(),
        ));
    }
    let version = u32_at(8)?;
    if version == 1 {
        return Err(Error::OldVersion {
            format: FORMAT,
            changes: CHANGES,
            path: name.to_owned(),
            version,
            current: VERSION,
        });
    }
    if version != VERSION {
        return Err(corrupt(8, format!("unsupported version {version}")));
    }
    let flags = u32_at(12)?;
    if flags > 1 {
        return Err(corrupt(12, format!("unknown flags {flags:#x}")));
    }
    let colored = flags == 1;
    let n_points = u64_at(16)?;
    let n_words = u64_at(24)?;
    let per_word: u64 = if colored { 6 } else { 4 };
    let expected = (HEADER as u64)
        .checked_add(
            n_words
                .checked_mul(per_word)
                .ok_or_else(|| corrupt(24, "word count overflows".into()))?,
        )
        .and_then(|v| v.checked_add(if colored { 2 } else { 0 }))
        .and_then(|v| v.checked_add(trailer_bytes(n_words, colored)?))
        .ok_or_else(|| corrupt(24, "word count overflows".into()))?;
    if expected != file_len {
        return Err(corrupt(
            24,
            format!("{n_words} words need {expected} bytes, the file has {file_len}"),
        ));
    }
    if usize::try_from(n_words).is_err() {
        return Err(corrupt(
            24,
            format!("{n_words} words do not fit in memory addresses"),
        ));
    }
    let root_center = DVec3::new(f64_at(32)?, f64_at(40)?, f64_at(48)?);
    let root_radius = f64_at(56)?;
    if !root_center.is_finite() || !(root_radius > 0.0) || !root_radius.is_finite() {
        return Err(corrupt(32, "root sphere is not finite and positive".into()));
    }
    let root_word = u32_at(64)?;
    Ok(Header {
        colored,
        n_points,
        n_words,
        root_center,
        root_radius,
        root_word,
    })
}

/// The page checksums of a file whose header parsed as `h`, after checking the header's
/// checksum against the header bytes `head`, the root's colour `root_color` (empty without
/// colours) and the checksums' bytes `table` (the file's tail from [`trailer_offset`]).
pub(crate) fn check_header_sum(
    h: &Header,
    head: &[u8],
    root_color: &[u8],
    table: &[u8],
    name: &str,
) -> Result<Vec<u32>> {
    cloud::io::checksum::check_trailer(&[head, root_color], table).ok_or_else(|| Error::Checksum {
        path: name.to_owned(),
        block: "the header (the header, the root's colour and the page checksums)".into(),
        offset: 0,
        end: trailer_offset(h.n_words, h.colored) + table.len() as u64,
    })
}

/// Checks page `p`'s bytes `data` against the table `sums`.
pub(crate) fn check_page(
    h: &Header,
    sums: &[u32],
    colors: bool,
    p: u64,
    data: &[u8],
    name: &str,
) -> Result<()> {
    let want = sums.get(sum_index(h.n_words, colors, p)).copied();
    if want == Some(cloud::io::checksum::crc32(data)) {
        return Ok(());
    }
    let (offset, end) = page_range(h.n_words, colors, p);
    Err(Error::Checksum {
        path: name.to_owned(),
        block: page_name(colors, p),
        offset,
        end,
    })
}

/// Parses a tree, checking every checksum; `name` labels errors.
pub fn from_bytes(b: &[u8], name: &str) -> Result<QTree> {
    let h = parse_header(b, b.len() as u64, name)?;
    let tail = trailer_offset(h.n_words, h.colored) as usize;
    let root_color = if h.colored {
        &b[colors_offset(h.n_words) as usize..][..2]
    } else {
        &[]
    };
    let sums = check_header_sum(&h, &b[..HEADER], root_color, &b[tail..], name)?;
    for colors in [false, true] {
        if colors && !h.colored {
            continue;
        }
        for p in 0..pages(h.n_words) {
            let (from, to) = page_range(h.n_words, colors, p);
            check_page(&h, &sums, colors, p, &b[from as usize..to as usize], name)?;
        }
    }
    let n = h.n_words as usize;
    let word = |k: usize| -> u32 {
        let o = HEADER + 4 * k;
        u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
    };
    let words: Vec<u32> = (0..n).map(word).collect();
    let (root_color, colors) = if h.colored {
        let base = HEADER + 4 * n;
        let c = |k: usize| -> u16 { u16::from_le_bytes([b[base + 2 * k], b[base + 2 * k + 1]]) };
        (c(0), Some((0..n).map(|k| c(k + 1)).collect()))
    } else {
        (0, None)
    };
    let tree = QTree {
        n_points: h.n_points,
        root_center: h.root_center,
        root_radius: h.root_radius,
        root_word: h.root_word,
        words,
        colors,
        root_color,
    };
    validate(&tree, name)?;
    Ok(tree)
}

/// Walks the whole tree: every word visited once, codes in range, offsets consistent.
fn validate(tree: &QTree, name: &str) -> Result<()> {
    let fail = |k: usize, reason: String| Error::Corrupt {
        format: FORMAT,
        path: name.to_owned(),
        offset: (HEADER + 4 * k) as u64,
        reason,
    };
    let root = Word::unpack(tree.root_word).ok_or_else(|| Error::Corrupt {
        format: FORMAT,
        path: name.to_owned(),
        offset: 64,
        reason: "bad root tree bits".into(),
    })?;
    let n = tree.words.len();
    let mut visited = vec![false; n];
    let mut leaves: u64 = u64::from(root.children == 0);
    // Breadth first over groups: (group position, node count, has offset word).
    let mut queue = std::collections::VecDeque::new();
    if root.children > 0 {
        queue.push_back((0usize, root.children as usize, root.grandchildren));
    }
    let mut expected_next = 0usize;
    while let Some((pos, count, has_offset)) = queue.pop_front() {
        if pos != expected_next {
            return Err(fail(
                pos.min(n.saturating_sub(1)),
                format!("group at word {pos} out of order (expected {expected_next})"),
            ));
        }
        let end = pos + usize::from(has_offset) + count;
        if end > n {
            return Err(fail(
                pos.min(n.saturating_sub(1)),
                "group runs past the end".into(),
            ));
        }
        let mut grand_at = if has_offset {
            tree.words[pos] as usize
        } else {
            0
        };
        let mut first_child_group = None;
        for k in pos..end {
            if visited[k] {
                return Err(fail(k, "word reached twice".into()));
            }
            visited[k] = true;
            if has_offset && k == pos {
                continue;
            }
            let w = Word::unpack(tree.words[k])
                .ok_or_else(|| fail(k, "grandchildren without children".into()))?;
            if w.sphere as usize >= quant::SPHERE_TABLE_LEN {
                return Err(fail(k, format!("sphere index {} out of range", w.sphere)));
            }
            if u32::from(w.normal) >= quant::NORMAL_CODES {
                return Err(fail(k, format!("normal code {} out of range", w.normal)));
            }
            if w.children > 0 {
                if !has_offset {
                    return Err(fail(
                        k,
                        "a node has children but its group has no offset".into(),
                    ));
                }
                first_child_group.get_or_insert(grand_at);
                queue.push_back((grand_at, w.children as usize, w.grandchildren));
                grand_at += usize::from(w.grandchildren) + w.children as usize;
            } else {
                leaves += 1;
            }
        }
        if has_offset && first_child_group.is_none() {
            return Err(fail(pos, "offset word in a group without children".into()));
        }
        expected_next = end;
    }
    if expected_next != n || visited.iter().any(|v| !v) {
        return Err(fail(
            expected_next.min(n.saturating_sub(1)),
            "words not reached by the tree".into(),
        ));
    }
    if leaves != tree.n_points {
        return Err(fail(
            0,
            format!(
                "{leaves} leaves but the header says {} points",
                tree.n_points
            ),
        ));
    }
    Ok(())
}
