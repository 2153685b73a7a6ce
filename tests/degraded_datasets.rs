//! The built-in degraded and scanned datasets on the real meshes (needs `pointsight fetch`;
//! runs when `POINTSIGHT_REAL_DATA=1`, as `just test` sets): the statistics they promise, and
//! that a scan keeps only points its scanner sees.

use std::path::PathBuf;

use cloud::glam::DVec3;

fn data_dir() -> PathBuf {
    std::env::var_os("POINTSIGHT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench-data")))
}

fn real_data() -> bool {
    let on = std::env::var("POINTSIGHT_REAL_DATA").as_deref() == Ok("1");
    if !on {
        eprintln!("POINTSIGHT_REAL_DATA is not 1: skipping the real-data check (run `just test`)");
    }
    on
}

#[test]
fn bunny_noise_has_sigma_half_a_spacing_and_clean_truth_positions() {
    if !real_data() {
        return;
    }
    let ds = harness::datasets::Datasets::default()
        .load("bunny-noise-0.5", &data_dir())
        .expect("bunny-noise-0.5");
    let truth = ds.truth_positions.as_ref().expect("truth positions");
    let clean = harness::datasets::Datasets::default()
        .load("bunny-69451", &data_dir())
        .expect("bunny-69451");
    assert_eq!(
        truth, &clean.cloud.positions,
        "the truth is the clean samples"
    );
    let spacing =
        cloud::spacing::density_spacing(&clean.cloud.positions, 8, 20_000, 15).expect("spacing");
    let n = truth.len() as f64;
    let s2: f64 = ds
        .cloud
        .positions
        .iter()
        .zip(truth)
        .map(|(p, q)| (*p - *q).length_squared())
        .sum();
    // Three axes of σ each.
    let sigma = (s2 / (3.0 * n)).sqrt();
    assert!(
        (sigma / (0.5 * spacing) - 1.0).abs() < 0.05,
        "{sigma} vs {}",
        0.5 * spacing
    );
}

#[test]
fn bunny_outliers_are_five_percent_and_flagged() {
    if !real_data() {
        return;
    }
    let ds = harness::datasets::Datasets::default()
        .load("bunny-outliers-0.05", &data_dir())
        .expect("dataset");
    let outliers = ds.outliers.as_ref().expect("flags");
    assert_eq!(outliers.iter().filter(|&&o| o).count(), 3_473);
    let (off, _) = ds.off_surface().expect("off surface").expect("a mesh");
    // Every outlier is scored apart.
    assert!(outliers.iter().zip(&off).all(|(o, f)| !o || *f));
}

#[test]
fn a_scan_keeps_only_what_its_scanners_see() {
    if !real_data() {
        return;
    }
    let ds = harness::datasets::Datasets::default()
        .load("bunny-scan-4", &data_dir())
        .expect("bunny-scan-4");
    let mesh = ds.mesh.as_ref().expect("mesh");
    let exact = truth::ExactVisibility::new(mesh).expect("bvh");
    let bbox = mesh.bbox().expect("bbox");
    let d = bbox.diagonal();
    let scanners = truth::scan::ring(bbox.center(), 1.5 * d, 0.5 * d, 4);
    let scan = ds.cloud.scan.as_ref().expect("scan indices");
    let hits = ds.truth_positions.as_ref().expect("hits");
    let mut per: [usize; 4] = [0; 4];
    for (i, p) in hits.iter().enumerate() {
        let from: DVec3 = scanners[scan[i] as usize];
        assert!(
            exact.is_visible(from, *p),
            "hit {i} hidden from scanner {}",
            scan[i]
        );
        assert!(exact.distance(*p) < 1e-9 * d, "hit {i} off the surface");
        per[scan[i] as usize] += 1;
    }
    assert!(per.iter().all(|&n| n > 3_000), "{per:?}");
}

#[test]
fn a_mobile_pass_scans_profiles_across_its_line_and_is_seen_from_the_vehicle() {
    if !real_data() {
        return;
    }
    let ds = harness::datasets::Datasets::default()
        .load("bunny-mobile", &data_dir())
        .expect("bunny-mobile");
    let mesh = ds.mesh.as_ref().expect("mesh");
    let exact = truth::ExactVisibility::new(mesh).expect("bvh");
    let bbox = mesh.bbox().expect("bbox");
    let (c, d) = (bbox.center(), bbox.diagonal());
    // 400 profile scanners evenly along x from -1.2 d to 1.2 d, at -d in y.
    let at = |k: usize| {
        let t = (k as f64 + 0.5) / 400.0;
        c + DVec3::new(-1.2 * d + 2.4 * d * t, -d, 0.0)
    };
    let scan = ds.cloud.scan.as_ref().expect("scan indices");
    let hits = ds.truth_positions.as_ref().expect("hits");
    let mut profiles = std::collections::BTreeSet::new();
    for (i, p) in hits.iter().enumerate() {
        let from = at(scan[i] as usize);
        // Each hit lies in its scanner's profile plane (across the travel) and is seen from it.
        assert!(
            (p.x - from.x).abs() < 1e-9 * d,
            "hit {i} off its profile plane"
        );
        assert!(
            exact.is_visible(from, *p),
            "hit {i} hidden from its scanner"
        );
        assert!(exact.distance(*p) < 1e-9 * d, "hit {i} off the surface");
        profiles.insert(scan[i]);
    }
    // The mesh is about 0.5 d wide along the pass: a fifth of the 400 profiles or more meet it.
    assert!(profiles.len() > 80, "{} profiles hit", profiles.len());
    // The views ride the vehicle: 16 cameras one diagonal off, looking at the centre.
    assert_eq!(ds.views.len(), 16);
    for v in &ds.views {
        assert!((v.eye.y - (c.y - d)).abs() < 1e-9 * d, "{:?}", v.eye);
        assert!(v.forward().dot((c - v.eye).normalize()) > 1.0 - 1e-9);
    }
}
