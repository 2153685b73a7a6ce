//! Seeded random number streams.
//!
//! Every random choice in pointsight takes a seed. A stream is named by a seed and a purpose
//! string (for example `"sample-surface"`), mixed into the 64-bit state, so two uses of the same
//! seed for different purposes never share a sequence. The generator is PCG-64 (`rand_pcg`),
//! whose output is fixed by its specification: the same seed gives the same numbers on every
//! platform and release, which `StdRng` does not promise.

pub use rand::RngExt;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

/// The generator type used throughout pointsight.
pub type Rng = Pcg64Mcg;

/// A generator for `seed` and `purpose`.
pub fn seeded(seed: u64, purpose: &str) -> Rng {
    Rng::seed_from_u64(mix(seed, purpose))
}

/// A standard normal variate (Box–Muller, one of the pair).
pub fn gaussian(rng: &mut Rng) -> f64 {
    use rand::RngExt as _;
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]: the logarithm stays finite
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// FNV-1a of the purpose, folded into the seed with a SplitMix64 finaliser.
fn mix(seed: u64, purpose: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in purpose.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    splitmix64(seed ^ h)
}

/// SplitMix64's finaliser (Steele, Lea and Flood 2014): a 64-bit hash of `z`, every bit
/// depending on every bit.
pub fn splitmix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_and_purposes_differ() {
        let a: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(seeded(7, "x"), |r, _: u64| Some(r.random()))
            .collect();
        let b: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(seeded(7, "x"), |r, _: u64| Some(r.random()))
            .collect();
        let c: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(seeded(7, "y"), |r, _: u64| Some(r.random()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
