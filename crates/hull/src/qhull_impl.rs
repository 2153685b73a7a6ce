//! `qhull`: Qhull 2020.2 through the `qhull` crate (qhull-rs, bundled C sources).
//!
//! Options: `Qt` (default: triangulated output; Qhull's default precision handling merges
//! nearly coplanar facets, so nearly coplanar points may be left out of the vertex set) or
//! `QJ` (joggled input: random noise instead of merging, retried with larger noise after
//! precision errors; the vertex set may differ from the exact one). Vertices map back to input
//! indices by their position in Qhull's point array. A `Qh` is not `Send`: one is built per
//! call, on the calling thread.

use qhull::Qh;

use crate::{ConvexHull, HullError, P3, guarded, validate};

/// Qhull's precision option.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QhullOption {
    /// Triangulated output, facet merging (Qhull's default precision handling).
    Qt,
    /// Joggled input.
    QJ,
}

/// The Qhull adapter.
#[derive(Debug, Clone, Copy)]
pub struct Qhull {
    option: QhullOption,
}

impl Qhull {
    /// Qhull with `option`.
    pub fn new(option: QhullOption) -> Self {
        Self { option }
    }
}

impl ConvexHull for Qhull {
    fn name(&self) -> &'static str {
        match self.option {
            QhullOption::Qt => "qhull",
            QhullOption::QJ => "qhull-qj",
        }
    }

    fn vertices(&self, points: &[P3]) -> Result<Vec<u32>, HullError> {
        validate(points)?;
        let arg = match self.option {
            QhullOption::Qt => "Qt",
            QhullOption::QJ => "QJ",
        };
        guarded("qhull", || {
            let mut flat: Vec<f64> = points.iter().flatten().copied().collect();
            let qh = Qh::builder()
                .qhull_args([arg])
                .map_err(|e| HullError::InvalidOption(format!("{e}")))?
                .build(3, &mut flat)
                .map_err(|e| HullError::Failed {
                    implementation: "qhull",
                    message: format!("{e}"),
                })?;
            let mut out: Vec<u32> = Vec::with_capacity(qh.num_vertices());
            for v in qh.vertices() {
                let i = v.index(&qh).ok_or_else(|| HullError::Failed {
                    implementation: "qhull",
                    message: "a vertex is not an input point".into(),
                })?;
                out.push(i as u32);
            }
            out.sort_unstable();
            out.dedup();
            Ok(out)
        })
    }
}
