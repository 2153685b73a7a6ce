//! Scoring, the callers' (methods return indices or splats; never a score): a visible set
//! against a ground truth ([`sets`]: precision, recall, F1, Jaccard), the image a visibility
//! method shows against the truth ([`pixels`]: pixel precision, coverage, their F1; a visible
//! set's image derived when the method gives none) and a render against a reference render
//! ([`image`]: PSNR, SSIM, holes).

pub mod image;
pub mod pixels;
pub mod sets;

pub use image::{hole_fraction, psnr, ssim};
pub use pixels::PixelScore;
pub use sets::Score;
