//! The network: the octree U-Net that gives each point its feature (once per cloud) and the
//! head that classifies a feature times the encoded view direction (per view), built from a
//! weights file by the PyTorch names of the authors' module tree (`UNet.conv1`,
//! `UNet.encoder.{i}.resblks.{j}.conv3x3a`, `VisNet.mlp.{k}`, …).

use rayon::prelude::*;

use crate::error::WeightsError;
use crate::layers::{Act, Dense, gemm};
use crate::octree::{NONE, Octree};
use crate::weights::{Config, Weights};

/// A residual block: two 3×3×3 convolutions (ReLU between), a 1×1 shortcut when the widths
/// differ, ReLU of the sum.
#[derive(Debug, Clone)]
struct ResBlock {
    a: Dense,
    b: Dense,
    shortcut: Option<Dense>,
}

impl ResBlock {
    fn load(
        w: &Weights,
        prefix: &str,
        cin: usize,
        cout: usize,
        cfg: &Config,
    ) -> Result<Self, WeightsError> {
        Ok(Self {
            a: Dense::conv_bn(w, &format!("{prefix}.conv3x3a"), 27, cin, cout, cfg)?,
            b: Dense::conv_bn(w, &format!("{prefix}.conv3x3b"), 27, cout, cout, cfg)?,
            shortcut: if cin == cout {
                None
            } else {
                Some(Dense::linear(
                    w,
                    &format!("{prefix}.conv1x1.conv.linear"),
                    Some(&format!("{prefix}.conv1x1.bn")),
                    cin,
                    cout,
                    cfg,
                )?)
            },
        })
    }

    fn forward(&self, x: &Act, nb: &[u32]) -> Act {
        let h = self.a.apply(x, Some(nb), x.rows).relu();
        let h = self.b.apply(&h, Some(nb), x.rows);
        match &self.shortcut {
            Some(s) => h.add_relu(&s.apply(x, None, x.rows)),
            None => h.add_relu(x),
        }
    }
}

fn blocks(
    w: &Weights,
    prefix: &str,
    n: usize,
    cin: usize,
    cout: usize,
    cfg: &Config,
) -> Result<Vec<ResBlock>, WeightsError> {
    (0..n)
        .map(|j| {
            let c = if j == 0 { cin } else { cout };
            ResBlock::load(w, &format!("{prefix}.resblks.{j}"), c, cout, cfg)
        })
        .collect()
}

/// The U-Net.
#[derive(Debug, Clone)]
pub struct UNet {
    cfg: Config,
    conv1: Dense,
    down: Vec<Dense>,
    encoder: Vec<Vec<ResBlock>>,
    up: Vec<Dense>,
    decoder: Vec<Vec<ResBlock>>,
    header: Dense,
}

impl UNet {
    /// The U-Net of `w`.
    pub fn load(w: &Weights) -> Result<Self, WeightsError> {
        let cfg = w.config.clone();
        let (enc, dec, s) = (&cfg.encoder_channels, &cfg.decoder_channels, cfg.stages());
        let conv1 = Dense::conv_bn(w, "UNet.conv1", 27, cfg.in_channels, enc[0], &cfg)?;
        let mut down = Vec::new();
        let mut encoder = Vec::new();
        let mut up = Vec::new();
        let mut decoder = Vec::new();
        for i in 0..s {
            down.push(Dense::conv_bn(
                w,
                &format!("UNet.downsample.{i}"),
                8,
                enc[i],
                enc[i + 1],
                &cfg,
            )?);
            encoder.push(blocks(
                w,
                &format!("UNet.encoder.{i}"),
                cfg.encoder_blocks[i],
                enc[i + 1],
                enc[i + 1],
                &cfg,
            )?);
            up.push(Dense::deconv_bn(
                w,
                &format!("UNet.upsample.{i}"),
                dec[i],
                dec[i + 1],
                &cfg,
            )?);
            let skip = dec[i + 1] + enc[s - 1 - i];
            decoder.push(blocks(
                w,
                &format!("UNet.decoder.{i}"),
                cfg.decoder_blocks[i],
                skip,
                dec[i + 1],
                &cfg,
            )?);
        }
        let header = Dense::linear(
            w,
            "UNet.header.linear",
            None,
            dec[s],
            cfg.feature_channels,
            &cfg,
        )?;
        Ok(Self {
            cfg,
            conv1,
            down,
            encoder,
            up,
            decoder,
            header,
        })
    }

    /// The feature of every finest node (`feature_channels` each).
    pub fn node_features(&self, octree: &Octree) -> Act {
        let (depth, s) = (self.cfg.depth, self.cfg.stages() as u32);
        let nb: Vec<Vec<u32>> = (depth - s..=depth).map(|d| octree.neighbours(d)).collect();
        let nb_at = |d: u32| nb[(d - (depth - s)) as usize].as_slice();
        // The input signal 'LP': each node's mean point, local (frac − 0.5) and global
        // (2^(1 − depth) · q − 1).
        let g = 2f32.powi(1 - depth as i32);
        let mut x = Act::zeros(octree.mean.len(), 6);
        for (row, m) in x.data.chunks_mut(6).zip(&octree.mean) {
            for a in 0..3 {
                row[a] = (m[a] - m[a].floor()) - 0.5;
                row[3 + a] = m[a] * g - 1.0;
            }
        }
        let mut convd: Vec<Act> = Vec::with_capacity(s as usize + 1);
        convd.push(self.conv1.apply(&x, Some(nb_at(depth)), x.rows).relu());
        for i in 0..s {
            let d = depth - i;
            let children = octree.children(d - 1);
            let rows = octree.level(d - 1).len();
            let mut h = self.down[i as usize]
                .apply(&convd[i as usize], Some(&children), rows)
                .relu();
            for b in &self.encoder[i as usize] {
                h = b.forward(&h, nb_at(d - 1));
            }
            convd.push(h);
        }
        let mut h = convd.pop().expect("the bottom level");
        for i in 0..s {
            let d = depth - s + i;
            let up = self.deconv(&self.up[i as usize], &h, octree, d).relu();
            let skip = convd.pop().expect("a skip level per stage");
            h = skip.concat(&up);
            for b in &self.decoder[i as usize] {
                h = b.forward(&h, nb_at(d + 1));
            }
        }
        self.header.apply(&h, None, h.rows)
    }

    /// The stride-2 deconvolution of `x` (level `d`) onto the non-empty nodes of level d + 1.
    fn deconv(&self, layer: &Dense, x: &Act, octree: &Octree, d: u32) -> Act {
        let z = layer.apply(x, None, x.rows);
        let cout = layer.cout / 8;
        let below = octree.level(d + 1);
        let mut out = Act::zeros(below.len(), cout);
        out.data
            .par_chunks_mut(cout)
            .zip(below.parent.par_iter().zip(below.keys.par_iter()))
            .for_each(|(row, (&p, &k))| {
                let c = (k & 7) as usize;
                row.copy_from_slice(&z.row(p as usize)[c * cout..(c + 1) * cout]);
            });
        out
    }
}

/// Each point's feature: ocnn's linear interpolation (`octree_linear_pts`) of the finest
/// nodes' features at the point, over the non-empty corners among the 8 around it.
pub fn interpolate(nodes: &Act, octree: &Octree) -> Act {
    let c = nodes.cols;
    let depth = octree.depth;
    let nb = octree.neighbours(depth);
    let mut out = Act::zeros(octree.q.len(), c);
    out.data
        .par_chunks_mut(c)
        .zip(octree.q.par_iter().zip(octree.point_node.par_iter()))
        .for_each(|(row, (q, &node))| {
            let f = [q[0] - 0.5, q[1] - 0.5, q[2] - 0.5];
            let i = [f[0].floor(), f[1].floor(), f[2].floor()];
            let frac = [f[0] - i[0], f[1] - i[1], f[2] - i[2]];
            // Offsets of the corners from the point's own cell, in {-1, 0, 1}.
            let base = [
                i[0] - q[0].floor(),
                i[1] - q[1].floor(),
                i[2] - q[2].floor(),
            ];
            let mut norm = 0f32;
            for corner in 0..8usize {
                let g = [(corner >> 2) & 1, (corner >> 1) & 1, corner & 1];
                let w = ((1.0 - g[0] as f32) - frac[0])
                    * ((1.0 - g[1] as f32) - frac[1])
                    * ((1.0 - g[2] as f32) - frac[2]);
                let w = w.abs();
                let o = [
                    base[0] as i64 + g[0] as i64,
                    base[1] as i64 + g[1] as i64,
                    base[2] as i64 + g[2] as i64,
                ];
                let k = ((o[0] + 1) * 9 + (o[1] + 1) * 3 + (o[2] + 1)) as usize;
                let n = nb[node as usize * 27 + k];
                if n == NONE {
                    continue;
                }
                norm += w;
                for (r, v) in row.iter_mut().zip(nodes.row(n as usize)) {
                    *r += w * v;
                }
            }
            let norm = norm + 1e-12;
            for r in row.iter_mut() {
                *r /= norm;
            }
        });
    out
}

/// The head: (feature ⊙ encoding) → hidden layers (ReLU) → two logits.
#[derive(Debug, Clone)]
pub struct Head {
    hidden: Vec<Dense>,
    out: Dense,
    multires: usize,
}

impl Head {
    /// The head of `w`.
    pub fn load(w: &Weights) -> Result<Self, WeightsError> {
        let cfg = &w.config;
        let mut hidden = Vec::new();
        let mut cin = cfg.feature_channels;
        for (k, &c) in cfg.head_channels.iter().enumerate() {
            hidden.push(Dense::linear(
                w,
                &format!("VisNet.mlp.{k}.conv.linear"),
                Some(&format!("VisNet.mlp.{k}.bn")),
                cin,
                c,
                cfg,
            )?);
            cin = c;
        }
        let k = cfg.head_channels.len();
        let out = Dense::linear(w, &format!("VisNet.mlp.{k}.linear"), None, cin, 2, cfg)?;
        Ok(Self {
            hidden,
            out,
            multires: cfg.multires,
        })
    }

    /// P(visible) of the rows of `features` seen along the unit directions `dirs` (one per
    /// row): softmax of the two logits, class 1.
    pub fn probabilities(&self, features: &[f32], dirs: &[[f64; 3]]) -> Vec<f32> {
        let c = 3 + 6 * self.multires;
        let n = dirs.len();
        let mut x = vec![0f32; n * c];
        for ((row, d), f) in x.chunks_mut(c).zip(dirs).zip(features.chunks(c)) {
            encode(d, self.multires, row);
            for (r, v) in row.iter_mut().zip(f) {
                *r *= v;
            }
        }
        let mut h = x;
        let mut cin = c;
        for layer in &self.hidden {
            let mut y = vec![0f32; n * layer.cout];
            for row in y.chunks_mut(layer.cout) {
                row.copy_from_slice(&layer.b);
            }
            gemm(&h, n, cin, &layer.w, layer.cout, &mut y);
            y.iter_mut().for_each(|v| *v = v.max(0.0));
            h = y;
            cin = layer.cout;
        }
        let mut logits = vec![0f32; n * 2];
        for row in logits.chunks_mut(2) {
            row.copy_from_slice(&self.out.b);
        }
        gemm(&h, n, cin, &self.out.w, 2, &mut logits);
        logits
            .chunks(2)
            .map(|l| {
                let m = l[0].max(l[1]);
                let (e0, e1) = ((l[0] - m).exp(), (l[1] - m).exp());
                e1 / (e0 + e1)
            })
            .collect()
    }
}

/// NeRF's positional encoding of a unit direction: d, then sin and cos of 2^k · d for
/// k = 0 .. multires − 1 (blocks of three), computed in f64 (sin and cos of d once, then the
/// double-angle formulas) and rounded to f32.
pub fn encode(d: &[f64; 3], multires: usize, out: &mut [f32]) {
    for a in 0..3 {
        out[a] = d[a] as f32;
    }
    let mut s = [d[0].sin(), d[1].sin(), d[2].sin()];
    let mut c = [d[0].cos(), d[1].cos(), d[2].cos()];
    for k in 0..multires {
        let base = 3 + 6 * k;
        for a in 0..3 {
            out[base + a] = s[a] as f32;
            out[base + 3 + a] = c[a] as f32;
        }
        for a in 0..3 {
            let (sa, ca) = (s[a], c[a]);
            s[a] = 2.0 * sa * ca;
            c[a] = (ca - sa) * (ca + sa);
        }
    }
}
