//! The memory guard: every allocation sized by user input (image resolutions, counts) is
//! estimated first and refused, with the estimate and the memory available, before anything
//! is allocated, instead of aborting the process.
//!
//! Available memory is `MemAvailable` of `/proc/meminfo` (Linux); where that cannot be read
//! the guard only refuses requests beyond the address space a 64-bit process can use (2^47
//! bytes). Estimates are upper bounds of the buffers a call allocates (tests compare them with
//! the sizes of the buffers made).

use crate::error::{Error, Result};

/// Bytes of memory available to this process, if the system says.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
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
    let limit = available_bytes().map_or(1u128 << 47, u128::from);
    if bytes > limit {
        return Err(Error::OutOfMemory {
            what: what.to_owned(),
            needed: human(bytes),
            available: human(limit),
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
