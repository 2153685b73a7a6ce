//! The weights file: the trained network's configuration and tensors, as the training
//! (`scripts/neuralvis/nvw.py`) writes them.
//!
//! Layout (little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `PSNVIS\0\x01` |
//! | 4 | format version ([`VERSION`]) |
//! | 4 | header length H |
//! | 8 | payload length P |
//! | H | header, JSON: `config` ([`Config`]), `tensors` (name, shape, byte offset), `record` |
//! | P | the tensors, f32, C order |
//! | 32 | SHA-256 of every byte before it |
//!
//! The tensors keep PyTorch's state-dict names and ocnn's layouts (an octree convolution's
//! `weights` is (kernel volume, in, out), a deconvolution's (8, out, in), a linear layer's
//! (out, in)) and the batch norms their running statistics: a state dict trained with ocnn is
//! exported unchanged, and the network folds the batch norms when it loads.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use sha2::{Digest, Sha256};

use crate::error::WeightsError;

/// The magic number.
pub const MAGIC: &[u8; 8] = b"PSNVIS\x00\x01";
/// The format version read here.
pub const VERSION: u32 = 1;
/// Bytes before the header.
const PREFIX: usize = 24;
/// Bytes of the checksum.
const DIGEST: usize = 32;

/// The network's configuration (the header's `config`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Config {
    /// Depth of the octree (its finest level holds the input signal).
    pub depth: u32,
    /// Levels up to this one are full in ocnn's octree.
    pub full_depth: u32,
    /// The cloud's bounding box is scaled into [-scale, scale]^3.
    pub scale: f64,
    /// The input signal (`LP`: local and global mean point of each finest node).
    pub feature: String,
    /// Channels of the input signal.
    pub in_channels: usize,
    /// Widths of the encoder: the first convolution's, then each stage's.
    pub encoder_channels: Vec<usize>,
    /// Widths of the decoder: the bottom's, then each stage's.
    pub decoder_channels: Vec<usize>,
    /// Residual blocks per encoder stage.
    pub encoder_blocks: Vec<usize>,
    /// Residual blocks per decoder stage.
    pub decoder_blocks: Vec<usize>,
    /// Channels of the point feature (= the encoding's width).
    pub feature_channels: usize,
    /// Frequencies of the positional encoding of the view direction.
    pub multires: usize,
    /// Hidden widths of the head.
    pub head_channels: Vec<usize>,
    /// Batch norm's epsilon.
    pub bn_eps: f64,
    /// The point interpolation (`linear`).
    pub interp: String,
    /// Convolutions over non-empty nodes only.
    pub nempty: bool,
}

impl Config {
    /// Number of encoder (and decoder) stages.
    pub fn stages(&self) -> usize {
        self.encoder_blocks.len()
    }

    /// Checks that this build implements the configuration.
    fn check(&self) -> Result<(), String> {
        let s = self.stages();
        if self.feature != "LP" || self.in_channels != 6 {
            return Err(format!(
                "input signal {} with {} channels (only LP, 6 channels, is implemented)",
                self.feature, self.in_channels
            ));
        }
        if self.interp != "linear" || !self.nempty {
            return Err("only linear interpolation over non-empty nodes is implemented".into());
        }
        if !(1..=16).contains(&self.depth) || s == 0 || (self.depth as usize) < s {
            return Err(format!("octree depth {} with {s} stages", self.depth));
        }
        if (self.depth as usize - s) < self.full_depth as usize {
            return Err(format!(
                "the bottom level {} is above the full depth {}: empty nodes would take part",
                self.depth as usize - s,
                self.full_depth
            ));
        }
        if self.encoder_channels.len() != s + 1
            || self.decoder_channels.len() != s + 1
            || self.decoder_blocks.len() != s
            || self.decoder_channels[0] != self.encoder_channels[s]
        {
            return Err("inconsistent stage lists".into());
        }
        if self.feature_channels != 3 + 6 * self.multires {
            return Err(format!(
                "feature width {} is not the encoding's 3 + 6 x {}",
                self.feature_channels, self.multires
            ));
        }
        if self.head_channels.is_empty() || !(self.scale > 0.0 && self.scale < 1.0) {
            return Err("empty head or scale outside (0, 1)".into());
        }
        if !(self.bn_eps > 0.0) {
            return Err("batch norm epsilon must be > 0".into());
        }
        Ok(())
    }
}

#[derive(Deserialize)]
struct Header {
    config: Config,
    tensors: Vec<Entry>,
    #[serde(default)]
    record: serde_json::Value,
}

#[derive(Deserialize)]
struct Entry {
    name: String,
    shape: Vec<usize>,
    offset: usize,
}

/// One tensor.
#[derive(Debug, Clone)]
pub struct Tensor {
    /// Its shape.
    pub shape: Vec<usize>,
    /// Its values, C order.
    pub data: Vec<f32>,
}

/// A checked weights file.
#[derive(Debug, Clone)]
pub struct Weights {
    /// Where it came from (a path, or a name for built-in bytes).
    pub source: PathBuf,
    /// The configuration.
    pub config: Config,
    /// The training's summary (seed, revision, steps, wall time) as the file records it.
    pub record: serde_json::Value,
    /// Hex SHA-256 of the file's content.
    pub sha256: String,
    tensors: HashMap<String, Tensor>,
}

impl Weights {
    /// Reads and checks `path`.
    pub fn load(path: &Path) -> Result<Self, WeightsError> {
        let bytes = std::fs::read(path).map_err(|e| WeightsError::Unreadable {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Checks `bytes` (named `source` in errors).
    pub fn from_bytes(bytes: &[u8], source: &Path) -> Result<Self, WeightsError> {
        let path = || source.to_owned();
        let len = bytes.len() as u64;
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            // A prefix of the magic number is a truncated file of ours, anything else foreign.
            return Err(if !bytes.is_empty() && MAGIC.starts_with(bytes) {
                WeightsError::Truncated {
                    path: path(),
                    expected: (PREFIX + DIGEST) as u64,
                    found: len,
                }
            } else {
                WeightsError::Foreign { path: path() }
            });
        }
        if bytes.len() < PREFIX {
            return Err(WeightsError::Truncated {
                path: path(),
                expected: (PREFIX + DIGEST) as u64,
                found: len,
            });
        }
        let u32_at =
            |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
        let version = u32_at(8);
        if version != VERSION {
            return Err(WeightsError::Version {
                path: path(),
                found: version,
                supported: VERSION,
            });
        }
        let header_len = u64::from(u32_at(12));
        let mut p = [0u8; 8];
        p.copy_from_slice(&bytes[16..24]);
        let payload_len = u64::from_le_bytes(p);
        let expected = (PREFIX as u64)
            .saturating_add(header_len)
            .saturating_add(payload_len)
            .saturating_add(DIGEST as u64);
        if len < expected {
            return Err(WeightsError::Truncated {
                path: path(),
                expected,
                found: len,
            });
        }
        if len > expected {
            return Err(WeightsError::Invalid {
                path: path(),
                reason: format!("{} bytes after the checksum", len - expected),
            });
        }
        let body = bytes.len() - DIGEST;
        let digest = Sha256::digest(&bytes[..body]);
        if digest.as_slice() != &bytes[body..] {
            return Err(WeightsError::Checksum { path: path() });
        }
        let invalid = |reason: String| WeightsError::Invalid {
            path: path(),
            reason,
        };
        let header_end = PREFIX + header_len as usize;
        let header: Header = serde_json::from_slice(&bytes[PREFIX..header_end])
            .map_err(|e| invalid(format!("its header is not the expected JSON: {e}")))?;
        header.config.check().map_err(invalid)?;
        let payload = &bytes[header_end..body];
        let mut tensors = HashMap::with_capacity(header.tensors.len());
        for e in header.tensors {
            let count = e
                .shape
                .iter()
                .try_fold(1usize, |a, &d| a.checked_mul(d))
                .ok_or_else(|| invalid(format!("tensor {} has an absurd shape", e.name)))?;
            let end = count
                .checked_mul(4)
                .and_then(|b| b.checked_add(e.offset))
                .filter(|&end| end <= payload.len() && e.offset % 4 == 0)
                .ok_or_else(|| invalid(format!("tensor {} lies outside the payload", e.name)))?;
            let data = payload[e.offset..end]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect::<Vec<_>>();
            if data.iter().any(|x| !x.is_finite()) {
                return Err(invalid(format!("tensor {} has a non-finite value", e.name)));
            }
            tensors.insert(
                e.name,
                Tensor {
                    shape: e.shape,
                    data,
                },
            );
        }
        Ok(Self {
            source: path(),
            config: header.config,
            record: header.record,
            sha256: digest.iter().map(|b| format!("{b:02x}")).collect(),
            tensors,
        })
    }

    /// The tensor `name`, which must have `shape`.
    pub fn tensor(&self, name: &str, shape: &[usize]) -> Result<&[f32], WeightsError> {
        let t = self
            .tensors
            .get(name)
            .ok_or_else(|| WeightsError::Invalid {
                path: self.source.clone(),
                reason: format!("tensor {name} is missing"),
            })?;
        if t.shape != shape {
            return Err(WeightsError::Invalid {
                path: self.source.clone(),
                reason: format!("tensor {name} has shape {:?}, expected {shape:?}", t.shape),
            });
        }
        Ok(&t.data)
    }

    /// Number of tensors.
    pub fn len(&self) -> usize {
        self.tensors.len()
    }

    /// True when there is no tensor.
    pub fn is_empty(&self) -> bool {
        self.tensors.is_empty()
    }
}
