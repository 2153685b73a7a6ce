//! `pointsight visible`: one method on one view (the output contract of a single file) or on
//! many views at once (a folder of index files).
//!
//! Per-dataset preparation (k-d tree, BVH) is done once; for many views, methods that say so
//! ([`crate::methods::Method::parallel_views`]) answer views in parallel, the others one after
//! another (their single view already uses every core).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use cloud::Camera;
use rayon::prelude::*;

use crate::cli::ParallelViews;
use crate::datasets::{self, Dataset};
use crate::methods::{self, Output, Params};
use crate::output;
use crate::score::Score;

/// What `visible` was asked.
#[derive(Debug, Clone)]
pub struct Request {
    /// Dataset name.
    pub dataset: String,
    /// `K`, `all` or `K1,K2,...`.
    pub view: String,
    /// A views file replacing the dataset's views.
    pub views: Option<PathBuf>,
    /// Method name.
    pub method: String,
    /// `--set` pairs.
    pub set: Vec<String>,
    /// Output file (one view) or folder (many).
    pub out: PathBuf,
    /// Score against the reference.
    pub score: bool,
    /// How to run many views.
    pub parallel_views: ParallelViews,
}

/// The view indices `spec` names among `n` views.
pub fn parse_views(spec: &str, n: usize) -> Result<Vec<usize>> {
    if n == 0 {
        bail!("there are no views");
    }
    if spec == "all" {
        return Ok((0..n).collect());
    }
    let mut out = Vec::new();
    for part in spec.split(',') {
        let k: usize = part
            .trim()
            .parse()
            .with_context(|| format!("--view {spec:?}: expected all, K or K1,K2,..."))?;
        if k >= n {
            bail!("view {k} does not exist: there are views 0..{}", n - 1);
        }
        if out.contains(&k) {
            bail!("--view {spec:?}: view {k} given twice");
        }
        out.push(k);
    }
    Ok(out)
}

fn indices_text(visible: &[u32]) -> String {
    let mut text = String::with_capacity(visible.len() * 8);
    for i in visible {
        text.push_str(&i.to_string());
        text.push('\n');
    }
    text
}

fn score_line(
    reference: &truth::Reference,
    ds: &Dataset,
    camera: &Camera,
    output: &Output,
) -> Result<String> {
    let truth = reference
        .visibility(
            &ds.cloud.positions,
            camera,
            &truth::ReferenceParams::default(),
        )?
        .visible;
    let s = Score::of(&output.visible, &truth);
    Ok(format!(
        "reference_visible={} precision={:.4} recall={:.4} f1={:.4}",
        truth.iter().filter(|&&t| t).count(),
        s.precision(),
        s.recall(),
        s.f1()
    ))
}

/// Runs the request; prints the contract lines.
pub fn run(req: &Request, data_dir: &Path) -> Result<()> {
    let params = Params::parse(&req.set)?;
    let method = methods::method(&req.method)?;
    let mut ds = datasets::load(&req.dataset, data_dir)?;
    let many = req.views.is_some() || req.view.parse::<usize>().is_err();
    if let Some(path) = &req.views {
        ds.views = cloud::io::views::read_views(path)?;
    }
    let reference = if req.score {
        Some(truth::Reference::new(&ds.mesh)?)
    } else {
        None
    };
    if !many {
        // The single-view contract: a file, `prepare_seconds`, then the contract line.
        let k: usize = req.view.parse()?;
        let camera = *ds.view(k)?;
        let start = Instant::now();
        let prepared = methods::prepare(method, &ds, &params)?;
        let prepare_seconds = start.elapsed().as_secs_f64();
        let (output, seconds) = methods::timed(prepared.as_ref(), &camera)?;
        output::write_atomic(&req.out, indices_text(&output.visible).as_bytes())?;
        println!("prepare_seconds={prepare_seconds:.6} rays={}", output.rays);
        if let Some(r) = &reference {
            println!("{}", score_line(r, &ds, &camera, &output)?);
        }
        println!(
            "method={} points={} visible={} seconds={seconds:.6}",
            method.name(),
            ds.cloud.len(),
            output.visible.len()
        );
        return Ok(());
    }

    let chosen = parse_views(&req.view, ds.views.len())?;
    let cameras: Vec<(usize, Camera)> = chosen.iter().map(|&k| (k, ds.views[k])).collect();
    let start = Instant::now();
    let prepared = methods::prepare(method, &ds, &params)?;
    let prepare_seconds = start.elapsed().as_secs_f64();
    let parallel = match req.parallel_views {
        ParallelViews::Auto => method.parallel_views(),
        ParallelViews::Yes => true,
        ParallelViews::No => false,
    };
    println!(
        "prepare_seconds={prepare_seconds:.6} views={} parallel_views={parallel}",
        cameras.len(),
    );
    let start = Instant::now();
    let run_one = |&(k, camera): &(usize, Camera)| -> Result<(usize, Output, f64)> {
        let (output, seconds) =
            methods::timed(prepared.as_ref(), &camera).with_context(|| format!("view {k}"))?;
        Ok((k, output, seconds))
    };
    let results: Vec<(usize, Output, f64)> = if parallel {
        cameras.par_iter().map(run_one).collect::<Result<_>>()?
    } else {
        cameras.iter().map(run_one).collect::<Result<_>>()?
    };
    let wall = start.elapsed().as_secs_f64();
    std::fs::create_dir_all(&req.out)
        .with_context(|| format!("cannot create {}", req.out.display()))?;
    for (k, output, seconds) in &results {
        output::write_atomic(
            &req.out.join(format!("view-{k}.txt")),
            indices_text(&output.visible).as_bytes(),
        )?;
        if let Some(r) = &reference {
            println!("view={k} {}", score_line(r, &ds, &ds.views[*k], output)?);
        }
        println!(
            "view={k} method={} points={} visible={} seconds={seconds:.6}",
            method.name(),
            ds.cloud.len(),
            output.visible.len()
        );
    }
    println!(
        "views={} points={} seconds={wall:.6} views_per_second={:.3}",
        results.len(),
        ds.cloud.len(),
        results.len() as f64 / wall.max(1e-12)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_specs() {
        assert_eq!(parse_views("all", 3).unwrap(), vec![0, 1, 2]);
        assert_eq!(parse_views("2,0", 3).unwrap(), vec![2, 0]);
        assert!(
            parse_views("3", 3)
                .unwrap_err()
                .to_string()
                .contains("view 3 does not exist")
        );
        assert!(parse_views("1,1", 3).is_err());
        assert!(parse_views("one", 3).is_err());
    }
}
