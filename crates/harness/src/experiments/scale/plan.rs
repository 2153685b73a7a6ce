//! The scale experiment's plan: which cells there are ([`cells`]: every registered method at
//! its default setting, the hulls, each LOD method's build and selection, the out-of-core
//! builds), at which sizes ([`sizes`], [`ooc_sizes`]), how many timed runs ([`repeats`]), and
//! which cells are not started ([`skip_reason`]: a predicted time over the cap; the disk an
//! out-of-core cell needs, `lod_build::disk_per_point`, [`disk_free`]).

use std::path::Path;
use std::time::Duration;

use anyhow::{Context as _, Result};
use registry::{Memory, Setting};

/// Sampling seed.
pub const SEED: u64 = 16;

/// The hull implementations measured on HPR's flipped set, with their memory budget in bytes
/// per point beyond the 48 of the sampled cloud (1.25 times the peak per point measured at 10^7
/// points, 10^6 for those that stop there).
pub const HULLS: &[(&str, u64)] = &[
    ("own", 135),
    ("qhull", 275),
    ("parry", 800),
    ("quickhull", 305),
    ("chull", 800),
];

/// One cell kind of the experiment.
#[derive(Debug, Clone)]
pub struct CellKind {
    /// Name (the CSV `method`).
    pub name: String,
    /// The setting it runs at (empty for hulls).
    pub setting: Setting,
    /// Its memory, as the guard knows it.
    pub memory: Memory,
    /// Why it cannot run here (an external method that is not installed).
    pub unavailable: Option<String>,
    /// An out-of-core LOD build (`NAME-build-ooc`): its own sizes, caps, memory limit and
    /// disk check ([`OOC_LIMIT`], [`OOC_CAP`]).
    pub out_of_core: bool,
}

/// Suffix of an out-of-core LOD build's cell: `pointsight lod-build` of a LAZ file the cell
/// writes first (the dragon sampled as the other cells sample it, streamed, never held),
/// within [`OOC_LIMIT`].
pub const OOC_SUFFIX: &str = "-build-ooc";

/// The memory limit of an out-of-core build cell (`lod-build --memory-limit`).
pub const OOC_LIMIT: u64 = 1 << 30;

/// The time cap of an out-of-core build cell (its preparation, writing the LAZ input, has
/// [`PREPARE_CAP_FACTOR`] times it): three hours, long enough for 10^9 points at the rates
/// measured (QSplat: 0.28 M points/s at 10^8 on a 2-core machine, so about an hour at 10^9;
/// the cap before, one hour, would have skipped the cell by its prediction from 10^8).
pub const OOC_CAP: Duration = Duration::from_secs(3 * 3600);

/// Disk copc_converter's out-of-core cell needs per point: the LAZ input (11.4), its scratch
/// folder (at most 40.7 at 10^7 points, 388 MiB, read every 200 ms) and the COPC file (9.5):
/// 62, and a quarter more for margin and for what the readings missed.
pub const COPC_OOC_DISK_PER_POINT: u64 = 80;

/// Disk the out-of-core cell of `name` (`NAME-build-ooc` without its suffix) needs per point:
/// the peer's converter's, else our build's (`lod_build::disk_per_point`; with normals given,
/// [`GIVEN`], the input's 12 bytes of normals a point more).
pub fn ooc_disk_per_point(name: &str) -> u64 {
    if name == super::copc::COPC_CONVERTER {
        COPC_OOC_DISK_PER_POINT
    } else if let Some(base) = name.strip_suffix(GIVEN) {
        crate::lod_build::disk_per_point(base) + 12
    } else {
        crate::lod_build::disk_per_point(name)
    }
}

/// Marks an out-of-core build whose input gives the normals (`NAME-given-build-ooc`): the LAZ
/// carries each sample's triangle normal as extra bytes (`NormalX`/`NormalY`/`NormalZ`), so the
/// build estimates none and times the structure alone, the work copc_converter does.
pub const GIVEN: &str = "-given";

/// Our out-of-core method of an out-of-core cell's name without [`OOC_SUFFIX`], and whether
/// its input gives the normals.
pub fn ooc_method(name: &str) -> (&str, bool) {
    name.strip_suffix(GIVEN)
        .map_or((name, false), |m| (m, true))
}

/// The largest size of a full run without `--max-points`: 10^7, so the whole `bench` stays
/// within the hour; the committed `reports/scale` is a `--max-points` run.
pub const DEFAULT_MAX_POINTS: u64 = 10_000_000;

/// The largest size of a quick run without `--max-points`.
pub const QUICK_MAX_POINTS: u64 = 1_000_000;

/// Sizes of the out-of-core cells: every power of ten from 10^6 to `max_points` (`--max-points
/// 1e9` adds the 10^9 cells), else to [`DEFAULT_MAX_POINTS`] (quick: [`QUICK_MAX_POINTS`]),
/// and 2·10^6 where 10^7 is reached (a size the structure is compared at).
pub fn ooc_sizes(quick: bool, max_points: Option<u64>) -> Vec<u64> {
    let mut sizes = decades(6, largest(quick, max_points).ilog10(), None);
    if sizes.contains(&10_000_000) {
        sizes.insert(1, 2_000_000);
    }
    sizes
}

fn largest(quick: bool, max_points: Option<u64>) -> u64 {
    max_points
        .unwrap_or(if quick {
            QUICK_MAX_POINTS
        } else {
            DEFAULT_MAX_POINTS
        })
        .max(1)
}

/// 10^from to 10^to, those above `max_points` left out.
pub fn decades(from: u32, to: u32, max_points: Option<u64>) -> Vec<u64> {
    (from..=to)
        .map(|e| 10u64.pow(e))
        .filter(|&n| max_points.is_none_or(|m| n <= m))
        .collect()
}

/// Bytes free for an unprivileged user on the file system of `dir` (or of its nearest
/// existing ancestor).
pub fn disk_free(dir: &Path) -> Result<u64> {
    let mut at = dir;
    while !at.exists() {
        at = at
            .parent()
            .context("no existing folder above the data folder")?;
    }
    let st = nix::sys::statvfs::statvfs(at)
        .with_context(|| format!("free space of {}", at.display()))?;
    Ok(st.blocks_available() as u64 * st.fragment_size() as u64)
}

/// Every cell kind, in report order: visibility methods, hulls, then each LOD method's build
/// and selection.
pub fn cells(catalogue: &registry::Catalogue, sweeps: &registry::Sweeps) -> Vec<CellKind> {
    let default_of = |name: &str| {
        sweeps
            .methods
            .get(name)
            .and_then(registry::MethodSweep::default_setting)
            .unwrap_or_default()
    };
    let mut out: Vec<CellKind> = catalogue
        .visibility_cards()
        .into_iter()
        .map(|m| CellKind {
            name: m.name.to_owned(),
            setting: default_of(m.name),
            memory: m.memory.clone(),
            unavailable: m.availability().err(),
            out_of_core: false,
        })
        .collect();
    out.extend(HULLS.iter().map(|&(h, bytes)| CellKind {
        name: format!("hull-{h}"),
        setting: Setting::default(),
        memory: Memory::PerPoint(bytes),
        unavailable: None,
        out_of_core: false,
    }));
    for m in catalogue.lod_cards() {
        for part in ["build", "select"] {
            out.push(CellKind {
                name: format!("{}-{part}", m.name),
                setting: default_of(m.name),
                memory: m.memory.clone(),
                unavailable: m.availability().err(),
                out_of_core: false,
            });
        }
    }
    // Each with the normals estimated, then given by its input ([`GIVEN`]).
    for given in ["", GIVEN] {
        out.extend(crate::lod_build::OUT_OF_CORE.iter().map(|m| CellKind {
            name: format!("{m}{given}{OOC_SUFFIX}"),
            // The setting of the selection from the built file.
            setting: default_of(m),
            memory: Memory::PerPoint(0),
            unavailable: None,
            out_of_core: true,
        }));
    }
    // The peer's build from the same LAZ (`copc`).
    out.push(CellKind {
        name: format!("{}{OOC_SUFFIX}", super::copc::COPC_CONVERTER),
        setting: Setting::default(),
        memory: Memory::PerPoint(0),
        unavailable: super::copc::converter().err(),
        out_of_core: true,
    });
    out
}

/// Sizes of the in-core cells: every power of ten from 10^4 to `max_points`, never above 10^8
/// (one process holds the whole cloud), else to [`DEFAULT_MAX_POINTS`] (quick:
/// [`QUICK_MAX_POINTS`]).
pub fn sizes(quick: bool, max_points: Option<u64>) -> Vec<u64> {
    decades(4, largest(quick, max_points).ilog10().min(8), None)
}

/// Timed runs of a cell's operation at `n` points (the median is its seconds): all of them
/// fall under the cap.
pub fn repeats(n: u64) -> usize {
    if n <= 1_000_000 { 3 } else { 1 }
}

/// The cap on a cell's preparation (sampling the cloud, a hull cell's flip, an LOD cell's
/// normals), which the operation's cap does not cover: this many times the operation's cap.
pub const PREPARE_CAP_FACTOR: u32 = 3;

/// Why a cell is not started, judging by the same method at the previous size (`previous`:
/// seconds and prepare seconds there, NaN when it did not finish; `before`: the size before
/// that): time grows by the factor it grew over the last step (at least 1), and a cell whose
/// [`repeats`] runs of the operation, or whose preparation, would so exceed its cap would only
/// hit it. `None`: run it.
pub fn skip_reason(
    previous: Option<(f64, f64)>,
    before: Option<(f64, f64)>,
    n: u64,
    cap: Duration,
) -> Option<String> {
    let (p, prep) = previous?;
    if p.is_nan() {
        return Some("skipped: the previous size did not finish".into());
    }
    let growth = |now: f64, then: Option<f64>| {
        then.filter(|&t| t > 0.0 && t.is_finite())
            .map_or(10.0, |t| (now / t).max(1.0))
    };
    let runs = repeats(n);
    let predicted = p * growth(p, before.map(|b| b.0)) * runs as f64;
    if predicted > cap.as_secs_f64() {
        return Some(format!(
            "skipped: {p:.1} s at {} points, so about {predicted:.0} s here for {runs} run{}, \
             over the {} s cap",
            n / 10,
            if runs == 1 { "" } else { "s" },
            cap.as_secs()
        ));
    }
    let prep_cap = (cap * PREPARE_CAP_FACTOR).as_secs_f64();
    if prep.is_finite() {
        let predicted = prep * growth(prep, before.map(|b| b.1));
        if predicted > prep_cap {
            return Some(format!(
                "skipped: its input took {prep:.1} s to prepare at {} points, so about \
                 {predicted:.0} s here, over the {prep_cap:.0} s cap on preparation",
                n / 10
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_out_of_core_sizes_and_the_free_disk() {
        assert_eq!(ooc_sizes(true, None), vec![1_000_000]);
        assert_eq!(
            ooc_sizes(false, None),
            vec![1_000_000, 2_000_000, 10_000_000]
        );
        assert_eq!(sizes(false, None).last(), Some(&10_000_000));
        assert_eq!(sizes(true, None).last(), Some(&1_000_000));
        assert_eq!(ooc_sizes(false, Some(10u64.pow(8))).len(), 4);
        // --max-points extends the out-of-core sizes (10^9) and caps the in-core ones at 10^8.
        assert_eq!(
            ooc_sizes(false, Some(10u64.pow(9))).last(),
            Some(&10u64.pow(9))
        );
        assert_eq!(ooc_sizes(true, Some(10u64.pow(7))).len(), 3);
        assert_eq!(ooc_method("qsplat-given"), ("qsplat", true));
        assert_eq!(ooc_method("spt"), ("spt", false));
        assert_eq!(
            ooc_disk_per_point("spt-given"),
            ooc_disk_per_point("spt") + 12
        );
        assert_eq!(ooc_sizes(false, Some(5 * 10u64.pow(5))), Vec::<u64>::new());
        assert_eq!(sizes(false, Some(10u64.pow(9))).last(), Some(&10u64.pow(8)));
        assert_eq!(sizes(false, Some(3 * 10u64.pow(5))).last(), Some(&100_000));
        let dir = tempfile::tempdir().unwrap();
        assert!(disk_free(&dir.path().join("not/yet")).unwrap() > 0);
    }

    #[test]
    fn a_cell_is_skipped_only_when_its_growth_would_pass_a_cap() {
        let cap = Duration::from_secs(40);
        // The first size always runs; a previous size that did not finish stops the method.
        assert_eq!(skip_reason(None, None, 10_000, cap), None);
        assert!(
            skip_reason(Some((f64::NAN, 1.0)), None, 100_000, cap)
                .unwrap()
                .contains("did not finish")
        );
        // 4.4 s after 0.5 s (growth 8.8): about 39 s, under the cap; after 0.4 s (11x): over.
        assert_eq!(
            skip_reason(Some((4.4, 9.0)), Some((0.5, 1.0)), 10u64.pow(8), cap),
            None
        );
        let why = skip_reason(Some((4.4, 9.0)), Some((0.4, 1.0)), 10u64.pow(8), cap).unwrap();
        assert!(
            why.contains("4.4 s at 10000000 points") && why.contains("48 s"),
            "{why}"
        );
        // One size only: grows tenfold. Shrinking time counts as growth 1 (sizes above 10^6:
        // one run each).
        let big = 10u64.pow(8);
        assert!(skip_reason(Some((4.1, 0.1)), None, big, cap).is_some());
        assert_eq!(skip_reason(Some((3.9, 0.1)), None, big, cap), None);
        assert_eq!(
            skip_reason(Some((39.0, 0.1)), Some((50.0, 0.1)), big, cap),
            None
        );
        // Up to 10^6 points a cell makes three runs, all under the cap: 7 s doubling is 14 s a
        // run, 42 s for three at 10^6 (skipped), 14 s for the one run at 10^7.
        let why = skip_reason(Some((7.0, 0.1)), Some((3.5, 0.1)), 1_000_000, cap).unwrap();
        assert!(why.contains("for 3 runs") && why.contains("42 s"), "{why}");
        assert_eq!(
            skip_reason(Some((7.0, 0.1)), Some((3.5, 0.1)), 10_000_000, cap),
            None
        );
        // The preparation has its own cap (three times the operation's).
        let why = skip_reason(Some((1.0, 20.0)), Some((0.5, 1.0)), 100, cap).unwrap();
        assert!(
            why.contains("prepare") && why.contains("120 s cap"),
            "{why}"
        );
        assert_eq!(
            skip_reason(Some((1.0, 20.0)), Some((0.5, 10.0)), 100, cap),
            None
        );
    }
}
