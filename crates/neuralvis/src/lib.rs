//! Learned point visibility: the network of Wang, Tian, Chen and Wang, "Neural Visibility of
//! Point Sets" (SIGGRAPH Asia 2025, arXiv 2509.24150), run in Rust; our training of their
//! design (`scripts/train-neuralvis.sh`).
//!
//! Visibility is a per-point binary classification (§3). The feature pass, once per cloud
//! ([`Model::features`], §3.1): the cloud is scaled by its bounding box into [−0.8, 0.8]^3
//! (their code's `normalize(bbmin, bbmax, scale=0.8)`), an octree of depth 8 is built over it
//! ([`octree`], ocnn's), each finest node carries its points' mean, local and global ("LP", 6
//! channels, no normals), and an octree U-Net (ResNet blocks of two 3×3×3 octree convolutions
//! with batch norm, stride-2 convolutions down and deconvolutions up, skip connections; [`net`])
//! gives each finest node a 63-channel feature, interpolated trilinearly at each point. The
//! head, per view ([`Model::probabilities`], §3.2): the point's feature times NeRF's positional
//! encoding of the unit direction from the eye to the point (10 frequencies, 63 channels) goes
//! through a shared MLP (two hidden layers with batch norm and ReLU, 128 and 64 wide) to two
//! logits; P(visible) is the softmax's second, and a point is visible when it reaches the
//! threshold (0.5 is the paper's argmax). The octree convolution is written here (no crate has
//! one) in ocnn's neighbour order, so a state dict trained with ocnn loads unchanged
//! ([`weights`]); the dense products are `ndarray`'s.
//!
//! What differs from the paper, and why:
//! - the committed weights are a smaller instance of the same network (`Config::cpu` in the
//!   training: half the channels, encoder blocks 1, 1, 2, 2 instead of 2, 3, 4, 6, decoder
//!   blocks 1 instead of 2; 4.3 M parameters against 39 M, 17 MB against 157 MB): trained on 2
//!   CPU cores and committed under 20 MB. The paper's configuration loads and runs here too;
//! - trained on 29 meshes of Debian's `libcgal-demo` (never a tuning or evaluation dataset's),
//!   with labels from our reference (`truth`: the z-buffer with exact silhouettes) instead of
//!   their ray–triangle test, eyes at 1.1 to 3 box diagonals in random directions, random
//!   rotations, and `cloud::degrade`'s noise, jitter, density fall-off, density fields and
//!   outliers (their augmentation is noise only); the training record beside the weights gives
//!   the steps, seed, wall time, loss curve and validation F1;
//! - the view direction and its encoding are computed in f64 and rounded to f32 (theirs in
//!   f32), here and in our training alike, so the two agree to rounding;
//! - the direction is from the camera's ray origin for the point (the eye; for an orthographic
//!   camera, the foot of the point on the near plane), so every camera model is answered; like
//!   the paper, no frustum test: a point outside the image is judged by its direction alone.
//!
//! A cloud at any scale and position is normalised as the paper does (its bounding box), so
//! only its shape matters; the octree's resolution (2^8 cells along the box's longest side)
//! bounds the detail the features see, whatever the number of points.

pub mod error;
pub mod layers;
pub mod net;
pub mod octree;
pub mod weights;

use std::path::Path;

use cloud::Camera;
use cloud::glam::DVec3;
use rayon::prelude::*;

pub use error::{Error, Result, WeightsError};
pub use weights::{Config, Weights};

/// Points per block of the head.
const HEAD_BLOCK: usize = 2048;

/// The name the committed weights go by.
pub const COMMITTED: &str = "committed";

/// The committed weights (`weights/neuralvis.nvw`, with its training record
/// `weights/neuralvis.training.json`), built into the crate.
pub const COMMITTED_BYTES: &[u8] = include_bytes!("../weights/neuralvis.nvw");

/// A loaded network.
#[derive(Debug, Clone)]
pub struct Model {
    weights: Weights,
    unet: net::UNet,
    head: net::Head,
}

/// The features of one cloud's points (the feature pass's result).
#[derive(Debug, Clone)]
pub struct Features {
    /// Channels per point.
    pub channels: usize,
    /// Per point, row-major.
    pub data: Vec<f32>,
    /// Non-empty finest nodes of the octree.
    pub nodes: usize,
}

impl Features {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.data.len() / self.channels.max(1)
    }

    /// True when there is no point.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

impl Model {
    /// The network of a weights file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_weights(Weights::load(path)?)
    }

    /// The committed network. Its weights are checked and its layers folded once per process
    /// (a constant of the build, like the bytes it comes from); every later call copies it, so
    /// a sweep's settings do not each pay the checksum and the folding.
    pub fn committed() -> Result<Self> {
        static FOLDED: std::sync::OnceLock<Model> = std::sync::OnceLock::new();
        if let Some(model) = FOLDED.get() {
            return Ok(model.clone());
        }
        let model =
            Self::from_weights(Weights::from_bytes(COMMITTED_BYTES, Path::new(COMMITTED))?)?;
        Ok(FOLDED.get_or_init(|| model).clone())
    }

    /// The network of checked weights.
    pub fn from_weights(weights: Weights) -> Result<Self> {
        Ok(Self {
            unet: net::UNet::load(&weights)?,
            head: net::Head::load(&weights)?,
            weights,
        })
    }

    /// The same network run on an octree of `depth` levels (the weights were trained at
    /// theirs; another depth changes the resolution the features see).
    pub fn with_depth(&self, depth: u32) -> Result<Self> {
        let cfg = &self.weights.config;
        let lowest = cfg.full_depth as usize + cfg.stages();
        if !(lowest..=16).contains(&(depth as usize)) {
            return Err(Error::InvalidParameter {
                name: "depth",
                reason: format!(
                    "{depth} is outside {lowest}..=16 (the network has {} stages above ocnn's full \
                     depth {})",
                    cfg.stages(),
                    cfg.full_depth
                ),
            });
        }
        let mut model = self.clone();
        model.weights.config.depth = depth;
        model.unet = net::UNet::load(&model.weights)?;
        Ok(model)
    }

    /// Its weights (configuration, record, checksum).
    pub fn weights(&self) -> &Weights {
        &self.weights
    }

    /// The points scaled by their bounding box into [−scale, scale]^3, in f32 (the paper's
    /// normalisation, computed in f64).
    pub fn normalise(&self, points: &[DVec3]) -> Result<Vec<[f32; 3]>> {
        if points.is_empty() {
            return Err(Error::Input("the cloud is empty".into()));
        }
        cloud::points::check_finite(points)?;
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let centre = (lo + hi) * 0.5;
        let d = hi - lo;
        let extent = d.x.max(d.y).max(d.z) + 1e-6;
        let factor = (2.0 * self.weights.config.scale) / extent;
        if !factor.is_finite() {
            return Err(Error::Input(format!(
                "the cloud's extent {extent} cannot be normalised"
            )));
        }
        Ok(points
            .par_iter()
            .map(|p| {
                [
                    ((p.x - centre.x) * factor) as f32,
                    ((p.y - centre.y) * factor) as f32,
                    ((p.z - centre.z) * factor) as f32,
                ]
            })
            .collect())
    }

    /// The feature pass: every point's view-independent feature.
    pub fn features(&self, points: &[DVec3]) -> Result<Features> {
        let cfg = &self.weights.config;
        let normalised = self.normalise(points)?;
        let top = cfg.depth - cfg.stages() as u32;
        let octree = octree::Octree::build(&normalised, cfg.depth, top);
        let nodes = self.unet.node_features(&octree);
        let per_point = net::interpolate(&nodes, &octree);
        Ok(Features {
            channels: per_point.cols,
            data: per_point.data,
            nodes: octree.level(cfg.depth).len(),
        })
    }

    /// P(visible) of each point seen from `camera` (the direction from the camera's ray origin
    /// for the point to the point).
    pub fn probabilities(
        &self,
        features: &Features,
        points: &[DVec3],
        camera: &Camera,
    ) -> Result<Vec<f32>> {
        self.probabilities_from(features, points, |p| camera.ray_origin_for(p))
    }

    /// P(visible) of each point with rays from `origin(p)`.
    pub fn probabilities_from(
        &self,
        features: &Features,
        points: &[DVec3],
        origin: impl Fn(DVec3) -> DVec3 + Sync,
    ) -> Result<Vec<f32>> {
        if features.len() != points.len()
            || features.channels != self.weights.config.feature_channels
        {
            return Err(Error::Input(format!(
                "features of {} points for a cloud of {}",
                features.len(),
                points.len()
            )));
        }
        let c = features.channels;
        let mut out = vec![0f32; points.len()];
        out.par_chunks_mut(HEAD_BLOCK)
            .zip(points.par_chunks(HEAD_BLOCK))
            .zip(features.data.par_chunks(HEAD_BLOCK * c))
            .for_each(|((out, pts), feat)| {
                let dirs: Vec<[f64; 3]> = pts
                    .iter()
                    .map(|&p| {
                        let d = p - origin(p);
                        let len = (d.x * d.x + d.y * d.y + d.z * d.z).sqrt();
                        if len > 0.0 {
                            [d.x / len, d.y / len, d.z / len]
                        } else {
                            [0.0; 3]
                        }
                    })
                    .collect();
                out.copy_from_slice(&self.head.probabilities(feat, &dirs));
            });
        Ok(out)
    }
}

/// Indices (ascending) of the probabilities that reach `threshold`.
pub fn visible(probabilities: &[f32], threshold: f32) -> Vec<u32> {
    probabilities
        .iter()
        .enumerate()
        .filter_map(|(i, &p)| (p >= threshold).then_some(i as u32))
        .collect()
}
