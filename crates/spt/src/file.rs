//! The file of a sequential point tree: the sorted list as a view scans it, then the splats.
//!
//! Dachsbacher et al. (2003, §4) keep the tree as one array in GPU memory; this file is that
//! array (with this crate's quantised boxes, [`crate::list`]) so that a cut needs only a
//! *prefix* of it: the groups whose parent could be refined somewhere on the object, and their
//! entries, come first.
//!
//! Layout (little-endian):
//! - header, [`HEADER`] bytes: magic `PSSPTREE`; version (u32, 3); flags (u32, bit 0:
//!   colours); points, groups, entries (u64 each); the hierarchy's local origin (3 × f64); the
//!   grid's origin (3 × f64) and step (f64); the leaf diameter (f64); the root's box (6 × u16)
//!   and the CRC-32 of the header's bytes before it (u32; version 1 had 4 zero bytes);
//! - groups, 24 bytes each: the parent's box (6 × u16), its e_g² (f32), the first and one past
//!   the last entry (u32 each), sorted by e_g² descending after the root's group (whose e_g² is
//!   +∞);
//! - entries, 16 bytes each: the node's box (6 × u16) and e_g² (f32);
//! - splats, 14 bytes an entry ([`crate::pack`]): centre within the entry's box (3 × u16),
//!   radius (f32), normal (octahedral, 2 × u16);
//! - with colours, 3 bytes an entry: the mean colour in [0, 1] (3 × u8);
//! - the block checksums ([`cloud::io::checksum`], CRC-32, u32 each): each section above
//!   (groups, entries, splats, colours, in that order) cut into blocks of [`BLOCK_ITEMS`]
//!   items (the last may be shorter), one checksum a block, the sections' in file order:
//!   4 bytes per 256 groups, 8 (12 with colours) per 256 entries, about 0.1 % of the file.
//!
//! Version 3 quantises the splats ([`crate::pack`]: the cut is unchanged, the centres and
//! normals drawn move by at most its stated bounds); versions 1 (no checksums) and 2 (splats
//! and colours as f32, 28 and 12 bytes) are refused with [`Error::OldVersion`].
//!
//! The block is the unit [`crate::paged`] reads (a read of some items reads the blocks that
//! hold them and checks each; [`crate::paged::BLOCK_GROUPS`] is a multiple of it). A value that
//! stays finite and in range after a flipped byte is caught only so.
//!
//! [`parse_header`] checks the magic and version (an older version is
//! [`Error::OldVersion`]: "rebuild it with `pointsight lod-build`"), the header's checksum
//! and that the counts fit the file's length (nothing is allocated from a count the file
//! cannot back); [`check`] checks every block's checksum of a whole file; [`crate::paged`]
//! checks each block it reads and every group, entry and splat as a cut reads it. A checksum
//! that fails is [`Error::Checksum`] naming the block and its bytes; any other failure is
//! [`Error::Corrupt`] with the byte offset. A damaged block-checksum table shows as a failed
//! check of its block.

use std::path::Path;

use cloud::glam::DVec3;

use crate::Spt;
use crate::list::{Entry, Grid, Group, QBox};
pub use crate::pack::{COLOR, SPLAT};
use crate::{Error, Result};

/// The file's magic.
pub const MAGIC: &[u8; 8] = b"PSSPTREE";
/// The format's version.
pub const VERSION: u32 = 3;
/// The format's name in the errors that say a file is damaged or too old.
pub const FORMAT: &str = "sequential point tree";
/// What the versions before [`VERSION`] lacked, as the version error says it.
const CHANGES: &str = ": checksums since 2, quantised splats since 3";
/// Items (groups, entries, splats or colours) per checksummed block.
pub const BLOCK_ITEMS: usize = 256;
/// The sections' names in errors.
const SECTION_NAMES: [&str; 4] = ["group", "entry", "splat", "colour"];
/// Bytes of the header.
pub const HEADER: usize = 8 + 4 + 4 + 3 * 8 + 3 * 8 + 3 * 8 + 8 + 8 + 12 + 4;
/// Bytes of a group.
pub const GROUP: usize = 24;
/// Bytes of an entry.
pub const ENTRY: usize = 16;

/// What the header says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    /// Colours stored.
    pub colors: bool,
    /// Points (leaves).
    pub points: u64,
    /// Groups.
    pub groups: u64,
    /// Entries (nodes).
    pub entries: u64,
    /// The hierarchy's local origin.
    pub local: DVec3,
    /// The grid's origin.
    pub grid_origin: DVec3,
    /// The grid's step.
    pub cell: f64,
    /// The leaf discs' diameter.
    pub leaf_diameter: f64,
    /// The root's box.
    pub root: QBox,
}

impl Header {
    /// Bytes of the whole file.
    pub fn file_bytes(&self) -> Option<u64> {
        let per_entry = (ENTRY + SPLAT + if self.colors { COLOR } else { 0 }) as u64;
        self.groups
            .checked_mul(GROUP as u64)?
            .checked_add(self.entries.checked_mul(per_entry)?)?
            .checked_add(HEADER as u64)?
            .checked_add(self.blocks().iter().sum::<u64>().checked_mul(4)?)
    }

    /// Items in each section (groups, entries, splats, colours).
    fn items(&self) -> [u64; 4] {
        let c = if self.colors { self.entries } else { 0 };
        [self.groups, self.entries, self.entries, c]
    }

    /// Checksummed blocks in each section.
    pub fn blocks(&self) -> [u64; 4] {
        self.items().map(|n| n.div_ceil(BLOCK_ITEMS as u64))
    }

    /// Byte offset of the block checksums (after the colours, or the splats without).
    pub fn sums_offset(&self) -> u64 {
        self.sections()[3] + self.items()[3] * COLOR as u64
    }

    /// Byte offset of the checksum of block `block` of section `section` (0 groups, 1 entries,
    /// 2 splats, 3 colours).
    pub(crate) fn sum_offset(&self, section: usize, block: u64) -> u64 {
        let before: u64 = self.blocks()[..section].iter().sum();
        self.sums_offset() + 4 * (before + block)
    }

    /// Byte range of block `block` of section `section`.
    pub(crate) fn block_range(&self, section: usize, block: u64) -> (u64, u64) {
        let size = [GROUP, ENTRY, SPLAT, COLOR][section] as u64;
        let first = block * BLOCK_ITEMS as u64;
        let last = (first + BLOCK_ITEMS as u64).min(self.items()[section]);
        let at = self.sections()[section];
        (at + first * size, at + last * size)
    }

    /// Checks the bytes `data` of blocks `first..` of section `section` against their
    /// checksums `sums` (u32 little-endian each); `path` labels errors.
    pub(crate) fn check_blocks(
        &self,
        section: usize,
        first: u64,
        data: &[u8],
        sums: &[u8],
        path: &str,
    ) -> Result<()> {
        let size = BLOCK_ITEMS * [GROUP, ENTRY, SPLAT, COLOR][section];
        for (k, (block, sum)) in data.chunks(size).zip(sums.chunks_exact(4)).enumerate() {
            let want = u32::from_le_bytes([sum[0], sum[1], sum[2], sum[3]]);
            if cloud::io::checksum::crc32(block) != want {
                let b = first + k as u64;
                let (offset, end) = self.block_range(section, b);
                return Err(Error::Checksum {
                    path: path.to_string(),
                    block: format!("{} block {b}", SECTION_NAMES[section]),
                    offset,
                    end,
                });
            }
        }
        Ok(())
    }

    /// Byte offsets of the groups, entries, splats and colours.
    pub fn sections(&self) -> [u64; 4] {
        let g = HEADER as u64;
        let e = g + self.groups * GROUP as u64;
        let s = e + self.entries * ENTRY as u64;
        let c = s + self.entries * SPLAT as u64;
        [g, e, s, c]
    }

    /// The header's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER);
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.extend_from_slice(&u32::from(self.colors).to_le_bytes());
        for v in [self.points, self.groups, self.entries] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in self
            .local
            .to_array()
            .into_iter()
            .chain(self.grid_origin.to_array())
        {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.cell.to_le_bytes());
        b.extend_from_slice(&self.leaf_diameter.to_le_bytes());
        push_box(&mut b, &self.root);
        let sum = cloud::io::checksum::crc32(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }
}

/// Appends a box's bytes (6 × u16).
pub(crate) fn push_box(b: &mut Vec<u8>, q: &QBox) {
    for v in q.lo.iter().chain(&q.hi) {
        b.extend_from_slice(&v.to_le_bytes());
    }
}

/// A box from its bytes (the first 12 of `r`).
pub(crate) fn box_of(r: &[u8]) -> QBox {
    let u = |o: usize| u16::from_le_bytes([r[o], r[o + 1]]);
    QBox {
        lo: [u(0), u(2), u(4)],
        hi: [u(6), u(8), u(10)],
    }
}

/// Appends a group's bytes.
pub fn push_group(b: &mut Vec<u8>, g: &Group) {
    push_box(b, &g.b);
    b.extend_from_slice(&g.e2.to_le_bytes());
    b.extend_from_slice(&g.start.to_le_bytes());
    b.extend_from_slice(&g.end.to_le_bytes());
}

/// Appends an entry's bytes.
pub fn push_entry(b: &mut Vec<u8>, e: &Entry) {
    push_box(b, &e.b);
    b.extend_from_slice(&e.e2.to_le_bytes());
}

/// The grid of `spt`'s boxes, its local origin included.
pub fn grid_of(spt: &Spt) -> Grid {
    Grid {
        local: spt.hierarchy.origin,
        origin: spt.quant.origin,
        cell: spt.quant.cell,
    }
}

/// The header of `spt`'s file.
pub fn header_of(spt: &Spt) -> Header {
    Header {
        colors: spt.colors,
        points: u64::from(spt.hierarchy.nodes[spt.hierarchy.root()].leaves),
        groups: spt.list.groups.len() as u64,
        entries: spt.list.entries.len() as u64,
        local: spt.hierarchy.origin,
        grid_origin: spt.quant.origin,
        cell: spt.quant.cell,
        leaf_diameter: spt.leaf_diameter,
        root: spt.quant.boxes[spt.hierarchy.root()],
    }
}

/// Serialises `spt`.
pub fn to_bytes(spt: &Spt) -> Vec<u8> {
    let h = header_of(spt);
    let mut b = h.to_bytes();
    b.reserve(h.file_bytes().unwrap_or(0) as usize);
    for g in &spt.list.groups {
        push_group(&mut b, g);
    }
    for e in &spt.list.entries {
        push_entry(&mut b, e);
    }
    let grid = grid_of(spt);
    for (e, &n) in spt.list.entries.iter().zip(&spt.list.node) {
        crate::pack::push_splat(&mut b, &spt.hierarchy.nodes[n as usize], &e.b, &grid);
    }
    if spt.colors {
        for &n in &spt.list.node {
            crate::pack::push_color(&mut b, &spt.hierarchy.nodes[n as usize]);
        }
    }
    seal(&mut b, &h);
    b
}

/// Appends the block checksums to `b`, a file's bytes up to them, whose header is `h`.
fn seal(b: &mut Vec<u8>, h: &Header) {
    let ends = h.sections().map(|s| s as usize);
    let mut sums = Vec::new();
    for (k, size) in [GROUP, ENTRY, SPLAT, COLOR].into_iter().enumerate() {
        let end = ends.get(k + 1).copied().unwrap_or(b.len());
        let section = &b[ends[k]..end];
        sums.extend(cloud::io::checksum::block_sums(section, BLOCK_ITEMS * size));
    }
    for s in sums {
        b.extend_from_slice(&s.to_le_bytes());
    }
}

/// Recomputes the checksums of a file's bytes `b` after a test changed them on purpose (to
/// reach the checks behind the checksums): the header's, and with `blocks` every block's
/// (the header must then still parse).
#[cfg(test)]
pub(crate) fn reseal(b: &mut Vec<u8>, blocks: bool) {
    let sum = cloud::io::checksum::crc32(&b[..HEADER - 4]);
    b[HEADER - 4..HEADER].copy_from_slice(&sum.to_le_bytes());
    if blocks {
        let h = parse_header(b, b.len() as u64, "reseal").unwrap();
        b.truncate(h.sums_offset() as usize);
        seal(b, &h);
    }
}

/// Checks every checksum of a whole file's bytes `bytes` (the header's and every block's) and
/// returns its header; `path` labels errors.
pub fn check(bytes: &[u8], path: &str) -> Result<Header> {
    let h = parse_header(bytes, bytes.len() as u64, path)?;
    for section in 0..4 {
        let blocks = h.blocks()[section];
        if blocks == 0 {
            continue;
        }
        let from = h.block_range(section, 0).0 as usize;
        let to = h.block_range(section, blocks - 1).1 as usize;
        let sums = h.sum_offset(section, 0) as usize;
        h.check_blocks(
            section,
            0,
            &bytes[from..to],
            &bytes[sums..sums + 4 * blocks as usize],
            path,
        )?;
    }
    Ok(h)
}

/// Reads the file at `path` whole and checks every checksum ([`check`]).
pub fn verify(path: &Path) -> Result<Header> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    check(&bytes, &path.display().to_string())
}

/// Writes `spt` to `path`, whole or not at all.
pub fn write(spt: &Spt, path: &Path) -> Result<()> {
    cloud::io::atomic::write(path, &to_bytes(spt)).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })
}

struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        if let Some(s) = self.bytes.get(self.at..self.at + N) {
            out.copy_from_slice(s);
        }
        self.at += N;
        out
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn dvec3(&mut self) -> DVec3 {
        DVec3::new(self.f64(), self.f64(), self.f64())
    }
    fn qbox(&mut self) -> QBox {
        QBox {
            lo: [self.u16(), self.u16(), self.u16()],
            hi: [self.u16(), self.u16(), self.u16()],
        }
    }
}

/// Parses and checks a header from the first [`HEADER`] bytes of a file of `len` bytes.
pub fn parse_header(bytes: &[u8], len: u64, path: &str) -> Result<Header> {
    let corrupt = |offset: u64, reason: String| Error::Corrupt {
        format: FORMAT,
        path: path.to_string(),
        offset,
        reason,
    };
    if bytes.len() < HEADER {
        return Err(corrupt(
            0,
            format!("{len} bytes is shorter than the header ({HEADER})"),
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err(corrupt(
            0,
            "not a sequential point tree file (bad magic)".into(),
        ));
    }
    let mut c = Cursor { bytes, at: 8 };
    let version = c.u32();
    if (1..VERSION).contains(&version) {
        return Err(Error::OldVersion {
            format: FORMAT,
            changes: CHANGES,
            path: path.to_string(),
            version,
            current: VERSION,
        });
    }
    if version != VERSION {
        return Err(corrupt(
            8,
            format!("version {version}, this reads {VERSION}"),
        ));
    }
    let sum = u32::from_le_bytes([
        bytes[HEADER - 4],
        bytes[HEADER - 3],
        bytes[HEADER - 2],
        bytes[HEADER - 1],
    ]);
    if cloud::io::checksum::crc32(&bytes[..HEADER - 4]) != sum {
        return Err(Error::Checksum {
            path: path.to_string(),
            block: "the header".into(),
            offset: 0,
            end: HEADER as u64,
        });
    }
    let flags = c.u32();
    if flags > 1 {
        return Err(corrupt(12, format!("unknown flags {flags:#x}")));
    }
    let h = Header {
        colors: flags & 1 != 0,
        points: c.u64(),
        groups: c.u64(),
        entries: c.u64(),
        local: c.dvec3(),
        grid_origin: c.dvec3(),
        cell: c.f64(),
        leaf_diameter: c.f64(),
        root: c.qbox(),
    };
    if h.file_bytes() != Some(len) {
        return Err(corrupt(
            16,
            format!(
                "{} groups and {} entries do not make a file of {len} bytes",
                h.groups, h.entries
            ),
        ));
    }
    if h.points == 0 || h.entries < h.points || h.groups == 0 || h.entries > u64::from(u32::MAX) {
        return Err(corrupt(
            16,
            format!(
                "{} points, {} groups, {} entries is not a tree",
                h.points, h.groups, h.entries
            ),
        ));
    }
    let positive = |x: f64| x > 0.0 && x.is_finite();
    let ordered = (0..3).all(|k| h.root.lo[k] <= h.root.hi[k]);
    if !(h.local.is_finite()
        && h.grid_origin.is_finite()
        && positive(h.cell)
        && positive(h.leaf_diameter)
        && ordered)
    {
        return Err(corrupt(
            40,
            "origin, grid step, leaf diameter or root box out of range".into(),
        ));
    }
    Ok(h)
}
