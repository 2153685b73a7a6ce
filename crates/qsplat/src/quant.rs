//! QSplat's quantisation (Rusinkiewicz and Levoy 2000, §3.2; seed 002 §5.2.1), as in the
//! original v1.0 source (qsplat_spherequant.cpp, qsplat_normquant.cpp).
//!
//! - **Sphere, 13 bits.** A child's centre and radius relative to its parent sphere (centre C,
//!   radius R): the parent's bounding cube is cut into 13 cells per axis; an entry is a cube of
//!   `size` cells (size 1..=13) at cell offsets (x, y, z), standing for the sphere of centre
//!   C + R·((size + 2x)/13 − 1, …) and radius R·size/13. Entries far from the parent (centre
//!   beyond 1 + √3·size/13 parent radii) are dropped, which leaves [`SPHERE_TABLE_LEN`] = 7,621
//!   entries, index < 2^13.
//! - **Normal, 14 bits.** The cube face of the largest component (6 faces) and the two other
//!   components, each warped by atan(x)·4/π and quantised to 52 levels: 6 × 52 × 52 = 16,224
//!   codes.
//! - **Cone, 2 bits.** x = ⌊4·√sin(half-angle)⌋ (0.999 for half-angles over 1.5 rad); decoded,
//!   sin(half-angle) ≤ (1 + x)²/16 ∈ {1/16, 4/16, 9/16, 1}.
//! - **Colour, 16 bits.** RGB565.
//!
//! NOTE (deviation): the original picks the sphere entry by snapping the child's bounding cube
//! outwards to the grid, which does not make the decoded *sphere* enclose the child sphere (a
//! sphere offset diagonally in its cube pokes out of the cube's inscribed sphere). Here the
//! encoder picks the smallest entry whose decoded sphere encloses the child's sphere, computed
//! with the decoder's own arithmetic, so that a decoded sphere always encloses its subtree. The
//! cone is widened by the angle the normal's quantisation moved it, for the same reason. The
//! original dithers normals with `rand()` before quantising; we do not (results must not depend
//! on an unseeded generator).

use std::f64::consts::PI;
use std::sync::OnceLock;

use cloud::glam::DVec3;

/// Grid cells per axis.
pub const N_GRID: u32 = 13;
/// Entries of the sphere table.
pub const SPHERE_TABLE_LEN: usize = 7_621;
/// Levels per normal component.
pub const N_NORMAL: u32 = 52;
/// Distinct normal codes.
pub const NORMAL_CODES: u32 = 6 * N_NORMAL * N_NORMAL;

/// A decoded table entry: centre offset in parent radii, radius in parent radii, and the
/// (size, x, y, z) it encodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereEntry {
    /// Centre offset in parent radii.
    pub offset: DVec3,
    /// Radius in parent radii.
    pub radius: f64,
    /// Cube size in cells.
    pub size: u32,
    /// Cell offsets.
    pub cell: [u32; 3],
}

/// The sphere table (decode: index → entry) and its inverse ((size, x, y, z) → index).
pub fn sphere_table() -> &'static (Vec<SphereEntry>, Vec<u16>) {
    static TABLE: OnceLock<(Vec<SphereEntry>, Vec<u16>)> = OnceLock::new();
    TABLE.get_or_init(|| {
        let n = N_GRID as usize;
        let mut entries = Vec::with_capacity(SPHERE_TABLE_LEN);
        let mut index = vec![u16::MAX; n * n * n * n];
        for size in 1..=N_GRID {
            for x in 0..=N_GRID - size {
                for y in 0..=N_GRID - size {
                    for z in 0..=N_GRID - size {
                        let c = |v: u32| (size + 2 * v) as f64 / N_GRID as f64 - 1.0;
                        let offset = DVec3::new(c(x), c(y), c(z));
                        let radius = size as f64 / N_GRID as f64;
                        if offset.length_squared() > (1.0 + 3f64.sqrt() * radius).powi(2) {
                            continue;
                        }
                        index[enc_key(size, [x, y, z])] = entries.len() as u16;
                        entries.push(SphereEntry {
                            offset,
                            radius,
                            size,
                            cell: [x, y, z],
                        });
                    }
                }
            }
        }
        (entries, index)
    })
}

fn enc_key(size: u32, [x, y, z]: [u32; 3]) -> usize {
    let n = N_GRID as usize;
    (size as usize - 1) + n * (x as usize + n * (y as usize + n * z as usize))
}

/// Decodes sphere entry `index` relative to the parent (centre, radius).
#[inline]
pub fn decode_sphere(index: u16, parent_center: DVec3, parent_radius: f64) -> Option<(DVec3, f64)> {
    let e = sphere_table().0.get(index as usize)?;
    Some((
        parent_center + e.offset * parent_radius,
        e.radius * parent_radius,
    ))
}

/// The smallest table entry whose decoded sphere encloses the sphere (center, radius), given
/// the decoded parent; `None` only if the child is not inside the parent sphere.
///
/// For a size, the entry whose centre is nearest the child's is the per-axis rounding of the
/// continuous cell offset (the distance is separable), and if any entry of that size encloses
/// the child, the nearest does; so one candidate per size is tried, smallest size first.
pub fn encode_sphere(
    center: DVec3,
    radius: f64,
    parent_center: DVec3,
    parent_radius: f64,
) -> Option<u16> {
    let (_, index) = sphere_table();
    let rel = (center - parent_center) / parent_radius;
    let rr = radius / parent_radius;
    let min_size = ((rr * N_GRID as f64).floor() as u32).clamp(1, N_GRID);
    for size in min_size..=N_GRID {
        let best = |v: f64| {
            ((((v + 1.0) * N_GRID as f64 - size as f64) / 2.0).round() as i64)
                .clamp(0, (N_GRID - size) as i64) as u32
        };
        let idx = index[enc_key(size, [best(rel.x), best(rel.y), best(rel.z)])];
        if idx == u16::MAX {
            // Only far-off entries are missing from the table; a child inside its parent never
            // rounds to one.
            continue;
        }
        let Some((c, r)) = decode_sphere(idx, parent_center, parent_radius) else {
            continue;
        };
        // Encloses, in the decoder's arithmetic.
        if r - ((c - center).length() + radius) >= 0.0 {
            return Some(idx);
        }
    }
    None
}

fn warp(x: f64) -> f64 {
    (x.atan() * 4.0 / PI).clamp(-1.0, 1.0)
}

fn unwarp(x: f64) -> f64 {
    (x * PI * 0.25).tan().clamp(-1.0, 1.0)
}

/// The normal table (code → unit normal).
pub fn normal_table() -> &'static Vec<DVec3> {
    static TABLE: OnceLock<Vec<DVec3>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let n = N_NORMAL;
        let mut t = Vec::with_capacity(NORMAL_CODES as usize);
        let level = |i: u32| unwarp((i as f64 + 0.5) * 2.0 / n as f64 - 1.0);
        for a in 0..6u32 {
            for u in 0..n {
                for v in 0..n {
                    let (cu, cv) = (level(u), level(v));
                    let major = (1.0 - cu * cu - cv * cv).max(0.0).sqrt()
                        * if a % 2 == 0 { 1.0 } else { -1.0 };
                    let nrm = match a / 2 {
                        0 => DVec3::new(major, cu, cv),
                        1 => DVec3::new(cv, major, cu),
                        _ => DVec3::new(cu, cv, major),
                    };
                    t.push(nrm.normalize_or(DVec3::Z));
                }
            }
        }
        t
    })
}

/// The 14-bit code of a unit normal.
pub fn encode_normal(n: DVec3) -> u16 {
    let n = n.normalize_or(DVec3::Z);
    let (ax, ay, az) = (n.x.abs(), n.y.abs(), n.z.abs());
    let (a, u, v) = if ax > ay && ax > az {
        (if n.x > 0.0 { 0 } else { 1 }, n.y, n.z)
    } else if ay > az {
        (if n.y > 0.0 { 2 } else { 3 }, n.z, n.x)
    } else {
        (if n.z > 0.0 { 4 } else { 5 }, n.x, n.y)
    };
    let q = |c: f64| (((warp(c) + 1.0) * 0.5 * N_NORMAL as f64) as u32).min(N_NORMAL - 1);
    ((a * N_NORMAL + q(u)) * N_NORMAL + q(v)) as u16
}

/// The unit normal of a code (invalid codes decode to +z).
pub fn decode_normal(code: u16) -> DVec3 {
    normal_table()
        .get(code as usize)
        .copied()
        .unwrap_or(DVec3::Z)
}

/// The 2-bit code of a cone half-angle (radians), rounded outwards.
pub fn encode_cone(half_angle: f64) -> u8 {
    let s = if half_angle > 1.5 {
        0.999
    } else {
        half_angle.max(0.0).sin()
    };
    ((4.0 * s.sqrt()) as u8).min(3)
}

/// The sine of the half-angle a cone code stands for (an upper bound of the encoded one's).
pub fn decode_cone_sin(code: u8) -> f64 {
    let x = f64::from(code & 3) + 1.0;
    x * x / 16.0
}

/// RGB888 to RGB565.
pub fn encode_rgb565(c: [u8; 3]) -> u16 {
    (u16::from(c[0] >> 3) << 11) | (u16::from(c[1] >> 2) << 5) | u16::from(c[2] >> 3)
}

/// RGB565 to RGB888 (low bits replicated).
pub fn decode_rgb565(v: u16) -> [u8; 3] {
    let (r, g, b) = ((v >> 11) as u8, ((v >> 5) & 63) as u8, (v & 31) as u8);
    [
        (r << 3) | (r >> 2),
        (g << 2) | (g >> 4),
        (b << 3) | (b >> 2),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_sizes_match_the_original() {
        assert_eq!(sphere_table().0.len(), SPHERE_TABLE_LEN);
        const { assert!(SPHERE_TABLE_LEN < 1 << 13) };
        assert_eq!(normal_table().len(), 16_224);
        const { assert!(NORMAL_CODES < 1 << 14) };
    }

    #[test]
    fn normals_round_trip_within_a_cell() {
        for k in 0..2_000 {
            let d = cloud::views::fibonacci_direction(k, 2_000);
            let back = decode_normal(encode_normal(d));
            assert!(back.dot(d) > 0.999, "{d} -> {back}");
        }
    }

    #[test]
    fn cone_codes_round_outwards() {
        for k in 0..200 {
            let a = k as f64 * 0.01;
            let code = encode_cone(a);
            assert!(decode_cone_sin(code) >= a.min(1.5).sin(), "{a}");
        }
        assert_eq!(decode_cone_sin(encode_cone(2.0)), 1.0);
    }

    #[test]
    fn rgb565_round_trip() {
        assert_eq!(
            decode_rgb565(encode_rgb565([255, 255, 255])),
            [255, 255, 255]
        );
        assert_eq!(decode_rgb565(encode_rgb565([0, 0, 0])), [0, 0, 0]);
        let c = decode_rgb565(encode_rgb565([200, 100, 50]));
        assert!(
            c.iter()
                .zip([200u8, 100, 50])
                .all(|(a, b)| a.abs_diff(b) <= 8)
        );
    }

    proptest::proptest! {
        #[test]
        fn encoded_sphere_encloses_the_child(
            cx in -1.0f64..1.0, cy in -1.0f64..1.0, cz in -1.0f64..1.0, r in 0.0f64..1.0,
            pc in proptest::array::uniform3(-50.0f64..50.0), pr in 0.01f64..100.0,
        ) {
            // A child inside the parent sphere.
            let rel = DVec3::new(cx, cy, cz);
            let rel = rel / rel.length().max(1.0);
            let len = rel.length();
            let r = r * (1.0 - len.min(1.0));
            proptest::prop_assume!(len + r <= 1.0);
            let parent = DVec3::from_array(pc);
            let center = parent + rel * pr;
            let radius = r * pr;
            let idx = encode_sphere(center, radius, parent, pr * (1.0 + 1e-12));
            proptest::prop_assert!(idx.is_some());
            let (c, q) = decode_sphere(idx.unwrap(), parent, pr * (1.0 + 1e-12)).unwrap();
            proptest::prop_assert!((c - center).length() + radius <= q);
            // The smallest size that any table entry achieves (brute force).
            let smallest = sphere_table()
                .0
                .iter()
                .filter(|e| {
                    let (c, q) = (parent + e.offset * pr * (1.0 + 1e-12), e.radius * pr * (1.0 + 1e-12));
                    (c - center).length() + radius <= q
                })
                .map(|e| e.size)
                .min();
            proptest::prop_assert_eq!(Some(sphere_table().0[idx.unwrap() as usize].size), smallest);
        }
    }
}
