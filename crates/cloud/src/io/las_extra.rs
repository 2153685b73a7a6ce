//! LAS extra bytes (LAS 1.4 R15 §2.6, the Extra Bytes VLR: user id `LASF_Spec`, record 4):
//! the descriptors that name and type the bytes a point record carries after its format's
//! fields, read to find the points' normals, and written for the normals pointsight exports.
//!
//! Each descriptor is 192 bytes: reserved (2), data type (1), options (1), name (32), unused
//! (4), no data, min and max (24 each), scale and offset (3 × f64 each), description (32). The
//! data types 1 to 10 are u8, i8, u16, i16, u32, i32, u64, i64, f32 and f64; type 0 is
//! `options` undocumented bytes; 11 to 30, deprecated, are pairs and triples of those. A value
//! is `raw × scale + offset` where the options' bits 3 and 4 say so.
//!
//! Normals are three fields named, case and spaces and underscores aside, `NormalX`,
//! `NormalY`, `NormalZ` (PDAL's dimensions, as CloudCompare writes them too), `normal x`...,
//! or `nx`, `ny`, `nz`. [`write_normals_vlr`] writes `NormalX`, `NormalY`, `NormalZ` as f32.

use las::Vlr;

/// Bytes of one descriptor.
const DESCRIPTOR: usize = 192;

/// The user id of the Extra Bytes VLR.
const USER: &str = "LASF_Spec";
/// Its record id.
const RECORD: u16 = 4;

/// Bytes of the normals [`write_normals_vlr`] describes: three f32.
pub const NORMAL_BYTES: u16 = 12;

/// The names [`write_normals_vlr`] gives the normals' fields.
pub const WRITTEN_NAMES: [&str; 3] = ["NormalX", "NormalY", "NormalZ"];

/// A scalar type of the extra bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl Kind {
    /// The scalar of data type `t` (1 to 10; the deprecated tuples 11 to 30 by their
    /// element's type) and how many of it a value holds.
    fn of(t: u8) -> Option<(Self, usize)> {
        let base = match t {
            1..=10 => t,
            11..=20 => t - 10,
            21..=30 => t - 20,
            _ => return None,
        };
        let count = match t {
            1..=10 => 1,
            11..=20 => 2,
            _ => 3,
        };
        let kind = [
            Kind::U8,
            Kind::I8,
            Kind::U16,
            Kind::I16,
            Kind::U32,
            Kind::I32,
            Kind::U64,
            Kind::I64,
            Kind::F32,
            Kind::F64,
        ][usize::from(base - 1)];
        Some((kind, count))
    }

    fn size(self) -> usize {
        match self {
            Kind::U8 | Kind::I8 => 1,
            Kind::U16 | Kind::I16 => 2,
            Kind::U32 | Kind::I32 | Kind::F32 => 4,
            Kind::U64 | Kind::I64 | Kind::F64 => 8,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kind::U8 => "u8",
            Kind::I8 => "i8",
            Kind::U16 => "u16",
            Kind::I16 => "i16",
            Kind::U32 => "u32",
            Kind::I32 => "i32",
            Kind::U64 => "u64",
            Kind::I64 => "i64",
            Kind::F32 => "f32",
            Kind::F64 => "f64",
        }
    }

    /// The value at the start of `b` (at least [`Kind::size`] bytes), little-endian.
    fn read(self, b: &[u8]) -> f64 {
        let a = |n: usize| -> [u8; 8] {
            let mut out = [0u8; 8];
            out[..n].copy_from_slice(&b[..n]);
            out
        };
        match self {
            Kind::U8 => f64::from(b[0]),
            Kind::I8 => f64::from(b[0] as i8),
            Kind::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Kind::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Kind::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Kind::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Kind::U64 => u64::from_le_bytes(a(8)) as f64,
            Kind::I64 => i64::from_le_bytes(a(8)) as f64,
            Kind::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Kind::F64 => f64::from_le_bytes(a(8)),
        }
    }
}

/// One field of the normals: where it lies in a point record and how it is decoded.
#[derive(Debug, Clone, PartialEq)]
struct Field {
    /// Byte offset within the record.
    at: usize,
    kind: Kind,
    scale: f64,
    offset: f64,
}

impl Field {
    /// The field's value in `record` (NaN where the record is too short to hold it).
    fn value(&self, record: &[u8]) -> f64 {
        match record.get(self.at..self.at + self.kind.size()) {
            Some(b) => self.kind.read(b) * self.scale + self.offset,
            None => f64::NAN,
        }
    }
}

/// The normals a LAS file's extra bytes give: the three fields and their names.
#[derive(Debug, Clone, PartialEq)]
pub struct ExtraNormals {
    /// The fields' names as the file spells them (x, y, z).
    pub names: [String; 3],
    fields: [Field; 3],
}

impl ExtraNormals {
    /// The normal of one point record (every byte of it, the format's fields first).
    pub fn of(&self, record: &[u8]) -> glam::Vec3 {
        let [x, y, z] = &self.fields;
        glam::DVec3::new(x.value(record), y.value(record), z.value(record)).as_vec3()
    }

    /// What [`crate::io::Loaded::normal_fields`] says of them: `NormalX,NormalY,NormalZ (LAS
    /// extra bytes, f32)`.
    pub fn describe(&self) -> String {
        let kinds: Vec<&str> = self.fields.iter().map(|f| f.kind.name()).collect();
        let kinds = if kinds.iter().all(|k| *k == kinds[0]) {
            kinds[0].to_owned()
        } else {
            kinds.join("/")
        };
        let scaled = self
            .fields
            .iter()
            .any(|f| f.scale != 1.0 || f.offset != 0.0);
        format!(
            "{} (LAS extra bytes, {kinds}{})",
            self.names.join(","),
            if scaled { ", scaled" } else { "" }
        )
    }
}

/// The axis (0, 1, 2) a field named `name` gives a normal of, if it is one of the names of
/// the module doc.
fn normal_axis(name: &str) -> Option<usize> {
    let key: String = name
        .chars()
        .filter(|c| !matches!(c, ' ' | '_' | '-'))
        .collect::<String>()
        .to_ascii_lowercase();
    match key.as_str() {
        "normalx" | "nx" => Some(0),
        "normaly" | "ny" => Some(1),
        "normalz" | "nz" => Some(2),
        _ => None,
    }
}

/// A descriptor's text field (NUL-padded) as a string.
fn text(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).trim().to_owned()
}

/// The normals described by `vlrs` (a file's VLRs and extended VLRs) for records of
/// `record_len` bytes whose extra bytes start at `extra_at`: `Ok(None)` when no Extra Bytes
/// VLR names all three; an error (a message) when it names them but they do not fit the
/// records, or a descriptor before them is of a type whose size is unknown.
pub fn find_normals<'a>(
    vlrs: impl IntoIterator<Item = &'a Vlr>,
    extra_at: usize,
    record_len: usize,
) -> Result<Option<ExtraNormals>, String> {
    let Some(vlr) = vlrs
        .into_iter()
        .find(|v| v.user_id == USER && v.record_id == RECORD)
    else {
        return Ok(None);
    };
    if vlr.data.len() % DESCRIPTOR != 0 {
        return Err(format!(
            "the Extra Bytes VLR holds {} bytes, not a whole number of {DESCRIPTOR}-byte \
             descriptors",
            vlr.data.len()
        ));
    }
    let mut found: [Option<(String, Field)>; 3] = [None, None, None];
    let mut at = extra_at;
    for d in vlr.data.chunks_exact(DESCRIPTOR) {
        let (data_type, options) = (d[2], d[3]);
        let name = text(&d[4..36]);
        let f64_at = |i: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&d[i..i + 8]);
            f64::from_le_bytes(b)
        };
        let size = if data_type == 0 {
            usize::from(options)
        } else if let Some((kind, count)) = Kind::of(data_type) {
            let axis = normal_axis(&name).filter(|&a| found[a].is_none() && count == 1);
            if let Some(axis) = axis {
                found[axis] = Some((
                    name.clone(),
                    Field {
                        at,
                        kind,
                        scale: if options & 8 != 0 { f64_at(112) } else { 1.0 },
                        offset: if options & 16 != 0 { f64_at(136) } else { 0.0 },
                    },
                ));
            }
            kind.size() * count
        } else {
            // A reserved type: the fields after it cannot be placed.
            if found.iter().all(Option::is_some) {
                break;
            }
            return Err(format!(
                "extra bytes field {name:?} has the reserved data type {data_type}, so the \
                 fields after it cannot be located"
            ));
        };
        at += size;
    }
    let [Some(x), Some(y), Some(z)] = found else {
        return Ok(None);
    };
    for (name, f) in [&x, &y, &z] {
        if f.at + f.kind.size() > record_len {
            return Err(format!(
                "extra bytes field {name:?} ends at byte {} of a point record of {record_len} \
                 bytes",
                f.at + f.kind.size()
            ));
        }
        if !(f.scale.is_finite() && f.scale != 0.0 && f.offset.is_finite()) {
            return Err(format!(
                "extra bytes field {name:?} has the scale {} and offset {}",
                f.scale, f.offset
            ));
        }
    }
    Ok(Some(ExtraNormals {
        names: [x.0, y.0, z.0],
        fields: [x.1, y.1, z.1],
    }))
}

/// The Extra Bytes VLR of three f32 fields, [`WRITTEN_NAMES`], the first [`NORMAL_BYTES`]
/// extra bytes of each record.
pub fn write_normals_vlr() -> Vlr {
    let mut data = Vec::with_capacity(3 * DESCRIPTOR);
    for (name, axis) in WRITTEN_NAMES.iter().zip(["x", "y", "z"]) {
        let mut d = [0u8; DESCRIPTOR];
        d[2] = 9; // f32
        d[4..4 + name.len()].copy_from_slice(name.as_bytes());
        let description = format!("unit normal, {axis}");
        d[160..160 + description.len()].copy_from_slice(description.as_bytes());
        data.extend_from_slice(&d);
    }
    Vlr {
        user_id: USER.to_owned(),
        record_id: RECORD,
        description: "Extra Bytes Record".to_owned(),
        data,
    }
}

/// The [`NORMAL_BYTES`] extra bytes of a point with normal `n`, as [`write_normals_vlr`]
/// describes them.
pub fn normal_bytes(n: glam::Vec3) -> Vec<u8> {
    let mut out = Vec::with_capacity(usize::from(NORMAL_BYTES));
    for v in n.to_array() {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn descriptor(name: &str, data_type: u8, options: u8, scale: f64, offset: f64) -> Vec<u8> {
        let mut d = vec![0u8; DESCRIPTOR];
        d[2] = data_type;
        d[3] = options;
        d[4..4 + name.len()].copy_from_slice(name.as_bytes());
        d[112..120].copy_from_slice(&scale.to_le_bytes());
        d[136..144].copy_from_slice(&offset.to_le_bytes());
        d
    }

    fn vlr(descriptors: &[Vec<u8>]) -> Vlr {
        Vlr {
            user_id: USER.into(),
            record_id: RECORD,
            description: String::new(),
            data: descriptors.concat(),
        }
    }

    #[test]
    fn each_naming_convention_is_found_after_other_fields() {
        for names in [
            ["NormalX", "NormalY", "NormalZ"],
            ["normal x", "normal y", "normal z"],
            ["nx", "ny", "nz"],
        ] {
            // An undocumented byte and an f64 before the normals.
            let v = vlr(&[
                descriptor("", 0, 1, 0.0, 0.0),
                descriptor("Deviation", 10, 0, 0.0, 0.0),
                descriptor(names[0], 9, 0, 0.0, 0.0),
                descriptor(names[1], 9, 0, 0.0, 0.0),
                descriptor(names[2], 9, 0, 0.0, 0.0),
            ]);
            let n = find_normals([&v], 20, 20 + 1 + 8 + 12).unwrap().unwrap();
            assert_eq!(n.names, names.map(String::from));
            let mut record = vec![0u8; 20 + 9];
            record.extend(normal_bytes(glam::Vec3::new(0.6, 0.0, -0.8)));
            assert_eq!(n.of(&record), glam::Vec3::new(0.6, 0.0, -0.8));
            assert!(n.describe().contains("(LAS extra bytes, f32)"), "{n:?}");
        }
    }

    #[test]
    fn scaled_integers_are_decoded_and_bad_layouts_refused() {
        // i16 with scale 1e-4: 10000 is 1.0.
        let v = vlr(&[
            descriptor("nx", 4, 8, 1e-4, 0.0),
            descriptor("ny", 4, 8, 1e-4, 0.0),
            descriptor("nz", 4, 24, 1e-4, 0.5),
        ]);
        let n = find_normals([&v], 0, 6).unwrap().unwrap();
        let record: Vec<u8> = [0i16, -10_000, -5000]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(n.of(&record), glam::Vec3::new(0.0, -1.0, 0.0));
        assert!(n.describe().contains("i16, scaled"), "{}", n.describe());
        // The fields run past the record.
        let err = find_normals([&v], 0, 5).unwrap_err();
        assert!(err.contains("\"nz\" ends at byte 6"), "{err}");
        // No VLR, or only two of the three: no normals.
        assert_eq!(find_normals([], 0, 6), Ok(None));
        let two = vlr(&[
            descriptor("nx", 9, 0, 0.0, 0.0),
            descriptor("ny", 9, 0, 0.0, 0.0),
        ]);
        assert_eq!(find_normals([&two], 0, 8), Ok(None));
        // A reserved type before them.
        let reserved = vlr(&[
            descriptor("odd", 40, 0, 0.0, 0.0),
            descriptor("nx", 9, 0, 0.0, 0.0),
            descriptor("ny", 9, 0, 0.0, 0.0),
            descriptor("nz", 9, 0, 0.0, 0.0),
        ]);
        let err = find_normals([&reserved], 0, 100).unwrap_err();
        assert!(err.contains("reserved data type 40"), "{err}");
        // A VLR that is not whole descriptors.
        let mut cut = two.clone();
        cut.data.pop();
        assert!(
            find_normals([&cut], 0, 8)
                .unwrap_err()
                .contains("383 bytes")
        );
    }

    #[test]
    fn the_written_vlr_reads_back() {
        let v = write_normals_vlr();
        let n = find_normals([&v], 26, 38).unwrap().unwrap();
        assert_eq!(n.names, WRITTEN_NAMES.map(String::from));
        let mut record = vec![7u8; 26];
        record.extend(normal_bytes(glam::Vec3::Y));
        assert_eq!(n.of(&record), glam::Vec3::Y);
    }
}
