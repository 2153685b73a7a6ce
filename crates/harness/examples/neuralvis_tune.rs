//! The learned method's threshold, chosen on the tuning datasets as the visibility experiment
//! chooses a tuned setting (`experiments::visibility::tuning`: the highest mean over the
//! datasets of each one's mean F1 over its views), from one feature pass per dataset: the
//! method runs through the registry (its card, its setting) and its score (P(visible)) is
//! thresholded here at every candidate; truth: `truth::Reference` on the dataset's own views.
//!
//! ```text
//! cargo run --release -p harness --example neuralvis_tune -- [--weights FILE]
//! ```

use anyhow::{Context, Result};
use clap::Parser;
use registry::{Input, Params};
use truth::reference::{Reference, ReferenceParams};

#[derive(Parser)]
struct Args {
    /// The tuning datasets (default: the visibility report's).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "bunny,bunny-69451,dragon-871414,sphere-plane-24000,torus-22321"
    )]
    datasets: Vec<String>,
    /// Weights file (default: the committed weights).
    #[arg(long)]
    weights: Option<String>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let clone = harness::paths::working_clone();
    let data_dir = harness::paths::data_dir(None, clone.as_deref())?.path;
    let thresholds: Vec<f32> = (6..=14).map(|k| k as f32 * 0.05).collect();
    let mut pairs = vec!["threshold=0.5".to_owned()];
    if let Some(w) = &args.weights {
        pairs.push(format!("weights={w}"));
    }
    let card = registry::Catalogue::builtin().card("neuralvis")?;
    let (setup, _) = card.setup(&Params::parse(&pairs)?)?;
    let mut means = vec![0f64; thresholds.len()];
    for name in &args.datasets {
        let ds = harness::datasets::Datasets::default().load(name, &data_dir)?;
        let mesh = ds.mesh.as_ref().context("a tuning dataset has a mesh")?;
        let reference = Reference::new(mesh)?;
        let prepared = setup.prepare(Input {
            cloud: &ds.cloud,
            mesh: None,
        })?;
        let mut f1 = vec![0f64; thresholds.len()];
        for camera in &ds.views {
            let truth =
                reference.visibility(&ds.cloud.positions, camera, &ReferenceParams::default())?;
            let score = prepared
                .visible(camera)?
                .score
                .context("neuralvis gives a score")?;
            for (k, &t) in thresholds.iter().enumerate() {
                let (mut tp, mut pred, mut real) = (0usize, 0usize, 0usize);
                for (&s, &v) in score.iter().zip(&truth.visible) {
                    let p = s >= t;
                    tp += usize::from(p && v);
                    pred += usize::from(p);
                    real += usize::from(v);
                }
                f1[k] += if pred + real == 0 {
                    1.0
                } else {
                    2.0 * tp as f64 / (pred + real) as f64
                };
            }
        }
        let n = ds.views.len() as f64;
        let per: Vec<f64> = f1.iter().map(|x| x / n).collect();
        for (m, x) in means.iter_mut().zip(&per) {
            *m += x / args.datasets.len() as f64;
        }
        println!(
            "{}",
            serde_json::json!({"dataset": name, "views": ds.views.len(), "thresholds": thresholds, "f1": per})
        );
    }
    let best = (0..thresholds.len())
        .max_by(|&a, &b| means[a].total_cmp(&means[b]))
        .context("no threshold")?;
    println!(
        "{}",
        serde_json::json!({"mean_f1": means, "thresholds": thresholds, "best_threshold": thresholds[best], "best_mean_f1": means[best]})
    );
    Ok(())
}
