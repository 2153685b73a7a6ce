//! A scale cell's body, run inside its own process: the cloud sampled from the mesh, then the
//! timed operation (a visibility method through the kernel, a hull on HPR's flipped set, an
//! LOD build or selection through the kernel's LOD form, or an out-of-core build from a LAZ
//! file the cell writes, [`ooc_cell`]), and the process's peak memory.

use crate::run::Run;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use registry::{Setting, kernel};

use super::plan::{OOC_LIMIT, OOC_SUFFIX, SEED, repeats};
use super::row::CellOutput;
use crate::rss::peak_rss_with_children;

/// The folder an out-of-core cell writes its input, scratch and output in (removed after the
/// cell by the process that started it, also when a cap stopped it).
pub fn ooc_dir(data_dir: &Path, method: &str, n: u64) -> PathBuf {
    data_dir.join(".scale-ooc").join(format!("{method}-{n}"))
}

/// Runs one cell in this process: samples `n` points of the dataset's mesh, calls
/// `on_prepared` with the seconds the input took (sampling, and a hull cell's flip or an LOD
/// cell's normals), runs `method` at `setting`, returns its seconds and this process's peak RSS.
pub fn cell(
    run: &Run,
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    on_prepared: impl Fn(f64),
) -> Result<CellOutput> {
    let started = Instant::now();
    // Each branch below calls it once its input is ready.
    let ready = |on_prepared: &dyn Fn(f64)| {
        let seconds = started.elapsed().as_secs_f64();
        on_prepared(seconds);
        seconds
    };
    // The mesh alone (not the dataset's own cloud: it would count in the peak).
    let (mesh, _) = run.datasets.load_mesh_of(dataset, data_dir)?;
    let bbox = mesh.bbox().context("the mesh has no vertices")?;
    let cam = cloud::views::fibonacci_views(&bbox, &cloud::ViewSpec::default())?[0];
    if let Some(m) = method.strip_suffix(OOC_SUFFIX) {
        let view = kernel::View {
            index: 0,
            camera: cam,
        };
        return ooc_cell(run, m, &mesh, &bbox, n, data_dir, (setting, &view), || {
            ready(&on_prepared)
        });
    }
    if let Some(kind) = super::normals::Kind::named(method) {
        // The mesh's normals (each sample's triangle's) are the reference.
        let mut cloud = cloud::sample::sample_surface(&mesh, usize::try_from(n)?, SEED)?;
        cloud.samples = None;
        let dir = super::normals::cell_dir(method, n, std::os::unix::process::parent_id());
        let python = super::normals::python();
        return super::normals::cell(kind, &cloud, &dir, &python, || ready(&on_prepared));
    }
    let n = usize::try_from(n)?;
    cloud::memory::ensure(
        48 * n as u128,
        &format!("{n} sampled points with their surface samples"),
    )?;
    let mut cloud = cloud::sample::sample_surface(&mesh, n, SEED)?;
    cloud.samples = None;
    let repeats = repeats(n as u64);
    let views = [kernel::View {
        index: 0,
        camera: cam,
    }];
    let prepare_seconds;
    let mut build_seconds = f64::NAN;
    let seconds = if let Some(h) = method.strip_prefix("hull-") {
        let hull = hull::by_name(h)?;
        let mut flipped = hpr::transform::transform(
            &cloud.positions,
            cam.eye,
            hpr::Kernel::Linear(hpr::Radius::Gamma(4.0)),
        )?
        .points;
        flipped.push(cam.eye.to_array());
        prepare_seconds = ready(&on_prepared);
        let (_, t) = registry::timing::measure(repeats, || hull.vertices(&flipped))?;
        t.median
    } else if let Some(m) = run.catalogue.card_named(method).filter(|m| !m.is_lod()) {
        prepare_seconds = ready(&on_prepared);
        let input = registry::Input {
            cloud: &cloud,
            mesh: Some(&mesh),
        };
        let (prepared, answers) =
            kernel::collect(&kernel::Cell::new(m, setting, &views, repeats), input);
        // A protocol 3 program ended and reaped now, so that its memory is in the peak.
        run.catalogue.end_programs();
        let prepared = prepared?;
        build_seconds = prepared.reported_seconds.unwrap_or(prepared.seconds);
        match answers.into_iter().next() {
            Some((_, Ok(a))) => a.timing.median,
            Some((_, Err(e))) => bail!(e),
            None => bail!("the kernel answered no view"),
        }
    } else if let Some((m, build)) = lod_cell(&run.catalogue, method) {
        let data = crate::experiments::lod::lod_data(cloud)?;
        prepare_seconds = ready(&on_prepared);
        let settings = [setting.clone()];
        let cell = kernel::LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: if build { 1 } else { repeats },
            build_repeats: if build { repeats } else { 1 },
        };
        let mut selection = None;
        let built = kernel::run_lod(&cell, &data.input(), |_, _, s| {
            selection = Some(s.map(|s| s.timing.median).map_err(|e| e.to_string()));
        })?;
        if build {
            built.timing.median
        } else {
            selection
                .context("the kernel made no selection")?
                .map_err(anyhow::Error::msg)?
        }
    } else {
        bail!("unknown scale cell {method:?}")
    };
    Ok(CellOutput {
        seconds,
        peak_rss_bytes: peak_rss_with_children(),
        prepare_seconds,
        detail: String::new(),
        accuracy: Default::default(),
        build_seconds,
    })
}

/// An out-of-core build cell: writes `n` points sampled from `mesh` (seed [`SEED`], the
/// points the other cells hold) as LAZ without holding them, calls `ready` (the preparation
/// ends there), then builds `method`'s file from it with `pointsight lod-build`'s code within
/// [`OOC_LIMIT`]. One run: the build reads and decodes the file, which is the operation.
/// Then the built file is selected from without loading it (`registry::lod_file`, a cache of
/// [`crate::experiments::lod::FILE_CACHE_BYTES`]) at `select`'s setting and view, through the kernel,
/// [`repeats`] timed runs: its time, splats and reads go in the detail, beside the in-memory
/// `NAME-select` cell's.
#[allow(clippy::too_many_arguments)]
fn ooc_cell(
    run: &Run,
    method: &str,
    mesh: &cloud::TriMesh,
    bbox: &cloud::Aabb,
    n: u64,
    data_dir: &Path,
    select: (&Setting, &kernel::View),
    ready: impl FnOnce() -> f64,
) -> Result<CellOutput> {
    let dir = ooc_dir(data_dir, &format!("{method}{OOC_SUFFIX}"), n);
    let (method, given) = super::plan::ooc_method(method);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    // The work in a closure, so that the folder goes whatever it returns.
    let outcome = (|| -> Result<CellOutput> {
        let input = dir.join("input.laz");
        let mut sampler = cloud::sample::SurfaceSampler::new(mesh, SEED)?;
        // A sample's weights sum to 1 only up to rounding: pad the box by a few ulps of its size.
        let pad = cloud::glam::DVec3::splat((bbox.max - bbox.min).max_element() * 1e-9 + 1e-12);
        let mut left = n;
        cloud::io::las::write_las_streamed(
            &input,
            bbox.min - pad,
            bbox.max + pad,
            given,
            |batch| {
                let k = left.min(1 << 16);
                if given {
                    // The same draws, each with its triangle's normal.
                    for _ in 0..k {
                        let s = sampler.draw();
                        batch
                            .positions
                            .push(cloud::sample::sample_position(mesh, &s));
                        batch
                            .normals
                            .push(mesh.face_normal(s.triangle as usize).as_vec3());
                    }
                } else {
                    sampler.positions_into(k as usize, &mut batch.positions);
                }
                left -= k;
                left > 0
            },
        )?;
        let prepare_seconds = ready();
        if method == super::copc::COPC_CONVERTER {
            return super::copc::build_cell(&input, &dir, n, prepare_seconds, OOC_LIMIT);
        }
        let out = dir.join(format!("{method}.lod"));
        let built = crate::lod_build::build(&input, method, OOC_LIMIT, &out, false)?;
        if given && built.given_normals.is_none() {
            bail!(
                "the build of {} did not read the normals it was given",
                input.display()
            );
        }
        let input_bytes = std::fs::metadata(&input).map_or(0, |m| m.len());
        let mib = |b: u64| b as f64 / 1048576.0;
        let (setting, view) = select;
        let file = registry::lod_file::open_file(&out, crate::experiments::lod::FILE_CACHE_BYTES)?;
        let m = run.catalogue.card(method)?;
        let settings = [setting.clone()];
        let views = [*view];
        let cell = kernel::LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: repeats(n),
            build_repeats: 1,
        };
        let data = registry::lod::LodData::none(SEED);
        let mut selection = None;
        kernel::select_lod(&cell, file.as_ref(), &data.input(), |_, _, s| {
            selection = Some(s.map_err(|e| anyhow::anyhow!("selection from the file: {e}")));
        });
        let s = selection.context("the kernel made no selection")??;
        let reads = s.reads.unwrap_or_default();
        Ok(CellOutput {
            seconds: built.seconds,
            peak_rss_bytes: peak_rss_with_children(),
            prepare_seconds,
            detail: format!(
                "normals {} ({} neighbour queries), limit {:.0} MiB, peak {:.0} MiB, {:.2} M points/s, {} chunks, {} {}, \
                 LAZ {:.0} MiB, scratch {:.0} MiB written, {:.0} MiB at most, file {:.0} MiB, \
                 stage seconds {}; selection from the file \
                 ({}, view 0): {:.3} ms median of {}, {} splats, read {:.1} MiB, cache {:.1} \
                 MiB, peak after {:.0} MiB",
                built
                    .given_normals
                    .as_deref()
                    .map_or("estimated".to_owned(), |f| format!("given: {f}")),
                built.neighbour_queries,
                mib(OOC_LIMIT),
                mib(built.peak_rss_bytes),
                built.points as f64 / built.seconds / 1e6,
                built.chunks,
                built.top_levels,
                built.top_unit,
                mib(input_bytes),
                mib(built.scratch_bytes),
                mib(built.scratch_peak_bytes),
                mib(built.file_bytes),
                crate::lod_build::stages_text(&built.stages),
                setting.label(),
                s.timing.median * 1e3,
                s.timing.samples,
                s.splats.len(),
                mib(reads.bytes_read),
                mib(reads.cache_bytes),
                mib(peak_rss_with_children()),
            ),
            accuracy: Default::default(),
            build_seconds: f64::NAN,
        })
    })();
    let _ = std::fs::remove_dir_all(&dir);
    outcome
}

/// The LOD method of a `NAME-build` or `NAME-select` cell, and whether it is the build.
fn lod_cell(
    catalogue: &registry::Catalogue,
    name: &str,
) -> Option<(&'static registry::Card, bool)> {
    let (m, build) = name
        .strip_suffix("-build")
        .map(|m| (m, true))
        .or_else(|| name.strip_suffix("-select").map(|m| (m, false)))?;
    Some((catalogue.card_named(m).filter(|m| m.is_lod())?, build))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_visibility_cell_reports_its_per_cloud_build_apart_from_its_view() {
        let dir = tempfile::tempdir().unwrap();
        let run = |method: &str| {
            cell(
                &Run::builtin(),
                "torus-22321",
                method,
                &Setting::default(),
                3_000,
                dir.path(),
                |_| {},
            )
            .unwrap()
        };
        // The caster's hierarchy and the learned method's feature pass are built once per
        // cloud: their seconds are the row's build, beside one view's answer.
        for method in ["raycast", "neuralvis"] {
            let out = run(method);
            assert!(out.seconds > 0.0, "{method}: {}", out.seconds);
            assert!(
                out.build_seconds.is_finite() && out.build_seconds > 0.0,
                "{method}: {}",
                out.build_seconds
            );
        }
        let hull = run("hull-own");
        assert!(hull.seconds > 0.0 && hull.build_seconds.is_nan());
    }

    #[test]
    fn a_warm_programs_memory_is_in_the_cells_peak() {
        // A protocol 3 program that holds 700 MB while it answers: the cell ends it before
        // reading the peak, which counts the children it waited for.
        let methods = tempfile::tempdir().unwrap();
        let folder = methods.path().join("holds-700mb");
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(
            folder.join("method.toml"),
            "protocol = 3\ncommand = [\"python3\", \"m.py\"]\nnormals = false\n",
        )
        .unwrap();
        std::fs::write(
            folder.join("m.py"),
            "import sys, json\nheld = b'\\x01' * (700 << 20)\nfor line in sys.stdin:\n    \
             r = json.loads(line)\n    \
             print(json.dumps({'id': r['id'], 'visible': [0], 'seconds': 0.0}), flush=True)\n",
        )
        .unwrap();
        let mut run = Run::builtin();
        run.add_methods(methods.path(), "the test's").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = cell(
            &run,
            "torus-22321",
            "holds-700mb",
            &Setting::default(),
            3_000,
            dir.path(),
            |_| {},
        )
        .unwrap();
        assert!(out.peak_rss_bytes >= 700 << 20, "{out:?}");
    }

    #[test]
    fn an_out_of_core_cell_builds_from_its_own_laz_and_leaves_nothing() {
        let mesh = cloud::synth::icosphere(3);
        let bbox = mesh.bbox().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let view = kernel::View {
            index: 0,
            camera: cloud::views::fibonacci_views(&bbox, &cloud::ViewSpec::default()).unwrap()[0],
        };
        let setting = Setting::parse("threshold_px=2");
        let out = ooc_cell(
            &Run::builtin(),
            "qsplat",
            &mesh,
            &bbox,
            5_000,
            dir.path(),
            (&setting, &view),
            || 0.5,
        )
        .unwrap();
        assert!(out.seconds > 0.0 && out.prepare_seconds == 0.5);
        assert!(
            out.detail.contains("1 chunks") && out.detail.contains("limit 1024 MiB"),
            "{}",
            out.detail
        );
        // The built file was selected from.
        let splats: u64 = out
            .detail
            .split("ms median of ")
            .nth(1)
            .and_then(|t| t.split(", ").nth(1))
            .and_then(|t| t.strip_suffix(" splats"))
            .and_then(|t| t.parse().ok())
            .unwrap_or(0);
        assert!(splats > 0 && splats <= 5_000, "{}", out.detail);
        assert!(!ooc_dir(dir.path(), "qsplat-build-ooc", 5_000).exists());
        assert!(
            out.detail.starts_with("normals estimated"),
            "{}",
            out.detail
        );
        // The same points with their triangles' normals in the LAZ: the build reads them and
        // estimates none (its neighbour queries are the spacing sample's alone).
        let given = ooc_cell(
            &Run::builtin(),
            "qsplat-given",
            &mesh,
            &bbox,
            5_000,
            dir.path(),
            (&setting, &view),
            || 0.5,
        )
        .unwrap();
        assert!(
            given.detail.starts_with("normals given: "),
            "{}",
            given.detail
        );
        let queries = |d: &str| -> u64 {
            d.split_once(" neighbour queries")
                .and_then(|(a, _)| a.rsplit_once('(')?.1.parse().ok())
                .unwrap()
        };
        assert!(
            queries(&given.detail) < queries(&out.detail),
            "{} | {}",
            given.detail,
            out.detail
        );
        assert!(!ooc_dir(dir.path(), "qsplat-given-build-ooc", 5_000).exists());
        assert!(
            ooc_cell(
                &Run::builtin(),
                "spt",
                &mesh,
                &bbox,
                100,
                dir.path(),
                (&setting, &view),
                || 0.0
            )
            .is_err()
        );
        assert!(!ooc_dir(dir.path(), "spt-build-ooc", 100).exists());
    }

    #[test]
    fn copc_converter_builds_from_the_same_laz_and_leaves_nothing() {
        if let Err(why) = super::super::copc::converter() {
            // The peer's tool: `just peers` installs it, and CI runs that first.
            assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
            eprintln!("skipped: {why}");
            return;
        }
        let mesh = cloud::synth::icosphere(3);
        let bbox = mesh.bbox().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let view = kernel::View {
            index: 0,
            camera: cloud::views::fibonacci_views(&bbox, &cloud::ViewSpec::default()).unwrap()[0],
        };
        let out = ooc_cell(
            &Run::builtin(),
            "copc_converter",
            &mesh,
            &bbox,
            20_000,
            dir.path(),
            (&Setting::default(), &view),
            || 0.25,
        )
        .unwrap();
        assert!(out.seconds > 0.0 && out.prepare_seconds == 0.25);
        assert!(
            out.detail.contains("--memory-limit 1024 MiB") && out.detail.contains("COPC file"),
            "{}",
            out.detail
        );
        // The converter's peak is counted in the cell's.
        assert!(out.peak_rss_bytes > crate::rss::peak_rss(), "{out:?}");
        assert!(!ooc_dir(dir.path(), "copc_converter-build-ooc", 20_000).exists());
    }
}
