//! A row of the visibility experiment's `builds.csv`: one method's preparation at one setting
//! on one dataset, with the build and an external program's cold call apart from it.

use serde::{Deserialize, Serialize};

use super::nan;

/// One row of `builds.csv`: one method's preparation at one setting on one dataset (one row
/// per shard that ran it).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BuildRow {
    /// Dataset.
    pub dataset: String,
    /// Method.
    pub method: String,
    /// Setting.
    pub params: String,
    /// The views this preparation answered.
    pub views: usize,
    /// Wall seconds of the preparation (one run): a built-in method's per-cloud state; for an
    /// external method, writing the points file it reads (normals and spacing included) when
    /// its program starts for this setting (protocols 1 and 2, and protocol 3's first setting
    /// on a cloud; a warm one's settings pay only for recognising the cloud).
    pub prepare_seconds: f64,
    /// The structure's build alone as the method accounts for it (an external program's
    /// `built` line, the ray caster's point hierarchy); NaN when it gives none.
    pub build_seconds: f64,
    /// An external program's cold call, when this setting's views started it: wall seconds
    /// from starting the program to its first answer (interpreter, imports, reading the
    /// points, build, first view), which its views' own seconds leave out. NaN for our
    /// methods and for a setting served by a protocol 3 program already running.
    #[serde(default = "nan")]
    pub cold_call_seconds: f64,
}

impl BuildRow {
    /// The build a pairing compares: the structure's own, else the whole preparation.
    pub(super) fn structure_seconds(&self, external: bool) -> f64 {
        match (self.build_seconds.is_nan(), external) {
            (false, _) => self.build_seconds,
            (true, false) => self.prepare_seconds,
            (true, true) => f64::NAN,
        }
    }
}
