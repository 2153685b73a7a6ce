//! XYZ reader: one point per line, whitespace- or comma-separated numbers. Blank lines, `#`
//! comments and lines starting with `//` are skipped; errors carry the 1-based line number.
//!
//! Which column holds what is decided by one documented rule, in this order:
//! 1. the columns the caller names ([`Columns`], `--columns x,y,z,r,g,b` on the command line,
//!    `columns = "..."` in a manifest);
//! 2. a header line before the first point: a comment whose words are column names, such as
//!    `# x y z nx ny nz` or CloudCompare's `//X,Y,Z,R,G,B` (names are case-insensitive: `x y z`,
//!    `nx ny nz`, `r g b` or `red green blue`; any other word is a column skipped, such as
//!    CloudCompare's scalar fields);
//! 3. otherwise the first point's count: three columns are `x y z`; six are `x y z` and a
//!    triple that is read as **normals** only when every triple has unit length within
//!    [`crate::normals::GIVEN_LENGTH_TOLERANCE`] (10^-3, the tolerance of every normal a file
//!    gives), as **colours** only when every value is an integer from 0 to 255,
//!    and is refused when both or neither hold, the error naming both readings (the first
//!    line each fails on) and how to say which; any other count is refused.
//!
//! Normals named by a header or the caller must be unit vectors (else
//! [`ReadErrorKind::BadNormal`], `crate::normals::is_given_normal`), colours integers from 0 to
//! 255. [`read_xyz`] says in `Loaded::normal_fields` which columns gave the normals and why.

use std::io::BufRead;
use std::path::Path;

use glam::{DVec3, Vec3};

use super::{open, parse_f64};
use crate::error::{Location, ReadError, ReadErrorKind};
use crate::points::PointCloud;

/// What one column of an XYZ file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// A coordinate: 0, 1, 2 for x, y, z.
    Position(usize),
    /// A normal's component.
    Normal(usize),
    /// A colour's channel (an integer 0–255).
    Colour(usize),
    /// Anything else: not read.
    Skip,
}

/// The columns of an XYZ file, in order: x, y and z once each; normals and colours all three
/// channels or none.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Columns(pub Vec<Column>);

impl Columns {
    /// The columns a list of names gives (`x,y,z,nx,ny,nz`; `_` or `skip` for a column not
    /// read; with `strict`, any other name is an error, else a column skipped).
    pub fn from_names<'a>(
        names: impl IntoIterator<Item = &'a str>,
        strict: bool,
    ) -> Result<Self, String> {
        let mut out = Vec::new();
        for name in names {
            let c = match name.to_ascii_lowercase().as_str() {
                "x" => Column::Position(0),
                "y" => Column::Position(1),
                "z" => Column::Position(2),
                "nx" => Column::Normal(0),
                "ny" => Column::Normal(1),
                "nz" => Column::Normal(2),
                "r" | "red" => Column::Colour(0),
                "g" | "green" => Column::Colour(1),
                "b" | "blue" => Column::Colour(2),
                "_" | "skip" => Column::Skip,
                other if strict => {
                    return Err(format!(
                        "unknown column {other:?}: the names are x, y, z, nx, ny, nz, r, g, b \
                         (or red, green, blue) and _ for a column not read"
                    ));
                }
                _ => Column::Skip,
            };
            if c != Column::Skip && out.contains(&c) {
                return Err(format!("column {name:?} is named twice"));
            }
            out.push(c);
        }
        for (kind, of) in [
            ("x, y and z", Column::Position as fn(usize) -> Column),
            ("nx, ny and nz", Column::Normal),
            ("r, g and b", Column::Colour),
        ] {
            let n = (0..3).filter(|&k| out.contains(&of(k))).count();
            if (kind == "x, y and z" && n != 3) || n % 3 != 0 {
                return Err(format!(
                    "the columns name {n} of {kind}: {}",
                    if kind == "x, y and z" {
                        "x, y and z are needed"
                    } else {
                        "give all three or none"
                    }
                ));
            }
        }
        Ok(Self(out))
    }

    fn has(&self, c: Column) -> bool {
        self.0.contains(&c)
    }
}

impl std::str::FromStr for Columns {
    type Err = String;

    /// `x,y,z,r,g,b` (commas or spaces).
    fn from_str(s: &str) -> Result<Self, String> {
        Self::from_names(
            s.split(|c: char| c == ',' || c.is_whitespace())
                .filter(|t| !t.is_empty()),
            true,
        )
    }
}

/// Reads an XYZ file; `columns` names what each column holds (else the module doc's rule).
/// `normal_fields` says which columns gave the normals, and what named them.
pub fn read_xyz(path: &Path, columns: Option<&Columns>) -> Result<super::Loaded, ReadError> {
    let reader = open(path)?;
    let (cloud, named) = parse_xyz(reader, columns)
        .map_err(|(location, kind)| ReadError::new(path, location, kind))?;
    let normal_fields = cloud.normals.as_ref().map(|_| match named {
        Named::Caller(c) => format!("columns {} (XYZ, named by --columns)", normal_columns(&c)),
        Named::Header(c) => format!("columns {} (XYZ, named by its header)", normal_columns(&c)),
        Named::Rule => "columns 4 to 6 (XYZ: every triple of unit length)".to_owned(),
    });
    Ok(super::Loaded {
        cloud,
        normal_fields,
        ..super::Loaded::default()
    })
}

/// What named an XYZ file's columns.
enum Named {
    /// The caller (`--columns`, a manifest's `columns`).
    Caller(Columns),
    /// A header line.
    Header(Columns),
    /// Nothing: the module doc's rule.
    Rule,
}

/// `4, 5 and 6`: the 1-based columns of the normal's components, in x, y, z order.
fn normal_columns(c: &Columns) -> String {
    let at = |k: usize| {
        c.0.iter()
            .position(|&x| x == Column::Normal(k))
            .map_or(0, |i| i + 1)
    };
    format!("{}, {} and {}", at(0), at(1), at(2))
}

/// The three values after x, y and z of six unnamed columns, and what they can be read as.
#[derive(Default)]
struct Unnamed {
    triples: Vec<[f64; 3]>,
    /// The first line whose triple is not a unit vector, and its length.
    not_unit: Option<(usize, [f64; 3], f64)>,
    /// The first line with a value that is not an integer 0–255, and that value.
    not_colour: Option<(usize, f64)>,
}

fn is_byte(v: f64) -> bool {
    (0.0..=255.0).contains(&v) && v.fract() == 0.0
}

fn parse_xyz<R: BufRead>(
    mut reader: R,
    given: Option<&Columns>,
) -> Result<(PointCloud, Named), (Location, ReadErrorKind)> {
    let mut positions = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut colours: Vec<[u8; 3]> = Vec::new();
    let mut columns: Option<Columns> = given.cloned();
    let mut from_header = false;
    let mut unnamed: Option<Unnamed> = None;
    let mut expected: Option<usize> = columns.as_ref().map(|c| c.0.len());
    let mut buf = String::new();
    let mut line_no = 0;
    loop {
        buf.clear();
        let n = reader
            .read_line(&mut buf)
            .map_err(|e| (Location::Line(line_no + 1), ReadErrorKind::Io(e)))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let here = Location::Line(line_no);
        let trimmed = buf.trim();
        let comment = trimmed
            .strip_prefix("//")
            .or_else(|| trimmed.strip_prefix('#'));
        if let Some(text) = comment {
            // A header: a comment before the first point whose words are column names.
            if positions.is_empty() && columns.is_none() {
                let words: Vec<&str> = text
                    .split(|c: char| c == ',' || c.is_whitespace())
                    .filter(|t| !t.is_empty())
                    .collect();
                let named = words.iter().any(|w| w.eq_ignore_ascii_case("x"));
                if named && let Ok(c) = Columns::from_names(words, false) {
                    expected = Some(c.0.len());
                    columns = Some(c);
                    from_header = true;
                }
            }
            continue;
        }
        let content = trimmed.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let values: Vec<&str> = content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
            .collect();
        let want = *expected.get_or_insert(if values.len() == 6 { 6 } else { 3 });
        if values.len() != want {
            return Err((
                here,
                ReadErrorKind::FieldCount {
                    expected: want,
                    found: values.len(),
                },
            ));
        }
        let index = positions.len();
        match &columns {
            Some(cols) => {
                let (mut p, mut nrm, mut col) = ([0.0; 3], [0.0f32; 3], [0u8; 3]);
                for (c, token) in cols.0.iter().zip(&values) {
                    match *c {
                        Column::Skip => {}
                        Column::Position(k) => {
                            p[k] = parse_f64(token).map_err(|kind| (here, kind))?;
                            if !p[k].is_finite() {
                                return Err((
                                    here,
                                    ReadErrorKind::NonFinite { index, value: p[k] },
                                ));
                            }
                        }
                        Column::Normal(k) => {
                            nrm[k] = parse_f64(token).map_err(|kind| (here, kind))? as f32;
                        }
                        Column::Colour(k) => {
                            let v = parse_f64(token).map_err(|kind| (here, kind))?;
                            if !is_byte(v) {
                                return Err((
                                    here,
                                    ReadErrorKind::Columns(format!(
                                        "colour value {token} is not an integer from 0 to 255"
                                    )),
                                ));
                            }
                            col[k] = v as u8;
                        }
                    }
                }
                positions.push(DVec3::from_array(p));
                if cols.has(Column::Normal(0)) {
                    let n = Vec3::from_array(nrm);
                    if !crate::normals::is_given_normal(n) {
                        return Err((
                            here,
                            ReadErrorKind::BadNormal {
                                index,
                                normal: nrm,
                                tolerance: crate::normals::GIVEN_LENGTH_TOLERANCE,
                            },
                        ));
                    }
                    normals.push(n);
                }
                if cols.has(Column::Colour(0)) {
                    colours.push(col);
                }
            }
            None => {
                let mut v = [0.0; 6];
                for (slot, token) in v.iter_mut().zip(&values) {
                    *slot = parse_f64(token).map_err(|kind| (here, kind))?;
                }
                if let Some(&value) = v[..3].iter().find(|v| !v.is_finite()) {
                    return Err((here, ReadErrorKind::NonFinite { index, value }));
                }
                positions.push(DVec3::new(v[0], v[1], v[2]));
                if want == 6 {
                    let u = unnamed.get_or_insert_with(Unnamed::default);
                    let t = [v[3], v[4], v[5]];
                    let length = DVec3::from_array(t).length();
                    let unit = Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32);
                    if u.not_unit.is_none() && !crate::normals::is_given_normal(unit) {
                        u.not_unit = Some((line_no, t, length));
                    }
                    if u.not_colour.is_none()
                        && let Some(&bad) = t.iter().find(|&&x| !is_byte(x))
                    {
                        u.not_colour = Some((line_no, bad));
                    }
                    u.triples.push(t);
                }
            }
        }
    }
    if positions.is_empty() {
        return Err((Location::File, ReadErrorKind::Empty));
    }
    let named = match (&columns, from_header) {
        (Some(c), true) => Named::Header(c.clone()),
        (Some(c), false) => Named::Caller(c.clone()),
        (None, _) => Named::Rule,
    };
    let mut cloud = PointCloud {
        positions,
        ..PointCloud::default()
    };
    if let Some(cols) = &columns {
        if cols.has(Column::Normal(0)) {
            cloud.normals = Some(normals);
        }
        if cols.has(Column::Colour(0)) {
            cloud.colors = Some(colours);
        }
    } else if let Some(u) = unnamed {
        match (u.not_unit, u.not_colour) {
            (None, Some(_)) => {
                cloud.normals = Some(
                    u.triples
                        .iter()
                        .map(|t| Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32))
                        .collect(),
                );
            }
            (Some(_), None) => {
                cloud.colors = Some(
                    u.triples
                        .iter()
                        .map(|t| [t[0] as u8, t[1] as u8, t[2] as u8])
                        .collect(),
                );
            }
            (not_unit, not_colour) => {
                return Err((
                    Location::File,
                    ReadErrorKind::Columns(ambiguous(not_unit, not_colour)),
                ));
            }
        }
    }
    Ok((cloud, named))
}

/// Why six unnamed columns cannot be read, naming both readings and how to say which.
fn ambiguous(not_unit: Option<(usize, [f64; 3], f64)>, not_colour: Option<(usize, f64)>) -> String {
    let how = "name the columns: --columns x,y,z,nx,ny,nz or --columns x,y,z,r,g,b on the \
               command line (`columns = \"...\"` in a manifest, `_` for a column not read), or \
               a header line before the points such as `# x y z nx ny nz` or `//X,Y,Z,R,G,B`";
    match (not_unit, not_colour) {
        (Some((nl, t, length)), Some((cl, value))) => format!(
            "six columns without a header, and the last three are neither normals (line {nl}: \
             ({}, {}, {}) has length {length:.4}, not 1 within {}) nor colours \
             (line {cl}: {value} is not an integer from 0 to 255): {how}",
            t[0],
            t[1],
            t[2],
            crate::normals::GIVEN_LENGTH_TOLERANCE
        ),
        _ => format!(
            "six columns without a header, and the last three read both as unit normals and \
             as colours from 0 to 255 (every triple is a unit vector of integers, such as \
             (0, 0, 1)): {how}"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<PointCloud, (Location, ReadErrorKind)> {
        parse_xyz(text.as_bytes(), None).map(|(c, _)| c)
    }

    #[test]
    fn reads_points_and_normals() {
        let cloud = parse("# header\n0 0 0 0 0 1\n1,2,3,0,0.6,0.8\n").unwrap();
        assert_eq!(
            cloud.positions,
            vec![DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0)]
        );
        assert_eq!(cloud.normals, Some(vec![Vec3::Z, Vec3::new(0.0, 0.6, 0.8)]));
        // Unit triples, one with -1: normals (not colours).
        let cloud = parse("0 0 0 0 0 -1\n1 2 3 0.6 0.8 0\n").unwrap();
        assert_eq!(
            cloud.normals,
            Some(vec![-Vec3::Z, Vec3::new(0.6, 0.8, 0.0)])
        );
        assert_eq!(cloud.colors, None);
    }

    #[test]
    fn six_columns_of_integers_are_colours_and_the_rule_refuses_what_is_neither() {
        let cloud = parse("0 0 0 200 100 50\n1 1 1 0 0 255\n").unwrap();
        assert_eq!(cloud.colors, Some(vec![[200, 100, 50], [0, 0, 255]]));
        assert_eq!(cloud.normals, None);
        // Neither: the error names both readings, their lines, and the flag.
        let (loc, kind) = parse("0 0 0 200 100 50\n1 1 1 0.5 0.5 0.5\n").unwrap_err();
        assert_eq!(loc, Location::File);
        let text = kind.to_string();
        assert!(
            text.contains("neither normals (line 1: (200, 100, 50) has length 229.1288")
                && text.contains("nor colours (line 2: 0.5 is not an integer")
                && text.contains("--columns x,y,z,r,g,b"),
            "{text}"
        );
        // Both: unit vectors of integers.
        let text = parse("0 0 0 0 0 1\n1 1 1 1 0 0\n")
            .unwrap_err()
            .1
            .to_string();
        assert!(
            text.contains("read both as unit normals and as colours"),
            "{text}"
        );
    }

    #[test]
    fn a_header_or_the_caller_names_the_columns() {
        let cloud = parse("# x y z r g b\n0 0 0 0 0 1\n").unwrap();
        assert_eq!(cloud.colors, Some(vec![[0, 0, 1]]));
        let cloud = parse("//X,Y,Z,R,G,B,Scalar_field\n1,2,3,10,20,30,0.5\n").unwrap();
        assert_eq!(cloud.positions, vec![DVec3::new(1.0, 2.0, 3.0)]);
        assert_eq!(cloud.colors, Some(vec![[10, 20, 30]]));
        let cloud = parse("# nx ny nz x y z\n0 1 0 5 6 7\n").unwrap();
        assert_eq!(cloud.positions, vec![DVec3::new(5.0, 6.0, 7.0)]);
        assert_eq!(cloud.normals, Some(vec![Vec3::Y]));
        // The caller's columns win over a header.
        let given: Columns = "x,y,z,_,nx,ny,nz".parse().unwrap();
        let (cloud, named) =
            parse_xyz("# x y z r g b\n0 0 0 9 0 0 1\n".as_bytes(), Some(&given)).unwrap();
        assert_eq!(cloud.normals, Some(vec![Vec3::Z]));
        assert!(matches!(named, Named::Caller(ref c) if normal_columns(c) == "5, 6 and 7"));
        // Named normals must be unit vectors, as every normal a file gives.
        let (loc, kind) = parse("# x y z nx ny nz\n0 0 0 0 0 1\n1 0 0 0 0 2\n").unwrap_err();
        assert_eq!(loc, Location::Line(3));
        assert!(matches!(kind, ReadErrorKind::BadNormal { index: 1, .. }));
        // Colours named must be bytes; the line is named.
        let (loc, kind) = parse("# x y z r g b\n0 0 0 1 2 3\n0 0 0 256 0 0\n").unwrap_err();
        assert_eq!(loc, Location::Line(3));
        assert!(
            kind.to_string()
                .contains("256 is not an integer from 0 to 255")
        );
        // Names checked.
        assert!(
            "x,y"
                .parse::<Columns>()
                .unwrap_err()
                .contains("x, y and z are needed")
        );
        assert!(
            "x,y,z,nx"
                .parse::<Columns>()
                .unwrap_err()
                .contains("all three or none")
        );
        assert!(
            "x,y,z,w"
                .parse::<Columns>()
                .unwrap_err()
                .contains("unknown column \"w\"")
        );
        assert!(
            "x,y,z,x"
                .parse::<Columns>()
                .unwrap_err()
                .contains("named twice")
        );
    }

    #[test]
    fn errors_name_the_line() {
        let (loc, kind) = parse("0 0 0\n1 1\n").unwrap_err();
        assert_eq!(loc, Location::Line(2));
        assert!(matches!(
            kind,
            ReadErrorKind::FieldCount {
                expected: 3,
                found: 2
            }
        ));

        let (loc, kind) = parse("0 0 0\n\n1 x 1\n").unwrap_err();
        assert_eq!(loc, Location::Line(3));
        assert!(matches!(kind, ReadErrorKind::NotANumber { .. }));

        let (loc, kind) = parse("0 0 0\n1 -inf 1\n").unwrap_err();
        assert_eq!(loc, Location::Line(2));
        assert!(matches!(kind, ReadErrorKind::NonFinite { index: 1, .. }));
    }

    #[test]
    fn empty_input() {
        let (loc, kind) = parse("# nothing\n\n").unwrap_err();
        assert_eq!(loc, Location::File);
        assert!(matches!(kind, ReadErrorKind::Empty));
    }
}
