//! The one table of time ratios against the peers: `reports/ratios.csv` ([`CSV`]) and its
//! page `reports/ratios.md` ([`MD`]), every ratio of [`super::rules::ratio`] over the
//! experiments' results under a reports folder, each with the run, machine and revision it
//! comes from. The README's headline quotes these rows (`tests/headline.rs` checks it).

use std::path::Path;

use anyhow::Result;

use super::rules::ratio::{self, Ratio};
use super::scale::{copc::COPC_CONVERTER, plan::OOC_SUFFIX};
use crate::output::meta::RunMeta;
use crate::output::{read_csv, write_csv};

pub use super::rules::ratio::markdown;

/// The file the ratios are written to, in the reports folder.
pub const CSV: &str = "ratios.csv";

/// The ratios as a page, in the reports folder.
pub const MD: &str = "ratios.md";

/// Every ratio of the experiments under `reports` (visibility, hull, scale; those whose
/// results are there), each with its run's start, machine and revision.
pub fn all(reports: &Path) -> Result<Vec<Ratio>> {
    let mut out = Vec::new();
    for name in ["visibility", "hull", "scale"] {
        let dir = reports.join(name);
        let csv = dir.join(if name == "visibility" {
            "peers.csv"
        } else {
            "results.csv"
        });
        if !csv.is_file() {
            continue;
        }
        let found = match name {
            "visibility" => ratio::visibility(&read_csv(&csv)?),
            "hull" => ratio::hull(&read_csv(&csv)?),
            _ => {
                let mut found = ratio::scale(
                    &read_csv(&csv)?,
                    &format!("{COPC_CONVERTER}{OOC_SUFFIX}"),
                    OOC_SUFFIX,
                );
                // The normal-estimation family: medians of alternated rounds.
                found.extend(super::scale::normals::ratios(&read_csv(&csv)?));
                found
            }
        };
        let meta = RunMeta::read(&dir).ok();
        for mut r in found {
            if let Some(m) = &meta {
                r.run = m.date_utc.clone();
                r.machine = format!("{} ({} cores)", m.cpu, m.cores);
                r.revision = m.git_revision.clone();
            }
            out.push(r);
        }
    }
    Ok(out)
}

/// Writes `ratios.csv` into `reports` (a header alone without ratios).
pub fn write(reports: &Path, ratios: &[Ratio]) -> Result<()> {
    if ratios.is_empty() {
        return crate::output::write_atomic(
            &reports.join(CSV),
            b"experiment,dataset,peer,peer_setting,ours,ours_setting,pairs,views,ratio,low,high,min,max,jaccard_min,note,run,machine,revision\n",
        );
    }
    write_csv(&reports.join(CSV), ratios)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_ratios_files_are_the_report_s_own() {
        // A reports folder holding them is still pointsight's, so the next bench replaces it.
        for f in [super::CSV, super::MD] {
            assert!(crate::output::folder::REPORT_FILES.contains(&f), "{f}");
        }
    }
}
