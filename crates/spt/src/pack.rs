//! A splat as the file stores it (format version 3): 14 bytes, and 3 of colour.
//!
//! Dachsbacher et al. (2003, §4) keep the splats in GPU memory as floats; QSplat (seed 002
//! §5.2.1; Rusinkiewicz and Levoy 2000) quantises every attribute of a node, its centre and
//! radius against its parent's in 13 steps, its normal in 14 bits. This file
//! follows the second in spirit while keeping the cut exact: the boxes and errors the cut reads
//! stay as [`crate::list`] has them (16-bit boxes, e_g² as f32), so a cut from the file selects
//! the very entries of the in-memory tree; only the attributes drawn are quantised:
//!
//! - **centre**, 3 × u16: its position within the entry's own box on the 16-bit grid
//!   ([`crate::list::QBox`]), in 65,535 steps per axis. A node's centre is the mean of its
//!   points, so it lies in its box (clamped where f32 rounding puts it a hair outside). Error
//!   per axis at most half a step, `(hi − lo) · cell / 131,070`, plus the f32 rounding of the
//!   centre the tree holds: for a leaf, whose box is its disc's, about 10⁻⁵ of its diameter;
//! - **radius**, f32: exact (a bounding sphere must not shrink, and it need not lie in the box);
//! - **normal**, 2 × u16: the octahedral map (Cigolle et al. 2014, "A Survey of Efficient
//!   Representations for Independent Unit Vectors", §3.2, their "oct32P": the best of the four
//!   lattice points around the projection). Angle to the unit normal at most
//!   [`NORMAL_MAX_ERROR`] radians (the tests measure it);
//! - **colour**, 3 × u8: the mean colour in [0, 1] in 255 steps, error at most 1/510.
//!
//! Versions 1 and 2 of the file stored the splat as 7 × f32 (28 bytes) and the colour as
//! 3 × f32 (12): the file is now about 62 bytes a point instead of 85 (the groups and entries
//! unchanged).

use cloud::glam::{DVec3, Vec3};

use crate::hierarchy::Node;
use crate::list::{GRID, Grid, QBox};

/// Bytes of a splat: centre (3 × u16), radius (f32), normal (2 × u16).
pub const SPLAT: usize = 6 + 4 + 4;
/// Bytes of a colour (3 × u8).
pub const COLOR: usize = 3;
/// The largest angle, in radians, between a unit normal and its decoded octahedral code (a
/// bound the tests check over a million directions: the measured maximum is 4.3e-5, 0.0025°).
pub const NORMAL_MAX_ERROR: f32 = 5.0e-5;

/// The largest octahedral code: even, so that 0 (the poles and the axes) is a code.
const OCT: f32 = 65_534.0;

/// Appends the splat bytes of node `n`, whose box is `q` on `grid`.
pub fn push_splat(b: &mut Vec<u8>, n: &Node, q: &QBox, grid: &Grid) {
    let g = (grid.local + n.center.as_dvec3() - grid.origin) / grid.cell;
    for k in 0..3 {
        let (lo, hi) = (f64::from(q.lo[k]), f64::from(q.hi[k]));
        let u = if hi > lo {
            ((g[k] - lo) / (hi - lo) * GRID).round().clamp(0.0, GRID) as u16
        } else {
            0
        };
        b.extend_from_slice(&u.to_le_bytes());
    }
    b.extend_from_slice(&n.radius().to_le_bytes());
    for u in oct_encode(n.normal) {
        b.extend_from_slice(&u.to_le_bytes());
    }
}

/// Appends the colour bytes of node `n`.
pub fn push_color(b: &mut Vec<u8>, n: &Node) {
    for v in n.color.to_array() {
        b.push((v.clamp(0.0, 1.0) * 255.0).round() as u8);
    }
}

/// The world centre, radius and unit normal of a splat's bytes `r` ([`SPLAT`] of them), whose
/// entry's box is `q` on the grid of origin `grid_origin` and step `cell`.
pub fn splat_of(r: &[u8], q: &QBox, grid_origin: DVec3, cell: f64) -> (DVec3, f32, Vec3) {
    let u = |o: usize| f64::from(u16::from_le_bytes([r[o], r[o + 1]]));
    let mut g = DVec3::ZERO;
    for k in 0..3 {
        let (lo, hi) = (f64::from(q.lo[k]), f64::from(q.hi[k]));
        g[k] = lo + (hi - lo) * (u(2 * k) / GRID);
    }
    let radius = f32::from_le_bytes([r[6], r[7], r[8], r[9]]);
    let oct = [
        u16::from_le_bytes([r[10], r[11]]),
        u16::from_le_bytes([r[12], r[13]]),
    ];
    (grid_origin + g * cell, radius, oct_decode(oct))
}

/// The colour of its bytes `c` ([`COLOR`] of them).
pub fn color_of(c: &[u8]) -> Vec3 {
    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0
}

/// ±1 by the sign, +1 at zero (the octahedral map's `signNotZero`).
fn sign(x: f64) -> f64 {
    if x >= 0.0 { 1.0 } else { -1.0 }
}

/// The octahedral code of unit vector `n`: the best of the four lattice points around its
/// projection (Cigolle et al. 2014, oct32P).
pub fn oct_encode(n: Vec3) -> [u16; 2] {
    let n = n.normalize_or(Vec3::Z);
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let (mut x, mut y) = (n.x / l1, n.y / l1);
    if n.z < 0.0 {
        let (sx, sy) = (sign(f64::from(x)) as f32, sign(f64::from(y)) as f32);
        (x, y) = ((1.0 - y.abs()) * sx, (1.0 - x.abs()) * sy);
    }
    let to = |v: f32| ((v.clamp(-1.0, 1.0) + 1.0) * 0.5 * OCT).clamp(0.0, OCT);
    let (fx, fy) = (to(x), to(y));
    // The nearest of the four by distance, in f64: their cosines to `n` differ by less than
    // f32 resolves near 1.
    let n64 = n.as_dvec3();
    let mut best = [fx.round() as u16, fy.round() as u16];
    let mut best_d2 = f64::INFINITY;
    for cx in [fx.floor(), fx.ceil()] {
        for cy in [fy.floor(), fy.ceil()] {
            let code = [cx as u16, cy as u16];
            let d2 = (oct_decode64(code) - n64).length_squared();
            if d2 < best_d2 {
                (best, best_d2) = (code, d2);
            }
        }
    }
    best
}

/// The unit vector of an octahedral code.
pub fn oct_decode(code: [u16; 2]) -> Vec3 {
    oct_decode64(code).as_vec3()
}

/// [`oct_decode`] in f64.
fn oct_decode64(code: [u16; 2]) -> DVec3 {
    let oct = f64::from(OCT);
    let x = f64::from(code[0]) / oct * 2.0 - 1.0;
    let y = f64::from(code[1]) / oct * 2.0 - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y))
    } else {
        (x, y)
    };
    DVec3::new(x, y, z).normalize_or(DVec3::Z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloud::rng::{RngExt, seeded};

    fn angle(a: Vec3, b: Vec3) -> f32 {
        a.cross(b).length().atan2(a.dot(b))
    }

    #[test]
    fn octahedral_normals_are_within_the_stated_bound() {
        let mut rng = seeded(1, "oct");
        let mut worst = 0.0f32;
        let mut dirs: Vec<Vec3> = (0..1_000_000)
            .map(|_| {
                let v = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                v.normalize_or(Vec3::X)
            })
            .collect();
        // The axes, the octahedron's edges and the seams of the fold.
        for s in [1.0, -1.0] {
            dirs.extend([Vec3::X * s, Vec3::Y * s, Vec3::Z * s]);
            dirs.push(Vec3::new(1.0, s, 0.0).normalize());
            dirs.push(Vec3::new(-1.0, s, 0.0).normalize());
            dirs.push(Vec3::new(s, 0.0, -1.0).normalize());
            dirs.push(Vec3::new(0.0, s, -1.0).normalize());
            dirs.push(Vec3::new(1.0, 1.0, s * 1e-7).normalize());
        }
        let mut at = Vec3::ZERO;
        for n in dirs {
            let back = oct_decode(oct_encode(n));
            assert!((back.length() - 1.0).abs() < 1e-6, "{n} {back}");
            if angle(n, back) > worst {
                (worst, at) = (angle(n, back), n);
            }
        }
        assert!(worst <= NORMAL_MAX_ERROR, "worst {worst} at {at}");
        // The bound is not loose by more than a factor of two.
        assert!(worst > NORMAL_MAX_ERROR / 2.0, "worst {worst}");
    }

    #[test]
    fn centres_decode_within_half_a_step_of_their_box() {
        let grid = Grid {
            local: DVec3::new(100.0, -50.0, 7.0),
            origin: DVec3::new(99.0, -51.0, 6.0),
            cell: 1e-4,
        };
        let mut rng = seeded(2, "centres");
        for _ in 0..10_000 {
            let lo = [0u16; 3].map(|_| rng.random_range(0..60_000u16));
            let hi = lo.map(|l| l + rng.random_range(0..5_000u16));
            let q = QBox { lo, hi };
            // A centre anywhere in the box, in local f32 coordinates as the tree holds it.
            let g = DVec3::new(
                rng.random_range(f64::from(lo[0])..=f64::from(hi[0])),
                rng.random_range(f64::from(lo[1])..=f64::from(hi[1])),
                rng.random_range(f64::from(lo[2])..=f64::from(hi[2])),
            );
            let world = grid.origin + g * grid.cell;
            let node = Node {
                center: (world - grid.local).as_vec3(),
                normal: Vec3::Z,
                diameter: 0.25,
                e_p: 0.0,
                e_t: 0.0,
                e_g: 0.0,
                color: Vec3::new(0.0, 0.5, 1.0),
                children: Vec::new(),
                leaves: 1,
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
            };
            let mut b = Vec::new();
            push_splat(&mut b, &node, &q, &grid);
            push_color(&mut b, &node);
            assert_eq!(b.len(), SPLAT + COLOR);
            let (c, r, n) = splat_of(&b, &q, grid.origin, grid.cell);
            assert_eq!((r, n), (0.125, Vec3::Z));
            let held = grid.local + node.center.as_dvec3();
            for k in 0..3 {
                let step = f64::from(hi[k] - lo[k]) * grid.cell / GRID;
                // Half a step, and the f32 rounding of the centre the tree holds (a box of one
                // grid point decodes to that point, the true centre).
                let bound = step / 2.0 + f64::from(node.center[k].abs() * f32::EPSILON);
                assert!((c[k] - held[k]).abs() <= bound, "{k}: {c} {held} {q:?}");
            }
            let col = color_of(&b[SPLAT..]);
            assert!((col - node.color).abs().max_element() <= 1.0 / 510.0 + 1e-7);
        }
    }
}
