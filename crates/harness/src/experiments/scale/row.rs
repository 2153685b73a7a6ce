//! What a scale cell reports: the child process's last line ([`CellOutput`], JSON) and the
//! row of `results.csv` ([`Row`]) the experiment makes of it, or of a cell not run.

use serde::{Deserialize, Serialize};

/// One cell.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Row {
    /// Method (cell kind).
    pub method: String,
    /// Points.
    pub n_points: u64,
    /// Seconds of the operation (NaN when it did not finish).
    pub seconds: f64,
    /// Peak resident memory of the cell's process and the programs it waited for (0 when it
    /// did not run).
    pub peak_rss_bytes: u64,
    /// `ok`, `timeout after S s`, `skipped: ...`, `refused: ...`, `error: ...`.
    pub status: String,
    /// Seconds the cell took to prepare its input before the operation (see
    /// [`CellOutput::prepare_seconds`]); NaN when it did not get that far (and in reports
    /// written before the column existed).
    #[serde(default = "nan")]
    pub prepare_seconds: f64,
    /// What else the cell reports (an out-of-core build: its limit, chunks, rate and files);
    /// empty for the others.
    #[serde(default)]
    pub detail: String,
}

/// What a cell process prints last (one JSON line).
#[derive(Debug, Serialize, Deserialize)]
pub struct CellOutput {
    /// Seconds (median of the runs).
    pub seconds: f64,
    /// Peak RSS of the process and of the largest child it waited for.
    pub peak_rss_bytes: u64,
    /// Seconds the cell took to prepare its input: sampling the cloud, and for a hull cell its
    /// flip, for an LOD cell the `lod` experiment's normals and spacing.
    #[serde(default = "nan")]
    pub prepare_seconds: f64,
    /// See [`Row::detail`].
    #[serde(default)]
    pub detail: String,
}

fn nan() -> f64 {
    f64::NAN
}
