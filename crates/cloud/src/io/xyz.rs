//! XYZ reader: one point per line, `x y z` or `x y z nx ny nz` (the normal a unit vector,
//! else [`ReadErrorKind::BadNormal`]), whitespace- or comma-separated. Blank lines and `#`
//! comments are skipped; errors carry the 1-based line number.

use std::io::BufRead;
use std::path::Path;

use glam::{DVec3, Vec3};

use super::{open, parse_f64};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// Reads an XYZ file.
pub fn read_xyz(path: &Path) -> Result<PointCloud, ReadError> {
    let reader = open(path)?;
    parse_xyz(reader).map_err(|(location, kind)| ReadError::new(path, location, kind))
}

fn parse_xyz<R: BufRead>(mut reader: R) -> Result<PointCloud, (Location, ReadErrorKind)> {
    let mut positions = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut with_normals: Option<bool> = None;
    let mut buf = String::new();
    let mut line_no = 0;
    let mut values = Vec::with_capacity(6);
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
        if content.is_empty() {
            continue;
        }
        let here = Location::Line(line_no);
        values.clear();
        for token in content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
        {
            values.push(parse_f64(token).map_err(|kind| (here, kind))?);
        }
        let expected = match with_normals {
            Some(true) => 6,
            Some(false) => 3,
            None if values.len() == 6 => 6,
            None => 3,
        };
        if values.len() != expected {
            return Err((
                here,
                ReadErrorKind::FieldCount {
                    expected,
                    found: values.len(),
                },
            ));
        }
        with_normals = Some(expected == 6);
        let index = positions.len();
        if let Some(&value) = values[..3].iter().find(|v| !v.is_finite()) {
            return Err((here, ReadErrorKind::NonFinite { index, value }));
        }
        positions.push(DVec3::new(values[0], values[1], values[2]));
        if expected == 6 {
            let n = Vec3::new(values[3] as f32, values[4] as f32, values[5] as f32);
            if !crate::normals::is_given_normal(n) {
                return Err((
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
    }
    if positions.is_empty() {
        return Err((Location::File, ReadErrorKind::Empty));
    }
    Ok(PointCloud {
        positions,
        normals: (with_normals == Some(true)).then_some(normals),
        ..PointCloud::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_points_and_normals() {
        let cloud = parse_xyz("# header\n0 0 0 0 0 1\n1,2,3,0,1,0\n".as_bytes()).unwrap();
        assert_eq!(
            cloud.positions,
            vec![DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0)]
        );
        assert_eq!(cloud.normals, Some(vec![Vec3::Z, Vec3::Y]));
    }

    #[test]
    fn errors_name_the_line() {
        let (loc, kind) = parse_xyz("0 0 0\n1 1\n".as_bytes()).unwrap_err();
        assert_eq!(loc, Location::Line(2));
        assert!(matches!(
            kind,
            ReadErrorKind::FieldCount {
                expected: 3,
                found: 2
            }
        ));

        let (loc, kind) = parse_xyz("0 0 0\n\n1 x 1\n".as_bytes()).unwrap_err();
        assert_eq!(loc, Location::Line(3));
        assert!(matches!(kind, ReadErrorKind::NotANumber { .. }));

        let (loc, kind) = parse_xyz("0 0 0\n1 -inf 1\n".as_bytes()).unwrap_err();
        assert_eq!(loc, Location::Line(2));
        assert!(matches!(kind, ReadErrorKind::NonFinite { index: 1, .. }));
    }

    #[test]
    fn empty_input() {
        let (loc, kind) = parse_xyz("# nothing\n\n".as_bytes()).unwrap_err();
        assert_eq!(loc, Location::File);
        assert!(matches!(kind, ReadErrorKind::Empty));
    }
}
