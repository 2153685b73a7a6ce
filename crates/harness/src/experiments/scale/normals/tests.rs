//! Tests of the scale experiment's normal-estimation family: the peers' runner, the forecast,
//! the rounds and the ratios, on synthetic rows and stand-in programs.

use super::*;
use cloud::glam::DVec3;

#[test]
fn accuracy_against_known_angles() {
    let z = Vec3::Z;
    // 10° tilts on half the points, exact on the other half, one flipped.
    let tilt = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
    let normals = [z, z, -z, tilt(10.0), tilt(10.0), tilt(30.0)];
    let reference = [z; 6];
    let a = accuracy(&normals, &reference, true).unwrap();
    // Sorted angles 0, 0, 0, 10, 10, 30: the nearest-rank median is the third.
    assert!(a.angle_median_deg.abs() < 1e-3, "{a:?}");
    assert!((a.angle_p95_deg - 30.0).abs() < 1e-3, "{a:?}");
    assert!((a.sign_agreement - 5.0 / 6.0).abs() < 1e-12, "{a:?}");
    assert!(
        accuracy(&normals, &reference, false)
            .unwrap()
            .sign_agreement
            .is_nan()
    );
    assert!(accuracy(&normals, &reference[..2], false).is_err());
    // A zero normal counts as 90°.
    let a = accuracy(&[Vec3::ZERO], &[z], true).unwrap();
    assert_eq!((a.angle_median_deg, a.sign_agreement), (90.0, 0.0));
}

#[test]
fn ours_on_a_sphere_agree_with_its_analytic_normals() {
    // A Fibonacci sphere: the normal of each point is its position.
    let n = 4000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let positions: Vec<DVec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            let t = golden * i as f64;
            DVec3::new(r * t.cos(), y, r * t.sin())
        })
        .collect();
    let reference: Vec<Vec3> = positions.iter().map(|p| p.as_vec3()).collect();
    let cloud = cloud::PointCloud {
        positions,
        normals: Some(reference.clone()),
        ..cloud::PointCloud::default()
    };
    let dir = tempfile::tempdir().unwrap();
    for kind in [Kind::Ours, Kind::OursOriented] {
        let out = cell(kind, &cloud, dir.path(), Path::new("python3"), || 0.0).unwrap();
        assert!(
            out.accuracy.angle_p95_deg < 2.0,
            "{kind:?}: {:?}",
            out.accuracy
        );
        if kind.oriented() {
            assert!(out.accuracy.sign_agreement > 0.999, "{:?}", out.accuracy);
        }
    }
    // Brute force: the same statistics computed directly from the estimate.
    let est = cloud::normals::estimate_normals(&cloud.positions, K, Orientation::AwayFromCentroid)
        .unwrap();
    let mut brute: Vec<f64> = est
        .iter()
        .zip(&reference)
        .map(|(a, b)| {
            let c = a.as_dvec3().normalize().dot(b.as_dvec3().normalize()).abs();
            c.min(1.0).acos().to_degrees()
        })
        .collect();
    brute.sort_by(f64::total_cmp);
    let a = accuracy(&est, &reference, false).unwrap();
    assert!(
        (a.angle_median_deg - brute[n / 2 - 1]).abs() < 1e-9,
        "{a:?}"
    );
    assert!(
        (a.angle_p95_deg - brute[n * 95 / 100 - 1]).abs() < 1e-9,
        "{a:?}"
    );
}

#[test]
fn a_missing_peer_is_unavailable_and_a_failing_or_hanging_one_is_named() {
    let missing = Path::new("/nonexistent/python");
    let why = availability(missing, "open3d").unwrap_err();
    assert!(why.contains("open3d"), "{why}");
    let ks = kinds(missing);
    for k in &ks {
        let peer = Kind::named(&k.name).unwrap().peer();
        assert_eq!(k.unavailable.is_some(), peer.is_some(), "{k:?}");
    }
    // The family reports the missing ones as skipped, not as errors.
    let rows = measure(
        &ks,
        &[10_000],
        CAP,
        false,
        |m, n| Row {
            method: m.into(),
            n_points: n,
            seconds: 1.0,
            peak_rss_bytes: 1,
            status: "ok".into(),
            prepare_seconds: 0.0,
            detail: String::new(),
            runs_seconds: String::new(),
            angle_median_deg: 1.0,
            angle_p95_deg: 2.0,
            sign_agreement: f64::NAN,
            build_seconds: f64::NAN,
        },
        |_, _| {},
    );
    for r in &rows {
        if Kind::named(&r.method).unwrap().peer().is_some() {
            assert!(r.status.starts_with("skipped: not installed"), "{r:?}");
        } else {
            assert_eq!(
                (r.status.as_str(), r.runs_seconds.as_str()),
                ("ok", "1.0000;1.0000;1.0000")
            );
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let sh = |body: &str| {
        let p = dir.path().join(format!("peer-{}.sh", body.len()));
        std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
        std::fs::set_permissions(&p, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
        p
    };
    let e = run_peer("normals-open3d", &sh("echo boom >&2; exit 3"), &[], CAP)
        .unwrap_err()
        .to_string();
    assert!(e.contains("normals-open3d") && e.contains("boom"), "{e}");
    let started = Instant::now();
    let hang = sh("sleep 30");
    let e = run_peer("normals-pcu", &hang, &[], Duration::from_millis(300))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("normals-pcu") && e.contains("did not finish"),
        "{e}"
    );
    assert!(started.elapsed() < Duration::from_secs(10));
    let ok = run_peer("normals-pcu", &sh("echo '{\"seconds\": 0.25}'"), &[], CAP).unwrap();
    assert_eq!(ok, 0.25);
}

#[test]
fn the_forecast_and_the_ratios() {
    let cap = Duration::from_secs(300);
    assert_eq!(forecast_skip(&[], 100, cap, 1), None);
    assert!(forecast_skip(&[(10, f64::NAN)], 100, cap, 1).is_some());
    // 117 s at 10^6 after 10 s at 10^5: exponent 1.07, about 250 s at 2·10^6: under the
    // cap for one round, over the size's budget for three.
    let done = [(100_000, 10.0), (1_000_000, 117.0)];
    assert_eq!(forecast_skip(&done, 2_000_000, cap, 1), None);
    assert_eq!(forecast_skip(&done, 2_000_000, cap, 2), None);
    let why = forecast_skip(&done, 2_000_000, cap, 3).unwrap();
    assert!(
        why.contains("over its 3 rounds, over the 600 s budget"),
        "{why}"
    );
    // 10 s at 10^5 alone: about 100 s a run at 10^6, 300 s over three rounds.
    assert_eq!(forecast_skip(&done[..1], 1_000_000, cap, 3), None);
    let why = forecast_skip(&done, 10_000_000, cap, 1).unwrap();
    assert!(why.contains("117.0 s at 1000000 points"), "{why}");
    assert!(why.contains("over the 300 s cap"), "{why}");
    assert_eq!(
        sizes(&[10_000, 10_000_000]),
        vec![10_000, 2_000_000, 10_000_000]
    );
    assert_eq!(sizes(&[10_000, 1_000_000]), vec![10_000, 1_000_000]);
    let row = |m: &str, runs: &str| Row {
        method: m.into(),
        n_points: 1000,
        seconds: 1.0,
        peak_rss_bytes: 1,
        status: "ok".into(),
        prepare_seconds: 0.0,
        detail: String::new(),
        runs_seconds: runs.into(),
        angle_median_deg: 1.0,
        angle_p95_deg: 2.0,
        sign_agreement: f64::NAN,
        build_seconds: f64::NAN,
    };
    let r = ratios(&[row("normals-ours", "1;2;1"), row("normals-open3d", "3;4;5")]);
    assert_eq!(r.len(), 1);
    // The pairs give 3, 2 and 5: the median is 3.
    assert_eq!(
        (r[0].ratio, r[0].min, r[0].max, r[0].pairs),
        (3.0, 2.0, 5.0, 3)
    );
    assert!(summary(&[row("normals-ours", "1;2;1")]).contains("normals-ours"));
}
