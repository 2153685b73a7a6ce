//! Sweeps as data: the settings each method is measured at, full and quick, with typed values.
//!
//! The built-in grids are [`BUILTIN`] (`sweeps.toml` beside this file: data, not code); an
//! external method's `method.toml` carries its own; a user's file (`pointsight run visibility
//! --config sweeps.toml`) replaces the grid of any method it names, in the spirit of
//! ann-benchmarks' `config.yml`. One format for all three:
//!
//! ```toml
//! repeats = 5                      # optional: timed runs per call (the experiments' default: 3)
//!
//! [hpr]
//! # Optional: the one setting that stands for the method where one must (agreement between
//! # methods on a cloud without a mesh, the scale experiment). Absent: a built-in method's card's
//! # default setting, else the grid's first automatic setting, else its first.
//! default = {gamma = "auto", kernel = "linear", perturb = 0, seed = 2007}
//!
//! [[hpr.grid]]                     # a block: scalars are fixed, lists are swept
//! kernel = "linear"
//! gamma = [1.5, 2.0, 2.5]
//! perturb = 0
//!
//! [[hpr.grid]]                     # a list of inline tables sweeps several keys together
//! size = [{width = 640, height = 360}, {width = 1280, height = 720}]
//!
//! [[hpr.quick_grid]]               # optional; --quick uses `grid` when absent
//! gamma = 3
//! ```
//!
//! A block's settings are the product of its lists, the first key written varying slowest
//! ([`crate::setting::Setting`]s of typed values). The built-in methods' default settings come
//! from their cards, joined with these grids by the catalogue (`Sweeps::builtin`,
//! `Sweeps::resolve` in [`crate::methods`]).

use std::collections::BTreeMap;
use std::path::Path;

use crate::error::{Error, Result};
use crate::setting::{Setting, Value};

/// The built-in grids (`sweeps.toml`).
pub const BUILTIN: &str = include_str!("sweeps.toml");

/// The most timed runs per call a sweep may ask for (each run's time is kept).
pub const MAX_REPEATS: usize = 1_000;

/// The most settings one block may expand to (its lists' product is checked before any is
/// made: a file of a few lines can ask for billions).
pub const MAX_SETTINGS: usize = 100_000;

/// One method's sweep.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MethodSweep {
    /// The full grid.
    pub grid: Vec<Setting>,
    /// The quick grid (`--quick`); empty: the full grid.
    pub quick_grid: Vec<Setting>,
    /// The setting that stands for the method; `None`: the first automatic one, else the first.
    pub default: Option<Setting>,
    /// The grid the robustness experiment tunes on the clean cloud; empty: the grid.
    pub robustness: Vec<Setting>,
    /// The automatic setting the robustness experiment recomputes on each degraded cloud;
    /// `None`: the default setting.
    pub robustness_auto: Option<Setting>,
    /// Why the robustness experiment leaves the method out (`skip_robustness = "why"`); the
    /// report lists it with the reason. `None`: it takes part.
    pub skip_robustness: Option<String>,
}

impl MethodSweep {
    /// The settings to run.
    pub fn settings(&self, quick: bool) -> &[Setting] {
        if quick && !self.quick_grid.is_empty() {
            &self.quick_grid
        } else {
            &self.grid
        }
    }

    /// The setting that stands for the method.
    pub fn default_setting(&self) -> Option<Setting> {
        self.default.clone().or_else(|| {
            self.grid
                .iter()
                .find(|s| s.is_auto())
                .or(self.grid.first())
                .cloned()
        })
    }

    /// The settings the robustness experiment tunes on the clean cloud (`robustness`, else the
    /// grid of `quick`).
    pub fn tuning(&self, quick: bool) -> &[Setting] {
        if self.robustness.is_empty() {
            self.settings(quick)
        } else {
            &self.robustness
        }
    }

    /// The setting the robustness experiment recomputes on each degraded cloud
    /// (`robustness_auto`, else the default setting).
    pub fn automatic(&self) -> Option<Setting> {
        self.robustness_auto
            .clone()
            .or_else(|| self.default_setting())
    }

    /// Reads one method's table (`grid`, `quick_grid`, `default`, `robustness`,
    /// `robustness_auto`, `skip_robustness`).
    pub fn from_toml(table: &toml::Table, where_: &str) -> Result<Self> {
        let mut out = Self::default();
        for (key, value) in table {
            let here = format!("{where_}.{key}");
            match key.as_str() {
                "grid" | "quick_grid" | "robustness" => {
                    let blocks = value.as_array().ok_or_else(|| {
                        Error::Sweep(format!("{here}: expected a list of tables ([[{here}]])"))
                    })?;
                    let mut settings = Vec::new();
                    for (i, block) in blocks.iter().enumerate() {
                        let block = block.as_table().ok_or_else(|| {
                            Error::Sweep(format!("{here}[{i}]: expected a table"))
                        })?;
                        settings.extend(expand(block, &format!("{here}[{i}]"))?);
                    }
                    match key.as_str() {
                        "grid" => out.grid = settings,
                        "quick_grid" => out.quick_grid = settings,
                        _ => out.robustness = settings,
                    }
                }
                "default" | "robustness_auto" => {
                    let t = value.as_table().ok_or_else(|| {
                        Error::Sweep(format!("{here}: expected a table of key = value"))
                    })?;
                    let mut s = Setting::default();
                    for (k, v) in t {
                        s.0.insert(k.clone(), value_from_toml(v, &format!("{here}.{k}"))?);
                    }
                    if key == "default" {
                        out.default = Some(s);
                    } else {
                        out.robustness_auto = Some(s);
                    }
                }
                "skip_robustness" => {
                    let why = value
                        .as_str()
                        .filter(|w| !w.trim().is_empty())
                        .ok_or_else(|| {
                            Error::Sweep(format!("{here}: expected the reason, a non-empty string"))
                        })?;
                    out.skip_robustness = Some(why.to_owned());
                }
                other => {
                    return Err(Error::Sweep(format!(
                        "{where_}: unknown key {other:?} (expected grid, quick_grid, default, robustness, robustness_auto, skip_robustness)"
                    )));
                }
            }
        }
        Ok(out)
    }
}

/// A TOML value as a parameter value.
fn value_from_toml(v: &toml::Value, where_: &str) -> Result<Value> {
    Ok(match v {
        toml::Value::Integer(i) => Value::Int(*i),
        toml::Value::Float(x) => Value::Float(*x),
        toml::Value::Boolean(b) => Value::Bool(*b),
        toml::Value::String(s) => Value::Text(s.clone()),
        other => {
            return Err(Error::Sweep(format!(
                "{where_}: expected a number, a flag or text, got {}",
                other.type_str()
            )));
        }
    })
}

/// The settings of one block: the product of its lists, first key slowest.
fn expand(block: &toml::Table, where_: &str) -> Result<Vec<Setting>> {
    let count = block.values().try_fold(1usize, |n, v| match v {
        toml::Value::Array(items) => n.checked_mul(items.len().max(1)),
        _ => Some(n),
    });
    if count.is_none_or(|n| n > MAX_SETTINGS) {
        return Err(Error::Sweep(format!(
            "{where_}: the block's lists multiply to {} settings, more than the {MAX_SETTINGS} \
             one block may hold; split it or shorten its lists",
            count.map_or("over 2^64".to_owned(), |n| n.to_string())
        )));
    }
    let mut settings = vec![Setting::default()];
    for (key, value) in block {
        let here = format!("{where_}.{key}");
        // Each choice of this key: the pairs it sets.
        let choices: Vec<Vec<(String, Value)>> = match value {
            toml::Value::Array(items) => {
                if items.is_empty() {
                    return Err(Error::Sweep(format!(
                        "{here}: an empty list sweeps nothing"
                    )));
                }
                items
                    .iter()
                    .map(|item| match item {
                        toml::Value::Table(t) => t
                            .iter()
                            .map(|(k, v)| {
                                Ok((k.clone(), value_from_toml(v, &format!("{here}.{k}"))?))
                            })
                            .collect::<Result<Vec<_>>>(),
                        v => Ok(vec![(key.clone(), value_from_toml(v, &here)?)]),
                    })
                    .collect::<Result<_>>()?
            }
            v => vec![vec![(key.clone(), value_from_toml(v, &here)?)]],
        };
        let mut next = Vec::with_capacity(settings.len() * choices.len());
        for s in &settings {
            for choice in &choices {
                let mut s = s.clone();
                for (k, v) in choice {
                    if s.0.insert(k.clone(), v.clone()).is_some() {
                        return Err(Error::Sweep(format!("{here}: {k} is set twice")));
                    }
                }
                next.push(s);
            }
        }
        settings = next;
    }
    Ok(settings)
}

/// Sweeps of several methods, and the number of timed runs per call.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sweeps {
    /// By method name.
    pub methods: BTreeMap<String, MethodSweep>,
    /// Timed runs per call, when the file sets it.
    pub repeats: Option<usize>,
}

impl Sweeps {
    /// Parses a sweeps file's text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self> {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| Error::Sweep(format!("{origin}: {e}")))?;
        let mut out = Self::default();
        for (key, value) in &table {
            match (key.as_str(), value) {
                ("repeats", toml::Value::Integer(r)) if (1..=MAX_REPEATS as i64).contains(r) => {
                    out.repeats = Some(*r as usize);
                }
                ("repeats", _) => {
                    return Err(Error::Sweep(format!(
                        "{origin}: repeats must be an integer from 1 to {MAX_REPEATS}"
                    )));
                }
                (name, toml::Value::Table(t)) => {
                    out.methods.insert(
                        name.to_owned(),
                        MethodSweep::from_toml(t, &format!("{origin}: {name}"))?,
                    );
                }
                (name, _) => {
                    return Err(Error::Sweep(format!(
                        "{origin}: {name} must be a table ([{name}]) of grid, quick_grid, default"
                    )));
                }
            }
        }
        Ok(out)
    }

    /// Reads a sweeps file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::Sweep(format!("{}: {e}", path.display())))?;
        Self::parse(&text, &path.display().to_string())
    }

    /// `over` replaces the sweeps of the methods it names (and the repeats, if set).
    pub fn overlay(mut self, over: Sweeps) -> Self {
        self.methods.extend(over.methods);
        if over.repeats.is_some() {
            self.repeats = over.repeats;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_expand_to_products_in_written_order() {
        let s = Sweeps::parse(
            r#"
            repeats = 4
            [m]
            [[m.grid]]
            b = [2, 1]
            a = "x"
            size = [{w = 640, h = 360}, {w = 1280, h = 720}]
            [[m.grid]]
            c = 1e-5
            "#,
            "t",
        )
        .unwrap();
        assert_eq!(s.repeats, Some(4));
        let labels: Vec<String> = s.methods["m"].grid.iter().map(Setting::label).collect();
        assert_eq!(
            labels,
            [
                "a=x;b=2;h=360;w=640",
                "a=x;b=2;h=720;w=1280",
                "a=x;b=1;h=360;w=640",
                "a=x;b=1;h=720;w=1280",
                "c=0.00001",
            ]
        );
        // Labels read back to the same typed values.
        for set in &s.methods["m"].grid {
            assert_eq!(Setting::parse(&set.label()), *set);
        }
        assert_eq!(s.methods["m"].settings(true).len(), 5);
    }

    #[test]
    fn errors_name_the_place() {
        for (text, needle) in [
            ("[m]\ngrid = 3", "m.grid"),
            ("[m]\n[[m.grid]]\ng = []", "m.grid[0].g"),
            ("[m]\n[[m.grid]]\ng = [[1]]", "m.grid[0].g"),
            ("[m]\nwhat = 1", "what"),
            ("repeats = 0", "repeats"),
            ("repeats = 1000000000000", "repeats"),
            (
                "[m]\n[[m.grid]]\na = [1,2,3,4,5,6,7,8,9,10]\nb = [1,2,3,4,5,6,7,8,9,10]\n\
                 c = [1,2,3,4,5,6,7,8,9,10]\nd = [1,2,3,4,5,6,7,8,9,10]\ne = [1,2,3,4,5,6,7,8,9,10]\n\
                 f = [1,2,3,4,5,6,7,8,9,10]",
                "1000000 settings",
            ),
            ("m = 3", "m must be a table"),
            ("[m]\n[[m.grid]]\nw = 1\ns = [{w = 2}]", "w is set twice"),
            ("[m]\nskip_robustness = 3", "m.skip_robustness"),
            ("[m]\nskip_robustness = \" \"", "m.skip_robustness"),
        ] {
            let e = Sweeps::parse(text, "f.toml").unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("f.toml"), "{text}: {e}");
        }
    }

    #[test]
    fn a_method_can_leave_robustness_with_a_reason() {
        let s = Sweeps::parse(
            "[m]\nskip_robustness = \"same sets as hpr\"\n[[m.grid]]\ng = 1",
            "f.toml",
        )
        .unwrap();
        let m = &s.methods["m"];
        assert_eq!(m.skip_robustness.as_deref(), Some("same sets as hpr"));
        assert_eq!(m.grid.len(), 1);
        let b = Sweeps::parse(BUILTIN, "sweeps.toml").unwrap();
        assert!(b.methods.values().all(|m| m.skip_robustness.is_none()));
    }
}
