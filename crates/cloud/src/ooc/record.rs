//! A prepared point on disk: the fixed-size record of a point (position, colour, its index in
//! the input, normal) as the scratch files hold it. Where the normals are estimated, the records
//! hold no normal ([`SHORT`] bytes, the normal read as zero): the estimates go to files of
//! normals beside the chunks' (`chunks::Set::normals`). The index takes 32 bits: the preparation refuses a cloud of more than
//! `u32::MAX` points as it reads it (the trees count leaves in 32 bits). Every record is
//! written twice (the input, then its chunk), so each byte saved here is saved twice.

use glam::{DVec3, Vec3};

use super::Point;

/// Bytes of a point on disk: position, colour, index in the input (32 bits), normal.
pub(super) const REC: usize = 24 + 3 + 4 + 12;
/// Bytes of a point on disk without its normal (the first bytes of a record).
pub(super) const SHORT: usize = REC - 12;

/// `p` and its input index (below 2^32: the caller checks) as a record.
pub(super) fn pack(p: &Point, index: u32, b: &mut [u8; REC]) {
    for k in 0..3 {
        b[8 * k..8 * k + 8].copy_from_slice(&p.position[k].to_le_bytes());
        b[31 + 4 * k..35 + 4 * k].copy_from_slice(&p.normal[k].to_le_bytes());
    }
    b[24..27].copy_from_slice(&p.color);
    b[27..31].copy_from_slice(&index.to_le_bytes());
}

/// A record's point and input index (the normal zero where only the first [`SHORT`] bytes
/// were read into a zeroed `b`).
pub(super) fn unpack(b: &[u8; REC]) -> (Point, u64) {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    let g = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap_or([0; 4]));
    (
        Point {
            position: DVec3::new(f(0), f(8), f(16)),
            normal: Vec3::new(g(31), g(35), g(39)),
            color: [b[24], b[25], b[26]],
        },
        u64::from(u32::from_le_bytes(b[27..31].try_into().unwrap_or([0; 4]))),
    )
}

/// A record's position alone.
pub(super) fn position_of(b: &[u8; REC]) -> DVec3 {
    let f = |o: usize| f64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
    DVec3::new(f(0), f(8), f(16))
}
