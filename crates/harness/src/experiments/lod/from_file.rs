//! The `lod` experiment on a dataset that is a built LOD file (the manifest's `lod_file`, a
//! QSplat or sequential point tree file): selection from the file without loading it, through
//! the same kernel (`registry::kernel::select_lod` on `registry::lod_file`), rows in the same
//! `results.csv` (method `qsplat` or `spt`), plus `file_reads.csv`: per selection, the bytes
//! it read from the file, the bytes the page cache held after it (0 for SPT, which keeps no
//! cache) and the bytes of the selection itself, so that selection memory can be read against
//! what the view draws. Its row in `builds.csv` is the file opened (header checked, its first
//! pages read): the build itself was `pointsight lod-build`'s, in another process. An external
//! LOD method that selects from a file of its own (the COPC peer, `methods/copc-lod`) says per
//! view what it read (the protocol's `bytes_read`): its rows join the same file and table, from
//! `lod`'s in-memory datasets.
//!
//! The reference is every leaf of the file (QSplat: its decoded, quantised spheres; SPT: its
//! leaf discs; the files keep no other positions), streamed in batches of [`LEAF_BATCH`] into
//! one `splat::render::Canvas` per view, so the reference of a cloud larger than memory is
//! rendered within the cache, the canvases and one batch (SPT: and the list of its leaf
//! entries, 4 bytes a point).

use anyhow::Result;
use registry::kernel;
use registry::lod::LodData;
use serde::{Deserialize, Serialize};
use splat::render::{Canvas, Image};

use super::{
    BuildRow, Context, Row, SEED, covered_box, panel, render_params, score, views_at, write_strip,
};
use crate::datasets::LodFileDataset;
use crate::progress;

/// Bytes of file pages each selector (and the reference's leaf stream) may cache.
pub const CACHE_BYTES: u64 = 64 << 20;

/// Leaves drawn into the reference canvases at a time.
pub const LEAF_BATCH: usize = 1 << 20;

/// One row of `file_reads.csv`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FileRead {
    /// Dataset name.
    pub dataset: String,
    /// The method that selected (`qsplat`, `spt`, or an external method with its own file).
    #[serde(default)]
    pub method: String,
    /// View index.
    pub view: usize,
    /// Eye distance factor.
    pub distance: f64,
    /// Setting.
    pub params: String,
    /// Splats drawn.
    pub points_rendered: usize,
    /// Selection time (median).
    pub seconds: f64,
    /// Bytes the view's first selection read from the file.
    pub bytes_read: u64,
    /// Bytes of pages the cache held after it.
    pub cache_bytes: u64,
    /// Bytes of the selection's splats.
    pub selection_bytes: u64,
    /// Bytes of the file.
    pub file_bytes: u64,
}

/// Measures the method that built the file of `ds` from it.
pub(super) fn measure(
    ctx: &Context,
    ds: &LodFileDataset,
    rows: &mut Vec<Row>,
    reads: &mut Vec<FileRead>,
    builds: &mut Vec<BuildRow>,
) -> Result<()> {
    let name = ds.name.as_str();
    for v in &ds.views {
        v.require(
            "the lod experiment (QSplat's frustum, the splat renderer)",
            &["pinhole"],
        )?;
    }
    let (views, at) = views_at(&ds.views)?;
    let bar = progress::bar(ds.n_points, format!("lod {name}: reference from the file"));
    let mut canvases: Vec<Canvas> = views
        .iter()
        .map(|v| Canvas::new(&v.camera, &render_params()))
        .collect();
    let leaves = registry::lod_file::file_leaves(&ds.path, CACHE_BYTES, LEAF_BATCH, |batch| {
        for c in &mut canvases {
            c.draw(batch);
        }
        bar.inc(batch.len() as u64);
    })?;
    bar.finish_and_clear();
    let references: Vec<Image> = canvases.into_iter().map(Canvas::finish).collect();
    let crop = covered_box(&references[0], 8);
    let mut strip = vec![
        panel(
            format!("reference: {leaves} leaves of the file"),
            &references[0],
        )
        .crop(crop.0, crop.1, crop.2, crop.3),
    ];
    let method = ctx.run.catalogue.card(ds.method)?;
    let settings = ctx
        .sweeps
        .methods
        .get(ds.method)
        .map(|s| s.settings(ctx.quick).to_vec())
        .unwrap_or_default();
    let opened = std::time::Instant::now();
    let built = registry::lod_file::open_file(&ds.path, CACHE_BYTES)?;
    let file_bytes = built.size().bytes as u64;
    builds.push(BuildRow {
        dataset: name.to_owned(),
        method: ds.method.to_owned(),
        n_points: ds.n_points as usize,
        seconds: opened.elapsed().as_secs_f64(),
        nodes: built.size().nodes,
        bytes_per_point: file_bytes as f64 / ds.n_points.max(1) as f64,
    });
    let data = LodData::none(SEED);
    let input = data.input();
    let cell = kernel::LodCell {
        method,
        settings: &settings,
        views: &views,
        repeats: ctx.repeats,
        build_repeats: 1,
    };
    let mut ds_rows: Vec<(usize, Row)> = Vec::new();
    let last = settings.len().saturating_sub(1);
    kernel::select_lod(&cell, built.as_ref(), &input, |k, v, selection| {
        let (view, distance) = at[v];
        let mut row = Row::new(
            name.to_owned(),
            view,
            distance,
            method.name.to_owned(),
            settings[k].label(),
            "ok".into(),
        );
        row.n_points = ds.n_points as usize;
        match selection {
            Ok(s) => {
                let img = score(&mut row, &s, &references[v], &views[v].camera);
                let r = s.reads.unwrap_or_default();
                reads.push(FileRead {
                    dataset: name.to_owned(),
                    method: method.name.to_owned(),
                    view,
                    distance,
                    params: row.params.clone(),
                    points_rendered: row.points_rendered,
                    seconds: row.seconds,
                    bytes_read: r.bytes_read,
                    cache_bytes: r.cache_bytes,
                    selection_bytes: r.selection_bytes,
                    file_bytes,
                });
                if v == 0 && (k == 0 || k == settings.len() / 2 || k == last) {
                    let title = format!("{} {}: {} splats", ds.method, row.params, s.splats.len());
                    strip.push(panel(title, &img).crop(crop.0, crop.1, crop.2, crop.3));
                }
            }
            Err(e) => {
                eprintln!("lod: {name} {} {} view {view}: {e}", ds.method, row.params);
                row.status = format!("error: {e}");
            }
        }
        ds_rows.push((v, row));
    });
    ds_rows.sort_by_key(|(v, _)| *v);
    rows.extend(ds_rows.into_iter().map(|(_, r)| r));
    let label = format!("{} (from the file)", ds.method);
    write_strip(ctx, name, strip, &[label.as_str()])
}

/// The summary's section on selections from files: means over the views per dataset,
/// distance and setting.
pub(super) fn table(reads: &[FileRead]) -> String {
    let mib = |b: f64| format!("{:.2}", b / f64::from(1u32 << 20));
    let mut keys: Vec<(String, String, f64, String)> = Vec::new();
    for r in reads {
        let k = (
            r.dataset.clone(),
            r.method.clone(),
            r.distance,
            r.params.clone(),
        );
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let rows: Vec<Vec<String>> = keys
        .iter()
        .map(|(ds, m, d, p)| {
            let of: Vec<&FileRead> = reads
                .iter()
                .filter(|r| {
                    &r.dataset == ds && &r.method == m && r.distance == *d && &r.params == p
                })
                .collect();
            let n = of.len() as f64;
            let mean = |f: &dyn Fn(&FileRead) -> f64| of.iter().map(|r| f(r)).sum::<f64>() / n;
            vec![
                ds.clone(),
                m.clone(),
                format!("×{d}"),
                p.clone(),
                format!("{:.0}", mean(&|r| r.points_rendered as f64)),
                format!("{:.3}", mean(&|r| r.seconds) * 1e3),
                mib(mean(&|r| r.bytes_read as f64)),
                mib(mean(&|r| r.cache_bytes as f64)),
                mib(mean(&|r| r.selection_bytes as f64)),
                mib(of.first().map_or(0.0, |r| r.file_bytes as f64)),
            ]
        })
        .collect();
    format!(
        "\n### Selection from built files\n\nDatasets that are a built file (`lod_file`); their rows \
         in the Builds table are the file opened (header checked, first pages read), the build \
         having been `pointsight lod-build`'s. A QSplat \
         file: each view's selection reads the pages it needs through a cache of {} MiB (the \
         cache keeps pages from the views before it; the repeats are served from it). A \
         sequential point tree's: each cut reads the prefix of the list its view needs block \
         by block, then the splats it selected, and keeps no cache (0 MiB; the repeats read \
         again, from the operating system's page cache). The reference is the file's leaves, \
         streamed. A peer that selects from a file of its own (`copc-lod`: the COPC file it \
         built, its hierarchy held in memory, each selected node's chunk read per view) on an \
         in-memory dataset: what it says it read, no cache. Means over the views; `read` is what a view's first selection read; \
         `selection ms` is the median of the timed runs.\n\n{}",
        CACHE_BYTES >> 20,
        super::markdown_table(
            &[
                "dataset",
                "method",
                "distance",
                "setting",
                "points",
                "selection ms",
                "read MiB",
                "cache MiB",
                "selection MiB",
                "file MiB",
            ],
            &rows,
        )
    )
}
