//! A point on disk, as the scratch files hold it: position, normal, colour and input index
//! ([`REC`] bytes), and a distributed one with its chunk ([`DREC`]).

use cloud::glam::{DVec3, Vec3};

use super::Point;

/// Bytes of a point on disk: position, normal, colour, input index.
pub(super) const REC: usize = 24 + 12 + 3 + 8;
/// A distributed point: the record and its chunk.
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
