//! `pointsight merge`: the reports folders of a sharded run (`--shard K/N` each) combined into
//! the folder an unsharded run would have written, then rendered. A shard's folder is one
//! experiment's (`run EXPERIMENT --shard K/N --out DIR`) or a reports folder of experiment
//! folders (`bench --shard K/N --reports DIR`); the two may be mixed.
//!
//! For an experiment that splits its cells ([`super::Experiment::shardable`]), every shard 1..N
//! must be present; each CSV is the shards' rows concatenated and put back in the unsharded
//! order, dataset-major (the run's dataset list) then by view, which is the order such
//! experiments write (rows of one cell come from one shard, in its order). Other files (renders)
//! come from the shard that wrote them. An experiment that does not split is one cell: exactly
//! one shard ran it and its folder is taken whole. The merged `metadata.json` is shard 1's,
//! with the shards' parameters united and every shard's own metadata (machine, revision, date,
//! seconds) under `shards`; `seconds` is the slowest shard's.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};

use super::{EXPERIMENTS, Experiment};
use crate::output::meta::RunMeta;

/// Merges every experiment found in `shards` into `out/EXPERIMENT/`; returns their names.
///
/// A shard folder is either what `run EXPERIMENT --shard K/N --out DIR` wrote (`DIR` holds
/// `metadata.json` and the results of that one experiment) or what `bench --shard K/N
/// --reports DIR` wrote (`DIR/EXPERIMENT/metadata.json` for each experiment).
pub fn merge(
    catalogue: &registry::Catalogue,
    out: &Path,
    shards: &[PathBuf],
) -> Result<Vec<String>> {
    // A folder of one run names its experiment in its metadata.
    let mut single: Vec<Option<RunMeta>> = Vec::with_capacity(shards.len());
    for s in shards {
        single.push(if s.join("metadata.json").exists() {
            Some(RunMeta::read(s).with_context(|| format!("{}: metadata.json", s.display()))?)
        } else {
            None
        });
    }
    let mut merged = Vec::new();
    for exp in EXPERIMENTS {
        let mut parts: Vec<(PathBuf, RunMeta)> = Vec::new();
        for (s, one) in shards.iter().zip(&single) {
            match one {
                Some(meta) if meta.experiment == exp.name() => {
                    parts.push((s.clone(), meta.clone()));
                }
                Some(_) => {}
                None => {
                    let dir = s.join(exp.name());
                    if dir.join("metadata.json").exists() {
                        let meta = RunMeta::read(&dir)
                            .with_context(|| format!("{}: metadata.json", dir.display()))?;
                        parts.push((dir, meta));
                    }
                }
            }
        }
        if parts.is_empty() {
            continue;
        }
        merge_experiment(catalogue, *exp, &parts, &out.join(exp.name()))?;
        merged.push(exp.name().to_owned());
    }
    if merged.is_empty() {
        bail!(
            "no experiment results in {} (a shard folder holds metadata.json, as `run \
             EXPERIMENT --shard K/N --out DIR` writes it, or EXPERIMENT/metadata.json, as \
             `bench --shard K/N --reports DIR` does)",
            shards
                .iter()
                .map(|s| s.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(merged)
}

fn merge_experiment(
    catalogue: &registry::Catalogue,
    exp: &dyn Experiment,
    parts: &[(PathBuf, RunMeta)],
    out: &Path,
) -> Result<()> {
    let name = exp.name();
    let first = &parts[0].1;
    let Some(shard) = first.shard else {
        bail!(
            "{name}: {} is not a shard's output (its metadata has no shard); merge takes the \
             folders of `--shard K/N` runs",
            parts[0].0.display()
        );
    };
    let mut seen = BTreeSet::new();
    for (dir, m) in parts {
        let s = m
            .shard
            .with_context(|| format!("{}: not a shard's output", dir.display()))?;
        if s.k == 0 || s.k > s.n {
            bail!("{name}: {} says shard {}/{}", dir.display(), s.k, s.n);
        }
        if s.n != shard.n {
            bail!(
                "{name}: {} is shard {}/{} but {} is of {} shards",
                dir.display(),
                s.k,
                s.n,
                parts[0].0.display(),
                shard.n
            );
        }
        if m.quick != first.quick || m.datasets != first.datasets {
            bail!(
                "{name}: {} ran other settings (quick or datasets) than {}",
                dir.display(),
                parts[0].0.display()
            );
        }
        if !seen.insert(s.k) {
            bail!("{name}: shard {}/{} given twice", s.k, s.n);
        }
    }
    if exp.shardable() {
        // Named up to ten (N comes from a file: it is not a count to allocate by).
        let missing: Vec<String> = (1..=shard.n)
            .filter(|k| !seen.contains(k))
            .take(10)
            .map(|k| format!("{k}/{}", shard.n))
            .collect();
        if !missing.is_empty() {
            let more = shard.n - seen.len() - missing.len();
            bail!(
                "{name}: shard(s) {}{} missing",
                missing.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            );
        }
    } else if parts.len() > 1 {
        bail!(
            "{name} does not split its cells, yet {} shards hold it",
            parts.len()
        );
    }

    // Written whole, replacing only a folder of pointsight's (`output::folder`).
    crate::output::folder::replace(out, crate::output::folder::Role::Experiment, |staging| {
        fill(catalogue, exp, parts, staging)
    })
}

/// Writes the merged experiment into `staging`, renders it and writes its findings beside it,
/// as an unsharded run of it would have.
fn fill(
    catalogue: &registry::Catalogue,
    exp: &dyn Experiment,
    parts: &[(PathBuf, RunMeta)],
    staging: &Path,
) -> Result<()> {
    let first = &parts[0].1;
    // Every file of every part: CSVs concatenated, others copied from the part that has them.
    let mut files: BTreeSet<String> = BTreeSet::new();
    for (dir, _) in parts {
        for e in std::fs::read_dir(dir)? {
            let e = e?;
            if e.file_type()?.is_file() {
                files.insert(e.file_name().to_string_lossy().into_owned());
            }
        }
    }
    for file in files.iter().filter(|f| *f != "metadata.json") {
        let sources: Vec<PathBuf> = parts
            .iter()
            .map(|(d, _)| d.join(file))
            .filter(|p| p.exists())
            .collect();
        if file.ends_with(".csv") {
            merge_csv(&sources, &first.datasets, &staging.join(file))?;
        } else if !file.ends_with(".md") {
            std::fs::copy(&sources[0], staging.join(file))
                .with_context(|| format!("cannot copy {}", sources[0].display()))?;
        }
    }
    let mut meta = first.clone();
    meta.shard = None;
    meta.shards = parts.iter().map(|(_, m)| m.clone()).collect();
    meta.seconds = parts.iter().map(|(_, m)| m.seconds).fold(0.0, f64::max);
    for (_, m) in &parts[1..] {
        unite(&mut meta.parameters, &m.parameters);
        for f in &m.user_files {
            if !meta.user_files.contains(f) {
                meta.user_files.push(f.clone());
            }
        }
    }
    meta.files = None;
    meta.write(staging)?;
    exp.render(catalogue, staging)?;
    super::findings::write_in(staging, exp.name())?;
    crate::output::folder::seal(staging)
}

/// `a` ∪ `b`: objects key by key, lists without repeats; elsewhere `a` stays.
fn unite(a: &mut serde_json::Value, b: &serde_json::Value) {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            for (k, v) in y {
                match x.get_mut(k) {
                    Some(old) => unite(old, v),
                    None => {
                        x.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (serde_json::Value::Array(x), serde_json::Value::Array(y)) => {
            for v in y {
                if !x.contains(v) {
                    x.push(v.clone());
                }
            }
        }
        _ => {}
    }
}

/// Concatenates CSV files with one header and sorts the rows (stably) by dataset (in
/// `datasets` order) and view, where those columns exist.
fn merge_csv(sources: &[PathBuf], datasets: &[String], out: &Path) -> Result<()> {
    let mut header: Option<csv::StringRecord> = None;
    let mut rows: Vec<csv::StringRecord> = Vec::new();
    for path in sources {
        let mut r = csv::Reader::from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let h = r.headers()?.clone();
        // An experiment writes an empty file for a table without rows.
        if h.is_empty() {
            continue;
        }
        match &header {
            None => header = Some(h),
            Some(first) if *first != h => bail!(
                "{}: columns differ from the other shards' ({} against {})",
                path.display(),
                h.iter().collect::<Vec<_>>().join(","),
                first.iter().collect::<Vec<_>>().join(",")
            ),
            Some(_) => {}
        }
        for rec in r.records() {
            rows.push(rec.with_context(|| format!("{}", path.display()))?);
        }
    }
    let Some(header) = header else {
        return crate::output::write_atomic(out, b"");
    };
    let col = |name: &str| header.iter().position(|h| h == name);
    let (d, v) = (col("dataset"), col("view"));
    rows.sort_by_key(|rec| {
        let dataset = d.and_then(|i| rec.get(i)).map_or(0, |name| {
            datasets
                .iter()
                .position(|x| x == name)
                .unwrap_or(usize::MAX)
        });
        let view = v
            .and_then(|i| rec.get(i))
            .and_then(|x| x.parse::<usize>().ok())
            .unwrap_or(0);
        (dataset, view)
    });
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(&header)?;
    for rec in &rows {
        w.write_record(rec)?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
    crate::output::write_atomic(out, &bytes)
}
