//! OFF reader (Object File Format, as used by CGAL's data set).
//!
//! Accepted: an optional `OFF`/`COFF`/`NOFF` keyword (alone or followed by the counts on the
//! same line), `#` comments and blank lines anywhere, then `n_vertices n_faces n_edges`, the
//! vertex lines (`x y z`, extra columns such as colours ignored) and the face lines
//! (`k i_1 .. i_k`, extra columns ignored). Polygons are split into triangle fans.
//! Errors carry the 1-based line number.

use std::io::BufRead;
use std::path::Path;

use glam::DVec3;

use super::{Loaded, capacity_for, open, parse_f64};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Reads an OFF file into its vertices and (fan-triangulated) faces.
pub fn read_off(path: &Path) -> Result<Loaded, ReadError> {
    let reader = open(path)?;
    parse_off(reader).map_err(|(location, kind)| ReadError::new(path, location, kind))
}

/// Lines with content (comments stripped), numbered from 1.
struct Lines<R> {
    inner: R,
    line_no: usize,
    buf: String,
}

impl<R: BufRead> Lines<R> {
    /// The next line holding at least one token, with its number; `Ok(None)` at the end.
    fn next_content(&mut self) -> Result<Option<(usize, &str)>, (Location, ReadErrorKind)> {
        loop {
            self.buf.clear();
            let n = self
                .inner
                .read_line(&mut self.buf)
                .map_err(|e| (Location::Line(self.line_no + 1), ReadErrorKind::Io(e)))?;
            if n == 0 {
                return Ok(None);
            }
            self.line_no += 1;
            let content = self.buf.split('#').next().unwrap_or("").trim();
            if !content.is_empty() {
                // Re-borrow: the trimmed slice lives in `self.buf`.
                let start = content.as_ptr() as usize - self.buf.as_ptr() as usize;
                let end = start + content.len();
                return Ok(Some((self.line_no, &self.buf[start..end])));
            }
        }
    }
}

fn parse_count(token: &str, line: usize) -> Result<usize, (Location, ReadErrorKind)> {
    token.parse::<usize>().map_err(|_| {
        (
            Location::Line(line),
            ReadErrorKind::BadHeader(format!("expected a count, found {token:?}")),
        )
    })
}

fn parse_off<R: BufRead>(reader: R) -> Result<Loaded, (Location, ReadErrorKind)> {
    let mut lines = Lines {
        inner: reader,
        line_no: 0,
        buf: String::new(),
    };

    // Header: keyword and counts, possibly on one line.
    let Some((_, first)) = lines.next_content()? else {
        return Err((Location::File, ReadErrorKind::Empty));
    };
    let mut tokens: Vec<String> = first.split_whitespace().map(str::to_owned).collect();
    let keyword = tokens[0].to_ascii_uppercase();
    if keyword.ends_with("OFF") {
        if !matches!(keyword.as_str(), "OFF" | "COFF" | "NOFF" | "CNOFF") {
            return Err((
                Location::Line(lines.line_no),
                ReadErrorKind::Unsupported(format!("OFF variant {keyword}")),
            ));
        }
        tokens.remove(0);
        if tokens.is_empty() {
            match lines.next_content()? {
                Some((_, l)) => tokens = l.split_whitespace().map(str::to_owned).collect(),
                None => {
                    return Err((
                        Location::Line(lines.line_no),
                        ReadErrorKind::BadHeader("the counts line is missing".into()),
                    ));
                }
            }
        }
    }
    let counts_line = lines.line_no;
    if tokens.len() < 2 {
        return Err((
            Location::Line(counts_line),
            ReadErrorKind::BadHeader(format!(
                "expected `n_vertices n_faces [n_edges]`, found {:?}",
                tokens.join(" ")
            )),
        ));
    }
    let n_vertices = parse_count(&tokens[0], counts_line)?;
    let n_faces = parse_count(&tokens[1], counts_line)?;
    if n_vertices == 0 {
        return Err((Location::Line(counts_line), ReadErrorKind::Empty));
    }

    let mut positions = Vec::with_capacity(capacity_for(n_vertices));
    for index in 0..n_vertices {
        let Some((line_no, line)) = lines.next_content()? else {
            return Err((
                Location::Line(lines.line_no),
                ReadErrorKind::Truncated {
                    what: "vertices",
                    expected: n_vertices,
                    found: index,
                },
            ));
        };
        let here = Location::Line(line_no);
        let mut xyz = [0.0; 3];
        let mut fields = line.split_whitespace();
        for (k, slot) in xyz.iter_mut().enumerate() {
            let token = fields.next().ok_or((
                here,
                ReadErrorKind::FieldCount {
                    expected: 3,
                    found: k,
                },
            ))?;
            *slot = parse_f64(token).map_err(|kind| (here, kind))?;
            if !slot.is_finite() {
                return Err((
                    here,
                    ReadErrorKind::NonFinite {
                        index,
                        value: *slot,
                    },
                ));
            }
        }
        positions.push(DVec3::from_array(xyz));
    }

    let mut triangles = Vec::with_capacity(capacity_for(n_faces));
    let mut corners: Vec<u32> = Vec::new();
    for face in 0..n_faces {
        let Some((line_no, line)) = lines.next_content()? else {
            return Err((
                Location::Line(lines.line_no),
                ReadErrorKind::Truncated {
                    what: "faces",
                    expected: n_faces,
                    found: face,
                },
            ));
        };
        let here = Location::Line(line_no);
        let mut fields = line.split_whitespace();
        let k_token = fields.next().unwrap_or("");
        let k = k_token.parse::<usize>().map_err(|_| {
            (
                here,
                ReadErrorKind::NotANumber {
                    field: k_token.to_owned(),
                },
            )
        })?;
        if k < 3 {
            return Err((here, ReadErrorKind::DegenerateFace { face, corners: k }));
        }
        corners.clear();
        for found in 0..k {
            let token = fields.next().ok_or((
                here,
                ReadErrorKind::FieldCount {
                    expected: k + 1,
                    found: found + 1,
                },
            ))?;
            let v = token.parse::<i64>().map_err(|_| {
                (
                    here,
                    ReadErrorKind::NotANumber {
                        field: token.to_owned(),
                    },
                )
            })?;
            if v < 0 || v as usize >= n_vertices {
                return Err((
                    here,
                    ReadErrorKind::FaceIndexOutOfRange {
                        face,
                        vertex: v,
                        n_vertices,
                    },
                ));
            }
            corners.push(v as u32);
        }
        for i in 1..k - 1 {
            triangles.push([corners[0], corners[i], corners[i + 1]]);
        }
    }

    Ok(Loaded {
        cloud: PointCloud {
            positions,
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
        parse_off(text.as_bytes())
    }

    fn check_err(text: &str, line: usize, expected: impl Fn(&ReadErrorKind) -> bool) {
        let (location, kind) = parse(text).unwrap_err();
        assert_eq!(location, Location::Line(line), "{kind}");
        assert!(expected(&kind), "unexpected error kind: {kind}");
    }

    const QUAD: &str = "OFF\n# a comment\n4 1 0\n\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    #[test]
    fn reads_a_quad_as_two_triangles() {
        let loaded = parse(QUAD).unwrap();
        assert_eq!(loaded.cloud.len(), 4);
        assert_eq!(loaded.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn counts_on_the_keyword_line() {
        let loaded = parse("OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(loaded.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn empty_file() {
        let (location, kind) = parse("").unwrap_err();
        assert_eq!(location, Location::File);
        assert!(matches!(kind, ReadErrorKind::Empty));
    }

    #[test]
    fn truncated_vertices() {
        check_err("OFF\n4 1 0\n0 0 0\n1 0 0\n", 4, |k| {
            matches!(
                k,
                ReadErrorKind::Truncated {
                    what: "vertices",
                    expected: 4,
                    found: 2
                }
            )
        });
    }

    #[test]
    fn huge_count_does_not_allocate_and_reports_truncation() {
        check_err("OFF\n18446744073709551615 0 0\n0 0 0\n", 3, |k| {
            matches!(
                k,
                ReadErrorKind::Truncated {
                    what: "vertices",
                    found: 1,
                    ..
                }
            )
        });
    }

    #[test]
    fn truncated_faces() {
        check_err("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 6, |k| {
            matches!(
                k,
                ReadErrorKind::Truncated {
                    what: "faces",
                    expected: 2,
                    found: 1
                }
            )
        });
    }

    #[test]
    fn non_numeric_coordinate() {
        check_err(
            "OFF\n3 0 0\n0 0 0\n1 zero 0\n0 1 0\n",
            4,
            |k| matches!(k, ReadErrorKind::NotANumber { field } if field == "zero"),
        );
    }

    #[test]
    fn nan_and_infinite_coordinates() {
        check_err("OFF\n3 0 0\n0 0 0\n1 nan 0\n0 1 0\n", 4, |k| {
            matches!(k, ReadErrorKind::NonFinite { index: 1, .. })
        });
        check_err("OFF\n3 0 0\n0 0 0\n1 0 0\n0 inf 0\n", 5, |k| {
            matches!(k, ReadErrorKind::NonFinite { index: 2, .. })
        });
    }

    #[test]
    fn face_index_out_of_range() {
        check_err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", 6, |k| {
            matches!(
                k,
                ReadErrorKind::FaceIndexOutOfRange {
                    face: 0,
                    vertex: 3,
                    n_vertices: 3
                }
            )
        });
        check_err("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", 6, |k| {
            matches!(k, ReadErrorKind::FaceIndexOutOfRange { vertex: -1, .. })
        });
    }

    #[test]
    fn too_few_coordinates() {
        check_err("OFF\n3 0 0\n0 0\n", 3, |k| {
            matches!(
                k,
                ReadErrorKind::FieldCount {
                    expected: 3,
                    found: 2
                }
            )
        });
    }

    #[test]
    fn bad_counts_line() {
        check_err("OFF\nthree 1 0\n", 2, |k| {
            matches!(k, ReadErrorKind::BadHeader(_))
        });
    }
}
