//! PLY reader over the `ply-rs-bw` crate (ASCII, binary little- and big-endian).
//!
//! The crate parses the header; the payload is read here one element at a time with the
//! crate's per-element functions, so that (a) nothing is allocated from the header's counts
//! beyond a small bound, (b) a short payload is reported as [`ReadErrorKind::Truncated`] with
//! how many elements were complete, and (c) each error carries the line (ASCII) or the byte
//! offset of the element (binary).
//!
//! Vertex properties read: `x y z` (required), `nx ny nz` (each a unit vector, else
//! [`ReadErrorKind::BadNormal`]), `red green blue`, texture coordinates as `u v`, `s t` or
//! `texture_u texture_v`. Faces: `vertex_indices` or
//! `vertex_index` lists, split into triangle fans. Other elements are read and skipped.

use std::io::BufRead;
use std::path::Path;

use glam::{DVec3, Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult,
};

use super::{CountingReader, Loaded, capacity_for, open};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Reads a PLY file into its vertices (with attributes) and fan-triangulated faces.
pub fn read_ply(path: &Path) -> Result<Loaded, ReadError> {
    let reader = open(path)?;
    parse_ply(reader).map_err(|(location, kind)| ReadError::new(path, location, kind))
}

/// One element record, whatever its element: the properties this reader understands.
#[derive(Debug, Default)]
struct Record {
    xyz: [f64; 3],
    normal: [f32; 3],
    rgb: [u8; 3],
    uv: [f32; 2],
    list: Vec<i64>,
}

fn scalar_f64(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

fn list_i64(p: Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
        Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
        Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
        _ => return None,
    })
}

impl PropertyAccess for Record {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if matches!(name, "vertex_indices" | "vertex_index") {
            return match list_i64(property) {
                Some(list) => {
                    self.list = list;
                    PropertyAccessResult::Set
                }
                None => PropertyAccessResult::UnsupportedType,
            };
        }
        let Some(value) = scalar_f64(&property) else {
            return PropertyAccessResult::Ignored;
        };
        match name {
            "x" => self.xyz[0] = value,
            "y" => self.xyz[1] = value,
            "z" => self.xyz[2] = value,
            "nx" => self.normal[0] = value as f32,
            "ny" => self.normal[1] = value as f32,
            "nz" => self.normal[2] = value as f32,
            "red" | "r" => self.rgb[0] = value.clamp(0.0, 255.0) as u8,
            "green" | "g" => self.rgb[1] = value.clamp(0.0, 255.0) as u8,
            "blue" | "b" => self.rgb[2] = value.clamp(0.0, 255.0) as u8,
            "u" | "s" | "texture_u" => self.uv[0] = value as f32,
            "v" | "t" | "texture_v" => self.uv[1] = value as f32,
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

fn has_all(def: &ElementDef, names: &[&str]) -> bool {
    names.iter().all(|n| def.properties.contains_key(*n))
}

fn has_any(def: &ElementDef, names: &[&str]) -> bool {
    names.iter().any(|n| def.properties.contains_key(*n))
}

type ParseResult<T> = Result<T, (Location, ReadErrorKind)>;

/// Reads the payload element by element, calling `sink` with each record.
fn read_elements<R: BufRead>(
    parser: &Parser<Record>,
    reader: &mut Reader<CountingReader<R>>,
    header: &Header,
    def: &ElementDef,
    what: &'static str,
    line_offset: usize,
    mut sink: impl FnMut(usize, Record, Location) -> ParseResult<()>,
) -> ParseResult<()> {
    let mut line = String::new();
    for index in 0..def.count {
        let truncated = |location| {
            (
                location,
                ReadErrorKind::Truncated {
                    what,
                    expected: def.count,
                    found: index,
                },
            )
        };
        let inner = reader.get_mut();
        let record = match header.encoding {
            Encoding::Ascii => {
                line.clear();
                let here = Location::Line(line_offset + index);
                let n = inner
                    .read_line(&mut line)
                    .map_err(|e| (here, ReadErrorKind::Io(e)))?;
                if n == 0 || line.trim().is_empty() {
                    return Err(truncated(here));
                }
                if let Some(token) = line.split_whitespace().find(|t| t.parse::<f64>().is_err()) {
                    return Err((
                        here,
                        ReadErrorKind::NotANumber {
                            field: token.to_owned(),
                        },
                    ));
                }
                // The crate's ASCII grammar rejects `nan` and `inf`; name them precisely.
                if let Some(value) = line
                    .split_whitespace()
                    .filter_map(|t| t.parse::<f64>().ok())
                    .find(|v| !v.is_finite())
                {
                    return Err((here, ReadErrorKind::NonFinite { index, value }));
                }
                let record = parser
                    .read_ascii_element(&line, def)
                    .map_err(|e| (here, ReadErrorKind::Malformed(e.to_string())))?;
                sink(index, record, here)?;
                continue;
            }
            Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
                let here = Location::Byte(inner.consumed);
                let result = if header.encoding == Encoding::BinaryLittleEndian {
                    parser.read_little_endian_element(inner, def)
                } else {
                    parser.read_big_endian_element(inner, def)
                };
                match result {
                    Ok(record) => (record, here),
                    Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                        return Err(truncated(here));
                    }
                    Err(e) => return Err((here, ReadErrorKind::Malformed(e.to_string()))),
                }
            }
        };
        sink(index, record.0, record.1)?;
    }
    Ok(())
}

/// The first sentence of a `ply-rs` header error and the offending line, without the parser's
/// debug dump ("Line 2: Couldn't parse line.\n\tString: 'format json 1.0'\n\tError: ParseError
/// {..}" becomes "couldn't parse line: \"format json 1.0\"").
fn header_message(full: &str) -> String {
    let mut lines = full.lines();
    let first = lines.next().unwrap_or_default();
    // "Line N: " is already the error's location.
    let first = first
        .split_once(": ")
        .filter(|(head, _)| head.starts_with("Line "))
        .map_or(first, |(_, rest)| rest)
        .trim_end_matches('.');
    let offending = full
        .split_once("String: '")
        .and_then(|(_, rest)| rest.split_once('\''))
        .map(|(text, _)| text.trim());
    match offending {
        Some(text) => format!("{}: {text:?}", first.to_lowercase()),
        None => first.to_owned(),
    }
}

fn parse_ply<R: BufRead>(reader: R) -> ParseResult<Loaded> {
    let mut counting = CountingReader::new(reader);
    if counting
        .fill_buf()
        .map_err(|e| (Location::File, ReadErrorKind::Io(e)))?
        .is_empty()
    {
        return Err((Location::File, ReadErrorKind::Empty));
    }
    let mut reader = Reader::new(counting);
    let parser = Parser::<Record>::new();
    let header = parser.read_header(&mut reader).map_err(|e| {
        let location = e.line().map_or(Location::File, Location::Line);
        (
            location,
            ReadErrorKind::BadHeader(header_message(&e.to_string())),
        )
    })?;
    // The number of lines the header used: ASCII payload lines are numbered after it.
    let mut next_line = reader.line();

    let mut cloud = PointCloud::default();
    let mut triangles = Vec::new();
    let mut n_vertices = None;
    let mut normal_fields = None;
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => {
                if !has_all(def, &["x", "y", "z"]) {
                    return Err((
                        Location::File,
                        ReadErrorKind::BadHeader("element vertex lacks x, y or z".into()),
                    ));
                }
                let with_normals = has_all(def, &["nx", "ny", "nz"]);
                let with_colors = has_all(def, &["red", "green", "blue"]);
                let with_uvs = has_any(def, &["u", "s", "texture_u"]);
                let cap = capacity_for(def.count);
                let mut positions = Vec::with_capacity(cap);
                let mut normals = Vec::with_capacity(if with_normals { cap } else { 0 });
                let mut colors = Vec::with_capacity(if with_colors { cap } else { 0 });
                let mut uvs = Vec::with_capacity(if with_uvs { cap } else { 0 });
                read_elements(
                    &parser,
                    &mut reader,
                    &header,
                    def,
                    "vertices",
                    next_line,
                    |index, r, here| {
                        if let Some(&value) = r.xyz.iter().find(|v| !v.is_finite()) {
                            return Err((here, ReadErrorKind::NonFinite { index, value }));
                        }
                        positions.push(DVec3::from_array(r.xyz));
                        if with_normals {
                            let n = Vec3::from_array(r.normal);
                            if !crate::normals::is_given_normal(n) {
                                return Err((
                                    here,
                                    ReadErrorKind::BadNormal {
                                        index,
                                        normal: r.normal,
                                        tolerance: crate::normals::GIVEN_LENGTH_TOLERANCE,
                                    },
                                ));
                            }
                            normals.push(n);
                        }
                        if with_colors {
                            colors.push(r.rgb);
                        }
                        if with_uvs {
                            uvs.push(Vec2::from_array(r.uv));
                        }
                        Ok(())
                    },
                )?;
                n_vertices = Some(positions.len());
                if with_normals {
                    normal_fields = Some("nx,ny,nz (PLY vertex properties)".to_owned());
                }
                cloud = PointCloud {
                    positions,
                    normals: with_normals.then_some(normals),
                    colors: with_colors.then_some(colors),
                    uvs: with_uvs.then_some(uvs),
                    ..PointCloud::default()
                };
            }
            "face" => {
                let n = n_vertices.ok_or((
                    Location::File,
                    ReadErrorKind::Unsupported("faces before vertices".into()),
                ))?;
                read_elements(
                    &parser,
                    &mut reader,
                    &header,
                    def,
                    "faces",
                    next_line,
                    |face, r, here| {
                        if r.list.len() < 3 {
                            return Err((
                                here,
                                ReadErrorKind::DegenerateFace {
                                    face,
                                    corners: r.list.len(),
                                },
                            ));
                        }
                        if let Some(&vertex) = r.list.iter().find(|&&v| v < 0 || v as usize >= n) {
                            return Err((
                                here,
                                ReadErrorKind::FaceIndexOutOfRange {
                                    face,
                                    vertex,
                                    n_vertices: n,
                                },
                            ));
                        }
                        for i in 1..r.list.len() - 1 {
                            triangles.push([
                                r.list[0] as u32,
                                r.list[i] as u32,
                                r.list[i + 1] as u32,
                            ]);
                        }
                        Ok(())
                    },
                )?;
            }
            _ => read_elements(
                &parser,
                &mut reader,
                &header,
                def,
                "elements",
                next_line,
                |_, _, _| Ok(()),
            )?,
        }
        next_line += def.count;
    }
    if cloud.positions.is_empty() {
        return Err((Location::File, ReadErrorKind::Empty));
    }
    Ok(Loaded {
        cloud,
        triangles,
        normal_fields,
        ..Loaded::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8]) -> ParseResult<Loaded> {
        parse_ply(bytes)
    }

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment test\nelement vertex 3\n\
        property float x\nproperty float y\nproperty float z\n\
        property uchar red\nproperty uchar green\nproperty uchar blue\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n";

    fn binary(little: bool, vertices: &[[f32; 3]], count: usize) -> Vec<u8> {
        let format = if little {
            "binary_little_endian"
        } else {
            "binary_big_endian"
        };
        let mut bytes = format!(
            "ply\nformat {format} 1.0\nelement vertex {count}\nproperty float x\n\
             property float y\nproperty float z\nend_header\n"
        )
        .into_bytes();
        for v in vertices {
            for c in v {
                bytes.extend(if little {
                    c.to_le_bytes()
                } else {
                    c.to_be_bytes()
                });
            }
        }
        bytes
    }

    #[test]
    fn ascii_with_colors_and_a_face() {
        let loaded = parse(ASCII.as_bytes()).unwrap();
        assert_eq!(loaded.cloud.len(), 3);
        assert_eq!(loaded.cloud.positions[1], DVec3::X);
        assert_eq!(loaded.cloud.colors.as_ref().unwrap()[2], [0, 0, 255]);
        assert_eq!(loaded.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn binary_both_endiannesses() {
        let pts = [[1.0, 2.0, 3.0], [-4.0, 5.5, 6.25]];
        for little in [true, false] {
            let loaded = parse(&binary(little, &pts, 2)).unwrap();
            assert_eq!(loaded.cloud.positions[1], DVec3::new(-4.0, 5.5, 6.25));
        }
    }

    #[test]
    fn binary_truncated_reports_count_and_offset() {
        let bytes = binary(true, &[[1.0, 2.0, 3.0]], 1000);
        let header_len = bytes.len() - 12;
        let (location, kind) = parse(&bytes).unwrap_err();
        assert_eq!(location, Location::Byte(header_len as u64 + 12));
        assert!(
            matches!(
                kind,
                ReadErrorKind::Truncated {
                    what: "vertices",
                    expected: 1000,
                    found: 1
                }
            ),
            "{kind}"
        );
    }

    #[test]
    fn absurd_count_is_truncation_not_an_allocation() {
        let bytes = binary(false, &[[1.0, 2.0, 3.0]], usize::MAX / 2);
        let (_, kind) = parse(&bytes).unwrap_err();
        assert!(
            matches!(kind, ReadErrorKind::Truncated { found: 1, .. }),
            "{kind}"
        );
    }

    #[test]
    fn binary_nan_names_vertex_and_offset() {
        let bytes = binary(true, &[[1.0, 2.0, 3.0], [f32::NAN, 0.0, 0.0]], 2);
        let header_len = bytes.len() - 24;
        let (location, kind) = parse(&bytes).unwrap_err();
        assert_eq!(location, Location::Byte(header_len as u64 + 12));
        assert!(
            matches!(kind, ReadErrorKind::NonFinite { index: 1, .. }),
            "{kind}"
        );
    }

    #[test]
    fn ascii_truncated_names_the_line() {
        let text = ASCII.replace("0 1 0 0 0 255\n3 0 1 2\n", "");
        let (location, kind) = parse(text.as_bytes()).unwrap_err();
        // 13 header lines, vertices on lines 14 and 15; the third would be line 16.
        assert_eq!(location, Location::Line(16));
        assert!(
            matches!(
                kind,
                ReadErrorKind::Truncated {
                    what: "vertices",
                    expected: 3,
                    found: 2
                }
            ),
            "{kind}"
        );
    }

    #[test]
    fn ascii_non_numeric_field() {
        let text = ASCII.replace("1 0 0 0 255 0", "1 oops 0 0 255 0");
        let (location, kind) = parse(text.as_bytes()).unwrap_err();
        assert_eq!(location, Location::Line(15));
        assert!(matches!(kind, ReadErrorKind::NotANumber { ref field } if field == "oops"));
    }

    #[test]
    fn ascii_infinite_coordinate() {
        let text = ASCII.replace("0 1 0 0 0 255", "0 inf 0 0 0 255");
        let (location, kind) = parse(text.as_bytes()).unwrap_err();
        assert_eq!(location, Location::Line(16));
        assert!(
            matches!(kind, ReadErrorKind::NonFinite { index: 2, .. }),
            "{kind}"
        );
    }

    #[test]
    fn face_out_of_range() {
        let text = ASCII.replace("3 0 1 2", "3 0 1 7");
        let (location, kind) = parse(text.as_bytes()).unwrap_err();
        assert_eq!(location, Location::Line(17));
        assert!(
            matches!(
                kind,
                ReadErrorKind::FaceIndexOutOfRange {
                    face: 0,
                    vertex: 7,
                    n_vertices: 3
                }
            ),
            "{kind}"
        );
    }

    #[test]
    fn empty_and_headerless() {
        assert!(matches!(parse(b"").unwrap_err().1, ReadErrorKind::Empty));
        assert!(matches!(
            parse(b"not a ply file\n").unwrap_err().1,
            ReadErrorKind::BadHeader(_)
        ));
        let no_vertices = "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n\
                           property float y\nproperty float z\nend_header\n";
        assert!(matches!(
            parse(no_vertices.as_bytes()).unwrap_err().1,
            ReadErrorKind::Empty
        ));
    }
}
