//! A point on disk, as the scratch files hold it: position, normal, colour and input index
//! ([`REC`] bytes, the pushed points' file), and a distributed one with its chunk, laid out by
//! [`Layout`] to hold only what the build keeps.

use cloud::glam::{DVec3, Vec3};
use cloud::ooc::Grid;

use super::Point;

/// Bytes of a point on disk: position, normal, colour, input index.
pub(super) const REC: usize = 24 + 12 + 3 + 8;
/// The most bytes a distributed point takes ([`Layout::len`]): the record and its chunk.
pub(super) const DREC: usize = REC + 4;

/// `p` as a record.
pub(super) fn pack(p: &Point, b: &mut [u8]) {
    for k in 0..3 {
        b[8 * k..8 * k + 8].copy_from_slice(&p.position[k].to_le_bytes());
        b[24 + 4 * k..28 + 4 * k].copy_from_slice(&p.normal[k].to_le_bytes());
    }
    b[36..39].copy_from_slice(&p.color);
    b[39..47].copy_from_slice(&p.index.to_le_bytes());
}

/// A record's point.
pub(super) fn unpack(b: &[u8]) -> Point {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    let g = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap_or([0; 4]));
    Point {
        position: DVec3::new(f(0), f(8), f(16)),
        normal: Vec3::new(g(24), g(28), g(32)),
        color: [b[36], b[37], b[38]],
        index: u64::from_le_bytes(b[39..47].try_into().unwrap_or([0; 8])),
    }
}

/// The layout of a distributed point (step 4 of the module doc): the preparation's own record
/// (`cloud::ooc::Layout`: the position as three `f64`, or as the three `i32` of the grid the
/// prepared points lie on, `cloud::ooc::Chunks::grid`, each checked to give back the very same
/// `f64`; the colour only where the build keeps colours; the input index in 32 bits, as a build
/// refuses 2^31 points or more, `Tally::check`; the normal), then the chunk. A LAZ point
/// without colour takes 32 bytes instead of 51, and each is written once and read once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Layout {
    record: cloud::ooc::Layout,
}

impl Layout {
    /// Positions on `grid` where given, colours where `colors`.
    pub(super) fn new(grid: Option<Grid>, colors: bool) -> Self {
        Layout {
            record: cloud::ooc::Layout::new(cloud::ooc::Records { grid, colors }, true),
        }
    }

    /// Bytes of a distributed point.
    pub(super) fn len(&self) -> usize {
        self.record.len() + 4
    }

    /// `p` of `chunk` into the first [`Layout::len`] bytes of `b`; `None` when its position is
    /// off the grid or its index above 32 bits (neither can happen to a prepared point).
    pub(super) fn pack(&self, p: &Point, chunk: u32, b: &mut [u8; DREC]) -> Option<()> {
        let point = cloud::ooc::Point {
            position: p.position,
            normal: p.normal,
            color: p.color,
        };
        let mut rec = [0u8; cloud::ooc::REC];
        self.record
            .pack(&point, u32::try_from(p.index).ok()?, &mut rec)
            .ok()?;
        let n = self.record.len();
        b[..n].copy_from_slice(&rec[..n]);
        b[n..n + 4].copy_from_slice(&chunk.to_le_bytes());
        Some(())
    }

    /// A distributed point and its chunk (the colour zero where the layout keeps none).
    pub(super) fn unpack(&self, b: &[u8]) -> (Point, u32) {
        let n = self.record.len();
        let mut rec = [0u8; cloud::ooc::REC];
        rec[..n].copy_from_slice(&b[..n]);
        let (p, index) = self.record.unpack(&rec);
        let chunk = u32::from_le_bytes([b[n], b[n + 1], b[n + 2], b[n + 3]]);
        (
            Point {
                position: p.position,
                normal: p.normal,
                color: p.color,
                index,
            },
            chunk,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_distributed_point_comes_back_as_it_went() {
        let grid = Grid {
            scale: [0.001, 0.01, 0.25],
            offset: [512_000.0, -3.5, 7.0],
        };
        let p = Point {
            position: DVec3::new(
                grid.coordinate(0, 123_456),
                grid.coordinate(1, -98_765),
                grid.coordinate(2, i32::MAX),
            ),
            normal: Vec3::new(0.25, -0.5, 0.75),
            color: [1, 2, 3],
            index: u64::from(u32::MAX),
        };
        for (grid, colors, len) in [
            (None, true, 47),
            (None, false, 44),
            (Some(grid), true, 35),
            (Some(grid), false, 32),
        ] {
            let layout = Layout::new(grid, colors);
            assert_eq!(layout.len(), len);
            let mut b = [0u8; DREC];
            layout.pack(&p, 77, &mut b).unwrap();
            let (q, chunk) = layout.unpack(&b[..layout.len()]);
            assert_eq!(chunk, 77);
            assert_eq!(
                q.position.to_array().map(f64::to_bits),
                p.position.to_array().map(f64::to_bits)
            );
            assert_eq!((q.normal, q.index), (p.normal, p.index));
            assert_eq!(q.color, if colors { p.color } else { [0; 3] });
        }
        let layout = Layout::new(Some(grid), false);
        let off = Point {
            position: DVec3::new(512_000.000_5, 0.0, 7.0),
            ..p
        };
        assert!(layout.pack(&off, 0, &mut [0; DREC]).is_none());
        let wide = Point {
            index: 1 << 32,
            ..p
        };
        assert!(layout.pack(&wide, 0, &mut [0; DREC]).is_none());
    }
}
