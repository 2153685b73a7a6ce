//! LAS and LAZ over the `las` crate (with its `laz-parallel` feature; cargo feature `formats`).
//! LAZ is decoded on every core (`laz`'s `ParLasZipDecompressor`, one chunk per thread) when
//! its chunk table passes [`parallel_safe`]'s checks, else on one thread as before.
//!
//! Reading keeps the scaled coordinates (integer × scale + offset, as the header says), RGB
//! (16-bit channels, kept as their high bytes), intensity and classification. Points are read
//! in chunks of [`CHUNK`] into the cloud's own arrays, so the memory held while reading is the
//! cloud plus one chunk (the `las` crate's whole-file `read_all` would hold the raw records
//! too). [`LasOptions::classes`] keeps only the listed classifications (for example 2 for
//! ground, 6 for buildings).
//!
//! Writing ([`write_las`]): LAS 1.4 point format 2 (with colour) or 0, LAZ-compressed when
//! the path ends in `.laz`. Coordinates are quantised: the offset is the bounding box's centre
//! and the scale the smallest power of ten that keeps the box inside the 32-bit integer range
//! (at least 1e-9), so a round trip moves a point by at most half the scale; the scale is
//! reported.

use std::path::Path;

use glam::DVec3;
use las::{Builder, Color, Point, PointDataBuilder, Reader, Transform, Vector, Writer};

use super::Loaded;
use crate::error::{Error, Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Points decoded per chunk.
pub const CHUNK: u64 = 1 << 20;

/// Options of the LAS reader.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LasOptions {
    /// Keep only points of these classification codes (all when `None`).
    pub classes: Option<Vec<u8>>,
    /// Decode LAZ on one thread even where the parallel decoder would be used (to compare the
    /// two; the answer is the same).
    pub one_thread: bool,
}

/// The bytes of the smallest LAS header (LAS 1.0 to 1.2, §2.2 of the specification).
const MIN_HEADER: u64 = 227;

/// The fields of the public header block the checks below need, read from the raw bytes
/// (the `las` crate does not expose the offsets).
struct RawHeader {
    /// "Offset to point data" (byte 96, u32).
    point_data: u64,
    /// Whether the point format's compression bits (6 and 7) are set (LAZ).
    compressed: bool,
    /// "Point data record length" (byte 105, u16).
    record: u64,
    /// The point count the `las` crate will use: the legacy 32-bit count (byte 107), or when
    /// it is 0 the LAS 1.4 64-bit count (byte 247).
    points: u64,
    /// "Header size" (byte 94): where the VLRs start.
    header_size: u64,
    /// "Number of variable length records" (byte 100).
    vlrs: u32,
    /// The version (major, minor) (bytes 24, 25).
    version: (u8, u8),
    /// The legacy 32-bit point count (byte 107).
    legacy: u64,
    /// The LAS 1.4 64-bit point count (byte 247; 0 before 1.4).
    large: u64,
    /// The x, y, z scale factors (byte 131).
    scale: [f64; 3],
    /// The box the header gives (bytes 179 to 226: max x, min x, max y, min y, max z, min z),
    /// as (min, max).
    bounds: ([f64; 3], [f64; 3]),
    /// Where the point records must end: the first of the extended VLRs (LAS 1.4) or the
    /// waveform data packets (LAS 1.3) when they follow the points, else the end of the file.
    points_end: u64,
    /// What [`RawHeader::points_end`] is.
    points_end_what: &'static str,
}

impl RawHeader {
    /// Where the point count used lies: the legacy field, or LAS 1.4's 64-bit one when that
    /// is 0.
    fn count_at(&self) -> u64 {
        if self.legacy != 0 { 107 } else { 247 }
    }

    /// The box points must lie in: the header's, widened by half a step of each axis's scale
    /// (a writer may take the box from the coordinates before they are rounded to the grid)
    /// and a few units in the last place of its magnitude.
    fn box_with_slack(&self) -> ([f64; 3], [f64; 3]) {
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

fn raw_header(path: &Path, len: u64) -> Result<RawHeader, ReadError> {
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
fn check_counts_and_scale(path: &Path, raw: &RawHeader) -> Result<(), ReadError> {
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
fn check_laz(path: &Path, raw: &RawHeader, len: u64) -> Result<(), ReadError> {
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
fn parallel_safe(path: &Path, raw: &RawHeader, len: u64) -> bool {
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

/// Reads a LAS or LAZ file whole.
pub fn read_las(path: &Path, options: &LasOptions) -> Result<Loaded, ReadError> {
    let mut stream = LasStream::open(path, options)?;
    let announced = stream.announced;
    let n = announced as usize;
    let path = stream.path.as_path();
    let keep_all = options.classes.is_none();
    let reserve = if keep_all { n } else { 0 };
    // A LAZ header may claim as many points as its file has bytes: check the arrays (position,
    // intensity, classification, colour: 30 bytes a point) against memory before reserving.
    crate::memory::ensure(
        30 * reserve as u128,
        &format!("the {n} points {} announces", path.display()),
    )
    .map_err(|e| {
        ReadError::new(
            path,
            Location::File,
            ReadErrorKind::Malformed(e.to_string()),
        )
    })?;
    let mut cloud = PointCloud {
        positions: Vec::with_capacity(reserve),
        intensity: Some(Vec::with_capacity(reserve)),
        classification: Some(Vec::with_capacity(reserve)),
        colors: stream.with_color.then(|| Vec::with_capacity(reserve)),
        ..PointCloud::default()
    };
    while stream.next_into(&mut cloud)? {}
    let path = stream.path.as_path();
    if cloud.positions.is_empty() {
        return Err(ReadError::new(
            path,
            Location::File,
            if options.classes.is_some() {
                ReadErrorKind::Unsupported(format!(
                    "no point has a classification in {:?}",
                    options.classes
                ))
            } else {
                ReadErrorKind::Empty
            },
        ));
    }
    cloud.positions.shrink_to_fit();
    Ok(Loaded {
        cloud,
        ..Loaded::default()
    })
}

/// A LAS or LAZ file read chunk by chunk ([`CHUNK`] points at a time), with every check of
/// [`read_las`]: the memory held is one chunk.
pub struct LasStream {
    path: std::path::PathBuf,
    reader: Reader,
    raw: RawHeader,
    len: u64,
    chunk: las::PointData,
    /// Points the header announces.
    pub announced: u64,
    read: u64,
    /// Whether the points have RGB.
    pub with_color: bool,
    /// Whether LAZ is decoded on every core ([`parallel_safe`]).
    pub parallel: bool,
    classes: Option<Vec<u8>>,
}

impl LasStream {
    /// Opens `path` and checks its header and (LAZ) chunk table against the file.
    pub fn open(path: &Path, options: &LasOptions) -> Result<Self, ReadError> {
        let len = std::fs::metadata(path)
            .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?
            .len();
        if len == 0 {
            return Err(ReadError::new(path, Location::File, ReadErrorKind::Empty));
        }
        let raw = raw_header(path, len)?;
        if raw.point_data > len {
            return Err(ReadError::new(
                path,
                Location::Byte(len),
                ReadErrorKind::BadHeader(format!(
                    "the point data starts at byte {} but the file ends at byte {len}",
                    raw.point_data
                )),
            ));
        }
        check_counts_and_scale(path, &raw)?;
        // The point count against the file, before the `las` crate multiplies it by the record
        // length (which overflows for absurd counts): uncompressed records must fit in the file;
        // LAZ never compresses below a byte a point.
        let data_bytes = len - raw.point_data;
        let fits = if raw.compressed {
            data_bytes
        } else {
            data_bytes / raw.record.max(1)
        };
        if raw.points > fits {
            return Err(ReadError::new(
                path,
                Location::Byte(if raw.compressed {
                    len
                } else {
                    raw.point_data + fits * raw.record
                }),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: usize::try_from(raw.points).unwrap_or(usize::MAX),
                    found: fits as usize,
                },
            ));
        }
        if raw.compressed {
            check_laz(path, &raw, len)?;
        }
        // LAZ decoded on every core where the chunk table is one the parallel decoder cannot
        // trip on (`laz`'s `ParLasZipDecompressor` asserts where the sequential one returns
        // errors); every other file, and every LAS, the sequential reader as before.
        let parallel = raw.compressed && !options.one_thread && parallel_safe(path, &raw, len);
        let parallelism = if parallel {
            las::LazParallelism::Yes
        } else {
            las::LazParallelism::No
        };
        let file = std::fs::File::open(path)
            .map_err(|e| ReadError::new(path, Location::File, ReadErrorKind::Io(e)))?;
        let reader = Reader::with_options(
            std::io::BufReader::new(file),
            las::ReaderOptions::default().with_laz_parallelism(parallelism),
        )
        .map_err(|e| {
            ReadError::new(
                path,
                Location::File,
                ReadErrorKind::BadHeader(e.to_string()),
            )
        })?;
        let header = reader.header().clone();
        let announced = header.number_of_points();
        // The same check on the count the crate parsed (it may differ from the raw fields above
        // for headers those fields do not describe).
        let record = raw.record.max(1);
        let plausible = if raw.compressed {
            data_bytes
        } else {
            data_bytes / record
        };
        if announced > plausible {
            return Err(ReadError::new(
                path,
                Location::Byte(if raw.compressed {
                    len
                } else {
                    raw.point_data + plausible * record
                }),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: announced as usize,
                    found: plausible as usize,
                },
            ));
        }
        let chunk = PointDataBuilder::new().for_header(&header).build();
        Ok(Self {
            path: path.to_owned(),
            reader,
            raw,
            len,
            chunk,
            announced,
            read: 0,
            with_color: header.point_format().has_color,
            parallel,
            classes: options.classes.clone(),
        })
    }

    /// Points decoded so far.
    pub fn read(&self) -> u64 {
        self.read
    }

    /// Appends the next chunk's points (those of the kept classes) to `cloud`'s positions,
    /// intensity, classification and colours (each where `cloud` has the array); `false` once
    /// every point was read. A file with fewer points than announced is
    /// [`ReadErrorKind::Truncated`].
    pub fn next_into(&mut self, cloud: &mut PointCloud) -> Result<bool, ReadError> {
        let (path, raw, announced, record) = (
            self.path.as_path(),
            &self.raw,
            self.announced,
            self.raw.record.max(1),
        );
        let read = self.read;
        let keep = |c: u8| self.classes.as_ref().is_none_or(|k| k.contains(&c));
        if read >= announced {
            return Ok(false);
        }
        // Where the failing points start: exact for LAS; for LAZ the start of the compressed
        // data, with the point range in the message.
        let malformed = |e: las::Error| {
            let at = if raw.compressed {
                raw.point_data
            } else {
                raw.point_data + read * record
            };
            ReadError::new(
                path,
                Location::Byte(at),
                ReadErrorKind::Malformed(format!(
                    "decoding points {read}.. of {announced}{}: {e}",
                    if raw.compressed {
                        " (corrupt compressed data)"
                    } else {
                        ""
                    }
                )),
            )
        };
        let got = self
            .reader
            .fill_points(CHUNK.min(announced - read), &mut self.chunk)
            .map_err(malformed)?;
        if got == 0 {
            return Err(ReadError::new(
                path,
                Location::Byte(self.len),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: announced as usize,
                    found: read as usize,
                },
            ));
        }
        let (lo, hi) = raw.box_with_slack();
        for (k, point) in self.chunk.points().enumerate() {
            let point = point.map_err(malformed)?;
            let index = (read + k as u64) as usize;
            let at = if raw.compressed {
                Location::File
            } else {
                Location::Byte(raw.point_data + index as u64 * record)
            };
            let xyz = [point.x, point.y, point.z];
            if let Some(&value) = xyz.iter().find(|v| !v.is_finite()) {
                return Err(ReadError::new(
                    path,
                    at,
                    ReadErrorKind::NonFinite { index, value },
                ));
            }
            // Every point in the header's box (corrupt data decodes to points anywhere).
            if (0..3).any(|a| !(lo[a] <= xyz[a] && xyz[a] <= hi[a])) {
                let (blo, bhi) = raw.bounds;
                return Err(ReadError::new(
                    path,
                    at,
                    ReadErrorKind::Malformed(format!(
                        "point {index} at ({}, {}, {}) lies outside the header's box \
                         ({}, {}, {}) .. ({}, {}, {}){}",
                        xyz[0],
                        xyz[1],
                        xyz[2],
                        blo[0],
                        blo[1],
                        blo[2],
                        bhi[0],
                        bhi[1],
                        bhi[2],
                        if raw.compressed {
                            " (corrupt compressed data, or a wrong box)"
                        } else {
                            " (corrupt data, or a wrong box)"
                        }
                    )),
                ));
            }
            let class = u8::from(point.classification);
            if !keep(class) {
                continue;
            }
            cloud.positions.push(DVec3::new(point.x, point.y, point.z));
            if let Some(v) = cloud.intensity.as_mut() {
                v.push(point.intensity);
            }
            if let Some(v) = cloud.classification.as_mut() {
                v.push(class);
            }
            if let Some(colors) = cloud.colors.as_mut() {
                let c = point.color.unwrap_or(Color::new(0, 0, 0));
                colors.push([
                    (c.red >> 8) as u8,
                    (c.green >> 8) as u8,
                    (c.blue >> 8) as u8,
                ]);
            }
        }
        self.read += got;
        Ok(true)
    }
}

/// True when `path` ends in `.laz` (any case): the writers compress then.
fn is_laz(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("laz"))
}

/// The scale [`write_las`] uses for points in `min..=max`.
pub fn las_scale(min: DVec3, max: DVec3) -> f64 {
    let half = ((max - min) * 0.5).max_element();
    let mut scale = 1e-9f64;
    while half / scale > 2.0e9 {
        scale *= 10.0;
    }
    scale
}

/// Writes `cloud` as LAS (or LAZ, by the extension), whole or not at all
/// ([`super::atomic`]); returns the scale used.
pub fn write_las(path: &Path, cloud: &PointCloud) -> Result<f64, Error> {
    let compress = is_laz(path);
    super::atomic::write_via(
        path,
        |partial| write_las_to(partial, path, cloud, compress),
        |source| Error::Write {
            path: path.to_owned(),
            source,
        },
    )
}

/// A LAS 1.4 header for points in `min..=max` (point format 0, or 2 with colours), and its
/// scale: the coordinates on an integer grid of [`las_scale`] around the box's centre.
fn las_header(
    min: DVec3,
    max: DVec3,
    colors: bool,
    compress: bool,
) -> Result<(las::Header, f64), las::Error> {
    let scale = las_scale(min, max);
    let center = (min + max) * 0.5;
    // An offset that is a multiple of the scale keeps every coordinate on the integer grid.
    let offset = (center / scale).round() * scale;
    let mut builder = Builder::from((1, 4));
    builder.point_format = las::point::Format::new(if colors { 2 } else { 0 })?;
    builder.transforms = Vector {
        x: Transform {
            scale,
            offset: offset.x,
        },
        y: Transform {
            scale,
            offset: offset.y,
        },
        z: Transform {
            scale,
            offset: offset.z,
        },
    };
    builder.point_format.is_compressed = compress;
    Ok((builder.into_header()?, scale))
}

/// Writes positions as LAS (or LAZ, by the extension) without holding them: `next` appends
/// the next batch to the vector it is given and says whether more follow. Every point must
/// lie in `min..=max` (the header's grid is sized from them; a point outside, or one that is
/// not finite, is an error). Whole or not at all; returns the scale and the points written.
pub fn write_las_streamed(
    path: &Path,
    min: DVec3,
    max: DVec3,
    mut next: impl FnMut(&mut Vec<DVec3>) -> bool,
) -> Result<(f64, u64), Error> {
    let compress = is_laz(path);
    let werr = |e: las::Error| Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(e.to_string()),
    };
    if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
        return Err(Error::Write {
            path: path.to_owned(),
            source: std::io::Error::other(format!("the box {min} .. {max} is not a box")),
        });
    }
    super::atomic::write_via(
        path,
        |partial| {
            let (header, scale) = las_header(min, max, false, compress).map_err(werr)?;
            let file = std::fs::File::create(partial).map_err(|source| Error::Write {
                path: path.to_owned(),
                source,
            })?;
            let mut writer = Writer::new(std::io::BufWriter::with_capacity(1 << 20, file), header)
                .map_err(werr)?;
            let mut batch = Vec::new();
            let mut count = 0u64;
            loop {
                batch.clear();
                let more = next(&mut batch);
                for p in &batch {
                    if !(p.is_finite() && p.cmpge(min).all() && p.cmple(max).all()) {
                        return Err(Error::Write {
                            path: path.to_owned(),
                            source: std::io::Error::other(format!(
                                "point {count} at {p} lies outside the announced box \
                                 {min} .. {max}"
                            )),
                        });
                    }
                    writer
                        .write_point(Point {
                            x: p.x,
                            y: p.y,
                            z: p.z,
                            ..Point::default()
                        })
                        .map_err(werr)?;
                    count += 1;
                }
                if !more {
                    break;
                }
            }
            writer.close().map_err(werr)?;
            Ok((scale, count))
        },
        |source| Error::Write {
            path: path.to_owned(),
            source,
        },
    )
}

fn write_las_to(
    partial: &Path,
    path: &Path,
    cloud: &PointCloud,
    compress: bool,
) -> Result<f64, Error> {
    let werr = |e: las::Error| Error::Write {
        path: path.to_owned(),
        source: std::io::Error::other(e.to_string()),
    };
    let bbox = cloud.bbox().ok_or(Error::EmptyCloud)?;
    let (header, scale) =
        las_header(bbox.min, bbox.max, cloud.colors.is_some(), compress).map_err(werr)?;
    let file = std::fs::File::create(partial).map_err(|source| Error::Write {
        path: path.to_owned(),
        source,
    })?;
    let mut writer =
        Writer::new(std::io::BufWriter::with_capacity(1 << 20, file), header).map_err(werr)?;
    for (i, p) in cloud.positions.iter().enumerate() {
        let mut point = Point {
            x: p.x,
            y: p.y,
            z: p.z,
            ..Point::default()
        };
        if let Some(v) = &cloud.intensity {
            point.intensity = v[i];
        }
        if let Some(v) = &cloud.classification {
            point.classification = las::point::Classification::new(v[i]).map_err(werr)?;
        }
        if let Some(c) = &cloud.colors {
            let [r, g, b] = c[i];
            point.color = Some(Color::new(
                u16::from(r) << 8 | u16::from(r),
                u16::from(g) << 8 | u16::from(g),
                u16::from(b) << 8 | u16::from(b),
            ));
        }
        writer.write_point(point).map_err(werr)?;
    }
    writer.close().map_err(werr)?;
    Ok(scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_streamed_file_reads_back_like_a_whole_one() {
        let dir = tempfile::tempdir().unwrap();
        let positions: Vec<DVec3> = (0..2500)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                DVec3::new(t.sin() * 3.0, t.cos() * 2.0, t)
            })
            .collect();
        let cloud = PointCloud {
            positions: positions.clone(),
            ..PointCloud::default()
        };
        let bbox = cloud.bbox().unwrap();
        for name in ["s.las", "s.laz"] {
            let whole = dir.path().join(format!("whole-{name}"));
            let streamed = dir.path().join(name);
            write_las(&whole, &cloud).unwrap();
            let mut at = 0;
            let (_, count) = write_las_streamed(&streamed, bbox.min, bbox.max, |batch| {
                let end = (at + 1000).min(positions.len());
                batch.extend_from_slice(&positions[at..end]);
                at = end;
                at < positions.len()
            })
            .unwrap();
            assert_eq!(count, 2500);
            let a = read_las(&whole, &LasOptions::default()).unwrap().cloud;
            let b = read_las(&streamed, &LasOptions::default()).unwrap().cloud;
            assert_eq!(a.positions, b.positions);
        }
    }

    #[test]
    fn a_point_outside_the_box_fails_and_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.laz");
        let err = write_las_streamed(&path, DVec3::ZERO, DVec3::ONE, |batch| {
            batch.push(DVec3::splat(0.5));
            batch.push(DVec3::new(0.5, 2.0, 0.5));
            false
        })
        .unwrap_err();
        assert!(
            err.to_string().contains("outside the announced box"),
            "{err}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert!(
            write_las_streamed(&path, DVec3::ONE, DVec3::ZERO, |_| false).is_err(),
            "an inverted box"
        );
    }
}
