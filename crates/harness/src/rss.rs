//! Peak memory of this process: its resident set's high-water mark (`VmHWM`), alone or with
//! the largest child process it waited for. The one reading that `lod-build` and the scale
//! experiment's cells report.

/// Peak resident set size of this process (`VmHWM` of `/proc/self/status`), bytes (0 where
/// unknown).
pub fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// [`peak_rss`] plus that of the largest child process it waited for
/// (`getrusage(RUSAGE_CHILDREN)`: an external method's program), bytes.
pub fn peak_rss_with_children() -> u64 {
    // ru_maxrss is in kilobytes on Linux.
    let children = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
        .map_or(0, |u| u64::try_from(u.max_rss()).unwrap_or(0) * 1024);
    peak_rss() + children
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_is_at_least_what_this_process_holds() {
        let held = vec![1u8; 32 << 20];
        std::hint::black_box(&held);
        assert!(peak_rss() >= 32 << 20);
        assert!(peak_rss_with_children() >= peak_rss());
    }
}
