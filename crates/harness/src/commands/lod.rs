//! `pointsight lod-build`: an LOD file built within a memory limit (out of core) or in
//! memory, and the one line of what it took.

use std::path::Path;

use anyhow::Result;

use crate::lod_build;

/// `pointsight lod-build`: builds `out` from `cloud` with `method`, in memory or within
/// `memory_limit` (a size such as `1GiB`); prints one `key=value` line.
pub fn lod_build(
    cloud: &Path,
    method: &str,
    memory_limit: &str,
    out: &Path,
    in_memory: bool,
) -> Result<()> {
    let built = if in_memory {
        lod_build::build_in_memory(cloud, method, out)?
    } else {
        let limit = lod_build::parse_size(memory_limit)?;
        let tty = crate::progress::enabled();
        lod_build::build(cloud, method, limit, out, tty)?
    };
    println!(
        "points={} seconds={:.3} points_per_second={:.0} peak_rss_bytes={} chunks={} \
         top_levels={} leaf_radius={:e} file_bytes={} scratch_bytes={} \
         scratch_peak_bytes={} normals={} neighbour_queries={} stage_seconds={}",
        built.points,
        built.seconds,
        built.points as f64 / built.seconds.max(1e-9),
        built.peak_rss_bytes,
        built.chunks,
        built.top_levels,
        built.leaf_radius,
        built.file_bytes,
        built.scratch_bytes,
        built.scratch_peak_bytes,
        if built.given_normals.is_some() {
            "given"
        } else {
            "estimated"
        },
        built.neighbour_queries,
        lod_build::stages_text(&built.stages)
    );
    Ok(())
}
