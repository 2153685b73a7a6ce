//! From per-pixel verdicts to points: the answer of a per-pixel operator.
//!
//! Both papers decide pixels: a pixel of the depth buffer is kept or discarded, and the point
//! it holds is what the final image shows (Pintus et al. 2011, §4, before hole filling;
//! Biasutti et al. 2019, §3, per projected point). A point that lost its pixel to a nearer
//! point is not shown, so it is not visible. Extension (not in either paper, off at 0):
//! `depth_tolerance` also counts as visible a point whose pixel is kept and whose depth is
//! within a relative `depth_tolerance` of the pixel's point (the splat baseline's rule, so that
//! several samples of one surface falling into one pixel are not all but one called hidden).

use crate::depth::{DepthBuffer, EMPTY};

/// The outcome of a screen-space operator for one view.
#[derive(Debug, Clone)]
pub struct Verdict {
    /// Indices of the visible points, ascending.
    pub visible: Vec<u32>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Per pixel (row-major): the point the pixel shows when the operator keeps it, else
    /// [`EMPTY`].
    pub pixel_point: Vec<u32>,
    /// Per point: the operator's score of its pixel (higher = more visible; 0 for points that
    /// are not in view or not within the tolerance of their pixel's point).
    pub score: Vec<f32>,
    /// Pixels that held a point.
    pub occupied: usize,
}

/// Checks a relative depth tolerance: finite and ≥ 0.
pub fn check_tolerance(depth_tolerance: f64) -> crate::Result<()> {
    if !(depth_tolerance >= 0.0 && depth_tolerance.is_finite()) {
        return Err(crate::Error::InvalidParameter {
            name: "depth_tolerance",
            reason: format!("{depth_tolerance}: must be a finite number >= 0"),
        });
    }
    Ok(())
}

/// The verdict from each pixel's score (`NaN` for empty pixels) and keep flag.
pub fn select(
    buffer: &DepthBuffer,
    pixel_score: &[f64],
    keep: impl Fn(f64) -> bool,
    depth_tolerance: f64,
) -> Verdict {
    let n = buffer.pixel_of.len();
    let pixel_point: Vec<u32> = buffer
        .point
        .iter()
        .zip(pixel_score)
        .map(|(&p, &s)| if p != EMPTY && keep(s) { p } else { EMPTY })
        .collect();
    let mut score = vec![0.0f32; n];
    let mut visible = Vec::new();
    for i in 0..n {
        let px = buffer.pixel_of[i];
        if px == EMPTY {
            continue;
        }
        let owner = buffer.point[px as usize];
        let own = owner == i as u32;
        let near = own
            || (depth_tolerance > 0.0
                && buffer.depth[i] <= buffer.depth[owner as usize] * (1.0 + depth_tolerance));
        if !near {
            continue;
        }
        score[i] = pixel_score[px as usize] as f32;
        if pixel_point[px as usize] != EMPTY {
            visible.push(i as u32);
        }
    }
    Verdict {
        visible,
        width: buffer.width,
        height: buffer.height,
        pixel_point,
        score,
        occupied: buffer.occupied,
    }
}
