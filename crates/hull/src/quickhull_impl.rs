//! `quickhull`: Jondolf's `quickhull` crate (`ConvexTriangleMesh`, f32 arithmetic).
//!
//! Input is rounded to f32 (on an HPR flipped cloud, many distinct points round to nearby or
//! equal f32 values), so its vertex set is the hull of different points: that difference is
//! what the harness measures. Indices are recovered by the f32 coordinates; coincident f32
//! points map to the lowest index.

use std::collections::HashMap;

use glam032::Vec3A;
use quickhull::ConvexTriangleMesh;

use crate::{ConvexHull, HullError, P3, guarded, validate};

/// The quickhull adapter.
#[derive(Debug, Clone, Copy, Default)]
pub struct QuickHull;

impl ConvexHull for QuickHull {
    fn name(&self) -> &'static str {
        "quickhull"
    }

    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError> {
        validate(points)?;
        guarded("quickhull", || {
            let input: Vec<Vec3A> = points
                .iter()
                .map(|p| Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32))
                .collect();
            let mesh = ConvexTriangleMesh::try_from_points(&input, None).map_err(|e| {
                HullError::Failed {
                    implementation: "quickhull",
                    message: format!("{e}"),
                }
            })?;
            let key = |v: &Vec3A| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(input.len());
            for (i, v) in input.iter().enumerate().rev() {
                index.insert(key(v), i as u32);
            }
            let mut out = Vec::with_capacity(mesh.vertices().len());
            for v in mesh.vertices() {
                out.push(*index.get(&key(v)).ok_or_else(|| HullError::Failed {
                    implementation: "quickhull",
                    message: "returned a vertex that is not an input point".into(),
                })?);
            }
            out.sort_unstable();
            out.dedup();
            Ok(out)
        })
    }
}
