//! Exact HPR changed no answer: the SHA-256 of every sorted visible index list of `own` over the
//! `hull` experiment's grid (views 0 to 3, γ ∈ {2, 3, 4}, every perturbation k with seed 2007)
//! equals the digest revision 5c38c1a computed (`tests/data/golden/hull_digests.csv`, written
//! by `crates/harness/examples/hull_digests.rs`, which compiles unchanged against that revision:
//! `cargo run --release -p harness --example hull_digests -- bench-data 4 DATASET...`).
//!
//! The digest is [`harness::experiments::hull::visible_sha256`], the hull experiment's
//! `visible_sha256` column. The synthetic datasets (cospherical points, a ball in front of a
//! plane, a torus, a vase) always run; the bunnies with `POINTSIGHT_REAL_DATA=1` (set by
//! `just test`, which fetches them first); the dragon (252 of the 336 HPR runs' points) also needs
//! `POINTSIGHT_SLOW=1`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use harness::experiments::hull::{GAMMAS, PERTURBS, SEED, visible_sha256};
use hpr::{HprParams, Kernel, Radius};

const SYNTHETIC: &[&str] = &[
    "sphere-20000",
    "sphere-plane-24000",
    "torus-22321",
    "vase-7171",
];
const REAL: &[&str] = &["bunny", "bunny-69451"];
const SLOW: &[&str] = &["dragon-871414"];
const VIEWS: usize = 4;

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

/// (dataset, view, γ, k) → (visible count, digest), from the golden file.
type Goldens = BTreeMap<(String, usize, u64, u64), (usize, String)>;

fn goldens() -> Goldens {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/golden/hull_digests.csv");
    let mut reader = csv::Reader::from_path(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    reader
        .records()
        .map(|r| {
            let r = r.expect("a record");
            let f = |i: usize| r.get(i).expect("six columns").to_owned();
            let num = |i: usize| f(i).parse::<f64>().expect("a number").to_bits();
            (
                (f(0), f(1).parse().expect("a view"), num(2), num(3)),
                (f(4).parse().expect("a count"), f(5)),
            )
        })
        .collect()
}

/// Runs exact HPR on every configuration of `dataset` and compares each digest.
fn check(dataset: &str, goldens: &Goldens) {
    let ds = harness::datasets::Datasets::default()
        .load(dataset, &data_dir())
        .unwrap_or_else(|e| panic!("{dataset} loads (after `pointsight fetch` for meshes): {e:#}"));
    let own = hull::by_name("own").expect("the own hull");
    let mut compared = 0;
    for view in 0..VIEWS {
        let eye = ds.view(view).expect("the view").eye;
        for &gamma in GAMMAS {
            for &perturb in PERTURBS {
                let key = (dataset.to_owned(), view, gamma.to_bits(), perturb.to_bits());
                let (count, digest) = goldens
                    .get(&key)
                    .unwrap_or_else(|| panic!("no golden for {key:?}"));
                let params = HprParams {
                    kernel: Kernel::Linear(Radius::Gamma(gamma)),
                    perturb,
                    seed: SEED,
                };
                let visible = hpr::visible(&ds.cloud.positions, eye, &params, own.as_ref())
                    .unwrap_or_else(|e| panic!("{key:?}: {e}"))
                    .visible;
                assert_eq!(
                    (visible.len(), &visible_sha256(&visible)),
                    (*count, digest),
                    "{dataset} view {view} gamma {gamma} k {perturb}: the visible set changed"
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, VIEWS * GAMMAS.len() * PERTURBS.len());
}

#[test]
fn golden_digests_cover_the_hull_grid() {
    let goldens = goldens();
    for dataset in SYNTHETIC.iter().chain(REAL).chain(SLOW) {
        let rows = goldens.keys().filter(|k| k.0 == *dataset).count();
        assert_eq!(rows, VIEWS * GAMMAS.len() * PERTURBS.len(), "{dataset}");
    }
    assert_eq!(
        goldens.len(),
        (SYNTHETIC.len() + REAL.len() + SLOW.len()) * 84
    );
}

#[test]
fn exact_hpr_matches_the_goldens_on_synthetic_clouds() {
    let goldens = goldens();
    for dataset in SYNTHETIC {
        check(dataset, &goldens);
    }
}

#[test]
fn exact_hpr_matches_the_goldens_on_the_bunnies() {
    if std::env::var("POINTSIGHT_REAL_DATA").as_deref() != Ok("1") {
        eprintln!("POINTSIGHT_REAL_DATA is not 1: skipping the bunnies' digests (run `just test`)");
        return;
    }
    let goldens = goldens();
    for dataset in REAL {
        check(dataset, &goldens);
    }
}

#[test]
fn exact_hpr_matches_the_goldens_on_the_dragon() {
    if std::env::var("POINTSIGHT_REAL_DATA").as_deref() != Ok("1")
        || std::env::var("POINTSIGHT_SLOW").as_deref() != Ok("1")
    {
        eprintln!(
            "POINTSIGHT_REAL_DATA and POINTSIGHT_SLOW are not both 1: skipping the dragon's digests"
        );
        return;
    }
    let goldens = goldens();
    for dataset in SLOW {
        check(dataset, &goldens);
    }
}
