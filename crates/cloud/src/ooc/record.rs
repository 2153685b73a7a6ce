//! A prepared point on disk: the fixed-size record of a point (position, colour, its index in
//! the input, normal) as the scratch files hold it, laid out by [`Layout`] so that a record
//! holds only what the input has:
//!
//! - the position as three `f64` (24 bytes), or, where the input declares the grid its
//!   positions lie on ([`Grid`]: LAS and LAZ store `scale · i + offset` with a 32-bit `i`), as
//!   the three `i32` (12 bytes), checked on the way in to give back the very same `f64`s;
//! - the colour (3 bytes) only where the input has colours;
//! - the input index (32 bits: the preparation refuses a cloud of more than `u32::MAX` points
//!   as it reads it, and the trees count leaves in 32 bits);
//! - the normal (12 bytes) only where it is given: estimated normals go to files of their own
//!   beside the chunks' (`chunks::Set::normals`).
//!
//! A LAZ point without colour, its normal estimated, takes 16 bytes instead of 31 (28 instead
//! of 43 with its normal given). Every record is written two or three times (the input, its
//! subset where the split makes one, then its chunk), so each byte saved here is saved as often.

use glam::{DVec3, Vec3};

use super::Point;
use crate::lod_file::{Error, Result};

/// The most bytes a record takes (position as `f64`, colour, index, normal): the size of the
/// buffers records are read into.
pub const REC: usize = 24 + 3 + 4 + 12;

/// The grid an input's positions lie on: along each axis, `scale · i + offset` for an `i32`
/// `i` (LAS's point records, as the `las` crate decodes them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Scale per axis.
    pub scale: [f64; 3],
    /// Offset per axis.
    pub offset: [f64; 3],
}

impl Grid {
    /// The integer of `x` on axis `a`, when one gives back exactly `x`
    /// ([`Grid::coordinate`]).
    pub fn integer(&self, a: usize, x: f64) -> Option<i32> {
        let (s, o) = (self.scale[a], self.offset[a]);
        let guess = ((x - o) / s).round();
        if !guess.is_finite() {
            return None;
        }
        let guess = guess as i64;
        [guess, guess - 1, guess + 1]
            .into_iter()
            .filter_map(|i| i32::try_from(i).ok())
            .find(|&i| self.coordinate(a, i).to_bits() == x.to_bits())
    }

    /// The coordinate of integer `i` on axis `a`.
    pub fn coordinate(&self, a: usize, i: i32) -> f64 {
        self.scale[a] * f64::from(i) + self.offset[a]
    }
}

/// What the scratch records keep of a point beside its input index and (where given) normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Records {
    /// The grid every input position lies on, when the input declares one: positions kept as
    /// integers (12 bytes instead of 24). A position off the grid is an error.
    pub grid: Option<Grid>,
    /// Colours kept (3 bytes); without, every point's colour is read back as zero.
    pub colors: bool,
}

impl Default for Records {
    /// Positions as `f64`, colours kept: any input.
    fn default() -> Self {
        Records {
            grid: None,
            colors: true,
        }
    }
}

/// The layout of the records of one preparation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    grid: Option<Grid>,
    colors: bool,
    normal: bool,
}

impl Layout {
    /// The layout for `records`, with the normal where `normal` (given normals).
    pub fn new(records: Records, normal: bool) -> Self {
        Layout {
            grid: records.grid,
            colors: records.colors,
            normal,
        }
    }

    /// The grid the positions are kept on, if any.
    pub(super) fn grid(&self) -> Option<Grid> {
        self.grid
    }

    fn position_bytes(&self) -> usize {
        if self.grid.is_some() { 12 } else { 24 }
    }

    /// Bytes of a record.
    pub fn len(&self) -> usize {
        self.position_bytes()
            + if self.colors { 3 } else { 0 }
            + 4
            + if self.normal { 12 } else { 0 }
    }

    /// Never: a record holds at least its index.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// `p`, point `index` of the input (below 2^32: the caller checks), as a record in the
    /// first [`Layout::len`] bytes of `b`; an error when its position is off the grid.
    pub fn pack(&self, p: &Point, index: u32, b: &mut [u8; REC]) -> Result<()> {
        let mut o = 0;
        match &self.grid {
            Some(g) => {
                for a in 0..3 {
                    let i = g
                        .integer(a, p.position[a])
                        .ok_or_else(|| Error::InvalidParameter {
                            name: "positions",
                            reason: format!(
                                "point {index} at {} is not on the grid the input declares \
                             (scale {:?}, offset {:?})",
                                p.position, g.scale, g.offset
                            ),
                        })?;
                    b[o..o + 4].copy_from_slice(&i.to_le_bytes());
                    o += 4;
                }
            }
            None => {
                for a in 0..3 {
                    b[o..o + 8].copy_from_slice(&p.position[a].to_le_bytes());
                    o += 8;
                }
            }
        }
        if self.colors {
            b[o..o + 3].copy_from_slice(&p.color);
            o += 3;
        }
        b[o..o + 4].copy_from_slice(&index.to_le_bytes());
        o += 4;
        if self.normal {
            for a in 0..3 {
                b[o..o + 4].copy_from_slice(&p.normal[a].to_le_bytes());
                o += 4;
            }
        }
        Ok(())
    }

    /// A record's point and input index (the normal zero where the layout has none, the
    /// colour zero where it keeps none).
    pub fn unpack(&self, b: &[u8; REC]) -> (Point, u64) {
        let position = self.position_of(b);
        let mut o = self.position_bytes();
        let mut color = [0; 3];
        if self.colors {
            color.copy_from_slice(&b[o..o + 3]);
            o += 3;
        }
        let index = u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        o += 4;
        let normal = if self.normal {
            Vec3::from_array(std::array::from_fn(|a| f32_at(b, o + 4 * a)))
        } else {
            Vec3::ZERO
        };
        (
            Point {
                position,
                normal,
                color,
            },
            u64::from(index),
        )
    }

    /// A record's position alone.
    pub(super) fn position_of(&self, b: &[u8]) -> DVec3 {
        match &self.grid {
            Some(g) => DVec3::from_array(std::array::from_fn(|a| {
                let o = 4 * a;
                g.coordinate(a, i32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]))
            })),
            None => DVec3::from_array(std::array::from_fn(|a| {
                let o = 8 * a;
                f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]))
            })),
        }
    }
}

fn f32_at(b: &[u8; REC], o: usize) -> f32 {
    f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(position: DVec3) -> Point {
        Point {
            position,
            normal: Vec3::new(0.25, -0.5, 1.0),
            color: [1, 2, 3],
        }
    }

    #[test]
    fn every_layout_gives_back_what_it_keeps() {
        let grid = Grid {
            scale: [1e-7, 1e-3, 0.01],
            offset: [0.5, 654_321.123, -17.0],
        };
        let p = point(DVec3::new(
            grid.coordinate(0, -2_000_000_000),
            grid.coordinate(1, 123_456_789),
            grid.coordinate(2, 7),
        ));
        for grid in [None, Some(grid)] {
            for colors in [false, true] {
                for normal in [false, true] {
                    let l = Layout::new(Records { grid, colors }, normal);
                    let mut b = [0xAAu8; REC];
                    l.pack(&p, 4_000_000_000, &mut b).unwrap();
                    // Bytes past the record are not read.
                    b[l.len()..].fill(0x55);
                    let (q, i) = l.unpack(&b);
                    assert_eq!(i, 4_000_000_000);
                    assert_eq!(
                        q.position.to_array().map(f64::to_bits),
                        p.position.to_array().map(f64::to_bits)
                    );
                    assert_eq!(l.position_of(&b), p.position);
                    assert_eq!(q.color, if colors { p.color } else { [0; 3] });
                    assert_eq!(q.normal, if normal { p.normal } else { Vec3::ZERO });
                    let expect = if grid.is_some() { 12 } else { 24 }
                        + if colors { 3 } else { 0 }
                        + 4
                        + if normal { 12 } else { 0 };
                    assert_eq!(l.len(), expect);
                }
            }
        }
    }

    #[test]
    fn a_position_off_the_grid_is_an_error_naming_the_point() {
        let l = Layout::new(
            Records {
                grid: Some(Grid {
                    scale: [0.01; 3],
                    offset: [0.0; 3],
                }),
                colors: false,
            },
            false,
        );
        let mut b = [0u8; REC];
        assert!(
            l.pack(&point(DVec3::new(0.01, 0.02, 0.03)), 5, &mut b)
                .is_ok()
        );
        let e = l
            .pack(&point(DVec3::new(0.015, 0.02, 0.03)), 5, &mut b)
            .unwrap_err();
        assert!(e.to_string().contains("point 5"), "{e}");
        // Beyond the 32-bit integers.
        assert!(
            l.pack(&point(DVec3::new(1e9, 0.0, 0.0)), 6, &mut b)
                .is_err()
        );
    }
}
