//! Opt-in (`POINTSIGHT_TRAIN_SMOKE=1`; it needs the training environment, which
//! `scripts/train-neuralvis.sh` installs, several GB): a short training run end to end, on one
//! training mesh and one validation mesh, with the small test configuration. The loss must fall
//! and the weights file it writes must load and answer here.

use std::path::Path;
use std::process::Command;

use cloud::glam::DVec3;

#[test]
fn a_short_training_lowers_the_loss_and_writes_weights_the_rust_side_reads() {
    if std::env::var_os("POINTSIGHT_TRAIN_SMOKE").is_none() {
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let run = std::env::temp_dir().join(format!("neuralvis-smoke-{}", std::process::id()));
    let status = Command::new(root.join("scripts/train-neuralvis.sh"))
        .args(["--smoke", "--steps", "40", "--run"])
        .arg(&run)
        .args([
            "--",
            "--config",
            "tiny",
            "--val-every",
            "40",
            "--max-points",
            "4000",
        ])
        .status()
        .expect("the training script runs");
    assert!(status.success(), "training failed: {status}");
    let record: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(run.join("neuralvis-tiny-d6.training.json")).expect("record"),
    )
    .expect("record JSON");
    let losses: Vec<f64> = record["losses"]
        .as_array()
        .expect("losses")
        .iter()
        .map(|l| l[1].as_f64().expect("a loss"))
        .collect();
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
    let (first, last) = (mean(&losses[..10]), mean(&losses[losses.len() - 10..]));
    assert!(last < first, "the loss did not fall: {first} -> {last}");
    let model = neuralvis::Model::load(&run.join("neuralvis-tiny-d6.nvw")).expect("weights load");
    let cloud: Vec<DVec3> = (0..500)
        .map(|i| {
            let t = f64::from(i) * 0.37;
            DVec3::new(t.sin(), t.cos(), (0.1 * t).sin())
        })
        .collect();
    let f = model.features(&cloud).expect("feature pass");
    let p = model
        .probabilities_from(&f, &cloud, |_| DVec3::new(0.0, 0.0, 5.0))
        .expect("head");
    assert!(p.iter().all(|x| (0.0..=1.0).contains(x)));
    let _ = std::fs::remove_dir_all(&run);
}
