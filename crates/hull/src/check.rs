//! Exact verification of a hull, independent of how it was built.
//!
//! - [`verify`]: a certificate check of a triangulated hull with exact predicates: the facets
//!   form a closed, consistently oriented surface of Euler characteristic 2 that is locally
//!   convex at every edge (hence the boundary of a convex polytope), every input point is on
//!   or below every facet (so the polytope is the hull), and the claimed vertex set is exactly
//!   the set of facet corners where at least three distinct facet planes meet (the extreme
//!   points), lowest index first among coincident points. O(n · facets): for tests.
//! - [`extreme_points_brute_force`]: the extreme points by enumeration of supporting planes,
//!   O(n⁴), independent of any hull algorithm: the oracle for small random and degenerate sets.

use std::collections::{HashMap, HashSet};

use crate::predicates::{P3, orient2d_sign, orient3d_sign};

/// Verifies `vertices` and `facets` as the exact hull of `points`; `Err` says what is wrong.
pub fn verify(points: &[P3], facets: &[[u32; 3]], vertices: &[u32]) -> Result<(), String> {
    let p = |i: u32| &points[i as usize];
    if facets.len() < 4 {
        return Err(format!("{} facets: not a closed polytope", facets.len()));
    }
    // Closed and consistently oriented: each directed edge once, its reverse once.
    let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
    for (f, t) in facets.iter().enumerate() {
        if t.iter().any(|&v| v as usize >= points.len()) {
            return Err(format!("facet {f} has an out-of-range vertex"));
        }
        for e in 0..3 {
            if edges.insert((t[e], t[(e + 1) % 3]), f).is_some() {
                return Err(format!(
                    "directed edge {}->{} appears twice",
                    t[e],
                    t[(e + 1) % 3]
                ));
            }
        }
    }
    for &(u, v) in edges.keys() {
        if !edges.contains_key(&(v, u)) {
            return Err(format!("edge {u}->{v} has no twin: the surface is open"));
        }
    }
    let corners: HashSet<u32> = facets.iter().flatten().copied().collect();
    let euler = corners.len() as i64 - (edges.len() / 2) as i64 + facets.len() as i64;
    if euler != 2 {
        return Err(format!("Euler characteristic {euler}, expected 2"));
    }
    // Local convexity: the far corner of each neighbour is on or below the facet.
    for t in facets {
        for e in 0..3 {
            let g = edges[&(t[(e + 1) % 3], t[e])];
            let far = facets[g]
                .iter()
                .copied()
                .find(|v| *v != t[e] && *v != t[(e + 1) % 3]);
            let Some(far) = far else {
                return Err("degenerate neighbour facet".into());
            };
            if orient3d_sign(p(t[0]), p(t[1]), p(t[2]), p(far)) < 0 {
                return Err(format!("reflex edge {}-{}", t[e], t[(e + 1) % 3]));
            }
        }
        if crate::predicates::collinear(p(t[0]), p(t[1]), p(t[2])) {
            return Err(format!("facet {t:?} is degenerate"));
        }
    }
    // Containment.
    for (i, q) in points.iter().enumerate() {
        for t in facets {
            if orient3d_sign(p(t[0]), p(t[1]), p(t[2]), q) < 0 {
                return Err(format!("point {i} is outside facet {t:?}"));
            }
        }
    }
    // Extreme corners: at least three distinct planes among the incident facets.
    let mut expected: Vec<u32> = Vec::new();
    for &v in &corners {
        let incident: Vec<&[u32; 3]> = facets.iter().filter(|t| t.contains(&v)).collect();
        let mut planes: Vec<&[u32; 3]> = Vec::new();
        for t in incident {
            let coplanar_with_known = planes.iter().any(|s| {
                t.iter()
                    .all(|&w| orient3d_sign(p(s[0]), p(s[1]), p(s[2]), p(w)) == 0)
            });
            if !coplanar_with_known {
                planes.push(t);
            }
        }
        if planes.len() >= 3 {
            expected.push(v);
        }
    }
    // Lowest index among coincident points.
    let expected = lowest_coincident(points, expected);
    let mut claimed = vertices.to_vec();
    claimed.sort_unstable();
    if claimed != expected {
        return Err(format!(
            "vertex set differs from the extreme corners: claimed {} vs expected {} (first difference near {:?})",
            claimed.len(),
            expected.len(),
            claimed.iter().zip(&expected).find(|(a, b)| a != b)
        ));
    }
    Ok(())
}

/// Replaces each index by the lowest index of a point at the same coordinates; sorted, unique.
fn lowest_coincident(points: &[P3], indices: Vec<u32>) -> Vec<u32> {
    let key = |p: &P3| p.map(f64::to_bits);
    let mut first: HashMap<[u64; 3], u32> = HashMap::new();
    for (i, q) in points.iter().enumerate().rev() {
        first.insert(key(q), i as u32);
    }
    let mut out: Vec<u32> = indices
        .iter()
        .map(|&i| first[&key(&points[i as usize])])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// The extreme points of `points` by brute force (O(n⁴)); lowest index among coincident
/// points. Returns `None` when the points do not span 3-d space.
pub fn extreme_points_brute_force(points: &[P3]) -> Option<Vec<u32>> {
    let n = points.len();
    let mut extreme: HashSet<u32> = HashSet::new();
    let mut spans = false;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (&points[i], &points[j], &points[k]);
                if crate::predicates::collinear(a, b, c) {
                    continue;
                }
                let signs: Vec<i32> = points.iter().map(|q| orient3d_sign(a, b, c, q)).collect();
                let pos = signs.iter().any(|&s| s > 0);
                let neg = signs.iter().any(|&s| s < 0);
                if pos || neg {
                    spans = true;
                }
                if pos && neg {
                    continue;
                }
                // A supporting plane: the extreme points of its coplanar subset are extreme.
                let on: Vec<usize> = (0..n).filter(|&q| signs[q] == 0).collect();
                let normal = normal(a, b, c);
                let drop = (0..3)
                    .max_by(|&x, &y| normal[x].abs().total_cmp(&normal[y].abs()))
                    .unwrap_or(2);
                let keep: Vec<usize> = (0..3).filter(|&d| d != drop).collect();
                let proj = |q: usize| [points[q][keep[0]], points[q][keep[1]]];
                for &q in &on {
                    if extreme_in_plane(q, &on, &proj, points) {
                        extreme.insert(q as u32);
                    }
                }
            }
        }
    }
    spans.then(|| lowest_coincident(points, extreme.into_iter().collect()))
}

fn normal(a: &P3, b: &P3, c: &P3) -> P3 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// Is point q a vertex of the 2-d hull of the coplanar set `on` (projected by `proj`)?
fn extreme_in_plane(
    q: usize,
    on: &[usize],
    proj: &dyn Fn(usize) -> [f64; 2],
    points: &[P3],
) -> bool {
    let others: Vec<usize> = on
        .iter()
        .copied()
        .filter(|&o| points[o] != points[q])
        .collect();
    let pq = proj(q);
    // On a segment between two others?
    for (x, &a) in others.iter().enumerate() {
        for &b in &others[x + 1..] {
            let (pa, pb) = (proj(a), proj(b));
            if orient2d_sign(pa, pb, pq) == 0
                && (pq[0] - pa[0]) * (pq[0] - pb[0]) <= 0.0
                && (pq[1] - pa[1]) * (pq[1] - pb[1]) <= 0.0
            {
                return false;
            }
        }
    }
    // Inside a triangle of three others?
    for (x, &a) in others.iter().enumerate() {
        for (y, &b) in others.iter().enumerate().skip(x + 1) {
            for &c in &others[y + 1..] {
                let (pa, pb, pc) = (proj(a), proj(b), proj(c));
                let s = orient2d_sign(pa, pb, pc);
                if s == 0 {
                    continue;
                }
                if orient2d_sign(pa, pb, pq) * s >= 0
                    && orient2d_sign(pb, pc, pq) * s >= 0
                    && orient2d_sign(pc, pa, pq) * s >= 0
                {
                    return false;
                }
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brute_force_on_a_cube_with_face_and_edge_points() {
        let mut pts: Vec<P3> = Vec::new();
        for i in 0..8 {
            pts.push([(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]);
        }
        pts.push([0.5, 0.5, 0.0]); // face centre
        pts.push([0.5, 0.0, 0.0]); // edge midpoint
        pts.push([0.5, 0.5, 0.5]); // interior
        pts.push([1.0, 1.0, 1.0]); // duplicate of vertex 7
        let ext = extreme_points_brute_force(&pts).unwrap();
        assert_eq!(ext, (0..8).collect::<Vec<u32>>());
    }

    #[test]
    fn brute_force_flat_input() {
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        assert_eq!(extreme_points_brute_force(&pts), None);
    }
}
