//! Memory bandwidth of this machine, STREAM-like, as the yardstick for the memory-bound scans
//! (the SPT cut, the SRN selection): a read (sum of 64-bit words) over a 1 GiB buffer and a
//! copy of 512 MiB into another 512 MiB, on one thread and on every core (rayon, one chunk per
//! thread), throughput in bytes (a copy counts the bytes read plus the bytes written, as
//! STREAM does). The buffers are far larger than the caches, so the figures are DRAM's.
//!
//! `lod`'s `spt-cut` and `srn-select` report entries per second; entries × 16 bytes (SPT's
//! list entry) or points × the bytes SRN reads per point, over the read figure here, is the
//! fraction of the memory speed they reach (the goal is at least 50 %).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;

const READ_BYTES: usize = 1 << 30;
const COPY_BYTES: usize = 1 << 29;

fn bandwidth(c: &mut Criterion) {
    let words: Vec<u64> = (0..READ_BYTES / 8).map(|i| i as u64).collect();
    let threads = rayon::current_num_threads();
    let mut g = c.benchmark_group("bandwidth");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(READ_BYTES as u64));
    g.bench_function("read 1 GiB, 1 thread", |b| {
        b.iter(|| {
            black_box(&words)
                .iter()
                .fold(0u64, |a, &w| a.wrapping_add(w))
        })
    });
    let chunk = words.len().div_ceil(threads);
    g.bench_function(format!("read 1 GiB, {threads} threads"), |b| {
        b.iter(|| {
            black_box(&words)
                .par_chunks(chunk)
                .map(|c| c.iter().fold(0u64, |a, &w| a.wrapping_add(w)))
                .reduce(|| 0, u64::wrapping_add)
        })
    });
    drop(words);
    let src: Vec<u64> = (0..COPY_BYTES / 8).map(|i| i as u64).collect();
    let mut dst = vec![0u64; src.len()];
    g.throughput(Throughput::Bytes(2 * COPY_BYTES as u64));
    g.bench_function("copy 512 MiB, 1 thread", |b| {
        b.iter(|| dst.copy_from_slice(black_box(&src)))
    });
    let chunk = src.len().div_ceil(threads);
    g.bench_function(format!("copy 512 MiB, {threads} threads"), |b| {
        b.iter(|| {
            dst.par_chunks_mut(chunk)
                .zip(src.par_chunks(chunk))
                .for_each(|(d, s)| d.copy_from_slice(black_box(s)))
        })
    });
    g.finish();
}

criterion_group!(benches, bandwidth);
criterion_main!(benches);
