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
    /// A normal-estimation cell's runs, in the order they ran (seconds joined by `;`), one a
    /// round of the family's alternation (`normals`); empty for the others.
    #[serde(default)]
    pub runs_seconds: String,
    /// A normal-estimation cell's accuracy against the mesh's normals: see
    /// [`Accuracy::angle_median_deg`] (NaN for the other cells).
    #[serde(default = "nan")]
    pub angle_median_deg: f64,
    /// See [`Accuracy::angle_p95_deg`].
    #[serde(default = "nan")]
    pub angle_p95_deg: f64,
    /// See [`Accuracy::sign_agreement`].
    #[serde(default = "nan")]
    pub sign_agreement: f64,
    /// A per-view cell's per-cloud preparation, outside `seconds` (see
    /// [`CellOutput::build_seconds`]); NaN for the other cells and in reports written before
    /// the column existed.
    #[serde(default = "nan")]
    pub build_seconds: f64,
}

impl Row {
    /// The row of a cell not run (or stopped before it reported): `status` says why.
    pub fn not_run(method: &str, n_points: u64, status: String) -> Row {
        Row {
            method: method.to_owned(),
            n_points,
            seconds: f64::NAN,
            peak_rss_bytes: 0,
            status,
            prepare_seconds: f64::NAN,
            detail: String::new(),
            runs_seconds: String::new(),
            angle_median_deg: f64::NAN,
            angle_p95_deg: f64::NAN,
            sign_agreement: f64::NAN,
            build_seconds: f64::NAN,
        }
    }
}

/// Normals against the mesh's (each point's triangle's normal): the unsigned angle between
/// the two lines, in degrees, its median and 95th percentile, and the share of points whose
/// normal points the mesh's way (NaN where the normals are not oriented). NaN everywhere when
/// the cell estimates no normals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Accuracy {
    /// Median unsigned angle error, degrees.
    #[serde(default = "nan", deserialize_with = "null_as_nan")]
    pub angle_median_deg: f64,
    /// 95th percentile of it.
    #[serde(default = "nan", deserialize_with = "null_as_nan")]
    pub angle_p95_deg: f64,
    /// Share of points with n · mesh normal > 0 (oriented cells only).
    #[serde(default = "nan", deserialize_with = "null_as_nan")]
    pub sign_agreement: f64,
}

impl Default for Accuracy {
    fn default() -> Self {
        Self {
            angle_median_deg: f64::NAN,
            angle_p95_deg: f64::NAN,
            sign_agreement: f64::NAN,
        }
    }
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
    /// See [`Row::accuracy`].
    #[serde(default)]
    pub accuracy: Accuracy,
    /// A visibility cell's per-cloud preparation through the kernel, which `seconds` (one
    /// view's answer) leaves out: the structure the method builds once per cloud and reuses
    /// for every view, such as the ray caster's hierarchy or a learned method's feature pass,
    /// as the method accounts for it (`registry::kernel::Preparation`, its reported seconds,
    /// else its wall time); NaN for the other cells.
    #[serde(default = "nan", deserialize_with = "null_as_nan")]
    pub build_seconds: f64,
}

fn nan() -> f64 {
    f64::NAN
}

/// A number that JSON wrote as `null` (serde_json's NaN) read back as NaN.
fn null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cells_output_without_accuracy_reads_back() {
        let out = CellOutput {
            seconds: 1.5,
            peak_rss_bytes: 7,
            prepare_seconds: 0.5,
            detail: String::new(),
            accuracy: Accuracy::default(),
            build_seconds: f64::NAN,
        };
        let line = serde_json::to_string(&out).unwrap();
        let back: CellOutput = serde_json::from_str(&line).unwrap();
        assert!(back.accuracy.angle_median_deg.is_nan() && back.seconds == 1.5);
        assert!(back.build_seconds.is_nan());
        let old: CellOutput =
            serde_json::from_str(r#"{"seconds":1.0,"peak_rss_bytes":1}"#).unwrap();
        assert!(old.accuracy.sign_agreement.is_nan() && old.build_seconds.is_nan());
    }
}
