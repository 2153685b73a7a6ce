//! Figures: one description per figure, written as a JSON twin and drawn as a PNG from it.
//!
//! An experiment builds a [`Figure`] (its panels, each panel's series, each series' method,
//! family, setting, variant, context flag and [`Style`], each point's x, y, interval, seconds
//! and setting) and calls [`Figure::write`], which writes `ID.json` (the plotted data, for a
//! reader to re-plot, for the results pages and for the tests) and draws `ID.png` from that same
//! description: one code path. A figure of more than [`MAX_SERIES`] series becomes small
//! multiples by family ([`arrange`]), the other families' best drawn in thin grey as context.
//!
//! The PNG: plotters draws into an in-memory RGB buffer with its `ab_glyph` text backend and
//! the DejaVu Sans font embedded by the `dejavu` crate (registered once as "sans-serif"), so no
//! font lookup can fail; the `image` crate encodes the PNG, written atomically. Logarithmic
//! axes are linear axes over log10 of the data with ticks labelled 10^k. Axes are zoomed to
//! the data (its intervals included) and shared by the panels; the legend stands in a column
//! right of the panels, never over the data; lines are dashed and markers shaped in pixel
//! space by the style's pattern and polygon ([`super::style`]), which the pages draw alike.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Result, anyhow, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::Serialize;

use super::style::{self, CONTEXT, Marker, Style};
use super::{write_atomic, write_png};

/// More series than this in one figure: small multiples by family.
pub const MAX_SERIES: usize = 10;

/// The JSON twin's format tag.
pub const FORMAT: &str = "pointsight-figure/1";

const FONT: &str = "sans-serif";

pub(crate) fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the embedded DejaVu font did not load"))
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Draw {
    /// A line through the points in order, with markers.
    Line,
    /// Markers only.
    Points,
    /// A Pareto front: a line through rings, each ring numbered (its name in the legend).
    Front,
}

/// One plotted point.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Point {
    /// x (for a categorical axis: the category's index).
    pub x: f64,
    /// y.
    pub y: f64,
    /// The interval of x (low, high), e.g. the fastest and slowest run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x_lo: Option<f64>,
    /// See `x_lo`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x_hi: Option<f64>,
    /// The interval of y (the figure's `interval` says what it is).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub y_lo: Option<f64>,
    /// See `y_lo`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub y_hi: Option<f64>,
    /// Seconds of the method at this point, where known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
    /// The setting behind this point (`k=v` pairs), where it varies along the series.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub setting: Option<String>,
    /// A name for the point (a Pareto front's: the method and setting).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

impl Point {
    /// A point at (x, y).
    pub fn new(x: f64, y: f64) -> Self {
        Self {
            x,
            y,
            ..Self::default()
        }
    }

    /// With the interval of y.
    pub fn y_interval(mut self, lo: f64, hi: f64) -> Self {
        (self.y_lo, self.y_hi) = (Some(lo), Some(hi));
        self
    }

    /// With the interval of x.
    pub fn x_interval(mut self, lo: f64, hi: f64) -> Self {
        (self.x_lo, self.x_hi) = (Some(lo), Some(hi));
        self
    }

    /// With the method's seconds.
    pub fn seconds(mut self, s: f64) -> Self {
        self.seconds = s.is_finite().then_some(s);
        self
    }

    /// With the setting.
    pub fn setting(mut self, s: impl Into<String>) -> Self {
        let s = s.into();
        self.setting = (!s.is_empty()).then_some(s);
        self
    }

    fn finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

/// One series: whose it is, how it looks, its points.
#[derive(Debug, Clone, Serialize)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The method (as the results name it).
    pub method: String,
    /// Its family (`registry::Method::family`): the colour.
    pub family: String,
    /// The setting, where one setting stands behind the whole series (else per point).
    pub setting: String,
    /// The variant (`best`, `auto`, `default`, `settings`, a distance `×k`, a parameter's
    /// value...): the marker.
    pub variant: String,
    /// Drawn as thin grey context for the other series, outside the distinct-style rule.
    pub context: bool,
    /// A peer's series (hollow marker).
    pub peer: bool,
    /// How it is drawn.
    pub draw: Draw,
    /// Its style: a function of (family, variant) ([`style::style`], [`style::ordinal`]).
    pub style: Style,
    /// The points ([`Figure::panels`] keeps only those it can draw).
    pub points: Vec<Point>,
}

impl Series {
    /// A series of `method` (of `family`) in `variant`, styled by (family, variant), labelled
    /// "method variant" (the method alone for the variants `settings` and "").
    pub fn new(method: &str, family: &str, variant: &str, draw: Draw, points: Vec<Point>) -> Self {
        let label = match variant {
            "" | "settings" => method.to_owned(),
            v => format!("{method} {v}"),
        };
        Self {
            label,
            method: method.to_owned(),
            family: family.to_owned(),
            setting: String::new(),
            variant: variant.to_owned(),
            context: false,
            peer: style::is_peer(family),
            draw,
            style: style::style(family, variant),
            points,
        }
    }

    /// With another legend text.
    pub fn label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// With the setting of the whole series.
    pub fn setting(mut self, setting: impl Into<String>) -> Self {
        self.setting = setting.into();
        self
    }

    /// Styled as the variant ranked `rank` of its family over the run ([`style::ordinal`]).
    pub fn ranked(mut self, rank: usize) -> Self {
        self.style = style::ordinal(&self.family, rank);
        self
    }

    /// A grey context copy.
    pub fn as_context(&self) -> Self {
        Self {
            context: true,
            style: CONTEXT,
            ..self.clone()
        }
    }

    fn has_line(&self) -> bool {
        matches!(self.draw, Draw::Line | Draw::Front)
    }
}

/// An axis.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Axis {
    /// Description.
    pub label: String,
    /// Logarithmic (the data must be positive).
    pub log: bool,
    /// Category names of a categorical axis (x = the index); empty: numeric.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub categories: Vec<String>,
}

impl Axis {
    /// A linear axis.
    pub fn linear(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            ..Self::default()
        }
    }

    /// A logarithmic axis.
    pub fn log(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            log: true,
            ..Self::default()
        }
    }

    /// A categorical axis.
    pub fn categories(label: impl Into<String>, categories: Vec<String>) -> Self {
        Self {
            label: label.into(),
            categories,
            ..Self::default()
        }
    }
}

/// One panel of a figure.
#[derive(Debug, Clone, Serialize)]
pub struct Panel {
    /// Caption (empty for a figure of one panel).
    pub title: String,
    /// The series, drawn in order (context first).
    pub series: Vec<Series>,
}

/// A figure: what `ID.json` holds and `ID.png` shows.
#[derive(Debug, Clone, Serialize)]
pub struct Figure {
    /// [`FORMAT`].
    pub format: &'static str,
    /// File stem (`ID.png`, `ID.json`) and anchor (`results.html#ID`).
    pub id: String,
    /// Caption.
    pub title: String,
    /// The x axis.
    pub x: Axis,
    /// The y axis.
    pub y: Axis,
    /// What a point's y interval is (`lowest to highest view`, `quartiles over the views`,
    /// `95 % bootstrap interval`); empty: none.
    pub interval: String,
    /// The panels.
    pub panels: Vec<Panel>,
    /// The PNG drawn from it.
    pub png: String,
}

/// `series` (and `shared`, drawn in every panel, e.g. a Pareto front) as panels: one panel
/// when there are at most [`MAX_SERIES`] series, else one panel per family (in order of first
/// appearance) holding that family's series and, in grey, every other family's `best` series
/// (all its series when it has none) as context.
pub fn arrange(series: Vec<Series>, shared: Vec<Series>) -> Vec<Panel> {
    if series.len() <= MAX_SERIES {
        let mut all = shared;
        all.extend(series);
        return vec![Panel {
            title: String::new(),
            series: all,
        }];
    }
    let families = super::distinct(series.iter().map(|s| s.family.as_str()));
    families
        .iter()
        .map(|f| {
            let mut panel: Vec<Series> = Vec::new();
            for g in families.iter().filter(|g| *g != f) {
                let of_g: Vec<&Series> = series.iter().filter(|s| &s.family == g).collect();
                let best: Vec<&Series> = of_g
                    .iter()
                    .copied()
                    .filter(|s| s.variant == "best")
                    .collect();
                let chosen = if best.is_empty() { of_g } else { best };
                panel.extend(chosen.into_iter().map(Series::as_context));
            }
            let own: Vec<Series> = series.iter().filter(|s| &s.family == f).cloned().collect();
            // The panel names the family, and the methods when they are named otherwise (not
            // FAMILY-something).
            let methods = super::distinct(own.iter().map(|s| s.method.as_str()));
            let title = if methods.iter().all(|m| {
                m == f
                    || m.strip_prefix(f.as_str())
                        .is_some_and(|r| r.starts_with('-'))
            }) {
                f.clone()
            } else {
                format!("{} ({f})", methods.join(", "))
            };
            // Shared series (a front) under the family's own.
            panel.extend(shared.iter().cloned());
            panel.extend(own);
            Panel {
                title,
                series: panel,
            }
        })
        .collect()
}

impl Figure {
    /// A figure of `panels` (see [`arrange`]).
    pub fn new(id: impl Into<String>, title: impl Into<String>, x: Axis, y: Axis) -> Self {
        let id = id.into();
        Self {
            format: FORMAT,
            png: format!("{id}.png"),
            id,
            title: title.into(),
            x,
            y,
            interval: String::new(),
            panels: Vec::new(),
        }
    }

    /// With the meaning of the points' y intervals.
    pub fn interval(mut self, what: impl Into<String>) -> Self {
        self.interval = what.into();
        self
    }

    /// True when `p` can be drawn on this figure's axes (finite; positive on a log axis).
    fn plottable(&self, p: &Point) -> bool {
        p.finite() && (!self.x.log || p.x > 0.0) && (!self.y.log || p.y > 0.0)
    }

    /// With these panels, holding what is drawn and nothing else: points that cannot be drawn
    /// (not finite, or not positive on a log axis) are left out, then series without a point
    /// (a method that never finished), then panels without a series of their own.
    pub fn panels(mut self, mut panels: Vec<Panel>) -> Self {
        for panel in &mut panels {
            for s in &mut panel.series {
                s.points.retain(|p| self.plottable(p));
            }
            panel.series.retain(|s| !s.points.is_empty());
        }
        panels.retain(|p| p.series.iter().any(|s| !s.context));
        self.panels = panels;
        self
    }

    /// With `series` (and `shared`) arranged by [`arrange`], series without a plottable point
    /// left out first (so they take no panel).
    pub fn series(self, mut series: Vec<Series>, shared: Vec<Series>) -> Self {
        series.retain(|s| s.points.iter().any(|p| self.plottable(p)));
        self.panels(arrange(series, shared))
    }

    /// True when no panel has a plottable point.
    pub fn is_empty(&self) -> bool {
        !self
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| &s.points)
            .any(|p| self.plottable(p))
    }

    /// Every series that is not context, once per identity (method, family, variant, label),
    /// fronts last.
    pub fn legend(&self) -> Vec<&Series> {
        let mut out: Vec<&Series> = Vec::new();
        for s in self.panels.iter().flat_map(|p| &p.series) {
            if !s.context
                && !out.iter().any(|o| {
                    (&o.method, &o.family, &o.variant, &o.label)
                        == (&s.method, &s.family, &s.variant, &s.label)
                })
            {
                out.push(s);
            }
        }
        out.sort_by_key(|s| s.draw == Draw::Front);
        out
    }

    /// Two different series (not context) with one style, if any: `(label, label)`.
    pub fn style_clash(&self) -> Option<(String, String)> {
        let legend = self.legend();
        for (i, a) in legend.iter().enumerate() {
            for b in &legend[i + 1..] {
                if a.style == b.style {
                    return Some((a.label.clone(), b.label.clone()));
                }
            }
        }
        None
    }

    /// Writes `dir/ID.json` and `dir/ID.png` (drawn from the same description); returns the
    /// markdown that shows it.
    pub fn write(&self, dir: &Path) -> Result<String> {
        if self.is_empty() {
            bail!("figure {:?} has no plottable point", self.id);
        }
        let json = serde_json::to_string_pretty(self)?;
        write_atomic(&dir.join(format!("{}.json", self.id)), json.as_bytes())?;
        let (w, h) = self.size();
        let rgb = self.draw(w, h)?;
        write_png(&dir.join(&self.png), w, h, &rgb)?;
        Ok(format!("![{}]({})\n\n", self.title, self.png))
    }

    /// The grid of panels: (columns, rows).
    fn grid(&self) -> (usize, usize) {
        let n = self.panels.len().max(1);
        let cols = match n {
            1 => 1,
            2 | 4 => 2,
            3 | 5 | 6 | 9 => 3,
            _ => 4,
        };
        (cols, n.div_ceil(cols))
    }

    /// The picture's size: one panel 1000 × 560; small multiples 300 × 240 each.
    fn size(&self) -> (u32, u32) {
        let (cols, rows) = self.grid();
        if self.panels.len() <= 1 {
            (1000 + LEGEND_W, 560)
        } else {
            let entries = self.legend_lines().len() as u32;
            let (pw, ph) = self.panel_size();
            let h = (TITLE_H + rows as u32 * ph + 40).max(TITLE_H + entries * 18 + 40);
            (cols as u32 * pw + 40 + LEGEND_W, h)
        }
    }
}

const LEGEND_W: u32 = 300;
const PANEL_W: u32 = 320;
const PANEL_H: u32 = 250;

impl Figure {
    /// A small multiple's size: larger when there are few.
    fn panel_size(&self) -> (u32, u32) {
        match self.panels.len() {
            0..=2 => (480, 340),
            3 | 4 => (420, 300),
            _ => (PANEL_W, PANEL_H),
        }
    }
}
const TITLE_H: u32 = 40;

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

/// The range of `values` padded by 5 % (half a decade, or 5 % of the value, when flat).
fn padded(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
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
fn fit_text(
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
fn text_width(text: &str, size: u32) -> u32 {
    let mut scratch = vec![255u8; 3];
    let area = BitMapBackend::with_buffer(&mut scratch, (1, 1)).into_drawing_area();
    area.estimate_text_size(text, &(FONT, size).into_font().into())
        .map_or(0, |(w, _)| w)
}

/// The letter standing for category `k` when the names do not fit under their slots.
fn category_key(k: usize) -> String {
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
enum LegendLine<'a> {
    Series(&'a Series),
    Context,
    Key(String),
}

impl Figure {
    /// True when the category names do not fit under their slots: the axis shows letters,
    /// the legend says what they stand for.
    fn category_keys(&self) -> bool {
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
        let size = if single { 14 } else { 11 };
        let widest = self
            .x
            .categories
            .iter()
            .map(|c| text_width(c, size))
            .max()
            .unwrap_or(0);
        widest + 8 > plot_w / n as u32
    }

    fn legend_lines(&self) -> Vec<LegendLine<'_>> {
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
        out.extend(named.into_iter().map(LegendLine::Key));
        out
    }

    /// The picture, RGB, `w` × `h`.
    fn draw(&self, w: u32, h: u32) -> Result<Vec<u8>> {
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
        let (y0, y1) = padded(ys.filter_map(|v| transform(v, yl)), yl)
            .ok_or_else(|| anyhow!("figure {:?} has no plottable point", self.id))?;

        let mut buf = vec![255u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|x| e(&x))?;
            let title_font: TextStyle = (FONT, 19).into_font().color(&BLACK);
            let title = fit_text(&root, &self.title, &title_font, w - 20);
            root.draw_text(&title, &title_font, (12, 10))
                .map_err(|x| e(&x))?;
            let plot_w = w - LEGEND_W;
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
                mesh.label_style((FONT, if single { 14 } else { 11 }))
                    .axis_desc_style((FONT, if single { 15 } else { 12 }))
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
                .shrink((plot_w, TITLE_H), (LEGEND_W, h - TITLE_H));
            draw_legend(&legend, &self.legend_lines()).map_err(|x| e(&x))?;
            root.present().map_err(|x| e(&x))?;
        }
        Ok(buf)
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type DrawResult = std::result::Result<
    (),
    DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
>;

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// A marker of `style` centred at `(x, y)`, radius `r` pixels: a circle for the round
/// markers, else the style's polygon.
fn draw_marker(area: &Area<'_>, style: &Style, (x, y): (f64, f64), r: f64) -> DrawResult {
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

fn draw_polyline(
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

fn draw_series(
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
        let font: TextStyle = (FONT, if r < 4.0 { 10 } else { 12 })
            .into_font()
            .color(&BLACK);
        for (k, &(x, y)) in xy.iter().enumerate() {
            // Numbers alternate above and below the ring, so neighbours do not collide.
            let dy = if k % 2 == 0 {
                -r * 1.6 - 14.0
            } else {
                r * 1.6 + 2.0
            };
            area.draw_text(
                &(k + 1).to_string(),
                &font,
                ((x + 3.0) as i32, (y + dy) as i32),
            )?;
        }
    }
    Ok(())
}

fn draw_legend(area: &Area<'_>, lines: &[LegendLine<'_>]) -> DrawResult {
    let centred = Pos::new(HPos::Left, VPos::Center);
    let font: TextStyle = (FONT, 13).into_font().color(&BLACK).pos(centred);
    let small: TextStyle = (FONT, 11)
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
                let text = fit_text(area, &s.label, &font, w - 56);
                area.draw_text(&text, &font, (48, y as i32))?;
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
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(method: &str, family: &str, variant: &str, draw: Draw) -> Series {
        Series::new(
            method,
            family,
            variant,
            draw,
            vec![
                Point::new(10.0, 0.91).y_interval(0.9, 0.93),
                Point::new(100.0, 0.95).seconds(0.1),
                Point::new(1000.0, 0.97),
            ],
        )
    }

    #[test]
    fn a_figure_writes_its_twin_and_a_png_drawn_from_it() {
        let dir = tempfile::tempdir().unwrap();
        let fig = Figure::new("f", "test", Axis::log("points"), Axis::linear("F1"))
            .interval("lowest to highest view")
            .series(
                vec![
                    series("hpr", "hpr-linear", "best", Draw::Line),
                    series("hpr", "hpr-linear", "auto", Draw::Line),
                    series("cgal-hpr", "cgal-hpr", "", Draw::Points),
                ],
                vec![],
            );
        let md = fig.write(dir.path()).unwrap();
        assert_eq!(md, "![test](f.png)\n\n");
        let img = image::open(dir.path().join("f.png")).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), fig.size());
        // Each series' colour is in the picture.
        for s in fig.legend() {
            let c = s.style.color;
            assert!(img.pixels().any(|p| p.0 == c), "{}", s.label);
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("f.json")).unwrap())
                .unwrap();
        assert_eq!(json["format"], FORMAT);
        let s0 = &json["panels"][0]["series"][0];
        assert_eq!(s0["method"], "hpr");
        assert_eq!(s0["family"], "hpr-linear");
        assert_eq!(s0["variant"], "best");
        assert_eq!(s0["style"]["marker"], "square");
        assert_eq!(s0["points"][0]["y_lo"], 0.9);
        assert_eq!(json["panels"][0]["series"][2]["peer"], true);
        assert!(fig.style_clash().is_none());
    }

    #[test]
    fn more_than_ten_series_become_small_multiples_with_grey_context() {
        let families = [
            "hpr-linear",
            "hpr-exp",
            "hpr-log",
            "robust",
            "raycast",
            "splat",
        ];
        let mut all = Vec::new();
        for f in families {
            all.push(series(f, f, "best", Draw::Line));
            all.push(series(f, f, "auto", Draw::Line));
        }
        let fig =
            Figure::new("g", "many", Axis::linear("x"), Axis::linear("y")).series(all, vec![]);
        assert_eq!(fig.panels.len(), families.len());
        for (p, f) in fig.panels.iter().zip(families) {
            assert_eq!(p.title, f);
            let own: Vec<&Series> = p.series.iter().filter(|s| !s.context).collect();
            assert_eq!(own.len(), 2);
            assert!(own.iter().all(|s| s.family == f));
            let context: Vec<&Series> = p.series.iter().filter(|s| s.context).collect();
            // The other families' best, in grey.
            assert_eq!(context.len(), families.len() - 1);
            assert!(
                context
                    .iter()
                    .all(|s| s.variant == "best" && s.style == CONTEXT)
            );
        }
        assert!(fig.style_clash().is_none());
        let dir = tempfile::tempdir().unwrap();
        fig.write(dir.path()).unwrap();
    }

    #[test]
    fn series_without_points_are_left_out() {
        let fig = Figure::new("d", "d", Axis::log("x"), Axis::linear("y")).series(
            vec![
                series("hpr", "hpr-linear", "best", Draw::Line),
                Series::new(
                    "chull",
                    "hull-chull",
                    "",
                    Draw::Points,
                    vec![Point::new(f64::NAN, 1.0)],
                ),
            ],
            vec![],
        );
        assert_eq!(fig.legend().len(), 1);
        assert_eq!(fig.legend()[0].method, "hpr");
    }

    #[test]
    fn axes_are_zoomed_to_the_data() {
        let (lo, hi) = padded([0.97, 0.99].into_iter(), false).unwrap();
        assert!(lo > 0.96 && hi < 1.0, "{lo} {hi}");
        let (lo, hi) = padded([1.0, 1000.0].into_iter().map(f64::log10), true).unwrap();
        assert!(lo > -0.2 && hi < 3.2);
    }

    #[test]
    fn dashes_follow_the_pattern_across_vertices() {
        let seg = dash_segments(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], &[8.0, 4.0]);
        // On 0..8, off 8..12 (crossing the corner), on 12..20.
        assert_eq!(seg.len(), 2);
        assert_eq!(seg[0], [(0.0, 0.0), (8.0, 0.0)]);
        assert_eq!(seg[1], [(10.0, 2.0), (10.0, 10.0)]);
        assert_eq!(dash_segments(&[(0.0, 0.0), (3.0, 4.0)], &[]).len(), 1);
    }

    #[test]
    fn an_empty_figure_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let fig = Figure::new("e", "e", Axis::log("x"), Axis::linear("y")).series(
            vec![Series::new(
                "a",
                "a",
                "",
                Draw::Line,
                vec![Point::new(0.0, 1.0)],
            )],
            vec![],
        );
        assert!(fig.write(dir.path()).is_err());
    }

    #[test]
    fn long_text_is_wrapped_within_the_width() {
        ensure_font().unwrap();
        let mut buf = vec![255u8; 400 * 100 * 3];
        let root = BitMapBackend::with_buffer(&mut buf, (400, 100)).into_drawing_area();
        let font: TextStyle = (FONT, 18).into_font().into();
        let text = "screenspace tol=0.01 half_width=2 levels=3 sectors=8 threshold=0.25 (F1 0.972)";
        let lines = wrap_text(&root, text, &font, 250);
        assert!(lines.len() >= 2, "{lines:?}");
        for l in &lines {
            assert!(root.estimate_text_size(l, &font).unwrap().0 <= 250, "{l}");
        }
        assert_eq!(lines.join(" "), text);
    }
}
