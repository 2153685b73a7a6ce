//! `parry`: `parry3d-f64::transformation::try_convex_hull` (QuickHull in f64 with its own
//! tolerances). It returns the hull's points without their input indices: they are recovered
//! by exact coordinates. The panicking `convex_hull` is not used.

use glam::DVec3;

use crate::{ConvexHull, HullError, P3, guarded, recover_indices, validate};

/// The parry adapter.
#[derive(Debug, Clone, Copy, Default)]
pub struct Parry;

impl ConvexHull for Parry {
    fn name(&self) -> &'static str {
        "parry"
    }

    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError> {
        validate(points)?;
        guarded("parry", || {
            let input: Vec<DVec3> = points.iter().map(|p| DVec3::from_array(*p)).collect();
            let (vertices, _faces) =
                parry3d_f64::transformation::try_convex_hull(&input).map_err(|e| {
                    HullError::Failed {
                        implementation: "parry",
                        message: format!("{e:?}"),
                    }
                })?;
            recover_indices("parry", points, vertices.iter().map(|v| v.to_array()))
        })
    }
}
