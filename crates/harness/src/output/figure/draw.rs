//! The PNG of a figure: panels, axes zoomed to the data, dashed lines and shaped markers in
//! pixel space, the legend in a column right of the panels (see the parent module).

use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::*;

pub(super) const PANEL_W: u32 = 320;
pub(super) const PANEL_H: u32 = 250;

impl Figure {
    /// A small multiple's size: larger when there are few.
    pub(super) fn panel_size(&self) -> (u32, u32) {
        match self.panels.len() {
            0..=2 => (480, 340),
            3 | 4 => (420, 300),
            _ => (PANEL_W, PANEL_H),
        }
    }
}
pub(super) const TITLE_H: u32 = 40;

pub(super) fn transform(v: f64, log: bool) -> Option<f64> {
    if log {
        (v > 0.0 && v.is_finite()).then(|| v.log10())
    } else {
        v.is_finite().then_some(v)
    }
}

pub(super) fn tick(v: f64, log: bool) -> String {
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

/// The share of the y range added on top of a figure with a numbered front, so the numbers above
/// its highest points stay inside the plot, clear of the panel's title.
const FRONT_HEADROOM: f64 = 0.14;

/// The range of `values` padded by 5 % (half a decade, or 5 % of the value, when flat).
pub(super) fn padded(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo > hi {
        return None;
    }
    Some(if lo == hi {
        let d = if log { 0.5 } else { lo.abs().max(1e-3) * 0.05 };
        (lo - d, hi + d)
    } else {
        let d = (hi - lo) * 0.05;
        (lo - d, hi + d)
    })
}

/// The on/off pieces of the polyline `pts` under a dash `pattern` (pixels; empty: the whole
/// line), continuing the pattern across vertices.
pub fn dash_segments(pts: &[(f64, f64)], pattern: &[f64]) -> Vec<[(f64, f64); 2]> {
    let mut out = Vec::new();
    if pattern.is_empty() {
        out.extend(pts.windows(2).map(|w| [w[0], w[1]]));
        return out;
    }
    let (mut k, mut left) = (0usize, pattern[0]);
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let mut t = 0.0;
        while t < len {
            let step = left.min(len - t);
            if k % 2 == 0 {
                let p = |s: f64| (a.0 + (b.0 - a.0) * s / len, a.1 + (b.1 - a.1) * s / len);
                out.push([p(t), p(t + step)]);
            }
            t += step;
            left -= step;
            if left <= 1e-9 {
                k = (k + 1) % pattern.len();
                left = pattern[k];
            }
        }
    }
    out
}

/// `text` cut to at most `width` pixels in `font`, with an ellipsis when cut.
pub(super) fn fit_text(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    text: &str,
    font: &TextStyle,
    width: u32,
) -> String {
    let fits = |t: &str| {
        area.estimate_text_size(t, font)
            .map(|(w, _)| w <= width)
            .unwrap_or(true)
    };
    if fits(text) {
        return text.to_owned();
    }
    let chars: Vec<char> = text.chars().collect();
    let (mut lo, mut hi) = (0usize, chars.len());
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        let t: String = chars[..mid].iter().collect::<String>() + "…";
        if fits(&t) { lo = mid } else { hi = mid - 1 }
    }
    chars[..lo].iter().collect::<String>() + "…"
}

/// The lines of `text` wrapped at spaces to at most `width` pixels in `font` (a word longer
/// than the width is cut with an ellipsis).
pub(crate) fn wrap_text(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    text: &str,
    font: &TextStyle,
    width: u32,
) -> Vec<String> {
    let fits = |t: &str| {
        area.estimate_text_size(t, font)
            .map(|(w, _)| w <= width)
            .unwrap_or(true)
    };
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let candidate = if line.is_empty() {
            word.to_owned()
        } else {
            format!("{line} {word}")
        };
        if fits(&candidate) {
            line = candidate;
        } else {
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            line = if fits(word) {
                word.to_owned()
            } else {
                fit_text(area, word, font, width)
            };
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The width in pixels of `text` in the figures' font at `size` points.
pub(super) fn text_width(text: &str, size: u32) -> u32 {
    let mut scratch = vec![255u8; 3];
    let area = BitMapBackend::with_buffer(&mut scratch, (1, 1)).into_drawing_area();
    area.estimate_text_size(text, &(FONT, size).into_font().into())
        .map_or(0, |(w, _)| w)
}

/// The letter standing for category `k` when the names do not fit under their slots.
pub(super) fn category_key(k: usize) -> String {
    let letters = b"abcdefghijklmnopqrstuvwxyz";
    format!(
        "{}{}",
        letters[k % 26] as char,
        if k >= 26 {
            (k / 26).to_string()
        } else {
            String::new()
        }
    )
}

/// What the legend column lists.
pub(super) enum LegendLine<'a> {
    Series(&'a Series),
    Context,
    Key(String),
    /// One line of a note (wrapped to the column).
    Note(String),
}

/// The lines of `text` wrapped at spaces to at most `width` pixels at `size` points.
pub(super) fn wrap_to(text: &str, size: u32, width: u32) -> Vec<String> {
    let mut scratch = vec![255u8; 3];
    let area = BitMapBackend::with_buffer(&mut scratch, (1, 1)).into_drawing_area();
    wrap_text(&area, text, &(FONT, size).into_font().into(), width)
}

/// Every text size the figures use. All even: plotters' glyph placement truncates half a
/// pixel (size / 2 + the glyph's top) towards zero, which at odd sizes lifts a glyph that sits
/// low (the decimal point) one pixel against the digits, so "0.05" read as "0·05".
#[cfg(test)]
pub(super) const TEXT_SIZES: [u32; 5] = [10, 12, 14, 16, 18];

/// The notes' (and keys') font size.
pub(super) const NOTE_FONT: u32 = 12;

impl Figure {
    /// True when the category names do not fit under their slots: the axis shows letters,
    /// the legend says what they stand for.
    pub(super) fn category_keys(&self) -> bool {
        let n = self.x.categories.len();
        if n == 0 {
            return false;
        }
        let single = self.panels.len() <= 1;
        let plot_w = if single {
            1000 - 100
        } else {
            self.panel_size().0 - 75
        };
        let size = if single { 14 } else { 12 };
        let widest = self
            .x
            .categories
            .iter()
            .map(|c| text_width(c, size))
            .max()
            .unwrap_or(0);
        widest + 8 > plot_w / n as u32
    }

    pub(super) fn legend_lines(&self) -> Vec<LegendLine<'_>> {
        let mut out: Vec<LegendLine<'_>> =
            self.legend().into_iter().map(LegendLine::Series).collect();
        if self
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .any(|s| s.context)
        {
            out.push(LegendLine::Context);
        }
        if self.category_keys() {
            for (k, c) in self.x.categories.iter().enumerate() {
                out.push(LegendLine::Key(format!("{}  {c}", category_key(k))));
            }
        }
        // The names of numbered points (a Pareto front's), once.
        let mut named = Vec::new();
        for s in self.legend().into_iter().filter(|s| s.draw == Draw::Front) {
            for (k, p) in s.points.iter().filter(|p| p.finite()).enumerate() {
                let line = format!("{} {}", k + 1, p.name.clone().unwrap_or_default());
                if !named.contains(&line) {
                    named.push(line);
                }
            }
        }
        // The names wrapped to the column (never cut: the parameter that tells two apart is
        // often the last), continuation lines indented.
        let width = self.legend_width() - 20;
        for line in named {
            for (k, part) in wrap_to(&line, NOTE_FONT, width - 12)
                .into_iter()
                .enumerate()
            {
                out.push(LegendLine::Key(if k == 0 {
                    part
                } else {
                    format!("    {part}")
                }));
            }
        }
        // The notes, under a gap, wrapped to the column.
        for note in &self.notes {
            out.push(LegendLine::Note(String::new()));
            out.extend(
                wrap_to(note, NOTE_FONT, width)
                    .into_iter()
                    .map(LegendLine::Note),
            );
        }
        out
    }

    /// The picture, RGB, `w` × `h`.
    pub(super) fn draw(&self, w: u32, h: u32) -> Result<Vec<u8>> {
        ensure_font()?;
        let e = |e: &dyn std::fmt::Debug| anyhow!("{e:?}");
        let (xl, yl) = (self.x.log, self.y.log);
        let categorical = !self.x.categories.is_empty();
        // Shared ranges over every panel, intervals included.
        let all = self
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| &s.points);
        let xs = all
            .clone()
            .flat_map(|p| [Some(p.x), p.x_lo, p.x_hi])
            .flatten();
        let ys = all.flat_map(|p| [Some(p.y), p.y_lo, p.y_hi]).flatten();
        let (x0, x1) = if categorical {
            (-0.5, self.x.categories.len() as f64 - 0.5)
        } else {
            padded(xs.filter_map(|v| transform(v, xl)), xl)
                .ok_or_else(|| anyhow!("figure {:?} has no plottable point", self.id))?
        };
        let (y0, mut y1) = padded(ys.filter_map(|v| transform(v, yl)), yl)
            .ok_or_else(|| anyhow!("figure {:?} has no plottable point", self.id))?;
        // A numbered front labels its points above them: room under the panel's title.
        if self.legend().iter().any(|s| s.draw == Draw::Front) {
            y1 += FRONT_HEADROOM * (y1 - y0);
        }

        let mut buf = vec![255u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|x| e(&x))?;
            let title_font: TextStyle = (FONT, 18).into_font().color(&BLACK);
            let title = fit_text(&root, &self.title, &title_font, w - 20);
            root.draw_text(&title, &title_font, (12, 10))
                .map_err(|x| e(&x))?;
            let legend_w = self.legend_width();
            let plot_w = w - legend_w;
            let (cols, rows) = self.grid();
            let single = self.panels.len() <= 1;
            let (pw, ph) = if single {
                (plot_w, h - TITLE_H)
            } else {
                self.panel_size()
            };
            let marker_r = if single { 4.5 } else { 3.5 };
            for (k, panel) in self.panels.iter().enumerate() {
                let (c, r) = ((k % cols) as u32, (k / cols) as u32);
                let left = if single { 0 } else { 40 } + c * pw;
                let area = root.clone().shrink((left, TITLE_H + r * ph), (pw, ph));
                let mut builder = ChartBuilder::on(&area);
                builder
                    .margin(8)
                    .margin_right(14)
                    .x_label_area_size(if single { 48 } else { 34 })
                    .y_label_area_size(if single { 72 } else { 46 });
                if !panel.title.is_empty() {
                    let font: TextStyle = (FONT, 14).into_font().into();
                    builder.caption(fit_text(&root, &panel.title, &font, pw - 20), font);
                }
                let mut chart = builder
                    .build_cartesian_2d(x0..x1, y0..y1)
                    .map_err(|x| e(&x))?;
                let cats: Vec<String> = if self.category_keys() {
                    (0..self.x.categories.len()).map(category_key).collect()
                } else {
                    self.x.categories.clone()
                };
                let x_fmt = move |v: &f64| {
                    if cats.is_empty() {
                        tick(*v, xl)
                    } else {
                        let i = v.round();
                        if (v - i).abs() < 1e-6 && i >= 0.0 {
                            cats.get(i as usize).cloned().unwrap_or_default()
                        } else {
                            String::new()
                        }
                    }
                };
                let y_fmt = move |v: &f64| tick(*v, yl);
                let mut mesh = chart.configure_mesh();
                mesh.label_style((FONT, if single { 14 } else { 12 }))
                    .axis_desc_style((FONT, if single { 14 } else { 12 }))
                    .x_label_formatter(&x_fmt)
                    .y_label_formatter(&y_fmt)
                    .light_line_style(RGBColor(238, 238, 238))
                    .bold_line_style(RGBColor(215, 215, 215));
                if categorical {
                    mesh.x_labels(2 * self.x.categories.len() + 1)
                        .disable_x_mesh();
                } else if !single {
                    mesh.x_labels(5).y_labels(5);
                }
                if single {
                    mesh.x_desc(&self.x.label).y_desc(&self.y.label);
                }
                mesh.draw().map_err(|x| e(&x))?;
                // The vertical rules under the data, labelled at the top: each label centred on
                // its rule on a white patch, in the first of three rows where it meets no
                // label placed before it.
                let rule_size = if single { 12 } else { 10 };
                let rule_font: TextStyle = (FONT, rule_size)
                    .into_font()
                    .color(&RULE_TEXT)
                    .pos(Pos::new(HPos::Center, VPos::Center));
                let mut row_ends = [f64::NEG_INFINITY; 3];
                for rule in &self.rules {
                    let Some(tx) = transform(rule.x, xl).filter(|t| *t > x0 && *t < x1) else {
                        continue;
                    };
                    let (px, top) = chart.backend_coord(&(tx, y1));
                    let (_, bottom) = chart.backend_coord(&(tx, y0));
                    draw_polyline(
                        &root,
                        &[(px as f64, top as f64), (px as f64, bottom as f64)],
                        RULE_LINE,
                        1,
                        &[5.0, 3.0],
                    )
                    .map_err(|x| e(&x))?;
                    let w = f64::from(text_width(&rule.label, rule_size)) + 4.0;
                    let left = px as f64 - w / 2.0;
                    let row = row_ends.iter().position(|end| left > *end).unwrap_or(0);
                    row_ends[row] = left + w;
                    let cy = top as f64 + 3.0 + (f64::from(rule_size) + 3.0) * (row as f64 + 0.5);
                    let half_h = f64::from(rule_size) / 2.0 + 1.0;
                    root.draw(&Rectangle::new(
                        [
                            (left as i32, (cy - half_h) as i32),
                            ((left + w) as i32, (cy + half_h) as i32),
                        ],
                        WHITE.filled(),
                    ))
                    .map_err(|x| e(&x))?;
                    root.draw_text(&rule.label, &rule_font, (px, cy as i32))
                        .map_err(|x| e(&x))?;
                }
                let to_px = |x: f64, y: f64| -> Option<(f64, f64)> {
                    let (tx, ty) = (transform(x, xl)?, transform(y, yl)?);
                    let (px, py) = chart.backend_coord(&(tx, ty));
                    Some((px as f64, py as f64))
                };
                let visible: Vec<&Series> = panel.series.iter().collect();
                let n_dodge = visible.iter().filter(|s| !s.context).count().max(1);
                let mut dodge_k = 0usize;
                for s in visible {
                    // Categorical axes: the series of a category side by side.
                    let dx = if categorical && !s.context {
                        let slot = 0.8 / n_dodge as f64;
                        let d = (dodge_k as f64 - (n_dodge as f64 - 1.0) / 2.0) * slot.min(0.12);
                        dodge_k += 1;
                        d
                    } else {
                        0.0
                    };
                    draw_series(&root, s, &to_px, dx, marker_r).map_err(|x| e(&x))?;
                }
            }
            // Small multiples: the axis descriptions once, under and left of the grid.
            if !single {
                let font: TextStyle = (FONT, 14).into_font().color(&BLACK);
                let grid_w = cols as u32 * pw;
                let x_text = fit_text(&root, &self.x.label, &font, grid_w);
                let centre_x = Pos::new(HPos::Center, VPos::Top);
                root.draw_text(
                    &x_text,
                    &font.pos(centre_x),
                    (
                        (40 + grid_w / 2) as i32,
                        (TITLE_H + rows as u32 * ph + 8) as i32,
                    ),
                )
                .map_err(|x| e(&x))?;
                let grid_h = rows as u32 * ph;
                // At most two lines in the 40 pixels left of the grid.
                let mut y_lines = wrap_text(&root, &self.y.label, &font, grid_h - 20);
                if y_lines.len() > 2 {
                    let rest = y_lines[1..].join(" ");
                    y_lines = vec![
                        y_lines[0].clone(),
                        fit_text(&root, &rest, &font, grid_h - 20),
                    ];
                }
                let rotated = font
                    .transform(FontTransform::Rotate270)
                    .pos(Pos::new(HPos::Center, VPos::Top));
                for (l, line) in y_lines.iter().enumerate() {
                    root.draw_text(
                        line,
                        &rotated,
                        (2 + 18 * l as i32, (TITLE_H + grid_h / 2) as i32),
                    )
                    .map_err(|x| e(&x))?;
                }
            }
            // The legend column.
            let legend = root
                .clone()
                .shrink((plot_w, TITLE_H), (legend_w, h - TITLE_H));
            draw_legend(&legend, &self.legend_lines()).map_err(|x| e(&x))?;
            root.present().map_err(|x| e(&x))?;
        }
        Ok(buf)
    }
}

/// A rule's line and label.
pub(super) const RULE_LINE: RGBColor = RGBColor(120, 120, 120);
pub(super) const RULE_TEXT: RGBColor = RGBColor(70, 70, 70);

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type DrawResult = std::result::Result<
    (),
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

pub(super) fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// A marker of `style` centred at `(x, y)`, radius `r` pixels: a circle for the round
/// markers, else the style's polygon.
pub(super) fn draw_marker(
    area: &Area<'_>,
    style: &Style,
    (x, y): (f64, f64),
    r: f64,
) -> DrawResult {
    let color = rgb(style.color);
    let hollow = style.hollow || style.marker == Marker::Ring;
    let centre = (x.round() as i32, y.round() as i32);
    let round = match style.marker {
        Marker::Circle => Some(r),
        Marker::Ring => Some(1.6 * r),
        Marker::Dot => Some(0.55 * r),
        _ => None,
    };
    if let Some(radius) = round {
        let radius = radius.round().max(1.0) as i32;
        if hollow {
            area.draw(&Circle::new(centre, radius, WHITE.filled()))?;
            area.draw(&Circle::new(centre, radius, color.stroke_width(2)))?;
        } else {
            area.draw(&Circle::new(centre, radius, color.filled()))?;
        }
        return Ok(());
    }
    let poly: Vec<(i32, i32)> = style
        .marker
        .polygon()
        .iter()
        .map(|[u, v]| ((x + u * r).round() as i32, (y + v * r).round() as i32))
        .collect();
    area.draw(&Polygon::new(
        poly.clone(),
        if hollow {
            WHITE.filled()
        } else {
            color.filled()
        },
    ))?;
    let mut outline = poly.clone();
    outline.push(poly[0]);
    area.draw(&PathElement::new(
        outline,
        color.stroke_width(if hollow { 2 } else { 1 }),
    ))?;
    Ok(())
}

pub(super) fn draw_polyline(
    area: &Area<'_>,
    pts: &[(f64, f64)],
    color: RGBColor,
    width: u32,
    pattern: &[f64],
) -> DrawResult {
    for [a, b] in dash_segments(pts, pattern) {
        area.draw(&PathElement::new(
            vec![
                (a.0.round() as i32, a.1.round() as i32),
                (b.0.round() as i32, b.1.round() as i32),
            ],
            color.stroke_width(width),
        ))?;
    }
    Ok(())
}

pub(super) fn draw_series(
    area: &Area<'_>,
    s: &Series,
    to_px: &dyn Fn(f64, f64) -> Option<(f64, f64)>,
    dx: f64,
    r: f64,
) -> DrawResult {
    let color = rgb(s.style.color);
    let pts: Vec<(&Point, (f64, f64))> = s
        .points
        .iter()
        .filter_map(|p| Some((p, to_px(p.x + dx, p.y)?)))
        .collect();
    if s.context {
        let xy: Vec<(f64, f64)> = pts.iter().map(|(_, q)| *q).collect();
        if s.has_line() {
            draw_polyline(area, &xy, color, 1, &[])?;
        } else {
            for &q in &xy {
                draw_marker(area, &CONTEXT, q, r)?;
            }
        }
        return Ok(());
    }
    // Intervals under the marks.
    let faint = color.mix(0.55).stroke_width(1);
    for (p, _) in &pts {
        if let (Some(lo), Some(hi)) = (p.y_lo, p.y_hi)
            && let (Some(a), Some(b)) = (to_px(p.x + dx, lo), to_px(p.x + dx, hi))
        {
            area.draw(&PathElement::new(
                vec![(a.0 as i32, a.1 as i32), (b.0 as i32, b.1 as i32)],
                faint,
            ))?;
        }
        if let (Some(lo), Some(hi)) = (p.x_lo, p.x_hi)
            && let (Some(a), Some(b)) = (to_px(lo + dx, p.y), to_px(hi + dx, p.y))
        {
            area.draw(&PathElement::new(
                vec![(a.0 as i32, a.1 as i32), (b.0 as i32, b.1 as i32)],
                faint,
            ))?;
        }
    }
    let xy: Vec<(f64, f64)> = pts.iter().map(|(_, q)| *q).collect();
    if s.has_line() {
        draw_polyline(area, &xy, color, 2, s.style.dash.pattern())?;
    }
    // Dense lines: a marker every few points, enough to tell the series apart.
    let stride = xy.len().div_ceil(40).max(1);
    for (k, &q) in xy.iter().enumerate() {
        if k % stride == 0 || k + 1 == xy.len() {
            draw_marker(area, &s.style, q, r)?;
        }
    }
    if s.draw == Draw::Front {
        let size = if r < 4.0 { 10 } else { 12 };
        let font: TextStyle = (FONT, size)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center));
        for (k, place) in front_labels(&xy, r * 1.6, size).into_iter().enumerate() {
            if place.leader {
                // A thin line from the ring's edge to the number placed apart.
                let (x, y) = xy[k];
                let (dx, dy) = (place.centre.0 - x, place.centre.1 - y);
                let len = dx.hypot(dy).max(1e-9);
                let from = (x + dx / len * r * 1.6, y + dy / len * r * 1.6);
                let to = (
                    place.centre.0 - dx / len * (size as f64 * 0.6),
                    place.centre.1 - dy / len * (size as f64 * 0.6),
                );
                draw_polyline(area, &[from, to], RULE_LINE, 1, &[])?;
            }
            area.draw_text(
                &(k + 1).to_string(),
                &font,
                (place.centre.0 as i32, place.centre.1 as i32),
            )?;
        }
    }
    Ok(())
}

/// Where a front's number goes: the centre of its box, and whether it stands apart from its
/// ring (then a leader line joins them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LabelPlace {
    pub centre: (f64, f64),
    pub leader: bool,
}

/// The places of the numbers 1, 2, ... of the front's rings at `rings` (pixels, radius
/// `ring`), `size`-point text: each the first box, in rings of growing distance and eight
/// directions (above first), that overlaps no ring and no number placed before it. A number
/// beyond the first distance stands apart, with a leader line.
pub(super) fn front_labels(rings: &[(f64, f64)], ring: f64, size: u32) -> Vec<LabelPlace> {
    type Box4 = (f64, f64, f64, f64);
    let overlap = |a: &Box4, b: &Box4| a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3;
    let obstacles: Vec<Box4> = rings
        .iter()
        .map(|&(x, y)| (x - ring, y - ring, x + ring, y + ring))
        .collect();
    let h = f64::from(size);
    let mut placed: Vec<Box4> = Vec::new();
    let mut out = Vec::new();
    const DIRECTIONS: [(f64, f64); 8] = [
        (0.0, -1.0),
        (0.0, 1.0),
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.7, -0.7),
        (-0.7, -0.7),
        (0.7, 0.7),
        (-0.7, 0.7),
    ];
    for (k, &(x, y)) in rings.iter().enumerate() {
        let w = f64::from(text_width(&(k + 1).to_string(), size)) + 2.0;
        let mut found = None;
        'search: for step in 0..8 {
            let d = ring + 2.0 + step as f64 * (h + 2.0);
            for (ux, uy) in DIRECTIONS {
                let c = (x + ux * (d + w / 2.0), y + uy * (d + h / 2.0));
                let b = (c.0 - w / 2.0, c.1 - h / 2.0, c.0 + w / 2.0, c.1 + h / 2.0);
                if !placed.iter().chain(&obstacles).any(|o| overlap(o, &b)) {
                    found = Some((c, b, step > 0));
                    break 'search;
                }
            }
        }
        let (centre, b, leader) = found.unwrap_or_else(|| {
            let c = (x, y - ring - 2.0 - h / 2.0);
            (
                c,
                (c.0 - w / 2.0, c.1 - h / 2.0, c.0 + w / 2.0, c.1 + h / 2.0),
                false,
            )
        });
        placed.push(b);
        out.push(LabelPlace { centre, leader });
    }
    out
}

/// Left of a series' label in the legend: its swatch.
pub(super) const LEGEND_TEXT_X: u32 = 48;

impl Figure {
    /// The legend column's width: its longest series label in the legend font, with the
    /// swatch and a margin, within [`LEGEND_W`, `LEGEND_MAX_W`] (a longer label is cut with an
    /// ellipsis).
    pub(super) fn legend_width(&self) -> u32 {
        let mut buf = vec![255u8; 3];
        let area = BitMapBackend::with_buffer(&mut buf, (1, 1)).into_drawing_area();
        let font: TextStyle = (FONT, LEGEND_FONT).into_font().into();
        let widest = self
            .legend()
            .iter()
            .filter_map(|s| area.estimate_text_size(&s.label, &font).ok())
            .map(|(w, _)| w)
            .max()
            .unwrap_or(0);
        (widest + LEGEND_TEXT_X + 12).clamp(LEGEND_W, LEGEND_MAX_W)
    }
}

/// The legend's font size for series labels.
pub(super) const LEGEND_FONT: u32 = 12;

pub(super) fn draw_legend(area: &Area<'_>, lines: &[LegendLine<'_>]) -> DrawResult {
    let centred = Pos::new(HPos::Left, VPos::Center);
    let font: TextStyle = (FONT, LEGEND_FONT).into_font().color(&BLACK).pos(centred);
    let small: TextStyle = (FONT, NOTE_FONT)
        .into_font()
        .color(&RGBColor(60, 60, 60))
        .pos(centred);
    let (w, _) = area.dim_in_pixel();
    let mut y = 14.0;
    for line in lines {
        match line {
            LegendLine::Series(s) => {
                // The dash is part of the identity: shown also for series drawn as markers.
                draw_polyline(
                    area,
                    &[(8.0, y), (40.0, y)],
                    rgb(s.style.color),
                    2,
                    s.style.dash.pattern(),
                )?;
                draw_marker(area, &s.style, (24.0, y), 4.5)?;
                let text = fit_text(area, &s.label, &font, w - LEGEND_TEXT_X - 8);
                area.draw_text(&text, &font, (LEGEND_TEXT_X as i32, y as i32))?;
                y += 18.0;
            }
            LegendLine::Context => {
                draw_polyline(area, &[(8.0, y), (40.0, y)], rgb(CONTEXT.color), 1, &[])?;
                draw_marker(area, &CONTEXT, (24.0, y), 4.5)?;
                area.draw_text("other families (context)", &font, (48, y as i32))?;
                y += 18.0;
            }
            LegendLine::Key(text) => {
                let text = fit_text(area, text, &small, w - 20);
                area.draw_text(&text, &small, (14, y as i32))?;
                y += 15.0;
            }
            LegendLine::Note(text) => {
                if !text.is_empty() {
                    area.draw_text(text, &small, (14, y as i32))?;
                }
                y += 15.0;
            }
        }
    }
    Ok(())
}
