//! The layers, with batch norm folded in: a dense map from gathered rows (an octree
//! convolution is a gather of each node's neighbours followed by one matrix product; a 1×1
//! convolution gathers the row itself), the stride-2 deconvolution (each child takes its
//! parent's row times the kernel of its position), and the row-wise tools (ReLU, concatenation).
//! The matrix products are `ndarray`'s (`matrixmultiply`), over blocks of rows in parallel.

use ndarray::linalg::general_mat_mul;
use ndarray::{ArrayView2, ArrayViewMut2};
use rayon::prelude::*;

use crate::error::WeightsError;
use crate::octree::NONE;
use crate::weights::{Config, Weights};

/// Rows per block of a product.
const BLOCK: usize = 256;

/// Activations: `rows` × `cols`, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Act {
    /// Rows (nodes or points).
    pub rows: usize,
    /// Channels.
    pub cols: usize,
    /// Values.
    pub data: Vec<f32>,
}

impl Act {
    /// Zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// ReLU in place.
    pub fn relu(mut self) -> Self {
        self.data.par_iter_mut().for_each(|x| *x = x.max(0.0));
        self
    }

    /// The columns of `self` then those of `other` (same rows).
    pub fn concat(&self, other: &Act) -> Act {
        let cols = self.cols + other.cols;
        let mut data = vec![0.0; self.rows * cols];
        data.par_chunks_mut(cols).enumerate().for_each(|(i, row)| {
            row[..self.cols].copy_from_slice(self.row(i));
            row[self.cols..].copy_from_slice(other.row(i));
        });
        Act {
            rows: self.rows,
            cols,
            data,
        }
    }

    /// ReLU of `self + other` (the residual sum).
    pub fn add_relu(mut self, other: &Act) -> Self {
        self.data
            .par_iter_mut()
            .zip(other.data.par_iter())
            .for_each(|(a, b)| *a = (*a + b).max(0.0));
        self
    }
}

/// A dense map of `kernel` gathered rows of `cin` channels to `cout` channels:
/// y = [x_{n_1} … x_{n_k}] · W + b, missing rows counting as zeros.
#[derive(Debug, Clone)]
pub struct Dense {
    /// Rows gathered per output row (27, 8 or 1).
    pub kernel: usize,
    /// Input channels.
    pub cin: usize,
    /// Output channels.
    pub cout: usize,
    /// (kernel · cin) × cout, row-major.
    pub w: Vec<f32>,
    /// cout.
    pub b: Vec<f32>,
}

/// The batch norm `prefix` (weight, bias, running mean and variance) as a scale and shift.
fn batch_norm(
    weights: &Weights,
    prefix: &str,
    c: usize,
    eps: f64,
) -> Result<(Vec<f32>, Vec<f32>), WeightsError> {
    let g = weights.tensor(&format!("{prefix}.weight"), &[c])?;
    let beta = weights.tensor(&format!("{prefix}.bias"), &[c])?;
    let mean = weights.tensor(&format!("{prefix}.running_mean"), &[c])?;
    let var = weights.tensor(&format!("{prefix}.running_var"), &[c])?;
    let mut scale = vec![0f32; c];
    let mut shift = vec![0f32; c];
    for j in 0..c {
        let s = f64::from(g[j]) / (f64::from(var[j]) + eps).sqrt();
        scale[j] = s as f32;
        shift[j] = (f64::from(beta[j]) - f64::from(mean[j]) * s) as f32;
    }
    Ok((scale, shift))
}

impl Dense {
    /// An octree convolution (`{prefix}.conv.weights`, (kernel, cin, cout)) with its batch norm
    /// (`{prefix}.bn`).
    pub fn conv_bn(
        weights: &Weights,
        prefix: &str,
        kernel: usize,
        cin: usize,
        cout: usize,
        cfg: &Config,
    ) -> Result<Self, WeightsError> {
        let w = weights.tensor(&format!("{prefix}.conv.weights"), &[kernel, cin, cout])?;
        let (scale, shift) = batch_norm(weights, &format!("{prefix}.bn"), cout, cfg.bn_eps)?;
        let w = w
            .chunks(cout)
            .flat_map(|row| row.iter().zip(&scale).map(|(x, s)| x * s))
            .collect();
        Ok(Self {
            kernel,
            cin,
            cout,
            w,
            b: shift,
        })
    }

    /// A linear layer (`{prefix}.weight`, (cout, cin)) followed by the batch norm `bn`, or with
    /// its own bias (`{prefix}.bias`) when `bn` is `None`.
    pub fn linear(
        weights: &Weights,
        prefix: &str,
        bn: Option<&str>,
        cin: usize,
        cout: usize,
        cfg: &Config,
    ) -> Result<Self, WeightsError> {
        let w = weights.tensor(&format!("{prefix}.weight"), &[cout, cin])?;
        let (scale, shift) = match bn {
            Some(bn) => batch_norm(weights, bn, cout, cfg.bn_eps)?,
            None => (
                vec![1.0; cout],
                weights.tensor(&format!("{prefix}.bias"), &[cout])?.to_vec(),
            ),
        };
        let mut t = vec![0f32; cin * cout];
        for o in 0..cout {
            for i in 0..cin {
                t[i * cout + o] = w[o * cin + i] * scale[o];
            }
        }
        Ok(Self {
            kernel: 1,
            cin,
            cout,
            w: t,
            b: shift,
        })
    }

    /// A stride-2 deconvolution (`{prefix}.deconv.weights`, (8, cout, cin)) with its batch
    /// norm, as a map of one row to the 8 children's: cin × (8 · cout).
    pub fn deconv_bn(
        weights: &Weights,
        prefix: &str,
        cin: usize,
        cout: usize,
        cfg: &Config,
    ) -> Result<Self, WeightsError> {
        let w = weights.tensor(&format!("{prefix}.deconv.weights"), &[8, cout, cin])?;
        let (scale, shift) = batch_norm(weights, &format!("{prefix}.bn"), cout, cfg.bn_eps)?;
        let mut t = vec![0f32; cin * 8 * cout];
        for c in 0..8 {
            for o in 0..cout {
                for i in 0..cin {
                    t[i * 8 * cout + c * cout + o] = w[(c * cout + o) * cin + i] * scale[o];
                }
            }
        }
        let b = (0..8).flat_map(|_| shift.iter().copied()).collect();
        Ok(Self {
            kernel: 1,
            cin,
            cout: 8 * cout,
            w: t,
            b,
        })
    }

    /// y_r = [x_{table[r·k]} … x_{table[r·k+k−1]}] · W + b for `rows` output rows (`table`:
    /// `rows × kernel` indices into `x`, [`NONE`] for zeros; `None`: row r itself).
    pub fn apply(&self, x: &Act, table: Option<&[u32]>, rows: usize) -> Act {
        debug_assert_eq!(x.cols, self.cin);
        let (k, cin, cout) = (self.kernel, self.cin, self.cout);
        let mut out = Act::zeros(rows, cout);
        out.data
            .par_chunks_mut(BLOCK * cout)
            .enumerate()
            .for_each(|(blk, chunk)| {
                let r0 = blk * BLOCK;
                let n = chunk.len() / cout;
                let mut col;
                let input: &[f32] = match table {
                    Some(table) => {
                        col = vec![0f32; n * k * cin];
                        for r in 0..n {
                            for j in 0..k {
                                let idx = table[(r0 + r) * k + j];
                                if idx != NONE {
                                    let dst = (r * k + j) * cin;
                                    col[dst..dst + cin].copy_from_slice(x.row(idx as usize));
                                }
                            }
                        }
                        &col
                    }
                    None => &x.data[r0 * cin..(r0 + n) * cin],
                };
                for row in chunk.chunks_mut(cout) {
                    row.copy_from_slice(&self.b);
                }
                gemm(input, n, k * cin, &self.w, cout, chunk);
            });
        out
    }
}

/// c += a (m × k) · b (k × n), row-major slices.
pub fn gemm(a: &[f32], m: usize, k: usize, b: &[f32], n: usize, c: &mut [f32]) {
    let (Ok(a), Ok(b), Ok(mut c)) = (
        ArrayView2::from_shape((m, k), a),
        ArrayView2::from_shape((k, n), b),
        ArrayViewMut2::from_shape((m, n), c),
    ) else {
        unreachable!("the shapes are the callers' own")
    };
    general_mat_mul(1.0, &a, &b, 1.0, &mut c);
}
