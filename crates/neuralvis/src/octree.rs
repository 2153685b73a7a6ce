//! The octree of a normalised cloud, as `ocnn.octree.Octree.build_octree` builds it, with the
//! neighbourhoods its convolutions read.
//!
//! A point p in [-1, 1]^3 (float32) goes to q = (p + 1) · 2^(depth − 1) in [0, 2^depth)^3 and
//! to the finest node whose integer coordinates are ⌊q⌋. A node's key is ocnn's shuffled key:
//! bit i of x, y and z at bits 3i + 2, 3i + 1 and 3i. Each level keeps its non-empty nodes in
//! ascending key order (ocnn's order for the features of non-empty nodes); a node's parent is
//! its key shifted right by 3, its child c (0..8) has key `key << 3 | c`, c = 4·dx + 2·dy + dz.
//!
//! Neighbourhoods are ocnn's (`construct_neigh`, `get_neigh` with `nempty`): for a 3×3×3
//! kernel, entry (dx+1)·9 + (dy+1)·3 + (dz+1) of a node is the non-empty node at its
//! coordinates plus (dx, dy, dz), or none; for the stride-2 kernels, entry c of a node is its
//! child c, or none. Levels below ocnn's full depth (where it treats every node as non-empty)
//! are not built: the configuration check keeps every convolution at or below it.

use rayon::prelude::*;

/// No node.
pub const NONE: u32 = u32::MAX;

/// One level's non-empty nodes.
#[derive(Debug, Clone)]
pub struct Level {
    /// Keys, ascending.
    pub keys: Vec<u64>,
    /// Per node, the index of its parent in the level above (empty for the coarsest kept).
    pub parent: Vec<u32>,
}

impl Level {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// True when the level has no node.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Index of the node with `key`, if non-empty.
    pub fn find(&self, key: u64) -> Option<u32> {
        self.keys.binary_search(&key).ok().map(|i| i as u32)
    }
}

/// The octree from the finest level `depth` up to `top`.
#[derive(Debug, Clone)]
pub struct Octree {
    /// Depth of the finest level.
    pub depth: u32,
    /// The coarsest level kept.
    pub top: u32,
    /// Levels `top..=depth` (index 0 is `top`).
    levels: Vec<Level>,
    /// Per point, its finest node.
    pub point_node: Vec<u32>,
    /// Per point, its position in [0, 2^depth)^3.
    pub q: Vec<[f32; 3]>,
    /// Per finest node, the mean of its points' q (ocnn's `octree.points[depth]`).
    pub mean: Vec<[f32; 3]>,
}

/// The shuffled key of integer coordinates at `depth` (≤ 21 bits each).
pub fn key_of(x: u32, y: u32, z: u32, depth: u32) -> u64 {
    let mut key = 0u64;
    for i in 0..depth {
        key |= (u64::from((x >> i) & 1) << (3 * i + 2))
            | (u64::from((y >> i) & 1) << (3 * i + 1))
            | (u64::from((z >> i) & 1) << (3 * i));
    }
    key
}

/// Integer coordinates of a shuffled key at `depth`.
pub fn coords_of(key: u64, depth: u32) -> [u32; 3] {
    let (mut x, mut y, mut z) = (0u32, 0u32, 0u32);
    for i in 0..depth {
        x |= (((key >> (3 * i + 2)) & 1) as u32) << i;
        y |= (((key >> (3 * i + 1)) & 1) as u32) << i;
        z |= (((key >> (3 * i)) & 1) as u32) << i;
    }
    [x, y, z]
}

impl Octree {
    /// Builds the octree of `points` (in [-1, 1]^3, float32) from `depth` up to `top`.
    pub fn build(points: &[[f32; 3]], depth: u32, top: u32) -> Self {
        let side = 1u32 << depth;
        let half = (1u32 << (depth - 1)) as f32;
        let q: Vec<[f32; 3]> = points
            .par_iter()
            .map(|p| {
                [
                    (p[0] + 1.0) * half,
                    (p[1] + 1.0) * half,
                    (p[2] + 1.0) * half,
                ]
            })
            .collect();
        let cell = |v: f32| (v.floor().max(0.0) as u32).min(side - 1);
        let keys: Vec<u64> = q
            .par_iter()
            .map(|v| key_of(cell(v[0]), cell(v[1]), cell(v[2]), depth))
            .collect();
        let mut finest = keys.clone();
        finest.par_sort_unstable();
        finest.dedup();
        let point_node: Vec<u32> = keys
            .par_iter()
            .map(|k| finest.binary_search(k).map_or(NONE, |i| i as u32))
            .collect();
        let mut sum = vec![[0f32; 3]; finest.len()];
        let mut count = vec![0u32; finest.len()];
        for (v, &n) in q.iter().zip(&point_node) {
            let s = &mut sum[n as usize];
            s[0] += v[0];
            s[1] += v[1];
            s[2] += v[2];
            count[n as usize] += 1;
        }
        let mean = sum
            .iter()
            .zip(&count)
            .map(|(s, &c)| {
                let c = c as f32;
                [s[0] / c, s[1] / c, s[2] / c]
            })
            .collect();
        let mut levels = vec![Level {
            keys: finest,
            parent: Vec::new(),
        }];
        for _ in top..depth {
            let child = levels.last_mut().expect("the finest level is there");
            let mut keys: Vec<u64> = Vec::new();
            let mut parent = Vec::with_capacity(child.keys.len());
            for &k in &child.keys {
                let pk = k >> 3;
                if keys.last() != Some(&pk) {
                    keys.push(pk);
                }
                parent.push((keys.len() - 1) as u32);
            }
            child.parent = parent;
            levels.push(Level {
                keys,
                parent: Vec::new(),
            });
        }
        levels.reverse();
        Self {
            depth,
            top,
            levels,
            point_node,
            q,
            mean,
        }
    }

    /// The level at `depth` (between `top` and the finest).
    pub fn level(&self, depth: u32) -> &Level {
        &self.levels[(depth - self.top) as usize]
    }

    /// The 3×3×3 neighbourhood of every node at `depth`: 27 indices per node ([`NONE`] for
    /// none), in ocnn's order.
    pub fn neighbours(&self, depth: u32) -> Vec<u32> {
        let level = self.level(depth);
        let side = 1i64 << depth;
        let mut out = vec![NONE; level.len() * 27];
        out.par_chunks_mut(27)
            .zip(level.keys.par_iter())
            .for_each(|(row, &key)| {
                let [x, y, z] = coords_of(key, depth);
                for (k, slot) in row.iter_mut().enumerate() {
                    let (dx, dy, dz) = (k as i64 / 9 - 1, (k as i64 / 3) % 3 - 1, k as i64 % 3 - 1);
                    let (nx, ny, nz) = (i64::from(x) + dx, i64::from(y) + dy, i64::from(z) + dz);
                    if (0..side).contains(&nx) && (0..side).contains(&ny) && (0..side).contains(&nz)
                    {
                        let nk = key_of(nx as u32, ny as u32, nz as u32, depth);
                        if let Some(i) = level.find(nk) {
                            *slot = i;
                        }
                    }
                }
            });
        out
    }

    /// The children of every node at `depth` (which must be above the finest level): 8
    /// indices into level `depth + 1` per node ([`NONE`] for an empty child), child c at c.
    pub fn children(&self, depth: u32) -> Vec<u32> {
        let (level, below) = (self.level(depth), self.level(depth + 1));
        let mut out = vec![NONE; level.len() * 8];
        for (j, (&p, &k)) in below.parent.iter().zip(&below.keys).enumerate() {
            out[p as usize * 8 + (k & 7) as usize] = j as u32;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_round_trip_and_follow_ocnn_bit_order() {
        // x's bit 0 is the key's bit 2, y's bit 1, z's bit 0 (ocnn's xyz2key).
        assert_eq!(key_of(1, 0, 0, 8), 4);
        assert_eq!(key_of(0, 1, 0, 8), 2);
        assert_eq!(key_of(0, 0, 1, 8), 1);
        assert_eq!(key_of(2, 0, 0, 8), 32);
        for (x, y, z) in [(0, 0, 0), (255, 1, 77), (13, 200, 255)] {
            assert_eq!(coords_of(key_of(x, y, z, 8), 8), [x, y, z]);
        }
    }

    #[test]
    fn levels_parents_children_and_neighbours_agree() {
        let pts: Vec<[f32; 3]> = (0..500)
            .map(|i| {
                let t = i as f32 * 0.0123;
                [0.7 * t.sin(), 0.7 * (1.3 * t).cos(), 0.6 * (0.7 * t).sin()]
            })
            .collect();
        let o = Octree::build(&pts, 6, 2);
        for d in 2..6 {
            let children = o.children(d);
            let below = o.level(d + 1);
            for (p, row) in children.chunks(8).enumerate() {
                for (c, &j) in row.iter().enumerate() {
                    if j != NONE {
                        assert_eq!(below.keys[j as usize], o.level(d).keys[p] << 3 | c as u64);
                        assert_eq!(below.parent[j as usize], p as u32);
                    }
                }
            }
            let nb = o.neighbours(d);
            for (i, row) in nb.chunks(27).enumerate() {
                // The centre is the node itself.
                assert_eq!(row[13], i as u32);
            }
        }
        for (i, &n) in o.point_node.iter().enumerate() {
            let [x, y, z] = coords_of(o.level(6).keys[n as usize], 6);
            let q = o.q[i];
            assert_eq!(
                [
                    q[0].floor() as u32,
                    q[1].floor() as u32,
                    q[2].floor() as u32
                ],
                [x, y, z]
            );
        }
    }
}
