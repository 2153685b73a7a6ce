//! Writes the SHA-256 of every sorted visible index list of exact HPR (`own`) over the hull
//! experiment's grid, as CSV: dataset,view,gamma,perturb,n_visible,sha256 (the indices in
//! decimal, one per line, each followed by '\n'). `tests/data/golden/hull_digests.csv` is this
//! program's output at revision 5c38c1a (it compiles unchanged there):
//! `hull_digests DATA_DIR VIEWS DATASET...`.
use anyhow::{Context as _, Result};
use sha2::{Digest, Sha256};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(data_dir), Some(views)) = (args.get(1), args.get(2)) else {
        anyhow::bail!("usage: hull_digests DATA_DIR VIEWS DATASET...");
    };
    let data_dir = std::path::PathBuf::from(data_dir);
    let views: usize = views.parse().context("VIEWS is a count")?;
    let own = hull::by_name("own")?;
    println!("dataset,view,gamma,perturb,n_visible,sha256");
    for name in &args[3..] {
        let ds = harness::datasets::Datasets::default().load(name, &data_dir)?;
        for view in 0..views {
            let cam = ds.view(view)?;
            for gamma in [2.0, 3.0, 4.0] {
                for perturb in [0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
                    let params = hpr::HprParams {
                        kernel: hpr::Kernel::Linear(hpr::Radius::Gamma(gamma)),
                        perturb,
                        seed: 2007,
                    };
                    let mut v =
                        hpr::visible(&ds.cloud.positions, cam.eye, &params, own.as_ref())?.visible;
                    v.sort_unstable();
                    let mut h = Sha256::new();
                    for i in &v {
                        h.update(format!("{i}\n").as_bytes());
                    }
                    let hex: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
                    println!("{name},{view},{gamma},{perturb:e},{},{hex}", v.len());
                }
            }
        }
    }
    Ok(())
}
