//! Plots as PNG files, on a headless machine without system fonts (the scale experiment's,
//! until it moves to [`super::figure`]).
//!
//! `plotters` draws into an in-memory RGB buffer with its `ab_glyph` text backend and the
//! DejaVu Sans font embedded by the `dejavu` crate (registered once as "sans-serif"), so no
//! font lookup can fail; the `image` crate encodes the PNG, written atomically. Logarithmic
//! axes are drawn as linear axes over log10 of the data with ticks labelled 10^k, which keeps
//! one code path for every axis combination.

use std::path::Path;

use anyhow::{Result, anyhow, bail};
use plotters::prelude::*;

use super::write_png;

/// A colour-blind-safe palette (Okabe–Ito), then greys.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(240, 228, 66),
    RGBColor(0, 0, 0),
    RGBColor(120, 120, 120),
    RGBColor(180, 180, 180),
];

const FONT: &str = "sans-serif";

use super::figure::ensure_font;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// A polyline through the points in order.
    Line,
    /// Filled circles.
    Points,
    /// Both.
    LinePoints,
    /// Hollow circles, larger (to mark a subset such as a Pareto front).
    Rings,
}

/// One named series of (x, y) points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Data.
    pub points: Vec<(f64, f64)>,
    /// How to draw it.
    pub mark: Mark,
    /// Palette index; by default the series' position.
    pub color: Option<usize>,
    /// Per point, the spread of x drawn as a horizontal bar (low, high); empty: none.
    pub x_spread: Vec<(f64, f64)>,
    /// Per point, the spread of y drawn as a vertical bar (low, high); empty: none.
    pub y_spread: Vec<(f64, f64)>,
}

impl Series {
    /// A series with the default colour.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Self {
            label: label.into(),
            points,
            mark,
            color: None,
            x_spread: Vec::new(),
            y_spread: Vec::new(),
        }
    }
}

/// An x–y chart.
#[derive(Debug, Clone, Default)]
pub struct Chart {
    /// Caption.
    pub title: String,
    /// X axis description.
    pub x_label: String,
    /// Y axis description.
    pub y_label: String,
    /// Logarithmic x axis (data must be positive).
    pub x_log: bool,
    /// Logarithmic y axis (data must be positive).
    pub y_log: bool,
    /// Fixed y range (in data units), else fitted.
    pub y_range: Option<(f64, f64)>,
    /// The series.
    pub series: Vec<Series>,
}

fn transform(v: f64, log: bool) -> Option<f64> {
    if log {
        (v > 0.0 && v.is_finite()).then(|| v.log10())
    } else {
        v.is_finite().then_some(v)
    }
}

fn tick(v: f64, log: bool) -> String {
    if log {
        let value = 10f64.powf(v);
        if (v - v.round()).abs() < 1e-9 {
            format_number(value)
        } else {
            String::new()
        }
    } else {
        format_number(v)
    }
}

/// Short human formatting for tick labels.
pub fn format_number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if a >= 1e6 {
        format!("{:.0}M", v / 1e6)
    } else if a >= 1e4 {
        format!("{:.0}k", v / 1e3)
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned()
    } else if a >= 1e-3 {
        format!("{v:.4}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned()
    } else {
        format!("{v:.0e}")
    }
}

fn padded(lo: f64, hi: f64, log: bool) -> (f64, f64) {
    if lo == hi {
        let d = if log { 0.5 } else { lo.abs().max(1.0) * 0.05 };
        (lo - d, hi + d)
    } else {
        let d = (hi - lo) * 0.05;
        (lo - d, hi + d)
    }
}

impl Chart {
    /// Renders the chart to a `width` × `height` PNG at `path`.
    pub fn save(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        ensure_font()?;
        let data: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| {
                s.points
                    .iter()
                    .filter_map(|&(x, y)| {
                        Some((transform(x, self.x_log)?, transform(y, self.y_log)?))
                    })
                    .collect()
            })
            .collect();
        let all: Vec<(f64, f64)> = data.iter().flatten().copied().collect();
        if all.is_empty() {
            bail!("chart {:?} has no plottable point", self.title);
        }
        let (x0, x1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        let (mut y0, mut y1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        if let Some((lo, hi)) = self.y_range {
            y0 = transform(lo, self.y_log).unwrap_or(y0);
            y1 = transform(hi, self.y_log).unwrap_or(y1);
        }
        let (x0, x1) = padded(x0, x1, self.x_log);
        let (y0, y1) = if self.y_range.is_some() {
            (y0, y1)
        } else {
            padded(y0, y1, self.y_log)
        };

        let mut buf = vec![255u8; width as usize * height as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("{e:?}"))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, (FONT, 20))
                .margin(14)
                .x_label_area_size(48)
                .y_label_area_size(72)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| anyhow!("{e:?}"))?;
            let (xl, yl) = (self.x_log, self.y_log);
            let x_fmt = move |v: &f64| tick(*v, xl);
            let y_fmt = move |v: &f64| tick(*v, yl);
            chart
                .configure_mesh()
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| anyhow!("{e:?}"))?;
            for (i, s) in self.series.iter().enumerate() {
                let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
                // Spread bars first, under the marks.
                let mut bars = Vec::new();
                for (k, &(x, y)) in s.points.iter().enumerate() {
                    if let Some(&(lo, hi)) = s.x_spread.get(k) {
                        bars.push([(lo, y), (hi, y)]);
                    }
                    if let Some(&(lo, hi)) = s.y_spread.get(k) {
                        bars.push([(x, lo), (x, hi)]);
                    }
                }
                let (xl, yl) = (self.x_log, self.y_log);
                chart
                    .draw_series(bars.into_iter().filter_map(|[a, b]| {
                        let a = (transform(a.0, xl)?, transform(a.1, yl)?);
                        let b = (transform(b.0, xl)?, transform(b.1, yl)?);
                        Some(PathElement::new(vec![a, b], color.mix(0.6).stroke_width(1)))
                    }))
                    .map_err(|e| anyhow!("{e:?}"))?;
            }
            for (i, (s, pts)) in self.series.iter().zip(&data).enumerate() {
                let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
                let anno = match s.mark {
                    Mark::Line | Mark::LinePoints => {
                        if s.mark == Mark::LinePoints {
                            chart
                                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                                .map_err(|e| anyhow!("{e:?}"))?;
                        }
                        chart
                            .draw_series(LineSeries::new(
                                pts.iter().copied(),
                                color.stroke_width(2),
                            ))
                            .map_err(|e| anyhow!("{e:?}"))?
                    }
                    Mark::Points => chart
                        .draw_series(
                            pts.iter()
                                .map(|&p| Circle::new(p, 3, color.mix(0.75).filled())),
                        )
                        .map_err(|e| anyhow!("{e:?}"))?,
                    Mark::Rings => chart
                        .draw_series(
                            pts.iter()
                                .map(|&p| Circle::new(p, 7, color.stroke_width(2))),
                        )
                        .map_err(|e| anyhow!("{e:?}"))?,
                };
                if !s.label.is_empty() {
                    anno.label(s.label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
                    });
                }
            }
            if self.series.iter().any(|s| !s.label.is_empty()) {
                chart
                    .configure_series_labels()
                    .label_font((FONT, 13))
                    .background_style(WHITE.mix(0.85))
                    .border_style(RGBColor(160, 160, 160))
                    .position(SeriesLabelPosition::LowerRight)
                    .draw()
                    .map_err(|e| anyhow!("{e:?}"))?;
            }
            root.present().map_err(|e| anyhow!("{e:?}"))?;
        }
        write_png(path, width, height, &buf)
    }
}

/// A grouped bar chart: one cluster per category, one bar per group.
#[derive(Debug, Clone, Default)]
pub struct Bars {
    /// Caption.
    pub title: String,
    /// Y axis description.
    pub y_label: String,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// Cluster names along x.
    pub categories: Vec<String>,
    /// (group name, one value per category; `None` for a missing bar).
    pub groups: Vec<(String, Vec<Option<f64>>)>,
}

impl Bars {
    /// Renders the bars to a PNG.
    pub fn save(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        ensure_font()?;
        let values: Vec<f64> = self
            .groups
            .iter()
            .flat_map(|(_, v)| v.iter().flatten().filter_map(|&v| transform(v, self.y_log)))
            .collect();
        if values.is_empty() {
            bail!("bar chart {:?} has no plottable value", self.title);
        }
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (y0, y1) = if self.y_log {
            (lo.floor(), hi.ceil().max(lo.floor() + 1.0))
        } else {
            (0.0f64.min(lo), hi * 1.08)
        };
        let n_cat = self.categories.len().max(1);
        let n_grp = self.groups.len().max(1);
        // Many groups: an empty slot on the right holds the legend, clear of the bars.
        let spare = usize::from(n_grp > 6);
        let mut buf = vec![255u8; width as usize * height as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("{e:?}"))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, (FONT, 20))
                .margin(14)
                .x_label_area_size(48)
                .y_label_area_size(72)
                .build_cartesian_2d(0.0..(n_cat + spare) as f64, y0..y1)
                .map_err(|e| anyhow!("{e:?}"))?;
            let cats = self.categories.clone();
            let x_fmt = move |v: &f64| {
                let i = v.floor() as usize;
                if (v - i as f64 - 0.5).abs() < 1e-6 {
                    cats.get(i).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            };
            let yl = self.y_log;
            let y_fmt = move |v: &f64| tick(*v, yl);
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(2 * (n_cat + spare) + 1)
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .y_desc(&self.y_label)
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| anyhow!("{e:?}"))?;
            let slot = 0.8 / n_grp as f64;
            for (g, (name, vals)) in self.groups.iter().enumerate() {
                let color = PALETTE[g % PALETTE.len()];
                let rects: Vec<Rectangle<(f64, f64)>> = vals
                    .iter()
                    .enumerate()
                    .filter_map(|(c, v)| {
                        let v = transform((*v)?, self.y_log)?;
                        let x = c as f64 + 0.1 + g as f64 * slot;
                        Some(Rectangle::new(
                            [(x, y0), (x + slot * 0.92, v)],
                            color.filled(),
                        ))
                    })
                    .collect();
                chart
                    .draw_series(rects)
                    .map_err(|e| anyhow!("{e:?}"))?
                    .label(name.clone())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
                    });
            }
            chart
                .configure_series_labels()
                .label_font((FONT, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .position(if spare > 0 {
                    SeriesLabelPosition::UpperRight
                } else {
                    SeriesLabelPosition::UpperLeft
                })
                .draw()
                .map_err(|e| anyhow!("{e:?}"))?;
            root.present().map_err(|e| anyhow!("{e:?}"))?;
        }
        write_png(path, width, height, &buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_render_to_valid_pngs() {
        let dir = tempfile::tempdir().unwrap();
        let chart = Chart {
            title: "test".into(),
            x_label: "points".into(),
            y_label: "seconds".into(),
            x_log: true,
            y_log: true,
            y_range: None,
            series: vec![
                Series::new(
                    "a",
                    vec![(10.0, 0.1), (100.0, 1.0), (1000.0, 3.0)],
                    Mark::LinePoints,
                ),
                Series::new("b", vec![(20.0, 0.5)], Mark::Rings),
            ],
        };
        let path = dir.path().join("c.png");
        chart.save(&path, 640, 400).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (640, 400));
        // Something other than white was drawn.
        assert!(img.pixels().filter(|p| p.0 != [255, 255, 255]).count() > 2000);

        let bars = Bars {
            title: "bars".into(),
            y_label: "s".into(),
            y_log: false,
            categories: vec!["x".into(), "y".into()],
            groups: vec![
                ("g1".into(), vec![Some(1.0), None]),
                ("g2".into(), vec![Some(2.0), Some(3.0)]),
            ],
        };
        bars.save(&dir.path().join("b.png"), 500, 300).unwrap();
    }

    #[test]
    fn empty_chart_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let chart = Chart {
            x_log: true,
            series: vec![Series::new("a", vec![(0.0, 1.0)], Mark::Line)],
            ..Chart::default()
        };
        assert!(chart.save(&dir.path().join("x.png"), 100, 100).is_err());
    }
}
