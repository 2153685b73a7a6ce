//! Insertion order: a biased randomised insertion order (BRIO) along a space-filling curve.
//!
//! Amenta, Choi and Rote, "Incremental constructions con BRIO" (SoCG 2003): points are split
//! into rounds of geometrically growing size (about n/2^k in round k from the end), inserted
//! round after round, and each round is sorted along a space-filling curve. The rounds keep the
//! randomised-incremental expected bounds; the curve order keeps each point-location walk short
//! (it starts where the previous insertion ended).
//!
//! NOTE: the curve is Morton's (Z-order), not Hilbert's as Amenta et al. use: on the dragon
//! (871k points) a bit-loop Hilbert key cost 90 ms against a few for Morton, and saved only 10%
//! of the walk steps.
//!
//! The rounds are drawn from a hash of each point's coordinates rather than from a random
//! generator: the order is deterministic, and coincident points land in the same round with the
//! same curve key, so ties are broken by index and the lowest index of a set of coincident
//! points is the one inserted first (the one the hull reports).

use rayon::prelude::*;

use crate::predicates::P3;

/// Number of BRIO rounds at most.
const LEVELS: u32 = 12;

/// Bits per axis of the quantised coordinates (the Morton key uses the top 20).
const BITS: u32 = 21;

/// Longest run of equal sort keys whose points are compared for coincidence.
const RUN_LIMIT: usize = 64;

/// An insertion order: the indices, and where each round starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Order {
    /// The indices in insertion order.
    pub indices: Vec<u32>,
    /// Start offsets of the rounds in `indices` (ascending, the first is 0).
    pub rounds: Vec<usize>,
    /// True when no two points (those in `skip` included) coincide: coincident points share a
    /// sort key, so only points with equal keys are compared.
    pub distinct: bool,
}

impl Order {
    /// The rounds as slices of indices.
    pub fn round_slices(&self) -> impl Iterator<Item = &[u32]> {
        self.rounds.iter().enumerate().map(|(k, &start)| {
            let end = self
                .rounds
                .get(k + 1)
                .copied()
                .unwrap_or(self.indices.len());
            &self.indices[start..end]
        })
    }
}

/// The indices of `points` (all of them except those in `skip`) in insertion order.
pub fn insertion_order(points: &[P3], skip: &[u32]) -> Order {
    let (lo, hi) = bounds(points);
    let scale: [f64; 3] = std::array::from_fn(|k| {
        let extent = hi[k] - lo[k];
        if extent > 0.0 {
            ((1u64 << BITS) - 1) as f64 / extent
        } else {
            0.0
        }
    });
    // Every point is keyed, `skip` included, so that the duplicate check below sees them all;
    // the skipped ones are left out of the order afterwards.
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let q: [u32; 3] = std::array::from_fn(|k| ((p[k] - lo[k]) * scale[k]) as u32);
            let level = (hash(p).trailing_zeros()).min(LEVELS - 1) as u64;
            // Higher levels (smaller rounds) first: sort key (LEVELS - 1 - level, curve key).
            let round = (LEVELS as u64 - 1 - level) << 60;
            (round | morton_key(q), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    // Coincident points hash alike and quantise alike: they share a key, and sit in one run
    // of equal keys. Runs longer than one are rare and short: compare their points. A run
    // longer than RUN_LIMIT (a dense cluster far from the rest of the cloud) would make this
    // quadratic: the answer is then "not known distinct".
    let distinct = (0..keyed.len().saturating_sub(1)).into_par_iter().all(|k| {
        let (key, i) = keyed[k];
        let mut run = keyed[k + 1..].iter().take_while(|w| w.0 == key);
        run.by_ref()
            .take(RUN_LIMIT)
            .all(|&(_, j)| points[i as usize] != points[j as usize])
            && run.next().is_none()
    });
    keyed.retain(|&(_, i)| !skip.contains(&i));
    let mut rounds = Vec::new();
    for (k, w) in keyed.iter().enumerate() {
        if k == 0 || w.0 >> 60 != keyed[k - 1].0 >> 60 {
            rounds.push(k);
        }
    }
    Order {
        indices: keyed.into_iter().map(|(_, i)| i).collect(),
        rounds,
        distinct,
    }
}

fn bounds(points: &[P3]) -> (P3, P3) {
    points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        },
    )
}

/// SplitMix64 of the coordinates' bit patterns (coincident points hash alike).
fn hash(p: &P3) -> u64 {
    let mut h = 0x9e37_79b9_7f4a_7c15u64;
    for c in p {
        let mut z = h ^ c.to_bits();
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h = z ^ (z >> 31);
    }
    h
}

/// Index along the 3-d Morton (Z-order) curve: the bits of x, y, z interleaved (60 bits).
pub fn morton_key(x: [u32; 3]) -> u64 {
    // Spread the top 20 bits of each coordinate to every third bit.
    fn spread(v: u32) -> u64 {
        let mut v = u64::from(v >> 1) & 0xf_ffff;
        v = (v | (v << 32)) & 0x000f_0000_0000_ffff;
        v = (v | (v << 16)) & 0x000f_0000_ff00_00ff;
        v = (v | (v << 8)) & 0x000f_00f0_0f00_f00f;
        v = (v | (v << 4)) & 0x00c3_0c30_c30c_30c3;
        v = (v | (v << 2)) & 0x0249_2492_4924_9249;
        v
    }
    (spread(x[0]) << 2) | (spread(x[1]) << 1) | spread(x[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_key_interleaves_the_top_twenty_bits() {
        let top = |b: u32| b << 1;
        assert_eq!(morton_key([top(1), 0, 0]), 0b100);
        assert_eq!(morton_key([0, top(1), 0]), 0b010);
        assert_eq!(morton_key([0, 0, top(1)]), 0b001);
        assert_eq!(morton_key([top(2), top(3), 0]), 0b110_010);
        let all = (1u32 << 21) - 1;
        assert_eq!(morton_key([all, all, all]), (1u64 << 60) - 1);
    }

    #[test]
    fn order_is_a_permutation_and_duplicates_keep_index_order() {
        let mut pts: Vec<P3> = (0..1000)
            .map(|i| [i as f64 % 7.0, (i * 13 % 11) as f64, (i % 5) as f64])
            .collect();
        pts.push(pts[3]);
        let order = insertion_order(&pts, &[0, 1]);
        // The lattice repeats itself: coincident points, so not known distinct.
        assert!(!order.distinct);
        assert_eq!(order.round_slices().map(<[u32]>::len).sum::<usize>(), 999);
        let order = order.indices;
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(sorted, (2..1001).collect::<Vec<u32>>());
        // Coincident points: the lower index comes first.
        let pos = |i: u32| order.iter().position(|&j| j == i).unwrap();
        for i in 2..1001u32 {
            for j in (i + 1)..1001u32 {
                if pts[i as usize] == pts[j as usize] {
                    assert!(pos(i) < pos(j));
                }
            }
        }
    }

    #[test]
    fn distinct_is_true_only_without_coincident_points() {
        let mut pts: Vec<P3> = (0..500)
            .map(|i| {
                let t = f64::from(i);
                [t.sin(), (1.7 * t).cos(), 0.01 * t]
            })
            .collect();
        assert!(insertion_order(&pts, &[]).distinct);
        // A copy of a skipped point still counts.
        pts.push(pts[7]);
        assert!(!insertion_order(&pts, &[7]).distinct);
        assert!(!insertion_order(&pts, &[]).distinct);
        // A dense cluster far from one other point: 1,000 distinct points share one key, too
        // many to compare, so the answer is the safe one.
        let mut cluster: Vec<P3> = (0..1000)
            .map(|i| [1.0 + f64::from(i) * 1e-12, 1.0, 1.0])
            .collect();
        cluster.push([1e6, 1e6, 1e6]);
        assert!(!insertion_order(&cluster, &[]).distinct);
        assert!(insertion_order(&cluster[..60], &[]).distinct);
    }
}
