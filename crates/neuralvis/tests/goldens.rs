//! The Rust network against goldens made by the training framework (PyTorch with ocnn's own
//! kernels, `scripts/neuralvis/golden.py`), and the weights file's checks.
//!
//! - `tiny.nvw` / `tiny.golden.json`: a small network of the paper's structure with seeded
//!   random weights and batch-norm statistics, a non-convex cloud, three eyes: every point's
//!   U-Net feature and P(visible) per eye, to 1e-4;
//! - `committed.golden.json`: the committed weights on a ball in front of a square from two
//!   eyes: P(visible) to 1e-4, and the visible sets at 0.5 equal but for points within 1e-4 of
//!   the threshold.

use std::path::{Path, PathBuf};

use cloud::glam::DVec3;
use neuralvis::{Features, Model, Weights, WeightsError};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

struct Golden {
    points: Vec<DVec3>,
    eyes: Vec<DVec3>,
    features: Option<Vec<Vec<f64>>>,
    probabilities: Vec<Vec<f64>>,
    sha256: Option<String>,
}

fn golden(name: &str) -> Golden {
    let text = std::fs::read_to_string(data(name)).expect("golden file");
    let v: serde_json::Value = serde_json::from_str(&text).expect("golden JSON");
    let rows = |key: &str| -> Vec<Vec<f64>> {
        v[key]
            .as_array()
            .expect("rows")
            .iter()
            .map(|r| {
                r.as_array()
                    .expect("row")
                    .iter()
                    .map(|x| x.as_f64().expect("number"))
                    .collect()
            })
            .collect()
    };
    let vec3 = |key: &str| {
        rows(key)
            .iter()
            .map(|r| DVec3::new(r[0], r[1], r[2]))
            .collect()
    };
    Golden {
        points: vec3("points"),
        eyes: vec3("eyes"),
        features: v.get("features").map(|_| rows("features")),
        probabilities: rows("probabilities"),
        sha256: v["weights_sha256"].as_str().map(str::to_owned),
    }
}

fn max_diff(a: impl Iterator<Item = (f64, f64)>) -> f64 {
    a.map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// P(visible) of every golden point from eye `j`, checked against the golden's to 1e-4.
fn checked_probabilities(model: &Model, features: &Features, g: &Golden, j: usize) -> Vec<f32> {
    let eye = g.eyes[j];
    let p = model
        .probabilities_from(features, &g.points, |_| eye)
        .expect("head");
    let d = max_diff(
        p.iter()
            .zip(&g.probabilities)
            .map(|(&a, row)| (f64::from(a), row[j])),
    );
    assert!(d <= 1e-4, "eye {j}: probabilities differ by {d}");
    p
}

#[test]
fn forward_pass_equals_the_training_frameworks_golden() {
    let model = Model::load(&data("tiny.nvw")).expect("tiny weights");
    let g = golden("tiny.golden.json");
    let features = model.features(&g.points).expect("feature pass");
    let expected = g.features.as_ref().expect("features in the golden");
    assert_eq!(features.len(), expected.len());
    let d = max_diff(
        features
            .data
            .chunks(features.channels)
            .zip(expected)
            .flat_map(|(a, b)| a.iter().map(|&x| f64::from(x)).zip(b.iter().copied())),
    );
    assert!(d <= 1e-4, "features differ by {d}");
    let spread = expected.iter().flatten().fold(0f64, |m, x| m.max(x.abs()));
    assert!(spread > 1e-2, "a golden of zeros tests nothing: {spread}");
    for j in 0..g.eyes.len() {
        checked_probabilities(&model, &features, &g, j);
    }
}

#[test]
fn committed_weights_on_a_synthetic_scene_equal_their_golden() {
    let model = Model::committed().expect("the committed weights load");
    let g = golden("committed.golden.json");
    assert_eq!(
        g.sha256.as_deref(),
        Some(model.weights().sha256.as_str()),
        "the golden was made from other weights: run scripts/neuralvis/golden.py committed"
    );
    let features = model.features(&g.points).expect("feature pass");
    for j in 0..g.eyes.len() {
        let p = checked_probabilities(&model, &features, &g, j);
        let ours = neuralvis::visible(&p, 0.5);
        let theirs: Vec<u32> = (0..g.points.len() as u32)
            .filter(|&i| g.probabilities[i as usize][j] >= 0.5)
            .collect();
        let differ = ours
            .iter()
            .filter(|i| !theirs.contains(i))
            .chain(theirs.iter().filter(|i| !ours.contains(i)));
        for &i in differ {
            assert!(
                (g.probabilities[i as usize][j] - 0.5).abs() < 1e-4,
                "eye {j}: point {i} is on the other side of 0.5"
            );
        }
        assert!(
            !ours.is_empty() && ours.len() < g.points.len(),
            "eye {j}: {} visible",
            ours.len()
        );
    }
}

fn write(bytes: &[u8], name: &str) -> (tempfile_dir::Dir, PathBuf) {
    let dir = tempfile_dir::Dir::new();
    let path = dir.0.join(name);
    std::fs::write(&path, bytes).expect("write");
    (dir, path)
}

/// A scratch folder removed on drop (no dev-dependency needed).
mod tempfile_dir {
    pub struct Dir(pub std::path::PathBuf);
    impl Dir {
        pub fn new() -> Self {
            use std::sync::atomic::{AtomicUsize, Ordering};
            static N: AtomicUsize = AtomicUsize::new(0);
            let p = std::env::temp_dir().join(format!(
                "neuralvis-test-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::SeqCst)
            ));
            std::fs::create_dir_all(&p).expect("scratch folder");
            Self(p)
        }
    }
    impl Drop for Dir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[test]
fn bad_weights_files_are_refused_with_their_name_and_cause() {
    let good = std::fs::read(data("tiny.nvw")).expect("tiny weights");
    assert!(Weights::from_bytes(&good, Path::new("tiny.nvw")).is_ok());

    let missing = data("no-such-weights.nvw");
    match Model::load(&missing) {
        Err(neuralvis::Error::Weights(WeightsError::Unreadable { path, .. })) => {
            assert_eq!(path, missing)
        }
        other => panic!("missing file: {other:?}"),
    }

    let (_d, truncated) = write(&good[..good.len() / 2], "truncated.nvw");
    let err = Model::load(&truncated).expect_err("truncated");
    assert!(
        matches!(err, neuralvis::Error::Weights(WeightsError::Truncated { ref path, expected, found })
            if *path == truncated && expected == good.len() as u64 && found == good.len() as u64 / 2),
        "{err:?}"
    );
    assert!(err.to_string().contains("truncated.nvw"), "{err}");
    let (_d, short) = write(&good[..5], "short.nvw");
    assert!(matches!(
        Model::load(&short),
        Err(neuralvis::Error::Weights(WeightsError::Truncated { .. }))
    ));

    let (_d, foreign) = write(
        b"PK\x03\x04 a zip file, say a PyTorch checkpoint",
        "model.pth",
    );
    let err = Model::load(&foreign).expect_err("foreign");
    assert!(
        matches!(err, neuralvis::Error::Weights(WeightsError::Foreign { ref path }) if *path == foreign),
        "{err:?}"
    );
    assert!(err.to_string().contains("model.pth"));

    let mut version = good.clone();
    version[8] = 9;
    assert!(matches!(
        Weights::from_bytes(&version, Path::new("v9.nvw")),
        Err(WeightsError::Version {
            found: 9,
            supported: 1,
            ..
        })
    ));

    let mut flipped = good.clone();
    let last = flipped.len() - 40;
    flipped[last] ^= 0x10;
    let err = Weights::from_bytes(&flipped, Path::new("flipped.nvw")).expect_err("corrupt");
    assert!(matches!(err, WeightsError::Checksum { .. }), "{err:?}");
    assert!(err.to_string().contains("flipped.nvw"));

    let mut longer = good.clone();
    longer.push(0);
    assert!(matches!(
        Weights::from_bytes(&longer, Path::new("longer.nvw")),
        Err(WeightsError::Invalid { .. })
    ));
}

#[test]
fn degenerate_clouds_are_refused_or_answered() {
    let model = Model::load(&data("tiny.nvw")).expect("tiny weights");
    assert!(matches!(
        model.features(&[]),
        Err(neuralvis::Error::Input(_))
    ));
    assert!(matches!(
        model.features(&[DVec3::new(f64::NAN, 0.0, 0.0)]),
        Err(neuralvis::Error::Cloud(_))
    ));
    // One point, and a cloud of identical points: one node, a finite answer.
    for cloud in [vec![DVec3::ONE], vec![DVec3::new(1e9, -3.0, 2.0); 5]] {
        let f = model.features(&cloud).expect("a feature");
        let p = model
            .probabilities_from(&f, &cloud, |_| DVec3::new(0.0, 0.0, -10.0))
            .expect("head");
        assert!(
            p.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)),
            "{p:?}"
        );
    }
}
