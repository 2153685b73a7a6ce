//! The brute-force cast: every point against the ray, O(n). The reference the k-d traversal
//! is tested against, ray for ray.

use cloud::glam::DVec3;

use crate::hit::{disc_entry, entry};

/// The point hit first (smallest entry parameter; ties: lowest index), or `None`.
pub fn cast_brute(points: &[DVec3], o: [f64; 3], d: [f64; 3], radius: f64) -> Option<(f64, u32)> {
    let r2 = radius * radius;
    let mut best: Option<(f64, u32)> = None;
    for (i, p) in points.iter().enumerate() {
        if let Some(t) = entry(&o, &d, &p.to_array(), r2)
            && best.is_none_or(|(bt, _)| t < bt)
        {
            best = Some((t, i as u32));
        }
    }
    best
}

/// [`cast_brute`] for oriented discs: the disc crossed first (ties: lowest index), `normals`
/// unit, one per point.
pub fn cast_brute_disc(
    points: &[DVec3],
    normals: &[[f64; 3]],
    o: [f64; 3],
    d: [f64; 3],
    radius: f64,
) -> Option<(f64, u32)> {
    let r2 = radius * radius;
    let mut best: Option<(f64, u32)> = None;
    for (i, (p, nrm)) in points.iter().zip(normals).enumerate() {
        if let Some(t) = disc_entry(&o, &d, &p.to_array(), nrm, r2)
            && best.is_none_or(|(bt, _)| t < bt)
        {
            best = Some((t, i as u32));
        }
    }
    best
}
