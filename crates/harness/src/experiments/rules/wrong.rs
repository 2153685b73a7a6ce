//! Wrong answers: a method that claims exactness and returned a set differing from the exact
//! one is never ranked.
//!
//! Who claims exactness: every convex hull of the hull experiment (a hull is exact by
//! definition), and every visibility method whose card says `exact` (`registry::Card::exact`:
//! exact HPR and its peers; the visibility experiment writes the claim into `peers.csv`'s
//! `claims_exact`). The exact set: our own hull's at perturbation 0 for the hulls
//! (`jaccard_vs_exact` of the hull results), our hpr's at the same γ for HPR's peers
//! (`jaccard` of `peers.csv`). A claim fails when the Jaccard index is below [`JACCARD`] on any
//! unperturbed cell; the method is then marked `wrong answers` with its worst Jaccard in every
//! table that lists it, and left out of every verdict (speed and accuracy alike).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

use crate::output::read_csv;

/// The lowest Jaccard index against the exact set a method claiming exactness may return.
pub const JACCARD: f64 = 0.999;

/// The methods whose exactness claim failed, each with its worst Jaccard index.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Wrong(pub BTreeMap<String, f64>);

impl Wrong {
    /// The worst Jaccard of `method` when its claim failed.
    pub fn get(&self, method: &str) -> Option<f64> {
        self.0.get(method).copied()
    }

    /// `wrong answers (worst Jaccard 0.030)` for a method whose claim failed.
    pub fn note(&self, method: &str) -> Option<String> {
        self.get(method).map(note)
    }

    /// `method: wrong answers (…)` for each method of `methods` whose claim failed, once each.
    pub fn notes<'a>(&self, methods: impl IntoIterator<Item = &'a str>) -> Vec<String> {
        let mut seen: Vec<&str> = methods
            .into_iter()
            .filter(|m| self.0.contains_key(*m))
            .collect();
        seen.sort_unstable();
        seen.dedup();
        seen.into_iter()
            .map(|m| format!("{m}: {}", note(self.0[m])))
            .collect()
    }
}

/// `wrong answers (worst Jaccard J)`.
pub fn note(jaccard: f64) -> String {
    format!("wrong answers (worst Jaccard {jaccard:.3})")
}

/// The columns of the hull results read here.
#[derive(Deserialize)]
struct HullRow {
    hull: String,
    perturb: f64,
    jaccard_vs_exact: f64,
    status: String,
}

/// The columns of `peers.csv` read here.
#[derive(Deserialize)]
struct PeerRow {
    peer: String,
    jaccard: f64,
    /// Absent from results written before the claim was recorded: no claim.
    #[serde(default)]
    claims_exact: bool,
}

/// The worst value per name over `(name, jaccard)` pairs, kept where below [`JACCARD`].
fn failing<'a>(pairs: impl Iterator<Item = (&'a str, f64)>) -> BTreeMap<String, f64> {
    let mut worst: BTreeMap<String, f64> = BTreeMap::new();
    for (name, j) in pairs.filter(|(_, j)| j.is_finite()) {
        let e = worst.entry(name.to_owned()).or_insert(j);
        *e = e.min(j);
    }
    worst.retain(|_, j| *j < JACCARD);
    worst
}

/// The hulls of the hull results in `dir` whose unperturbed sets missed the exact one (none
/// without results).
pub fn hulls(dir: &Path) -> Result<Wrong> {
    let path = dir.join("results.csv");
    if !path.is_file() {
        return Ok(Wrong::default());
    }
    let rows: Vec<HullRow> = read_csv(&path)?;
    Ok(Wrong(failing(
        rows.iter()
            .filter(|r| r.status == "ok" && r.perturb == 0.0)
            .map(|r| (r.hull.as_str(), r.jaccard_vs_exact)),
    )))
}

/// The peers claiming exactness in the visibility results in `dir` whose sets missed our
/// partner's at the same setting (none without `peers.csv`).
pub fn peers(dir: &Path) -> Result<Wrong> {
    let path = dir.join("peers.csv");
    if !path.is_file() {
        return Ok(Wrong::default());
    }
    let rows: Vec<PeerRow> = read_csv(&path)?;
    Ok(Wrong(failing(
        rows.iter()
            .filter(|r| r.claims_exact)
            .map(|r| (r.peer.as_str(), r.jaccard)),
    )))
}

/// The wrong answers the scale experiment in `dir` knows of, from its sibling experiments'
/// results in the same reports folder: the hull experiment's hulls (as scale names them,
/// `hull-NAME`) and the visibility experiment's peers. Only a folder named `scale` (a reports
/// folder's, as `bench` and `run` write it) has siblings: a `run scale --out DIR` has none.
pub fn for_scale(dir: &Path) -> Result<Wrong> {
    let root = match (dir.file_name(), dir.parent()) {
        (Some(name), Some(root)) if name == "scale" => root,
        _ => return Ok(Wrong::default()),
    };
    let mut out: BTreeMap<String, f64> = hulls(&root.join("hull"))?
        .0
        .into_iter()
        .map(|(h, j)| (format!("hull-{h}"), j))
        .collect();
    out.extend(peers(&root.join("visibility"))?.0);
    Ok(Wrong(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hull_below_the_bar_on_one_unperturbed_cell_is_wrong_and_perturbed_cells_do_not_count() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("results.csv"),
            "hull,perturb,jaccard_vs_exact,status\n\
             own,0,1,ok\n\
             qhull,0,1,ok\n\
             qhull,0.01,0.2,ok\n\
             quick,0,1,ok\n\
             quick,0,0.9985,ok\n\
             broken,0,0.1,error: x\n",
        )
        .unwrap();
        let w = hulls(dir.path()).unwrap();
        assert_eq!(w.0.keys().collect::<Vec<_>>(), ["quick"]);
        assert_eq!(
            w.note("quick").as_deref(),
            Some("wrong answers (worst Jaccard 0.999)")
        );
        assert_eq!(w.notes(["qhull", "quick", "quick"]).len(), 1);
        // Scale names the hull `hull-quick`, from the sibling folder.
        std::fs::create_dir_all(dir.path().join("r/hull")).unwrap();
        std::fs::create_dir_all(dir.path().join("r/scale")).unwrap();
        std::fs::create_dir_all(dir.path().join("r/elsewhere")).unwrap();
        std::fs::copy(
            dir.path().join("results.csv"),
            dir.path().join("r/hull/results.csv"),
        )
        .unwrap();
        let s = for_scale(&dir.path().join("r/scale")).unwrap();
        assert!(s.get("hull-quick").is_some() && s.get("quick").is_none());
        // A scale run into a folder of its own has no siblings to read.
        assert!(
            for_scale(&dir.path().join("r/elsewhere"))
                .unwrap()
                .0
                .is_empty()
        );
    }

    #[test]
    fn a_peer_fails_only_when_it_claims_exactness() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("peers.csv"),
            "peer,jaccard,claims_exact\nexact-peer,0.5,true\nrough-peer,0.5,false\n\
             good-peer,1,true\n",
        )
        .unwrap();
        let w = peers(dir.path()).unwrap();
        assert_eq!(w.0.keys().collect::<Vec<_>>(), ["exact-peer"]);
        // An older peers.csv without the column claims nothing.
        std::fs::write(
            dir.path().join("peers.csv"),
            "peer,jaccard\nexact-peer,0.5\n",
        )
        .unwrap();
        assert!(peers(dir.path()).unwrap().0.is_empty());
    }
}
