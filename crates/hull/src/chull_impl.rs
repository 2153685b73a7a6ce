//! `chull`: the `chull` crate (unmaintained since 2020) through its `ConvexHullWrapper`, which
//! runs QuickHull on big integers (coordinates divided by f64::EPSILON), exact but slow.
//!
//! The crate's plain f64 `ConvexHull` fails on HPR shells with `RoundOffError`, so it is not
//! used. The wrapper returns the kept points converted back to f64: t(x) = trunc(x / ε) · ε,
//! which equals x except that values below 1 in magnitude lose their bits below 2⁻⁵². Input
//! indices are recovered by matching t(input) bit for bit.

use std::collections::HashMap;

use chull::ConvexHullWrapper;

use crate::{ConvexHull, HullError, P3, guarded, validate};

/// The chull adapter.
#[derive(Debug, Clone, Copy, Default)]
pub struct Chull;

/// The wrapper's round trip of one coordinate.
fn round_trip(x: f64) -> f64 {
    (x / f64::EPSILON).trunc() * f64::EPSILON
}

impl ConvexHull for Chull {
    fn name(&self) -> &'static str {
        "chull"
    }

    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError> {
        validate(points)?;
        guarded("chull", || {
            let input: Vec<Vec<f64>> = points.iter().map(|p| p.to_vec()).collect();
            let hull = ConvexHullWrapper::try_new(&input, None).map_err(|e| HullError::Failed {
                implementation: "chull",
                message: format!("{e:?}"),
            })?;
            let (vertices, _indices) = hull.vertices_indices();
            let key = |p: [f64; 3]| p.map(|c| round_trip(c).to_bits());
            let mut index: HashMap<[u64; 3], u32> = HashMap::with_capacity(points.len());
            for (i, p) in points.iter().enumerate().rev() {
                index.insert(key(*p), i as u32);
            }
            let mut out = Vec::with_capacity(vertices.len());
            for v in &vertices {
                let found =
                    index
                        .get(&key([v[0], v[1], v[2]]))
                        .ok_or_else(|| HullError::Failed {
                            implementation: "chull",
                            message: format!("returned a vertex {v:?} that is not an input point"),
                        })?;
                out.push(*found);
            }
            out.sort_unstable();
            out.dedup();
            Ok(out)
        })
    }
}
