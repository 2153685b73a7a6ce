//! The image pyramid of the depth buffer (Pintus et al. 2011, §4: the operators run on a
//! multi-level screen-space hierarchy so that a fixed window in pixels reaches ever wider
//! neighbourhoods): level 0 is the depth buffer, and each pixel of level l + 1 keeps the
//! nearest point of its 2 × 2 children on level l (sides rounded up, so an odd last column or
//! row has one child). A level-l pixel (x, y) therefore holds the nearest point of the
//! level-0 block [x·2^l, (x+1)·2^l) × [y·2^l, (y+1)·2^l) clipped to the image; the brute force
//! in the tests recomputes exactly that.
//!
//! Deviation: the paper builds the levels with GPU mip-map passes; here each level is one CPU
//! pass over the level below it.

use crate::depth::{DepthBuffer, EMPTY};

/// One level: its size and the nearest point per pixel.
#[derive(Debug, Clone)]
pub struct Level {
    /// Width (level 0's width / 2^l, rounded up).
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Nearest point per pixel (row-major), or [`EMPTY`].
    pub point: Vec<u32>,
}

/// Levels 0..n of a depth buffer.
#[derive(Debug, Clone)]
pub struct Pyramid {
    /// Level 0 first.
    pub levels: Vec<Level>,
}

/// Orders points by (depth, index): the nearer wins, ties to the lower index.
#[inline]
pub fn nearer(buffer: &DepthBuffer, a: u32, b: u32) -> u32 {
    if a == EMPTY {
        return b;
    }
    if b == EMPTY {
        return a;
    }
    let (da, db) = (buffer.depth[a as usize], buffer.depth[b as usize]);
    if da < db || (da == db && a < b) { a } else { b }
}

impl Pyramid {
    /// `levels` levels (at least 1; stops early once a level is 1 × 1).
    pub fn build(buffer: &DepthBuffer, levels: u32) -> Self {
        let mut out = vec![Level {
            width: buffer.width,
            height: buffer.height,
            point: buffer.point.clone(),
        }];
        while (out.len() as u32) < levels.max(1) {
            let last = &out[out.len() - 1];
            if last.width == 1 && last.height == 1 {
                break;
            }
            let (w, h) = (last.width.div_ceil(2), last.height.div_ceil(2));
            let mut point = vec![EMPTY; w as usize * h as usize];
            for y in 0..h {
                for x in 0..w {
                    let mut best = EMPTY;
                    for cy in 2 * y..(2 * y + 2).min(last.height) {
                        for cx in 2 * x..(2 * x + 2).min(last.width) {
                            let c = last.point[(cy * last.width + cx) as usize];
                            best = nearer(buffer, best, c);
                        }
                    }
                    point[(y * w + x) as usize] = best;
                }
            }
            out.push(Level {
                width: w,
                height: h,
                point,
            });
        }
        Self { levels: out }
    }
}
