//! Pictures of visible sets: every point drawn in the colour of its class (true positive,
//! false positive, false negative, hidden), panels composed into one captioned PNG, like seed
//! 000's Figure 5.
//!
//! Points are drawn as 2 × 2 pixel dots without a depth test, class by class: hidden points
//! first (light grey), then true positives (green), false negatives (blue) and false positives
//! (red) last, so that errors are never covered by correct points.

use std::path::Path;

use anyhow::{Result, anyhow};
use cloud::Camera;
use cloud::glam::DVec3;
use plotters::prelude::*;

use super::figure::{ensure_font, wrap_text};
use super::write_png;

/// Class colours.
pub const HIDDEN: [u8; 3] = [205, 205, 205];
/// True positive.
pub const TRUE_POSITIVE: [u8; 3] = [0, 150, 90];
/// False negative.
pub const FALSE_NEGATIVE: [u8; 3] = [0, 90, 220];
/// False positive.
pub const FALSE_POSITIVE: [u8; 3] = [225, 30, 30];

/// An RGB image with a caption.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Caption.
    pub title: String,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixels, RGB, row-major.
    pub rgb: Vec<u8>,
}

/// Draws `points` classified by `predicted` against `truth` (one flag each) as seen by
/// `camera`; with `predicted = None` the reference alone is drawn (visible green, hidden grey).
pub fn classified_panel(
    title: &str,
    camera: &Camera,
    points: &[DVec3],
    truth: &[bool],
    predicted: Option<&[bool]>,
) -> Panel {
    let (w, h) = (camera.width, camera.height);
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    let class = |i: usize| -> [u8; 3] {
        match (truth[i], predicted.map(|p| p[i])) {
            (true, None) | (true, Some(true)) => TRUE_POSITIVE,
            (true, Some(false)) => FALSE_NEGATIVE,
            (false, Some(true)) => FALSE_POSITIVE,
            (false, _) => HIDDEN,
        }
    };
    for layer in [HIDDEN, TRUE_POSITIVE, FALSE_NEGATIVE, FALSE_POSITIVE] {
        for (i, &p) in points.iter().enumerate() {
            if class(i) != layer {
                continue;
            }
            let Some((x, y)) = camera.project(p).and_then(|q| q.pixel(w, h)) else {
                continue;
            };
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (px, py) = (x + dx, y + dy);
                if px < w && py < h {
                    let k = 3 * (py as usize * w as usize + px as usize);
                    rgb[k..k + 3].copy_from_slice(&layer);
                }
            }
        }
    }
    Panel {
        title: title.to_owned(),
        width: w,
        height: h,
        rgb,
    }
}

impl Panel {
    /// The part of the panel inside the pixel rectangle [x0, x1) × [y0, y1).
    pub fn crop(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Panel {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        let (x0, y0) = (x0.min(x1), y0.min(y1));
        let mut rgb = Vec::with_capacity(((x1 - x0) * (y1 - y0) * 3) as usize);
        for y in y0..y1 {
            let row = 3 * (y as usize * self.width as usize);
            rgb.extend_from_slice(&self.rgb[row + 3 * x0 as usize..row + 3 * x1 as usize]);
        }
        Panel {
            title: self.title.clone(),
            width: x1 - x0,
            height: y1 - y0,
            rgb,
        }
    }
}

/// The pixel rectangle holding every projected point, with a margin, clamped to the image.
pub fn footprint(camera: &Camera, points: &[DVec3], margin: u32) -> (u32, u32, u32, u32) {
    let (mut x0, mut y0, mut x1, mut y1) = (camera.width, camera.height, 0, 0);
    for &p in points {
        if let Some((x, y)) = camera
            .project(p)
            .and_then(|q| q.pixel(camera.width, camera.height))
        {
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    if x0 > x1 {
        return (0, 0, camera.width, camera.height);
    }
    (
        x0.saturating_sub(margin),
        y0.saturating_sub(margin),
        (x1 + margin + 1).min(camera.width),
        (y1 + margin + 1).min(camera.height),
    )
}

/// Composes panels (all the same size) into a grid with `cols` columns, a caption over each
/// (wrapped to the panel's width: captions never run into each other) and a legend at the
/// bottom (wrapped to the picture's width); writes the PNG.
pub fn compose(panels: &[Panel], cols: usize, legend: &str, path: &Path) -> Result<()> {
    ensure_font()?;
    let first = panels
        .first()
        .ok_or_else(|| anyhow!("no panel to compose"))?;
    let (pw, ph) = (first.width, first.height);
    let rows = panels.len().div_ceil(cols) as u32;
    let w = cols as u32 * pw;
    let title_font: TextStyle = ("sans-serif", 18).into_font().color(&BLACK);
    let legend_font: TextStyle = ("sans-serif", 16).into_font().color(&BLACK);
    // Line breaks first, on a scratch area (text measuring needs a drawing area).
    let (captions, legend_lines) = {
        let mut scratch = vec![255u8; 3];
        let area = BitMapBackend::with_buffer(&mut scratch, (1, 1)).into_drawing_area();
        let captions: Vec<Vec<String>> = panels
            .iter()
            .map(|p| wrap_text(&area, &p.title, &title_font, pw.saturating_sub(16)))
            .collect();
        (
            captions,
            wrap_text(&area, legend, &legend_font, w.saturating_sub(16)),
        )
    };
    let caption_lines = captions.iter().map(Vec::len).max().unwrap_or(1).max(1) as u32;
    let caption = 8 + 21 * caption_lines;
    let legend_h = 10 + 20 * legend_lines.len() as u32;
    let h = rows * (ph + caption) + legend_h;
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        for (k, panel) in panels.iter().enumerate() {
            let (cx, cy) = ((k % cols) as u32 * pw, (k / cols) as u32 * (ph + caption));
            for (l, line) in captions[k].iter().enumerate() {
                root.draw_text(
                    line,
                    &title_font,
                    (cx as i32 + 8, cy as i32 + 5 + 21 * l as i32),
                )
                .map_err(|e| anyhow!("{e:?}"))?;
            }
            for y in 0..ph.min(panel.height) {
                for x in 0..pw.min(panel.width) {
                    let k = 3 * (y as usize * panel.width as usize + x as usize);
                    let c = &panel.rgb[k..k + 3];
                    if c != [255, 255, 255] {
                        root.draw_pixel(
                            ((cx + x) as i32, (cy + caption + y) as i32),
                            &RGBColor(c[0], c[1], c[2]),
                        )
                        .map_err(|e| anyhow!("{e:?}"))?;
                    }
                }
            }
            root.draw(&Rectangle::new(
                [
                    (cx as i32, (cy + caption) as i32),
                    ((cx + pw) as i32 - 1, (cy + caption + ph) as i32 - 1),
                ],
                RGBColor(200, 200, 200).stroke_width(1),
            ))
            .map_err(|e| anyhow!("{e:?}"))?;
        }
        for (l, line) in legend_lines.iter().enumerate() {
            root.draw_text(
                line,
                &legend_font,
                (8, (h - legend_h) as i32 + 6 + 20 * l as i32),
            )
            .map_err(|e| anyhow!("{e:?}"))?;
        }
        root.present().map_err(|e| anyhow!("{e:?}"))?;
    }
    write_png(path, w, h, &buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Long captions are wrapped: no caption pixel lies right of its own panel's column (an
    /// unwrapped caption runs into the next panel, "threshold=0.25 (F1 0.9" over "vardensity
    /// k=16 ...").
    #[test]
    fn captions_wrap_inside_their_panel() {
        let dir = tempfile::tempdir().unwrap();
        let panel = |title: &str| Panel {
            title: title.to_owned(),
            width: 240,
            height: 60,
            rgb: vec![255; 240 * 60 * 3],
        };
        let panels = vec![
            panel("screenspace tol=0.01 half_width=2 levels=3 sectors=8 threshold=0.25 (F1 0.972)"),
            panel("vardensity tol=0.01 k=16 max_radius=32 threshold=0.9 (F1 0.955)"),
        ];
        let path = dir.path().join("c.png");
        compose(&panels, 2, "a legend that is long enough to need a second line when the picture is only 480 pixels wide", &path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.width(), 480);
        // Text rows: the caption band above the first panel's frame.
        let frame_top = (0..img.height())
            .find(|&y| img.get_pixel(0, y).0 == [200, 200, 200])
            .unwrap();
        assert!(
            frame_top >= 8 + 2 * 21,
            "captions were not wrapped: {frame_top}"
        );
        for y in 0..frame_top {
            // The first caption stays left of the second panel (a margin of 4 pixels).
            for x in 236..244 {
                assert_eq!(img.get_pixel(x, y).0, [255, 255, 255], "({x}, {y})");
            }
        }
    }
}
