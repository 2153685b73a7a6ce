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
use plotters::style::FontStyle;
use serde::Serialize;

use super::style::{self, CONTEXT, Marker, Style};
use super::{write_atomic, write_png};

mod draw;
#[cfg(test)]
mod tests;

pub(crate) use draw::wrap_text;
use draw::*;
pub use draw::{dash_segments, format_number};

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

/// A vertical rule across every panel at one x, with its label (an LOD budget, say).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rule {
    /// Where (in the data's units, not log10 on a log axis).
    pub x: f64,
    /// What it marks, printed beside it at the top of the plot.
    pub label: String,
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
    /// Vertical rules drawn in every panel (those inside the x range).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub rules: Vec<Rule>,
    /// Notes about data that is not drawn (images identical to the reference, say), printed
    /// under the legend.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
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
            rules: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// With vertical rules at these x, labelled.
    pub fn rules(mut self, rules: Vec<Rule>) -> Self {
        self.rules = rules;
        self
    }

    /// With notes printed under the legend.
    pub fn notes(mut self, notes: Vec<String>) -> Self {
        self.notes = notes;
        self
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
        self.distinct_colours();
        self
    }

    /// Gives each series identity of the figure (as the legend lists them) a colour no other
    /// identity has: a series whose colour another already took (two variants of one family,
    /// a method and its variant in one panel) takes the next free shade of it
    /// ([`style::free_shade`]); the first keeps the table's. Context, fronts and wrong answers
    /// keep their reserved colours.
    fn distinct_colours(&mut self) {
        type Key = (String, String, String, String);
        let key = |s: &Series| -> Key {
            (
                s.method.clone(),
                s.family.clone(),
                s.variant.clone(),
                s.label.clone(),
            )
        };
        let mut taken: Vec<[u8; 3]> = Vec::new();
        let mut chosen: Vec<(Key, [u8; 3])> = Vec::new();
        for s in self.panels.iter().flat_map(|p| &p.series) {
            let k = key(s);
            if s.context
                || s.draw == Draw::Front
                || s.variant == style::WRONG
                || s.style.color == style::WRONG_COLOR
                || chosen.iter().any(|(c, _)| *c == k)
            {
                continue;
            }
            let colour = if taken.contains(&s.style.color) {
                style::free_shade(s.style.color, &taken).unwrap_or(s.style.color)
            } else {
                s.style.color
            };
            taken.push(colour);
            chosen.push((k, colour));
        }
        for s in self.panels.iter_mut().flat_map(|p| &mut p.series) {
            if s.context {
                continue;
            }
            if let Some((_, c)) = chosen.iter().find(|(k, _)| *k == key(s)) {
                s.style.color = *c;
            }
        }
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
            (1000 + self.legend_width(), 560)
        } else {
            let entries = self.legend_lines().len() as u32 + 1;
            let (pw, ph) = self.panel_size();
            let h = (TITLE_H + rows as u32 * ph + 40).max(TITLE_H + entries * 18 + 40);
            (cols as u32 * pw + 40 + self.legend_width(), h)
        }
    }
}

/// The legend column's narrowest and widest: between them it is as wide as its longest entry,
/// so that no series' label is cut ("copc_converter-build-ooc (slope 0.94, 2 sizes)" was).
const LEGEND_W: u32 = 300;
const LEGEND_MAX_W: u32 = 560;
