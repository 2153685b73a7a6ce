//! The scale experiment's peer build: copc_converter (crates.io, the `copc-lod` peer's
//! converter, `methods/copc-lod`) on the same LAZ input as our out-of-core builds
//! (`NAME-build-ooc`), with the same thread count (rayon's: `RAYON_NUM_THREADS`, else every
//! core) and the same memory limit (`plan::OOC_LIMIT`, given by the cell, as `--memory-limit`; copc_converter budgets
//! 75 % of it). Its wall time is the cell's seconds; its peak memory is the largest child's
//! (`getrusage(RUSAGE_CHILDREN)`, which the cell's peak adds to its own); its scratch folder is
//! measured every [`SCRATCH_POLL`] for the most it held at once.
//!
//! The converter is found as `just peers` installs it: `COPC_CONVERTER` when set, else
//! `.tools/bin/copc_converter` in the clone around the working directory
//! (`paths::working_clone`), else on `PATH`; a cell without it is a row saying so.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};

use super::row::CellOutput;
use crate::rss::peak_rss_with_children;

/// The cell's method name (`copc_converter-build-ooc`, beside `qsplat-build-ooc`).
pub const COPC_CONVERTER: &str = "copc_converter";

/// How often the scratch folder's size is read.
pub const SCRATCH_POLL: Duration = Duration::from_millis(200);

/// The converter's path, or why there is none (run `--version` to check it starts).
pub fn converter() -> std::result::Result<PathBuf, String> {
    let candidates: Vec<PathBuf> = match std::env::var_os("COPC_CONVERTER") {
        Some(p) => vec![PathBuf::from(p)],
        None => crate::paths::working_clone()
            .map(|clone| clone.join(".tools/bin/copc_converter"))
            .into_iter()
            .chain([PathBuf::from("copc_converter")])
            .collect(),
    };
    for p in &candidates {
        let ok = Command::new(p)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Ok(p.clone());
        }
    }
    Err(format!(
        "copc_converter is not installed ({}; run `just peers`)",
        candidates
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// Bytes of the files under `dir` (0 where it cannot be read: it may be changing).
fn dir_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => dir_bytes(&e.path()),
            Ok(_) => e.metadata().map_or(0, |m| m.len()),
            Err(_) => 0,
        })
        .sum()
}

/// Builds the COPC file of `input` (`n` points) in `dir` with copc_converter, timed; the
/// cell's output (`prepare_seconds` from the cell).
pub fn build_cell(
    input: &Path,
    dir: &Path,
    n: u64,
    prepare_seconds: f64,
    memory_limit: u64,
) -> Result<CellOutput> {
    let program = converter().map_err(anyhow::Error::msg)?;
    let out = dir.join("cloud.copc.laz");
    let tmp = dir.join("scratch");
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let threads = rayon::current_num_threads();
    let log = dir.join("copc_converter.log");
    let log_file =
        std::fs::File::create(&log).with_context(|| format!("creating {}", log.display()))?;
    let done = AtomicBool::new(false);
    let peak_scratch = AtomicU64::new(0);
    let start = Instant::now();
    let status = std::thread::scope(|s| {
        s.spawn(|| {
            while !done.load(Ordering::Relaxed) {
                peak_scratch.fetch_max(dir_bytes(&tmp), Ordering::Relaxed);
                std::thread::sleep(SCRATCH_POLL);
            }
        });
        let status = Command::new(&program)
            .arg(input)
            .arg(&out)
            .arg("--memory-limit")
            .arg(format!("{}Mi", memory_limit >> 20))
            .arg("--threads")
            .arg(threads.to_string())
            .arg("--temp-dir")
            .arg(&tmp)
            .args(["--progress", "plain"])
            .stdin(Stdio::null())
            .stdout(Stdio::from(log_file))
            .stderr(Stdio::inherit())
            .status();
        done.store(true, Ordering::Relaxed);
        status
    })
    .with_context(|| format!("starting {}", program.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    if !status.success() {
        let tail = std::fs::read_to_string(&log).unwrap_or_default();
        let tail: String = tail.lines().rev().take(5).collect::<Vec<_>>().join(" | ");
        bail!("{} exited with {status}: {tail}", program.display());
    }
    let mib = |b: u64| b as f64 / 1048576.0;
    // ru_maxrss of the children waited for: the converter alone (this process waited for no
    // other).
    let converter_peak =
        nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
            .map_or(0, |u| u64::try_from(u.max_rss()).unwrap_or(0) * 1024);
    let input_bytes = std::fs::metadata(input).map_or(0, |m| m.len());
    let file_bytes = std::fs::metadata(&out).map_or(0, |m| m.len());
    Ok(CellOutput {
        seconds,
        peak_rss_bytes: peak_rss_with_children(),
        prepare_seconds,
        detail: format!(
            "copc_converter --threads {threads} --memory-limit {} MiB: peak {:.0} MiB (the \
             converter's own), {:.2} M points/s, LAZ {:.0} MiB, scratch {:.0} MiB at most \
             (read every {} ms), COPC file {:.0} MiB; no selection from the file here (the \
             lod experiment's copc-lod selects from its own)",
            memory_limit >> 20,
            mib(converter_peak),
            n as f64 / seconds / 1e6,
            mib(input_bytes),
            mib(peak_scratch.load(Ordering::Relaxed)),
            SCRATCH_POLL.as_millis(),
            mib(file_bytes),
        ),
        accuracy: Default::default(),
        build_seconds: f64::NAN,
    })
}
