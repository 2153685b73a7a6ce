//! Wavefront OBJ reader: vertices (`v x y z [w]`, with optional `r g b` in [0, 1] after them,
//! as MeshLab and Open3D write) and faces (`f`), polygons split into triangle fans.
//!
//! Face corners may be `v`, `v/vt`, `v/vt/vn` or `v//vn`; indices are 1-based, negative ones
//! count back from the last vertex read. Normals (`vn`) and texture coordinates (`vt`) are not
//! attached to vertices (OBJ indexes them per corner, not per vertex); points and lines (`p`,
//! `l`), groups, materials and other statements are skipped. Errors carry the 1-based line.

use std::io::BufRead;
use std::path::Path;

use glam::DVec3;

use super::{Loaded, open, parse_f64};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Reads an OBJ file into its vertices and fan-triangulated faces.
pub fn read_obj(path: &Path) -> Result<Loaded, ReadError> {
    let reader = open(path)?;
    parse_obj(reader).map_err(|(location, kind)| ReadError::new(path, location, kind))
}

fn parse_obj<R: BufRead>(mut reader: R) -> Result<Loaded, (Location, ReadErrorKind)> {
    let mut positions: Vec<DVec3> = Vec::new();
    let mut colors: Vec<[u8; 3]> = Vec::new();
    let mut faces: Vec<(usize, Vec<i64>)> = Vec::new();
    let mut buf = String::new();
    let mut line_no = 0;
    let mut any = false;
    loop {
        buf.clear();
        let n = reader
            .read_line(&mut buf)
            .map_err(|e| (Location::Line(line_no + 1), ReadErrorKind::Io(e)))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let content = buf.split('#').next().unwrap_or("").trim();
        let mut tokens = content.split_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        any = true;
        let here = Location::Line(line_no);
        match keyword {
            "v" => {
                let values = tokens
                    .map(parse_f64)
                    .collect::<Result<Vec<f64>, _>>()
                    .map_err(|k| (here, k))?;
                if !matches!(values.len(), 3 | 4 | 6) {
                    return Err((
                        here,
                        ReadErrorKind::FieldCount {
                            expected: 3,
                            found: values.len(),
                        },
                    ));
                }
                let index = positions.len();
                if let Some(&value) = values[..3].iter().find(|v| !v.is_finite()) {
                    return Err((here, ReadErrorKind::NonFinite { index, value }));
                }
                positions.push(DVec3::new(values[0], values[1], values[2]));
                if values.len() == 6 {
                    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                    colors.push([c(values[3]), c(values[4]), c(values[5])]);
                }
            }
            "f" => {
                let mut corners = Vec::new();
                for token in tokens {
                    let first = token.split('/').next().unwrap_or("");
                    let v: i64 = first.parse().map_err(|_| {
                        (
                            here,
                            ReadErrorKind::NotANumber {
                                field: token.to_owned(),
                            },
                        )
                    })?;
                    // Resolve relative indices against the vertices read so far.
                    let resolved = if v < 0 {
                        positions.len() as i64 + v
                    } else {
                        v - 1
                    };
                    corners.push(if v == 0 { -1 } else { resolved });
                }
                if corners.len() < 3 {
                    return Err((
                        here,
                        ReadErrorKind::DegenerateFace {
                            face: faces.len(),
                            corners: corners.len(),
                        },
                    ));
                }
                faces.push((line_no, corners));
            }
            _ => {}
        }
    }
    if !any || positions.is_empty() {
        return Err((Location::File, ReadErrorKind::Empty));
    }
    if !colors.is_empty() && colors.len() != positions.len() {
        return Err((
            Location::File,
            ReadErrorKind::BadHeader(format!(
                "{} of {} vertices have colours: give all or none",
                colors.len(),
                positions.len()
            )),
        ));
    }
    let n_vertices = positions.len();
    let mut triangles = Vec::with_capacity(faces.len());
    for (face, (line, corners)) in faces.iter().enumerate() {
        for &v in corners {
            if v < 0 || v as usize >= n_vertices {
                return Err((
                    Location::Line(*line),
                    ReadErrorKind::FaceIndexOutOfRange {
                        face,
                        vertex: if v < 0 { v } else { v + 1 },
                        n_vertices,
                    },
                ));
            }
        }
        for i in 1..corners.len() - 1 {
            triangles.push([corners[0] as u32, corners[i] as u32, corners[i + 1] as u32]);
        }
    }
    Ok(Loaded {
        cloud: PointCloud {
            positions,
            colors: (!colors.is_empty()).then_some(colors),
            ..PointCloud::default()
        },
        triangles,
        ..Loaded::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Loaded, (Location, ReadErrorKind)> {
        parse_obj(text.as_bytes())
    }

    #[test]
    fn a_quad_with_every_corner_form() {
        let text = "# exported by hand\nmtllib x.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    vt 0 0\nvn 0 0 1\nusemtl m\nf 1/1/1 2//1 3/1 -1\n";
        let loaded = parse(text).unwrap();
        assert_eq!(loaded.cloud.len(), 4);
        assert_eq!(loaded.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(loaded.cloud.positions[2], DVec3::new(1.0, 1.0, 0.0));
        let coloured = parse("v 0 0 0 1 0 0\nv 1 0 0 0 0.5 1\nv 0 1 0 0 0 0\nf 1 2 3\n").unwrap();
        assert_eq!(coloured.cloud.colors.unwrap()[1], [0, 128, 255]);
    }

    #[test]
    fn errors_name_the_line() {
        for (text, line, needle) in [
            ("v 0 0 0\nv 1 0 zero\n", 2, "zero"),
            ("v 0 0 0\nv 1 0\n", 2, "expected 3 fields"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "vertex 4"),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "2 corners"),
            ("v 0 0 nan\n", 1, "non-finite"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "face 0"),
        ] {
            let (location, kind) = parse(text).unwrap_err();
            assert_eq!(location, Location::Line(line), "{text:?}: {kind}");
            assert!(kind.to_string().contains(needle), "{text:?}: {kind}");
        }
        assert!(matches!(
            parse("# nothing\n").unwrap_err().1,
            ReadErrorKind::Empty
        ));
    }
}
