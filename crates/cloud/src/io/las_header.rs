//! The LAS public header block read from its raw bytes, and the checks made on it and on a
//! LAZ file's structure before the `las` and `laz` crates read them ([`super::las`]): what the
//! crates trust (counts, offsets, the chunk table) is checked against the file, and what
//! corrupt data would otherwise slip through as points (a scale of 0, a count lower than the
//! records the file holds, LAS 1.4's two counts disagreeing) is an error naming the byte.

use std::path::Path;

use crate::error::{Location, ReadError, ReadErrorKind};

/// The bytes of the smallest LAS header (LAS 1.0 to 1.2, §2.2 of the specification).
const MIN_HEADER: u64 = 227;

/// The fields of the public header block the checks below need, read from the raw bytes
/// (the `las` crate does not expose the offsets).
pub(super) struct RawHeader {
    /// "Offset to point data" (byte 96, u32).
    pub(super) point_data: u64,
    /// Whether the point format's compression bits (6 and 7) are set (LAZ).
    pub(super) compressed: bool,
    /// "Point data record length" (byte 105, u16).
    pub(super) record: u64,
    /// The point count the `las` crate will use: the legacy 32-bit count (byte 107), or when
    /// it is 0 the LAS 1.4 64-bit count (byte 247).
    pub(super) points: u64,
    /// "Header size" (byte 94): where the VLRs start.
    pub(super) header_size: u64,
    /// "Number of variable length records" (byte 100).
    pub(super) vlrs: u32,
    /// The version (major, minor) (bytes 24, 25).
    pub(super) version: (u8, u8),
    /// The legacy 32-bit point count (byte 107).
    pub(super) legacy: u64,
    /// The LAS 1.4 64-bit point count (byte 247; 0 before 1.4).
    pub(super) large: u64,
    /// The x, y, z scale factors (byte 131).
    pub(super) scale: [f64; 3],
    /// The box the header gives (bytes 179 to 226: max x, min x, max y, min y, max z, min z),
    /// as (min, max).
    pub(super) bounds: ([f64; 3], [f64; 3]),
    /// Where the point records must end: the first of the extended VLRs (LAS 1.4) or the
    /// waveform data packets (LAS 1.3) when they follow the points, else the end of the file.
    pub(super) points_end: u64,
    /// What [`RawHeader::points_end`] is.
    pub(super) points_end_what: &'static str,
}

impl RawHeader {
    /// Where the point count used lies: the legacy field, or LAS 1.4's 64-bit one when that
    /// is 0.
    pub(super) fn count_at(&self) -> u64 {
        if self.legacy != 0 { 107 } else { 247 }
    }

    /// The box points must lie in: the header's, widened by half a step of each axis's scale
    /// (a writer may take the box from the coordinates before they are rounded to the grid)
    /// and a few units in the last place of its magnitude.
    pub(super) fn box_with_slack(&self) -> ([f64; 3], [f64; 3]) {
        let (lo, hi) = self.bounds;
        let mut out = (lo, hi);
        for a in 0..3 {
            let slack =
                0.5 * self.scale[a].abs() + 4.0 * f64::EPSILON * lo[a].abs().max(hi[a].abs());
            out.0[a] = lo[a] - slack;
            out.1[a] = hi[a] + slack;
        }
        out
    }
}

pub(super) fn raw_header(path: &Path, len: u64) -> Result<RawHeader, ReadError> {
    use std::io::Read;
    if len < MIN_HEADER {
        return Err(ReadError::new(
            path,
            Location::Byte(len),
            ReadErrorKind::BadHeader(format!(
                "the file ends after {len} bytes, inside the LAS header (at least \
                 {MIN_HEADER} bytes)"
            )),
        ));
    }
    let mut head = [0u8; 255];
    let got = (len as usize).min(head.len());
    super::open(path)?
        .read_exact(&mut head[..got])
        .map_err(|e| ReadError::new(path, Location::Byte(0), ReadErrorKind::Io(e)))?;
    let u32_at = |i: usize| u32::from_le_bytes([head[i], head[i + 1], head[i + 2], head[i + 3]]);
    let header_size = u16::from_le_bytes([head[94], head[95]]);
    let legacy = u64::from(u32_at(107));
    let large = if (head[24], head[25]) >= (1, 4) && got >= 255 {
        let mut b = [0u8; 8];
        b.copy_from_slice(&head[247..255]);
        u64::from_le_bytes(b)
    } else {
        0
    };
    let u64_at = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&head[i..i + 8]);
        u64::from_le_bytes(b)
    };
    let f64_at = |i: usize| f64::from_bits(u64_at(i));
    let version = (head[24], head[25]);
    let point_data = u64::from(u32_at(96));
    // Extended VLRs (1.4: start at byte 235, count at 243) and waveform data packets (1.3 and
    // later: start at byte 227) after the points bound them.
    let mut points_end = (len, "the end of the file");
    if version >= (1, 3) && got >= 235 {
        let waveform = u64_at(227);
        if waveform >= point_data && waveform > 0 && waveform < points_end.0 {
            points_end = (waveform, "the waveform data packets");
        }
    }
    if version >= (1, 4) && got >= 255 && u32_at(243) > 0 {
        let evlr = u64_at(235);
        if evlr >= point_data && evlr < points_end.0 {
            points_end = (evlr, "the extended VLRs");
        }
    }
    Ok(RawHeader {
        point_data,
        compressed: head[104] & 0xC0 != 0,
        record: u64::from(u16::from_le_bytes([head[105], head[106]])),
        points: if legacy != 0 { legacy } else { large },
        header_size: u64::from(header_size),
        vlrs: u32_at(100),
        version,
        legacy,
        large,
        scale: [f64_at(131), f64_at(139), f64_at(147)],
        bounds: (
            [f64_at(187), f64_at(203), f64_at(219)],
            [f64_at(179), f64_at(195), f64_at(211)],
        ),
        points_end: points_end.0,
        points_end_what: points_end.1,
    })
}

/// The header's fields that decide how many points there are and where they lie, checked
/// against each other and the file: no scale factor is 0 (or not finite; every coordinate
/// would be the offset); LAS 1.4's legacy count, when set, equals its 64-bit count; and an
/// uncompressed file holds no more whole point records between the point data and
/// [`RawHeader::points_end`] than the header announces (a count too low would drop the rest
/// silently; fewer records than announced is [`ReadErrorKind::Truncated`], checked after).
pub(super) fn check_counts_and_scale(path: &Path, raw: &RawHeader) -> Result<(), ReadError> {
    let bad = |at: u64, message: String| {
        Err(ReadError::new(
            path,
            Location::Byte(at),
            ReadErrorKind::BadHeader(message),
        ))
    };
    for (axis, &scale) in raw.scale.iter().enumerate() {
        if scale == 0.0 || !scale.is_finite() {
            return bad(
                131 + 8 * axis as u64,
                format!(
                    "the {} scale factor is {scale}: every point's {} would be its offset",
                    ["x", "y", "z"][axis],
                    ["x", "y", "z"][axis]
                ),
            );
        }
    }
    if raw.version >= (1, 4) && raw.legacy != 0 && raw.legacy != raw.large {
        return bad(
            107,
            format!(
                "LAS 1.4 point counts disagree: the legacy count (byte 107) says {} but the \
                 64-bit count (byte 247) says {}",
                raw.legacy, raw.large
            ),
        );
    }
    if !raw.compressed && raw.record > 0 && raw.points_end >= raw.point_data {
        let records = (raw.points_end - raw.point_data) / raw.record;
        if raw.points < records {
            return bad(
                raw.point_data + raw.points * raw.record,
                format!(
                    "the header announces {} points but the point data holds {records} records \
                     of {} bytes (up to {} at byte {})",
                    raw.points, raw.record, raw.points_end_what, raw.points_end
                ),
            );
        }
    }
    Ok(())
}

/// Reads `buf.len()` bytes at `offset`, as a located error when the file is shorter.
fn read_at(path: &Path, offset: u64, buf: &mut [u8]) -> Result<(), ReadError> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = std::fs::File::open(path)
        .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?;
    file.seek(SeekFrom::Start(offset))
        .and_then(|_| file.read_exact(buf))
        .map_err(|e| ReadError::new(path, Location::Byte(offset), ReadErrorKind::Io(e)))
}

/// The structure of a LAZ file checked before `laz` decodes it, because `laz` trusts it: it
/// panics on a LASzip record without items and reserves whatever chunk count the chunk table
/// announces (a 598-byte file asked for 16 GB). Checked here (LAZ 1.4 specification, §2.2
/// the LASzip VLR, §2.3 the chunk table): the LASzip VLR exists, lists at least one item and
/// has the length its item count implies; the chunk table lies inside the file and announces no
/// more chunks than there are points (each chunk holds at least one).
pub(super) fn check_laz(path: &Path, raw: &RawHeader, len: u64) -> Result<(), ReadError> {
    let bad = |at: u64, message: String| {
        Err(ReadError::new(
            path,
            Location::Byte(at),
            ReadErrorKind::BadHeader(message),
        ))
    };
    // The LASzip VLR.
    let Some(body) = laszip_vlr(path, raw, len)? else {
        return bad(
            raw.header_size,
            "a compressed point format without a LASzip VLR".to_owned(),
        );
    };
    // The chunk table.
    if raw.point_data + 8 > len {
        return bad(len, "truncated LAZ: no chunk table offset".to_owned());
    }
    let mut offset = [0u8; 8];
    read_at(path, raw.point_data, &mut offset)?;
    let table = i64::from_le_bytes(offset);
    let table = match u64::try_from(table) {
        Ok(t) if t.checked_add(8).is_some_and(|end| end <= len) && t >= raw.point_data + 8 => t,
        // -1: the writer did not record it; `laz` then finds the table at the end.
        _ if table == -1 => return Ok(()),
        _ => {
            return bad(
                len,
                format!(
                    "truncated LAZ: the chunk table should be at byte {table} but the file ends \
                     at byte {len}"
                ),
            );
        }
    };
    let mut head = [0u8; 8];
    read_at(path, table, &mut head)?;
    let chunks = u64::from(u32::from_le_bytes([head[4], head[5], head[6], head[7]]));
    if chunks > raw.points.max(1) || chunks > len {
        return bad(
            table + 4,
            format!(
                "the LAZ chunk table announces {chunks} chunks for {} points",
                raw.points
            ),
        );
    }
    // The header's count against the chunks (a count too low would drop the points of the
    // chunks after it silently): chunks of a fixed size hold ⌈points / size⌉ chunks; chunks of
    // variable size list their counts, which add up to the points.
    let chunk_size = u32::from_le_bytes([body[12], body[13], body[14], body[15]]);
    let counted = if chunk_size == u32::MAX {
        laz::LazVlr::from_buffer(&body).ok().and_then(|vlr| {
            use std::io::{Seek, SeekFrom};
            let mut file = std::fs::File::open(path).ok()?;
            file.seek(SeekFrom::Start(raw.point_data)).ok()?;
            let table =
                laz::laszip::ChunkTable::read_from(std::io::BufReader::new(file), &vlr).ok()?;
            table
                .as_ref()
                .iter()
                .try_fold(0u64, |a, e| a.checked_add(e.point_count))
        })
    } else {
        None
    };
    let consistent = match counted {
        Some(sum) => sum == raw.points,
        None if chunk_size == u32::MAX || chunk_size == 0 => true,
        None => chunks == raw.points.div_ceil(u64::from(chunk_size)),
    };
    if !consistent {
        return bad(
            raw.count_at(),
            format!(
                "the header announces {} points but the LAZ chunk table holds {}",
                raw.points,
                match counted {
                    Some(sum) => format!("{sum} points in {chunks} chunks"),
                    None => format!("{chunks} chunks of {chunk_size} points"),
                }
            ),
        );
    }
    Ok(())
}

/// Whether a LAZ file (already through [`check_laz`]) may go to the parallel decoder: its
/// chunk table, read and checked here, describes the points and bytes the file has, so that
/// none of the decoder's assertions and buffer sizes can depend on a corrupt number. Any doubt
/// is `false` (the sequential decoder then reads it, or reports what is wrong):
/// - the LASzip VLR parses, its items' sizes add up to the header's record length, and its
///   chunks are fixed-size with 1 ≤ chunk size ≤ points, or variable-size;
/// - the chunk table's offset is recorded (not −1) and the table has at least two chunks;
/// - fixed-size: ⌈points / chunk size⌉ chunks; variable-size: every chunk has 1 to 2^31 − 1
///   points and their sum is the point count;
/// - every chunk has 1 to 2^31 − 1 bytes and their sum fits between the table's offset and the
///   table (sums checked for overflow).
pub(super) fn parallel_safe(path: &Path, raw: &RawHeader, len: u64) -> bool {
    use std::io::{Seek, SeekFrom};
    let Ok(Some(body)) = laszip_vlr(path, raw, len) else {
        return false;
    };
    // The items' sizes (6 bytes each after the 34-byte head: type, size, version), in u64.
    let item_bytes: u64 = body[34..]
        .chunks_exact(6)
        .map(|c| u64::from(u16::from_le_bytes([c[2], c[3]])))
        .sum();
    let Ok(vlr) = laz::LazVlr::from_buffer(&body) else {
        return false;
    };
    let points = raw.points;
    let variable = vlr.uses_variable_size_chunks();
    let chunk_size = u64::from(vlr.chunk_size());
    if item_bytes != raw.record || (!variable && !(1..=points).contains(&chunk_size)) {
        return false;
    }
    let mut offset = [0u8; 8];
    if read_at(path, raw.point_data, &mut offset).is_err() {
        return false;
    }
    let Ok(table) = u64::try_from(i64::from_le_bytes(offset)) else {
        return false;
    };
    if table < raw.point_data + 8 || table + 8 > len {
        return false;
    }
    let Ok(mut file) = std::fs::File::open(path) else {
        return false;
    };
    if file.seek(SeekFrom::Start(raw.point_data)).is_err() {
        return false;
    }
    let Ok(chunks) = laz::laszip::ChunkTable::read_from(std::io::BufReader::new(&mut file), &vlr)
    else {
        return false;
    };
    let entries = chunks.as_ref();
    // `laz` decodes each count as an i32 and widens it: a negative one is near 2^64, so every
    // count must be below 2^31 and the sums are checked (a wrapped sum could pass).
    let small = |x: u64| (1..1 << 31).contains(&x);
    let sum = |f: fn(&laz::laszip::ChunkTableEntry) -> u64| {
        entries.iter().try_fold(0u64, |a, e| {
            small(f(e)).then(|| a.checked_add(f(e))).flatten()
        })
    };
    // The chunks lie between the table's offset field and the table.
    let data = table - raw.point_data - 8;
    let counts_ok = if variable {
        sum(|e| e.point_count) == Some(points)
    } else {
        entries.len() as u64 == points.div_ceil(chunk_size)
    };
    entries.len() >= 2 && counts_ok && sum(|e| e.byte_count).is_some_and(|b| b <= data)
}

/// The LASzip VLR's body (`None`: the file has none): the first VLR whose user id is exactly
/// `laszip encoded` (the bytes before its first NUL, as `las` reads it) and whose record id is
/// 22204, the one `las` hands to `laz`. An error when any VLR runs past the end of the file or
/// that one has not the length its item count implies.
fn laszip_vlr(path: &Path, raw: &RawHeader, len: u64) -> Result<Option<Vec<u8>>, ReadError> {
    let bad = |at: u64, message: String| {
        Err(ReadError::new(
            path,
            Location::Byte(at),
            ReadErrorKind::BadHeader(message),
        ))
    };
    let mut at = raw.header_size;
    let mut found = None;
    for _ in 0..raw.vlrs {
        let mut head = [0u8; 54];
        if at + 54 > len {
            return bad(
                at,
                format!("the VLR at byte {at} runs past the end of the file"),
            );
        }
        read_at(path, at, &mut head)?;
        let user = &head[2..18];
        let user = &user[..user.iter().position(|&c| c == 0).unwrap_or(user.len())];
        let record_id = u16::from_le_bytes([head[18], head[19]]);
        let length = u64::from(u16::from_le_bytes([head[20], head[21]]));
        if found.is_none() && user == b"laszip encoded" && record_id == 22204 {
            if length < 34 || at + 54 + length > len {
                return bad(at, format!("the LASzip VLR has {length} bytes"));
            }
            let mut body = vec![0u8; length as usize];
            read_at(path, at + 54, &mut body)?;
            let n = u64::from(u16::from_le_bytes([body[32], body[33]]));
            if n == 0 || 34 + 6 * n != length {
                return bad(
                    at + 54 + 32,
                    format!("the LASzip VLR lists {n} items in {length} bytes (34 + 6 per item)"),
                );
            }
            found = Some(body);
        }
        at += 54 + length;
    }
    Ok(found)
}
