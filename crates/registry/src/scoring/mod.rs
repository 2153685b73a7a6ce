//! Scoring, the callers' (methods return indices or splats; never a score): a visible set
//! against a ground truth ([`sets`]: precision, recall, F1, Jaccard) and a render against a
//! reference render ([`image`]: PSNR, SSIM, holes).

pub mod image;
pub mod sets;

pub use image::{hole_fraction, psnr, ssim};
pub use sets::Score;
