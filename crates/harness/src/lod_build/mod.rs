//! `pointsight lod-build`: an LOD method's file built from a point file within a memory limit,
//! out of core when the cloud does not fit (`qsplat::ooc`, which starts from
//! `cloud::ooc::prepare`; `spt::ooc` fed by `cloud::ooc::prepare`), the same bytes as the
//! in-memory build when it does.
//!
//! The cloud is prepared by the `lod` experiment's rules: normals from the file (PLY, PCD, XYZ,
//! E57, or LAS and LAZ extra bytes; each a unit vector, else an error naming the file and the
//! point; then no normal is estimated and only the spacing sample is searched), or 16-nearest-
//! neighbour estimates oriented by Hoppe's spanning tree (`cloud::orient`) when it has none; the leaf radius
//! [`LEAF_RADIUS_SPACINGS`] density spacings (the `lod` experiment's `REF_RADIUS` is this)
//! (`cloud::spacing::density_spacing`, k = 8, 20,000 points, seed 1); the file's colours when
//! it has them (the experiment paints its own texture instead, which a file build cannot know).
//!
//! Input ([`input`]): LAS and LAZ are streamed chunk by chunk (`cloud::io::las::LasStream`), the
//! next batch decoded on a thread of its own while the preparation writes the current one
//! (`read_ahead`); PLY, E57 and the other formats are read whole first (their readers are not
//! streamed), so for those the memory limit covers the build but not the reading.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use cloud::glam::DVec3;
use cloud::ooc::{Normals, Point, Radius};

use crate::rss::peak_rss;

pub mod input;
mod read_ahead;

/// The density-spacing rule of the `lod` experiment.
pub const SPACING_K: usize = 8;
/// Points the spacing samples.
pub const SPACING_SAMPLE: usize = 20_000;
/// The spacing's seed.
pub const SPACING_SEED: u64 = 1;
/// Neighbours of an estimated normal.
pub const NORMALS_K: usize = 16;

/// The leaf radius in density spacings: the `lod` experiment's reference splat radius, defined
/// here so that the experiments (the scale experiment's out-of-core cells) can call this module
/// without it calling back.
pub const LEAF_RADIUS_SPACINGS: f64 = 1.5;

/// The LOD methods with an out-of-core build.
pub const OUT_OF_CORE: &[&str] = &["qsplat", "spt"];

/// What `lod-build` did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Built {
    /// Points.
    pub points: u64,
    /// Wall-clock seconds, reading included.
    pub seconds: f64,
    /// Peak resident set size of this process (`VmHWM`), bytes.
    pub peak_rss_bytes: u64,
    /// Chunks (1: built in memory).
    pub chunks: u64,
    /// Levels above the chunks (qsplat); nodes above the chunks (spt).
    pub top_levels: u32,
    /// What [`Built::top_levels`] counts: `top levels` (qsplat) or `top nodes` (spt).
    pub top_unit: &'static str,
    /// Largest halo, points.
    pub largest_halo: u64,
    /// The leaf radius.
    pub leaf_radius: f64,
    /// Bytes of the file written.
    pub file_bytes: u64,
    /// Bytes written to scratch files.
    pub scratch_bytes: u64,
    /// The most bytes the scratch files held at once.
    pub scratch_peak_bytes: u64,
    /// Wall-clock seconds of each stage, in the order they began ([`Stages`]' keys).
    pub stages: Vec<(&'static str, f64)>,
    /// Where the normals came from: the file's fields (`cloud::io::Loaded::normal_fields`), or
    /// `None` when they were estimated.
    pub given_normals: Option<String>,
    /// Points whose neighbours were searched (`cloud::ooc::Summary::neighbour_queries`): the
    /// normals' and the spacing sample's.
    pub neighbour_queries: u64,
}

/// The wall-clock time of a build's stages, as its progress reports them: a stage runs from
/// its first report to the next stage's (a key met again adds to its first entry).
#[derive(Debug)]
pub struct Stages {
    done: Vec<(&'static str, f64)>,
    current: (&'static str, Instant),
}

impl Stages {
    /// A clock whose first stage, `key`, begins now.
    pub fn start(key: &'static str) -> Self {
        Stages {
            done: Vec::new(),
            current: (key, Instant::now()),
        }
    }

    /// Stage `key` is running now (a new one begins when it differs from the current).
    pub fn at(&mut self, key: &'static str) {
        if key != self.current.0 {
            self.close();
            self.current = (key, Instant::now());
        }
    }

    fn close(&mut self) {
        let (key, since) = self.current;
        let seconds = since.elapsed().as_secs_f64();
        match self.done.iter_mut().find(|e| e.0 == key) {
            Some(e) => e.1 += seconds,
            None => self.done.push((key, seconds)),
        }
    }

    /// The stages' seconds, the current one ended now.
    pub fn finish(mut self) -> Vec<(&'static str, f64)> {
        self.close();
        self.done
    }
}

/// `stages` as `key:seconds` pairs joined by commas (`read:2.61,split:1.30`).
pub fn stages_text(stages: &[(&'static str, f64)]) -> String {
    stages
        .iter()
        .map(|(k, s)| format!("{k}:{s:.2}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Disk a `qsplat` out-of-core build cell of the scale experiment needs per point: the LAZ input takes 11.4 bytes per point
/// and the written file 6.8; the scratch files (positions as the LAZ grid's integers, no
/// colours where the file has none: 16-byte records, and 12 bytes of normal) held at most 29.0
/// bytes per point at once at 10^7 points (290 MB, 13 chunks) and 28.3 at 10^8 (2,831 MB, 154
/// chunks; `Scratch::peak_bytes`; 28.2 at 10^9), of 56.5 and 72.6 written in all (the split's
/// subsets): 47 in all, and a quarter more for margin.
pub const OOC_DISK_PER_POINT: u64 = 59;

/// Disk an `spt` out-of-core build cell of the scale experiment needs per point: the LAZ (11.4),
/// then the scratch, the preparation's and SPT's together, at most 67.7 bytes per point at once
/// at 10^7 and 10^8 (98 before SPT read the prepared chunks where they lie instead of copying
/// them), and while the file (62.3, format version 3) is merged, the sorted runs (about 68):
/// about 142, and a sixth more for margin (235 before the version 3 file, whose splats and runs
/// are smaller).
pub const SPT_OOC_DISK_PER_POINT: u64 = 165;

/// Disk the out-of-core build of `method` (one of [`OUT_OF_CORE`]) needs per point, its LAZ
/// input and the file it writes included.
pub fn disk_per_point(method: &str) -> u64 {
    if method == "spt" {
        SPT_OOC_DISK_PER_POINT
    } else {
        OOC_DISK_PER_POINT
    }
}

/// A size: a number of bytes, optionally with a unit (`B`, `KiB`, `MiB`, `GiB`, `TiB`; `K`,
/// `M`, `G`, `T` and `KB`, `MB`, `GB`, `TB` are read as the binary units too).
pub fn parse_size(text: &str) -> Result<u64> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .parse()
        .with_context(|| format!("size {text:?}: expected a number with a unit like 512MiB"))?;
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        other => bail!("size {text:?}: unknown unit {other:?} (B, KiB, MiB, GiB, TiB)"),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || !(1.0..=1e18).contains(&bytes) {
        bail!("size {text:?} is out of range");
    }
    Ok(bytes as u64)
}

/// Bytes per point read at once from a LAS or LAZ file beside the stream's own
/// (`LasStream::bytes_per_point`): the decoded positions, colours and normals, and two batches
/// (the one being prepared and the one read ahead, `read_ahead`).
const READ_BYTES_PER_POINT: u64 = 27 + 12 + 2 * size_of::<Point>() as u64;

/// Points read at once under `memory_limit` from a stream of `stream_bytes_per_point`: an
/// eighth of the limit (the reading buffers are gone before the first chunk is loaded), at
/// most [`cloud::io::las::CHUNK`].
fn read_chunk(memory_limit: u64, stream_bytes_per_point: u64) -> u64 {
    (memory_limit / 8 / (READ_BYTES_PER_POINT + stream_bytes_per_point))
        .clamp(1 << 14, cloud::io::las::CHUNK)
}

/// The options of the `lod` experiment's preparation for a cloud with or without normals,
/// under `memory_limit`, in chunks of `bytes_per_point` (the method's), its scratch records
/// keeping what `records` says.
pub fn prepare_options(
    memory_limit: u64,
    has_normals: bool,
    bytes_per_point: u64,
    records: cloud::ooc::Records,
) -> cloud::ooc::Options {
    cloud::ooc::Options {
        memory_limit,
        bytes_per_point,
        records,
        normals: if has_normals {
            Normals::Given
        } else {
            Normals::Estimate { k: NORMALS_K }
        },
        radius: Radius::DensitySpacing {
            k: SPACING_K,
            sample: SPACING_SAMPLE,
            seed: SPACING_SEED,
            factor: LEAF_RADIUS_SPACINGS,
        },
        fail_after_bytes: None,
    }
}

/// QSplat's build options from the preparation's, with or without colours.
fn qsplat_options(prepare: &cloud::ooc::Options, colors: bool) -> qsplat::ooc::Options {
    qsplat::ooc::Options {
        memory_limit: prepare.memory_limit,
        colors,
        normals: prepare.normals,
        radius: prepare.radius,
        grid: prepare.records.grid,
        fail_after_bytes: prepare.fail_after_bytes,
    }
}

/// The key and the progress bar's words of a stage of the preparation.
fn prepare_stage(stage: cloud::ooc::Stage) -> (&'static str, &'static str) {
    match stage {
        cloud::ooc::Stage::Read => ("read", "reading"),
        cloud::ooc::Stage::Split => ("split", "splitting into chunks"),
        cloud::ooc::Stage::Guide => ("guide", "orienting the normals' guide"),
        cloud::ooc::Stage::Neighbours => ("normals", "normals and spacing within chunks"),
        cloud::ooc::Stage::Halos => ("halos", "normals and spacing across chunk borders"),
    }
}

/// Builds `method`'s file of the cloud in `cloud_path` into `out` within `memory_limit`
/// bytes (`progress`: a bar on a terminal). The public entry a scale cell calls.
///
/// `spt`: the points are prepared by `cloud::ooc::prepare` (the same normals and leaf radius
/// as the QSplat build, out of core) and piped into `spt::ooc` (leaf diameter twice the
/// radius, as the `lod` experiment gives SPT), one stage after the other under the same limit.
pub fn build(
    cloud_path: &Path,
    method: &str,
    memory_limit: u64,
    out: &Path,
    progress: bool,
) -> Result<Built> {
    naming(
        cloud_path,
        build_unnamed(cloud_path, method, memory_limit, out, progress),
    )
}

/// `result`, its error prefixed with the cloud file when it does not name it already (a
/// cloud without a surface, a method refusing it).
fn naming<T>(cloud_path: &Path, result: Result<T>) -> Result<T> {
    result.map_err(|e| {
        let name = cloud_path.display().to_string();
        if format!("{e:#}").contains(&name) {
            e
        } else {
            e.context(name)
        }
    })
}

fn build_unnamed(
    cloud_path: &Path,
    method: &str,
    memory_limit: u64,
    out: &Path,
    progress: bool,
) -> Result<Built> {
    if !OUT_OF_CORE.contains(&method) {
        bail!(
            "lod-build: method {method:?} has no out-of-core build (these have: {OUT_OF_CORE:?})"
        );
    }
    let start = Instant::now();
    let bar = progress.then(|| crate::progress::bar(0, "reading"));
    let clock = std::cell::RefCell::new(Stages::start("read"));
    let set = |(key, msg): (&'static str, &'static str), count: u64| {
        clock.borrow_mut().at(key);
        if let Some(b) = &bar {
            if b.message() != msg {
                b.set_message(msg);
            }
            b.set_position(count);
        }
    };
    // LAS and LAZ are decoded on a thread of their own, a batch ahead of the preparation.
    let built = std::thread::scope(|scope| -> Result<Built> {
        let (mut input, info) = input::Input::open(scope, cloud_path, memory_limit)?;
        if let Some(b) = &bar {
            b.set_length(info.points);
        }
        let (has_normals, colors) = (info.normals.is_some(), info.colors);
        let records = cloud::ooc::Records {
            grid: info.grid,
            colors,
        };
        let mut source =
            |batch: &mut Vec<Point>| -> Result<bool, cloud::lod_file::Error> { input.next(batch) };
        let built = if method == "spt" {
            let opts = prepare_options(
                memory_limit,
                has_normals,
                spt::ooc::PREPARE_BYTES_PER_POINT,
                records,
            );
            let (prepared, summary) = cloud::ooc::prepare(&mut source, &opts, out, &mut |s, n| {
                set(prepare_stage(s), n)
            })?;
            // A whole cloud's preparation left no scratch files: its numbers add to the build's;
            // a chunked one's count with the build's own (`spt::ooc::build_prepared`).
            let (prepared_bytes, prepared_peak) = match &prepared {
                cloud::ooc::Prepared::Whole(_) => {
                    (summary.scratch_bytes, summary.scratch_peak_bytes)
                }
                cloud::ooc::Prepared::Chunked(_) => (0, 0),
            };
            let built = spt::ooc::build_prepared(
                prepared,
                &spt::ooc::Options {
                    memory_limit,
                    colors,
                    fail_after_bytes: None,
                },
                out,
                2.0 * summary.leaf_radius,
                &mut |stage: spt::ooc::Stage, count: u64| {
                    set(
                        match stage {
                            spt::ooc::Stage::Count => ("count", "counting octree cells"),
                            spt::ooc::Stage::Distribute => ("distribute", "distributing to chunks"),
                            spt::ooc::Stage::Build => ("build", "building chunks"),
                            spt::ooc::Stage::Merge => ("merge", "merging the sorted list"),
                        },
                        count,
                    );
                },
            )?;
            Built {
                points: built.points,
                seconds: 0.0,
                peak_rss_bytes: 0,
                chunks: built.chunks,
                top_levels: built.top_nodes as u32,
                top_unit: "top nodes",
                largest_halo: summary.largest_halo,
                leaf_radius: summary.leaf_radius,
                file_bytes: 0,
                scratch_bytes: built.scratch_bytes + prepared_bytes,
                scratch_peak_bytes: built.scratch_peak_bytes.max(prepared_peak),
                stages: Vec::new(),
                given_normals: info.normals.clone(),
                neighbour_queries: summary.neighbour_queries,
            }
        } else {
            let opts = qsplat_options(
                &prepare_options(
                    memory_limit,
                    has_normals,
                    qsplat::ooc::BYTES_PER_POINT,
                    records,
                ),
                colors,
            );
            let summary = qsplat::ooc::build_file(&mut source, &opts, out, &mut |stage, count| {
                set(
                    match stage {
                        qsplat::ooc::Stage::Prepare(s) => prepare_stage(s),
                        qsplat::ooc::Stage::Build => ("roots", "building chunk roots"),
                        qsplat::ooc::Stage::Encode => ("encode", "encoding chunks"),
                        qsplat::ooc::Stage::Write => ("write", "writing levels"),
                    },
                    count,
                )
            })?;
            Built {
                points: summary.points,
                seconds: 0.0,
                peak_rss_bytes: 0,
                chunks: summary.chunks,
                top_levels: summary.top_levels,
                top_unit: "top levels",
                largest_halo: summary.largest_halo,
                leaf_radius: summary.leaf_radius,
                file_bytes: 0,
                scratch_bytes: summary.scratch_bytes,
                scratch_peak_bytes: summary.scratch_peak_bytes,
                stages: Vec::new(),
                given_normals: info.normals.clone(),
                neighbour_queries: summary.neighbour_queries,
            }
        };
        Ok(built)
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let stages = clock.into_inner().finish();
    Ok(Built {
        stages,
        seconds: start.elapsed().as_secs_f64(),
        peak_rss_bytes: peak_rss(),
        file_bytes: std::fs::metadata(out).map_or(0, |m| m.len()),
        ..built
    })
}

/// The in-memory build of the same file (the whole cloud read, then
/// `qsplat::ooc::in_memory`, or `cloud::ooc::prepare_in_memory` and `spt::ooc::in_memory`): the reference the out-of-core build equals, and the baseline
/// of its rate and memory.
pub fn build_in_memory(cloud_path: &Path, method: &str, out: &Path) -> Result<Built> {
    naming(cloud_path, build_in_memory_unnamed(cloud_path, method, out))
}

fn build_in_memory_unnamed(cloud_path: &Path, method: &str, out: &Path) -> Result<Built> {
    if !OUT_OF_CORE.contains(&method) {
        bail!("lod-build: method {method:?} has no file (these have: {OUT_OF_CORE:?})");
    }
    let start = Instant::now();
    let mut clock = Stages::start("read");
    let loaded = cloud::io::read_with(cloud_path, &cloud::io::ReadOptions::default())?;
    clock.at("build");
    let given_normals = loaded.normal_fields;
    let c = loaded.cloud;
    let n = c.len() as u64;
    let positions: Vec<DVec3> = c.positions;
    let prepare = prepare_options(
        u64::MAX,
        c.normals.is_some(),
        if method == "spt" {
            spt::ooc::PREPARE_BYTES_PER_POINT
        } else {
            qsplat::ooc::BYTES_PER_POINT
        },
        cloud::ooc::Records::default(),
    );
    let neighbour_queries = cloud::ooc::in_memory_queries(n, &prepare);
    let radius = if method == "spt" {
        let (normals, radius) = cloud::ooc::prepare_in_memory(&positions, c.normals, &prepare)?;
        let spt = spt::ooc::in_memory(positions, normals, c.colors, 2.0 * radius)?;
        spt::file::write(&spt, out)?;
        radius
    } else {
        let opts = qsplat_options(&prepare, c.colors.is_some());
        let (tree, radius) = qsplat::ooc::in_memory(positions, c.normals, c.colors, &opts)?;
        qsplat::file::write(&tree, out)?;
        radius
    };
    Ok(Built {
        points: n,
        seconds: start.elapsed().as_secs_f64(),
        peak_rss_bytes: peak_rss(),
        chunks: 1,
        top_levels: 0,
        top_unit: if method == "spt" {
            "top nodes"
        } else {
            "top levels"
        },
        largest_halo: 0,
        leaf_radius: radius,
        file_bytes: std::fs::metadata(out).map_or(0, |m| m.len()),
        scratch_bytes: 0,
        scratch_peak_bytes: 0,
        stages: clock.finish(),
        given_normals,
        neighbour_queries,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_size("4GiB").unwrap(), 4 << 30);
        assert_eq!(parse_size("1.5G").unwrap(), 3 << 29);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert!(parse_size("12 parsecs").is_err());
        assert!(parse_size("MiB").is_err());
        assert!(parse_size("0").is_err());
    }
}
