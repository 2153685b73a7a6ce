//! PCD reader (the Point Cloud Library's format) over the `pcd-rs` crate: `ascii`, `binary` and
//! `binary_compressed` data (cargo feature `formats`).
//!
//! Fields read: `x y z` (required, float or double), `normal_x normal_y normal_z` (each a
//! unit vector, else [`ReadErrorKind::BadNormal`]), `rgb` or
//! `rgba` (PCL's packed 0x00RRGGBB, stored as a float or an unsigned integer) and `intensity`
//! (scaled to 16 bits when it is a float in [0, 1], else clamped). Other fields are skipped.
//!
//! Before anything is decoded the header's point count is checked against the file: binary
//! data must hold `POINTS × record size` bytes, compressed data must announce exactly that many
//! uncompressed bytes and no more compressed bytes than the file has, so a lying header cannot
//! drive an allocation. Errors name the file and the line (header) or byte offset (data).
//!
//! A point whose x, y and z are all NaN is skipped: PCL writes that for "no return" in
//! organised clouds (`is_dense false`, e.g. from depth cameras), and PCL's own
//! `removeNaNFromPointCloud` drops them. Any other non-finite coordinate is an error.

use std::io::Read;
use std::path::Path;

use glam::{DVec3, Vec3};
use pcd_rs::{DataKind, DynReader, Field, PcdMeta, ValueKind};

use super::{CountingReader, Loaded, capacity_for, open};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

fn kind_size(kind: ValueKind) -> u64 {
    match kind {
        ValueKind::U8 | ValueKind::I8 => 1,
        ValueKind::U16 | ValueKind::I16 => 2,
        ValueKind::U32 | ValueKind::I32 | ValueKind::F32 => 4,
        ValueKind::U64 | ValueKind::I64 | ValueKind::F64 => 8,
    }
}

fn first_f64(field: &Field) -> Option<f64> {
    Some(match field {
        Field::I8(v) => f64::from(*v.first()?),
        Field::I16(v) => f64::from(*v.first()?),
        Field::I32(v) => f64::from(*v.first()?),
        Field::I64(v) => *v.first()? as f64,
        Field::U8(v) => f64::from(*v.first()?),
        Field::U16(v) => f64::from(*v.first()?),
        Field::U32(v) => f64::from(*v.first()?),
        Field::U64(v) => *v.first()? as f64,
        Field::F32(v) => f64::from(*v.first()?),
        Field::F64(v) => *v.first()?,
    })
}

fn packed_rgb(field: &Field) -> Option<[u8; 3]> {
    let bits = match field {
        Field::F32(v) => v.first()?.to_bits(),
        Field::U32(v) => *v.first()?,
        Field::I32(v) => *v.first()? as u32,
        _ => return None,
    };
    Some([(bits >> 16) as u8, (bits >> 8) as u8, bits as u8])
}

/// The header keywords, in PCL's order.
const KEYWORDS: [&str; 10] = [
    "VERSION",
    "FIELDS",
    "SIZE",
    "TYPE",
    "COUNT",
    "WIDTH",
    "HEIGHT",
    "VIEWPOINT",
    "POINTS",
    "DATA",
];

/// A header error from `pcd-rs`, located at the line of the keyword its message names (the
/// crate reports the line where it noticed, which is the end of the header).
fn header_error(path: &Path, e: &pcd_rs::Error) -> ReadError {
    use std::io::BufRead;
    let message = e.to_string();
    // The keyword the message names first ("SIZE entry conflicts with FIELDS entry": SIZE).
    let keyword = KEYWORDS
        .iter()
        .filter_map(|k| Some((message.find(k)?, k)))
        .min()
        .map(|(_, k)| k);
    let line = keyword.and_then(|k| {
        open(path)
            .ok()?
            .lines()
            .take(64)
            .position(|l| l.is_ok_and(|l| l.split_whitespace().next() == Some(k)))
    });
    let detail = message
        .split_once(": ")
        .filter(|(head, _)| head.starts_with("parsing error at line"))
        .map_or(message.as_str(), |(_, rest)| rest);
    ReadError::new(
        path,
        line.map_or(Location::File, |l| Location::Line(l + 1)),
        ReadErrorKind::BadHeader(detail.to_owned()),
    )
}

/// The number of non-blank lines after the header of an ASCII PCD.
fn ascii_data_lines(path: &Path, header_lines: usize) -> usize {
    use std::io::BufRead;
    open(path).map_or(0, |r| {
        r.lines()
            .skip(header_lines)
            .map_while(Result::ok)
            .filter(|l| !l.trim().is_empty())
            .count()
    })
}

/// Reads a PCD file.
pub fn read_pcd(path: &Path) -> Result<Loaded, ReadError> {
    let err = |location, kind| ReadError::new(path, location, kind);
    let file_len = std::fs::metadata(path)
        .map_err(|e| err(Location::File, ReadErrorKind::Io(e)))?
        .len();
    if file_len == 0 {
        return Err(err(Location::File, ReadErrorKind::Empty));
    }
    // The header, and where the data starts.
    let mut counting = CountingReader::new(open(path)?);
    let meta = PcdMeta::from_reader(&mut counting).map_err(|e| header_error(path, &e))?;
    let data_start = counting.consumed;
    let header_lines = {
        let mut head = Vec::new();
        open(path)?
            .take(data_start)
            .read_to_end(&mut head)
            .map_err(|e| err(Location::File, ReadErrorKind::Io(e)))?;
        head.iter().filter(|&&b| b == b'\n').count()
    };
    let n = usize::try_from(meta.num_points).map_err(|_| {
        err(
            Location::File,
            ReadErrorKind::BadHeader("too many points".into()),
        )
    })?;
    let record: u64 = meta
        .field_defs
        .iter()
        .map(|f| kind_size(f.kind) * f.count)
        .sum();
    let need = meta.num_points.saturating_mul(record);
    let remaining = file_len - data_start;
    match meta.data {
        DataKind::Binary if remaining < need => {
            return Err(err(
                Location::Byte(file_len),
                ReadErrorKind::Truncated {
                    what: "points",
                    expected: n,
                    found: (remaining / record.max(1)) as usize,
                },
            ));
        }
        DataKind::BinaryCompressed => {
            let mut sizes = [0u8; 8];
            counting
                .read_exact(&mut sizes)
                .map_err(|e| err(Location::Byte(data_start), ReadErrorKind::Io(e)))?;
            let compressed =
                u64::from(u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]));
            let uncompressed =
                u64::from(u32::from_le_bytes([sizes[4], sizes[5], sizes[6], sizes[7]]));
            if uncompressed != need || compressed > remaining.saturating_sub(8) {
                return Err(err(
                    Location::Byte(data_start),
                    ReadErrorKind::Malformed(format!(
                        "binary_compressed sizes {compressed} (compressed) and {uncompressed} \
                         (uncompressed) do not match {n} points of {record} bytes in a file with \
                         {remaining} data bytes"
                    )),
                ));
            }
        }
        _ => {}
    }
    let names: Vec<String> = meta.field_defs.iter().map(|f| f.name.clone()).collect();
    let find = |name: &str| names.iter().position(|f| f == name);
    let (Some(ix), Some(iy), Some(iz)) = (find("x"), find("y"), find("z")) else {
        return Err(err(
            Location::File,
            ReadErrorKind::BadHeader(format!("no x y z fields (fields: {})", names.join(" "))),
        ));
    };
    let normal = match (find("normal_x"), find("normal_y"), find("normal_z")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let rgb = find("rgb").or_else(|| find("rgba"));
    let intensity = find("intensity");
    let intensity_is_float = intensity.is_some_and(|i| {
        matches!(
            meta.field_defs.iter().nth(i).map(|f| f.kind),
            Some(ValueKind::F32 | ValueKind::F64)
        )
    });

    let reader: DynReader<_> =
        DynReader::from_reader(open(path)?).map_err(|e| header_error(path, &e))?;
    let mut cloud = PointCloud {
        positions: Vec::with_capacity(capacity_for(n)),
        ..PointCloud::default()
    };
    let mut normals = Vec::new();
    let mut colors = Vec::new();
    let mut intensities = Vec::new();
    let mut records = 0;
    for (index, rec) in reader.enumerate() {
        // ASCII: the header's lines plus this record's; binary: the record's offset.
        let here = match meta.data {
            DataKind::Ascii => Location::Line(header_lines + 1 + index),
            _ => Location::Byte(data_start + index as u64 * record),
        };
        let rec = rec.map_err(|e| {
            // An ASCII record missing altogether is a truncated file, not a malformed line.
            if meta.data == DataKind::Ascii && ascii_data_lines(path, header_lines) <= index {
                err(
                    here,
                    ReadErrorKind::Truncated {
                        what: "points",
                        expected: n,
                        found: index,
                    },
                )
            } else {
                err(here, ReadErrorKind::Malformed(e.to_string()))
            }
        })?;
        records += 1;
        let fields = &rec.0;
        let get = |i: usize| fields.get(i).and_then(first_f64);
        let (Some(x), Some(y), Some(z)) = (get(ix), get(iy), get(iz)) else {
            return Err(err(here, ReadErrorKind::Malformed("x y z missing".into())));
        };
        // PCL marks "no return" in organised clouds (is_dense = false) with x = y = z = NaN:
        // such points are skipped, as PCL's removeNaNFromPointCloud does.
        if x.is_nan() && y.is_nan() && z.is_nan() {
            continue;
        }
        if let Some(&value) = [x, y, z].iter().find(|v| !v.is_finite()) {
            return Err(err(here, ReadErrorKind::NonFinite { index, value }));
        }
        cloud.positions.push(DVec3::new(x, y, z));
        if let Some([a, b, c]) = normal {
            let v = |i| get(i).map_or(f32::NAN, |v| v as f32);
            let n = Vec3::new(v(a), v(b), v(c));
            if !crate::normals::is_given_normal(n) {
                return Err(err(
                    here,
                    ReadErrorKind::BadNormal {
                        index,
                        normal: n.to_array(),
                        tolerance: crate::normals::GIVEN_LENGTH_TOLERANCE,
                    },
                ));
            }
            normals.push(n);
        }
        if let Some(i) = rgb {
            colors.push(fields.get(i).and_then(packed_rgb).unwrap_or([0; 3]));
        }
        if let Some(i) = intensity {
            let v = get(i).unwrap_or(0.0);
            let scaled = if intensity_is_float && v <= 1.0 {
                v * 65535.0
            } else {
                v
            };
            intensities.push(scaled.clamp(0.0, 65535.0) as u16);
        }
    }
    if records != n {
        return Err(err(
            Location::Byte(file_len),
            ReadErrorKind::Truncated {
                what: "points",
                expected: n,
                found: records,
            },
        ));
    }
    if cloud.positions.is_empty() {
        return Err(err(Location::File, ReadErrorKind::Empty));
    }
    cloud.normals = normal.map(|_| normals);
    cloud.colors = rgb.map(|_| colors);
    cloud.intensity = intensity.map(|_| intensities);
    Ok(Loaded {
        cloud,
        normal_fields: normal.map(|_| "normal_x,normal_y,normal_z (PCD fields)".to_owned()),
        ..Loaded::default()
    })
}

/// Writes `cloud` as an ASCII PCD with `x y z` (and `rgb` when it has colours), the form PCL's
/// tools and Open3D read (used by the tests to make files with known values).
pub fn pcd_ascii(cloud: &PointCloud) -> String {
    let with_rgb = cloud.colors.is_some();
    let mut s = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z{}\nSIZE 8 8 8{}\n\
         TYPE F F F{}\nCOUNT 1 1 1{}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n\
         DATA ascii\n",
        if with_rgb { " rgb" } else { "" },
        if with_rgb { " 4" } else { "" },
        if with_rgb { " U" } else { "" },
        if with_rgb { " 1" } else { "" },
        n = cloud.len()
    );
    for (i, p) in cloud.positions.iter().enumerate() {
        s.push_str(&format!("{} {} {}", p.x, p.y, p.z));
        if let Some(c) = &cloud.colors {
            let [r, g, b] = c[i];
            s.push_str(&format!(
                " {}",
                (u32::from(r) << 16) | (u32::from(g) << 8) | u32::from(b)
            ));
        }
        s.push('\n');
    }
    s
}
