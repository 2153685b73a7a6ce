//! A COPC file read as the COPC 1.0 specification lays it out (copc.io, "COPC Specification
//! 1.0"): a LAS 1.4 header, the `copc` info VLR (record 1: the octree's centre, half size and
//! root spacing, and where the root hierarchy page is), the LASzip VLR, an Extra Bytes VLR, and
//! the hierarchy: pages of 32-byte entries (a voxel key `level x y z`, then `offset`,
//! `byte_size` and `point_count`; a count of −1 points to a child page), each node's points one
//! LAZ 1.4 layered chunk at `offset`. The header, the VLRs and the hierarchy are parsed here,
//! bounded by the file's length (the `las` crate's COPC reader reads only the first EVLR and
//! sizes buffers from the file's own numbers; a damaged file must be an error naming it, never
//! a panic or an allocation the file asks for); a node's chunk is decoded by the `laz` crate's
//! layered decompressor (as `las::CopcReader` does), only its `x y z` and Extra Bytes layers.
//!
//! The file must hold the points of the cloud pointsight sent, each naming its original index
//! in the Extra Bytes attribute `index` (u32, written by [`crate::input`]): [`Copc::open`]
//! checks the header's point count against it and that the hierarchy is an octree (every key
//! inside its level, every node's parent present, the counts summing to the header's);
//! [`Copc::verify`] decodes every node and checks that each index 0..n comes back exactly
//! once.

use std::collections::HashMap;
use std::fs::File;
use std::io::Cursor;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use laz::DecompressionSelection;
use laz::laszip::{LazItem, LazVlr};
use laz::record::{LayeredPointRecordDecompressor, RecordDecompressor};

use crate::error::{Result, copc, io};
use crate::input::{INDEX_NAME, INDEX_TYPE};

/// Deepest octree level accepted (keys up to 2^30 per axis).
pub const MAX_LEVEL: i32 = 30;

/// A voxel key: level, then the cell along x, y and z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Key {
    /// Level (0: the root).
    pub l: i32,
    /// Cell along x.
    pub x: i32,
    /// Cell along y.
    pub y: i32,
    /// Cell along z.
    pub z: i32,
}

impl Key {
    /// The root.
    pub const ROOT: Key = Key {
        l: 0,
        x: 0,
        y: 0,
        z: 0,
    };

    /// The child in octant `dir` (bit 0: +x half, bit 1: +y, bit 2: +z), as COPC numbers them.
    pub fn child(self, dir: usize) -> Key {
        let bit = |b: usize| i32::from((dir >> b) & 1 == 1);
        Key {
            l: self.l + 1,
            x: 2 * self.x + bit(0),
            y: 2 * self.y + bit(1),
            z: 2 * self.z + bit(2),
        }
    }

    /// The parent (the root's is itself).
    pub fn parent(self) -> Key {
        if self.l == 0 {
            return self;
        }
        Key {
            l: self.l - 1,
            x: self.x >> 1,
            y: self.y >> 1,
            z: self.z >> 1,
        }
    }
}

/// One node of the hierarchy.
#[derive(Debug, Clone)]
pub struct Node {
    /// Its key.
    pub key: Key,
    /// Offset of its chunk in the file.
    pub offset: u64,
    /// Bytes of its chunk.
    pub bytes: u64,
    /// Points in its chunk.
    pub points: u64,
    /// Its children's positions in [`Copc::nodes`], per octant.
    pub children: [Option<u32>; 8],
}

/// An opened COPC file: its header's numbers and its hierarchy, held in memory.
pub struct Copc {
    /// The file.
    pub path: PathBuf,
    file: File,
    /// Its length.
    pub file_bytes: u64,
    /// Points (the header's count, checked against the cloud and the hierarchy).
    pub n_points: u64,
    scale: [f64; 3],
    offset: [f64; 3],
    /// The octree's centre.
    pub center: [f64; 3],
    /// Half the root cube's side.
    pub halfsize: f64,
    /// The root level's point spacing (halved per level).
    pub spacing: f64,
    record_len: usize,
    index_at: usize,
    items: Vec<LazItem>,
    /// The nodes, the root first, each after its parent.
    pub nodes: Vec<Node>,
    /// Bytes read by [`Copc::open`]: the header, the VLRs and the hierarchy pages.
    pub opened_bytes: u64,
}

/// A node's decoded points: original indices and positions.
#[derive(Debug, Default)]
pub struct NodePoints {
    /// Original indices.
    pub indices: Vec<u32>,
    /// Positions (dequantised), when asked for.
    pub positions: Vec<[f64; 3]>,
}

fn le_u16(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn le_u32(b: &[u8], o: usize) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[o..o + 4]);
    u32::from_le_bytes(a)
}
fn le_i32(b: &[u8], o: usize) -> i32 {
    le_u32(b, o) as i32
}
fn le_u64(b: &[u8], o: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[o..o + 8]);
    u64::from_le_bytes(a)
}
fn le_f64(b: &[u8], o: usize) -> f64 {
    f64::from_bits(le_u64(b, o))
}
/// A NUL-padded ASCII field.
fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// Bytes of one Extra Bytes attribute of `data_type` (LAS 1.4 R15, table 24; type 0 is
/// `options` raw bytes); `None` for the deprecated array types.
fn attribute_size(data_type: u8, options: u8) -> Option<usize> {
    Some(match data_type {
        0 => usize::from(options),
        1 | 2 => 1,
        3 | 4 => 2,
        5 | 6 | 9 => 4,
        7 | 8 | 10 => 8,
        _ => return None,
    })
}

impl Copc {
    /// Opens `path`, which must hold `expected_points` points (see the module's doc).
    pub fn open(path: &Path, expected_points: u64) -> Result<Copc> {
        let file = File::open(path).map_err(io(path))?;
        let file_bytes = file.metadata().map_err(io(path))?.len();
        let bad = |what: String| copc(path, what);
        let read_at = |offset: u64, len: u64, what: &str| -> Result<Vec<u8>> {
            if offset.checked_add(len).is_none_or(|end| end > file_bytes) {
                return Err(copc(
                    path,
                    format!(
                        "{what} ({len} bytes at {offset}) runs past the end of the file ({file_bytes} bytes)"
                    ),
                ));
            }
            let mut buf = vec![0u8; len as usize];
            file.read_exact_at(&mut buf, offset).map_err(io(path))?;
            Ok(buf)
        };
        let h = read_at(0, 375, "the LAS 1.4 header")?;
        if &h[0..4] != b"LASF" {
            return Err(bad("no LASF signature".into()));
        }
        if (h[24], h[25]) != (1, 4) {
            return Err(bad(format!("LAS {}.{}, not 1.4", h[24], h[25])));
        }
        let header_size = u64::from(le_u16(&h, 94));
        let point_data = u64::from(le_u32(&h, 96));
        let n_vlrs = le_u32(&h, 100);
        let format = h[104];
        let record_len = usize::from(le_u16(&h, 105));
        let scale = [le_f64(&h, 131), le_f64(&h, 139), le_f64(&h, 147)];
        let offset = [le_f64(&h, 155), le_f64(&h, 163), le_f64(&h, 171)];
        let n_points = le_u64(&h, 247);
        if header_size < 375 || point_data < header_size || point_data > file_bytes {
            return Err(bad(format!(
                "header size {header_size}, point data at {point_data} in {file_bytes} bytes"
            )));
        }
        if format & 0x80 == 0 {
            return Err(bad("its points are not LAZ-compressed".into()));
        }
        let base = match format & 0x3f {
            6 => 30,
            7 => 36,
            8 => 38,
            f => return Err(bad(format!("point format {f}, not 6, 7 or 8"))),
        };
        if scale.iter().chain(&offset).any(|v| !v.is_finite()) || scale.iter().any(|&s| s <= 0.0) {
            return Err(bad(format!("scale {scale:?}, offset {offset:?}")));
        }
        if n_points != expected_points {
            return Err(bad(format!(
                "{n_points} points, the cloud has {expected_points}"
            )));
        }
        // The VLRs, between the header and the points.
        let mut pos = header_size;
        let (mut info, mut laz, mut extra) = (None, None, None);
        for k in 0..n_vlrs {
            let vh = read_at(pos, 54, &format!("VLR {k}'s header"))?;
            let len = u64::from(le_u16(&vh, 20));
            if pos + 54 + len > point_data {
                return Err(bad(format!("VLR {k} runs into the points")));
            }
            let data = read_at(pos + 54, len, &format!("VLR {k}"))?;
            match (text(&vh[2..18]).as_str(), le_u16(&vh, 18)) {
                ("copc", 1) => info = Some(data),
                ("laszip encoded", 22204) => laz = Some(data),
                ("LASF_Spec", 4) => extra = Some(data),
                _ => {}
            }
            pos += 54 + len;
        }
        let info = info.ok_or_else(|| bad("no COPC info VLR".into()))?;
        if info.len() != 160 {
            return Err(bad(format!(
                "a COPC info VLR of {} bytes, not 160",
                info.len()
            )));
        }
        let center = [le_f64(&info, 0), le_f64(&info, 8), le_f64(&info, 16)];
        let halfsize = le_f64(&info, 24);
        let spacing = le_f64(&info, 32);
        let (root_page, root_size) = (le_u64(&info, 40), le_u64(&info, 48));
        if center.iter().any(|c| !c.is_finite())
            || !(halfsize.is_finite() && halfsize > 0.0)
            || !(spacing.is_finite() && spacing > 0.0)
        {
            return Err(bad(format!(
                "COPC info: centre {center:?}, half size {halfsize}, spacing {spacing}"
            )));
        }
        let laz = laz.ok_or_else(|| bad("no LASzip VLR".into()))?;
        let items = LazVlr::from_buffer(&laz)
            .map_err(|e| bad(format!("LASzip VLR: {e}")))?
            .items()
            .clone();
        let items_size: usize = items.iter().map(|i| usize::from(i.size())).sum();
        if items_size != record_len {
            return Err(bad(format!(
                "LASzip items of {items_size} bytes for records of {record_len}"
            )));
        }
        // The index attribute's place in the record.
        let extra = extra.ok_or_else(|| bad("no Extra Bytes VLR (no `index` attribute)".into()))?;
        let mut at = base;
        let mut index_at = None;
        for d in extra.chunks_exact(192) {
            let size = attribute_size(d[2], d[3])
                .ok_or_else(|| bad(format!("Extra Bytes data type {}", d[2])))?;
            if text(&d[4..36]) == INDEX_NAME {
                if d[2] != INDEX_TYPE {
                    return Err(bad(format!("`index` of data type {}, not u32", d[2])));
                }
                index_at = Some(at);
            }
            at += size;
        }
        let index_at = index_at.ok_or_else(|| bad("no Extra Bytes attribute `index`".into()))?;
        if at != record_len {
            return Err(bad(format!(
                "records of {record_len} bytes, {at} by the format and Extra Bytes"
            )));
        }
        // The hierarchy: pages from the root's, each read once.
        let mut opened_bytes = pos;
        let mut entries: HashMap<Key, (u64, i32, i32)> = HashMap::new();
        let mut pages = vec![(root_page, root_size)];
        let mut seen_pages = std::collections::HashSet::new();
        let mut page_bytes = 0u64;
        while let Some((at, size)) = pages.pop() {
            if !seen_pages.insert(at) {
                return Err(bad(format!(
                    "the hierarchy page at {at} is referenced twice"
                )));
            }
            if size == 0 || size % 32 != 0 {
                return Err(bad(format!("a hierarchy page of {size} bytes at {at}")));
            }
            page_bytes += size;
            if page_bytes > file_bytes {
                return Err(bad("the hierarchy pages outgrow the file".into()));
            }
            let page = read_at(at, size, "a hierarchy page")?;
            opened_bytes += size;
            for e in page.chunks_exact(32) {
                let key = Key {
                    l: le_i32(e, 0),
                    x: le_i32(e, 4),
                    y: le_i32(e, 8),
                    z: le_i32(e, 12),
                };
                let (off, bytes, count) = (le_u64(e, 16), le_i32(e, 24), le_i32(e, 28));
                let cells = if (0..=MAX_LEVEL).contains(&key.l) {
                    1i64 << key.l
                } else {
                    0
                };
                if ![key.x, key.y, key.z]
                    .iter()
                    .all(|&c| (0..cells).contains(&i64::from(c)))
                {
                    return Err(bad(format!("hierarchy key {key:?} is outside the octree")));
                }
                if count == -1 {
                    let size = u64::try_from(bytes)
                        .map_err(|_| bad(format!("child page of {bytes} bytes")))?;
                    pages.push((off, size));
                    continue;
                }
                if count < 0 {
                    return Err(bad(format!("node {key:?} has {count} points")));
                }
                if entries.insert(key, (off, bytes, count)).is_some() {
                    return Err(bad(format!("node {key:?} is listed twice")));
                }
            }
        }
        // Checked as an octree, then laid out root first, each node after its parent.
        let mut total = 0u64;
        for (key, &(off, bytes, count)) in &entries {
            if key.l > 0 && !entries.contains_key(&key.parent()) {
                return Err(bad(format!("node {key:?} has no parent in the hierarchy")));
            }
            if count > 0 {
                let fits = bytes > 0
                    && off >= point_data
                    && off
                        .checked_add(bytes as u64)
                        .is_some_and(|end| end <= file_bytes);
                if !fits {
                    return Err(bad(format!(
                        "node {key:?}'s chunk ({bytes} bytes at {off}) is not within the points"
                    )));
                }
            }
            total += count as u64;
        }
        if total != n_points {
            return Err(bad(format!(
                "the hierarchy holds {total} points, the header {n_points}"
            )));
        }
        let root = entries
            .get(&Key::ROOT)
            .ok_or_else(|| bad("no root node".into()))?;
        let node = |key: Key, &(off, bytes, count): &(u64, i32, i32)| Node {
            key,
            offset: off,
            bytes: bytes.max(0) as u64,
            points: count as u64,
            children: [None; 8],
        };
        let mut nodes = vec![node(Key::ROOT, root)];
        let mut k = 0;
        while k < nodes.len() {
            let key = nodes[k].key;
            for dir in 0..8 {
                let c = key.child(dir);
                if let Some(e) = entries.get(&c) {
                    nodes[k].children[dir] = Some(nodes.len() as u32);
                    nodes.push(node(c, e));
                }
            }
            k += 1;
        }
        Ok(Copc {
            path: path.to_owned(),
            file,
            file_bytes,
            n_points,
            scale,
            offset,
            center,
            halfsize,
            spacing,
            record_len,
            index_at,
            items,
            nodes,
            opened_bytes,
        })
    }

    /// The cube of node `k`: its low and high corners.
    pub fn bounds(&self, k: usize) -> ([f64; 3], [f64; 3]) {
        let key = self.nodes[k].key;
        let side = 2.0 * self.halfsize / f64::from(1u32 << key.l);
        let cell = [key.x, key.y, key.z];
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for a in 0..3 {
            lo[a] = self.center[a] - self.halfsize + side * f64::from(cell[a]);
            hi[a] = lo[a] + side;
        }
        (lo, hi)
    }

    /// The point spacing of level `l`: the root's halved per level.
    pub fn level_spacing(&self, l: i32) -> f64 {
        self.spacing / f64::from(1u32 << l)
    }

    /// Reads and decodes node `k`'s chunk: its points' original indices, and their positions
    /// when `positions`. Returns them and the bytes read.
    pub fn read_node(&self, k: usize, positions: bool) -> Result<(NodePoints, u64)> {
        let node = &self.nodes[k];
        let mut out = NodePoints::default();
        if node.points == 0 {
            return Ok((out, 0));
        }
        let bad = |what: String| copc(&self.path, format!("node {:?}: {what}", node.key));
        let mut chunk = vec![0u8; node.bytes as usize];
        self.file
            .read_exact_at(&mut chunk, node.offset)
            .map_err(io(&self.path))?;
        let mut selection = DecompressionSelection::base().decompress_extra_bytes();
        if positions {
            selection = selection.decompress_z();
        }
        let n = node.points as usize;
        // The decoder reads what the chunk holds; a damaged chunk may make it panic rather
        // than fail (its checks are debug assertions), which is caught and named.
        let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut d = LayeredPointRecordDecompressor::new(Cursor::new(&chunk[..]));
            d.set_fields_from(&self.items).map_err(|e| e.to_string())?;
            d.set_selection(selection);
            let mut rec = vec![0u8; self.record_len];
            let mut indices = Vec::with_capacity(n.min(1 << 20));
            let mut xyz = Vec::with_capacity(if positions { n.min(1 << 20) } else { 0 });
            for p in 0..n {
                d.decompress_next(&mut rec)
                    .map_err(|e| format!("point {p} of {n}: {e}"))?;
                let index = le_u32(&rec, self.index_at);
                if u64::from(index) >= self.n_points {
                    return Err(format!(
                        "point {p} names index {index}, outside the cloud's {} points",
                        self.n_points
                    ));
                }
                indices.push(index);
                if positions {
                    let q =
                        |a: usize| f64::from(le_i32(&rec, 4 * a)) * self.scale[a] + self.offset[a];
                    xyz.push([q(0), q(1), q(2)]);
                }
            }
            Ok((indices, xyz))
        }));
        match decoded {
            Ok(Ok((indices, xyz))) => {
                out.indices = indices;
                out.positions = xyz;
                Ok((out, node.bytes))
            }
            Ok(Err(what)) => Err(bad(what)),
            Err(_) => Err(bad(
                "its chunk does not decode (the decoder panicked)".into()
            )),
        }
    }

    /// Decodes every node and checks that each index 0..n comes back exactly once; returns
    /// the bytes read.
    pub fn verify(&self) -> Result<u64> {
        let n = self.n_points as usize;
        let mut seen = vec![false; n];
        let mut read = 0;
        for k in 0..self.nodes.len() {
            let (pts, bytes) = self.read_node(k, false)?;
            read += bytes;
            for i in pts.indices {
                if std::mem::replace(&mut seen[i as usize], true) {
                    return Err(copc(
                        &self.path,
                        format!(
                            "index {i} comes back twice (again in node {:?})",
                            self.nodes[k].key
                        ),
                    ));
                }
            }
        }
        // The counts sum to n (checked by `open`) and no index repeats: each came back once.
        Ok(read)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn children_and_parents_follow_copc_key_numbering() {
        let k = Key {
            l: 2,
            x: 1,
            y: 2,
            z: 3,
        };
        // Octant bit 0 is +x, bit 1 +y, bit 2 +z.
        assert_eq!(
            k.child(5),
            Key {
                l: 3,
                x: 3,
                y: 4,
                z: 7
            }
        );
        for dir in 0..8 {
            assert_eq!(k.child(dir).parent(), k);
        }
        assert_eq!(Key::ROOT.parent(), Key::ROOT);
    }

    #[test]
    fn a_file_that_is_not_copc_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("copc-lod-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("short.laz");
        std::fs::write(&path, b"LASF and not much else").expect("write");
        let e = Copc::open(&path, 1).err().expect("refused").to_string();
        assert!(
            e.contains("short.laz") && e.contains("runs past the end"),
            "{e}"
        );
        let mut header = vec![0u8; 375];
        header[..4].copy_from_slice(b"LASF");
        header[24] = 1;
        header[25] = 2;
        std::fs::write(&path, &header).expect("write");
        let e = Copc::open(&path, 1).err().expect("refused").to_string();
        assert!(e.contains("LAS 1.2, not 1.4"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
