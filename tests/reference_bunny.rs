//! The reference against the exact segment test on the real bunny (needs `pointsight fetch`).
//!
//! Runs when `POINTSIGHT_REAL_DATA=1` (set by `just test`, which fetches first); otherwise it
//! says why it did nothing. With the variable set, missing data is a failure.

use std::path::PathBuf;

use truth::{Reference, ReferenceParams};

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

#[test]
fn reference_matches_the_exact_test_on_every_bunny_view() {
    if std::env::var("POINTSIGHT_REAL_DATA").as_deref() != Ok("1") {
        eprintln!("POINTSIGHT_REAL_DATA is not 1: skipping the real-data check (run `just test`)");
        return;
    }
    let ds = harness::datasets::Datasets::default()
        .load("bunny-69451", &data_dir())
        .expect("bunny-69451 loads after `pointsight fetch`");
    let reference = Reference::new(ds.mesh.as_ref().unwrap()).unwrap();
    for (k, cam) in ds.views.iter().enumerate() {
        let exact = reference
            .exact()
            .visibility(cam.eye, &ds.cloud.positions)
            .unwrap();
        for exact_fallback in [false, true] {
            let params = ReferenceParams {
                exact_fallback,
                ..ReferenceParams::default()
            };
            let r = reference
                .visibility(&ds.cloud.positions, cam, &params)
                .unwrap();
            let agree = r.visible.iter().zip(&exact).filter(|(a, b)| a == b).count() as f64
                / ds.cloud.len() as f64;
            assert!(
                agree >= 0.995,
                "view {k} (exact fallback {exact_fallback}): agreement {agree:.5} < 0.995"
            );
        }
    }
}
