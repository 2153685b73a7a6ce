//! The memory guard: every allocation sized by user input (image resolutions, counts) is
//! estimated first and refused, with the estimate and the memory available, before anything
//! is allocated, instead of aborting the process.
//!
//! Available memory is the least of what the system and the process's own limits leave (Linux):
//! - free memory, `MemAvailable` of `/proc/meminfo`;
//! - the address-space limit (`RLIMIT_AS`, `ulimit -v`, `prlimit --as`) less the process's
//!   virtual size (`VmSize`): an allocation beyond it fails however much memory is free;
//! - the data-segment limit (`RLIMIT_DATA`) less the process's data (`VmData`);
//! - its control group's limit less its usage: `memory.max` and `memory.current` (cgroup v2),
//!   or `memory.limit_in_bytes` and `memory.usage_in_bytes` (v1), of the group
//!   `/proc/self/cgroup` names, or of the root of `/sys/fs/cgroup` as a container sees it.
//!
//! Where none of them can be read the guard only refuses requests beyond the address space a
//! 64-bit process can use (2^47 bytes). The refusal names the limit that binds. Estimates are
//! upper bounds of the buffers a call allocates (tests compare them with the sizes of the
//! buffers made).

use std::path::Path;

use crate::error::{Error, Result};

/// What bounds the memory this process can allocate now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// Free memory (`MemAvailable`).
    Free,
    /// The address-space limit less the virtual size.
    AddressSpace,
    /// The data-segment limit less the data size.
    Data,
    /// The control group's memory limit less its usage.
    Cgroup,
}

impl Bound {
    /// How a refusal names it.
    pub fn describe(self) -> &'static str {
        match self {
            Bound::Free => "free memory",
            Bound::AddressSpace => "left under the process's address-space limit, RLIMIT_AS",
            Bound::Data => "left under the process's data-size limit, RLIMIT_DATA",
            Bound::Cgroup => "left under its control group's memory limit",
        }
    }
}

/// Bytes of memory available to this process and what bounds them (the least of the sources
/// in the module doc), if any can be read.
pub fn headroom() -> Option<(u64, Bound)> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let status = read("/proc/self/status").unwrap_or_default();
    let limits = read("/proc/self/limits").unwrap_or_default();
    let free = read("/proc/meminfo").and_then(|m| field_kib(&m, "MemAvailable:"));
    [
        (free, Bound::Free),
        (
            room(
                limit(&limits, "Max address space"),
                field_kib(&status, "VmSize:"),
            ),
            Bound::AddressSpace,
        ),
        (
            room(
                limit(&limits, "Max data size"),
                field_kib(&status, "VmData:"),
            ),
            Bound::Data,
        ),
        (cgroup_room(), Bound::Cgroup),
    ]
    .into_iter()
    .filter_map(|(bytes, bound)| bytes.map(|b| (b, bound)))
    .min_by_key(|&(b, _)| b)
}

/// Bytes of memory available to this process, if the system says ([`headroom`]).
pub fn available_bytes() -> Option<u64> {
    headroom().map(|(b, _)| b)
}

/// A `NAME:   N kB` line of `/proc/meminfo` or `/proc/self/status`, in bytes.
fn field_kib(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kb: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    kb.checked_mul(1024)
}

/// The soft limit of the `/proc/self/limits` row `name` (`None`: unlimited or unreadable).
fn limit(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    line[name.len()..].split_whitespace().next()?.parse().ok()
}

/// What a limit leaves beside the usage (`None` when there is no limit).
fn room(limit: Option<u64>, used: Option<u64>) -> Option<u64> {
    Some(limit?.saturating_sub(used.unwrap_or(0)))
}

/// The control group's limit less its usage (module doc); `None` without a limit.
fn cgroup_room() -> Option<u64> {
    let groups = std::fs::read_to_string("/proc/self/cgroup").unwrap_or_default();
    cgroup_room_in(Path::new("/sys/fs/cgroup"), &groups)
}

/// [`cgroup_room`] under the cgroup file system mounted at `root`, `groups` being
/// `/proc/self/cgroup`'s text.
fn cgroup_room_in(root: &Path, groups: &str) -> Option<u64> {
    let read = |p: &Path| -> Option<u64> {
        let t = std::fs::read_to_string(p).ok()?;
        // "max" (v2) is no limit; v1 writes a huge number for none, which is no bound either.
        t.trim().parse().ok()
    };
    let mut best: Option<u64> = None;
    for line in groups.lines() {
        // "0::/path" (v2) or "4:memory:/path" (v1).
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next(), parts.next()?, parts.next()?);
        let rel = path.trim_start_matches('/');
        let (base, limit_file, usage_file) = if controllers.is_empty() {
            (root.to_path_buf(), "memory.max", "memory.current")
        } else if controllers.split(',').any(|c| c == "memory") {
            (
                root.join("memory"),
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            )
        } else {
            continue;
        };
        // The group's own folder, else the root as a container mounts its group there.
        for dir in [base.join(rel), base] {
            if let Some(limit) = read(&dir.join(limit_file)) {
                let used = read(&dir.join(usage_file)).unwrap_or(0);
                let r = limit.saturating_sub(used);
                best = Some(best.map_or(r, |b| b.min(r)));
                break;
            }
        }
    }
    best
}

/// `bytes` in a human unit.
pub fn human(bytes: u128) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut k = 0;
    while v >= 1024.0 && k + 1 < units.len() {
        v /= 1024.0;
        k += 1;
    }
    format!("{v:.1} {}", units[k])
}

/// Fails with [`Error::OutOfMemory`] when `bytes` (for `what`) exceeds what is available.
pub fn ensure(bytes: u128, what: &str) -> Result<()> {
    let (limit, bound) = headroom().map_or((1u128 << 47, None), |(b, k)| (u128::from(b), Some(k)));
    if bytes > limit {
        return Err(Error::OutOfMemory {
            what: what.to_owned(),
            needed: human(bytes),
            available: match bound {
                Some(k) => format!("{} ({})", human(limit), k.describe()),
                None => human(limit),
            },
        });
    }
    Ok(())
}

/// Bytes of `per_pixel` bytes over a `width` × `height` image (times `copies`), without
/// overflow.
pub fn image_bytes(width: u32, height: u32, per_pixel: u64, copies: u64) -> u128 {
    u128::from(width) * u128::from(height) * u128::from(per_pixel) * u128::from(copies.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_process_limits_are_read() {
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max data size             unlimited            unlimited            bytes\n\
                      Max address space         1073741824           unlimited            bytes\n";
        assert_eq!(limit(limits, "Max address space"), Some(1 << 30));
        assert_eq!(limit(limits, "Max data size"), None);
        let status = "Name:\tpointsight\nVmSize:\t  262144 kB\nVmData:\t 1024 kB\n";
        assert_eq!(field_kib(status, "VmSize:"), Some(256 << 20));
        assert_eq!(
            room(
                limit(limits, "Max address space"),
                field_kib(status, "VmSize:")
            ),
            Some(768 << 20)
        );
        assert_eq!(room(None, Some(5)), None);
        // This process (whatever its limits) has some headroom, and a bound for it.
        assert!(headroom().is_some_and(|(b, _)| b > 0));
    }

    #[test]
    fn cgroup_limits_v1_and_v2() {
        let root = tempfile::tempdir().unwrap();
        let v2 = root.path().join("user.slice/job");
        std::fs::create_dir_all(&v2).unwrap();
        std::fs::write(v2.join("memory.max"), "1073741824\n").unwrap();
        std::fs::write(v2.join("memory.current"), "268435456\n").unwrap();
        assert_eq!(
            cgroup_room_in(root.path(), "0::/user.slice/job\n"),
            Some(768 << 20)
        );
        // "max": no limit.
        std::fs::write(v2.join("memory.max"), "max\n").unwrap();
        assert_eq!(cgroup_room_in(root.path(), "0::/user.slice/job\n"), None);
        // v1, the group's folder not visible (a container): the root's files.
        let v1 = root.path().join("memory");
        std::fs::create_dir_all(&v1).unwrap();
        std::fs::write(v1.join("memory.limit_in_bytes"), "536870912\n").unwrap();
        std::fs::write(v1.join("memory.usage_in_bytes"), "134217728\n").unwrap();
        let groups = "5:devices:/\n4:memory:/process_api/abc\n0::/\n";
        assert_eq!(cgroup_room_in(root.path(), groups), Some(384 << 20));
    }

    #[test]
    fn huge_requests_are_refused_with_the_estimate() {
        let err = ensure(image_bytes(100_000, 100_000, 28, 1), "a ray list")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("a ray list") && err.contains("260.8 GiB"),
            "{err}"
        );
        assert!(ensure(1024, "a little").is_ok());
        assert_eq!(human(1536), "1.5 KiB");
        assert_eq!(
            image_bytes(u32::MAX, u32::MAX, 8, 2),
            16 * u128::from(u32::MAX).pow(2)
        );
    }
}
