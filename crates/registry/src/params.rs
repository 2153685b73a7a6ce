//! A method's parameters in two forms, ripgrep's low-level and high-level arguments: the
//! `KEY=VALUE` pairs as given ([`Params`]: the command line's `--set`, Python's keyword
//! arguments, a sweep's setting), and their typed reading against the [`Param`]s a method's
//! card declares ([`Reader`]), which each adapter does once, into a struct of its own, before
//! any work. A parameter's default and help are written once, in its [`Param`]: listings print
//! them, the method's default setting is made of them (`Card::default_setting`),
//! and a key absent from a setting reads as its default. A given key the adapter did not read
//! is refused when the reading ends ([`Reader::finish`]).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::setting::{Setting, Value};

/// What a parameter is when a setting does not give it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamDefault {
    /// This value.
    Value(&'static str),
    /// A value that depends on another parameter's: `(that parameter's value, this default)`
    /// pairs.
    Per {
        /// The other parameter.
        key: &'static str,
        /// Its values and this parameter's default at each.
        values: &'static [(&'static str, &'static str)],
    },
    /// No value: the method follows the rule said here (`the view's`; an external program's
    /// own default, which it applies itself).
    Rule(&'static str),
}

impl fmt::Display for ParamDefault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamDefault::Value(v) | ParamDefault::Rule(v) => f.write_str(v),
            ParamDefault::Per { key, values } => {
                let parts: Vec<String> = values
                    .iter()
                    .map(|(when, v)| format!("{v} ({key}={when})"))
                    .collect();
                f.write_str(&parts.join(", "))
            }
        }
    }
}

/// A parameter a method accepts: its key, its default and one line of help, written once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// Key.
    pub key: &'static str,
    /// What it is when absent.
    pub default: ParamDefault,
    /// True when the method's default setting names it at its default (the keys its sweeps
    /// vary); false for a choice of implementation no sweep varies (HPR's hull), left implied.
    pub named: bool,
    /// One line of help.
    pub help: &'static str,
}

impl Param {
    /// A parameter of default `value`, named in the default setting.
    pub const fn value(key: &'static str, value: &'static str, help: &'static str) -> Self {
        Self {
            key,
            default: ParamDefault::Value(value),
            named: true,
            help,
        }
    }

    /// A parameter of default `value`, left implied by the default setting.
    pub const fn implied(key: &'static str, value: &'static str, help: &'static str) -> Self {
        Self::value(key, value, help).unnamed()
    }

    /// A parameter with no default value: absent, the method follows `rule`.
    pub const fn rule(key: &'static str, rule: &'static str, help: &'static str) -> Self {
        Self {
            key,
            default: ParamDefault::Rule(rule),
            named: false,
            help,
        }
    }

    /// A parameter whose default depends on `other`'s value, named in the default setting at
    /// `other`'s default.
    pub const fn per(
        key: &'static str,
        other: &'static str,
        values: &'static [(&'static str, &'static str)],
        help: &'static str,
    ) -> Self {
        Self {
            key,
            default: ParamDefault::Per { key: other, values },
            named: true,
            help,
        }
    }

    /// The same parameter, left implied by the default setting.
    pub const fn unnamed(self) -> Self {
        Self {
            named: false,
            ..self
        }
    }
}

/// The `KEY=VALUE` pairs of one setting, as given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params {
    values: BTreeMap<String, String>,
}

impl Params {
    /// Parses `KEY=VALUE` strings; a repeated key is an error.
    pub fn parse<S: AsRef<str>>(pairs: &[S]) -> Result<Self> {
        let mut values = BTreeMap::new();
        for pair in pairs {
            let pair = pair.as_ref();
            let (k, v) = pair.split_once('=').ok_or_else(|| Error::BadPair {
                pair: pair.to_owned(),
                reason: "expected NAME=VALUE".into(),
            })?;
            let (k, v) = (k.trim(), v.trim());
            if k.is_empty() {
                return Err(Error::BadPair {
                    pair: pair.to_owned(),
                    reason: "empty name".into(),
                });
            }
            if values.insert(k.to_owned(), v.to_owned()).is_some() {
                return Err(Error::BadPair {
                    pair: pair.to_owned(),
                    reason: format!("{k} given twice"),
                });
            }
        }
        Ok(Self { values })
    }

    /// Builds parameters from key/value pairs (a later pair replaces an earlier one).
    pub fn from_pairs(pairs: &[(&str, String)]) -> Self {
        Self {
            values: pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.clone()))
                .collect(),
        }
    }

    /// Sets `key` to `value` (replacing what it was).
    pub fn insert(&mut self, key: &str, value: &str) {
        self.values.insert(key.to_owned(), value.to_owned());
    }

    /// The text given for `key`.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.values.get(key).map(String::as_str)
    }

    /// The keys given, sorted.
    pub fn keys(&self) -> impl Iterator<Item = &str> {
        self.values.keys().map(String::as_str)
    }

    /// The parameters as `k=v` pairs joined by `;` (for CSV `params` columns), sorted by key.
    pub fn canonical(&self) -> String {
        self.values
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(";")
    }
}

impl Setting {
    /// The setting as `KEY=VALUE` parameters.
    pub fn params(&self) -> Params {
        Params::from_pairs(
            &self
                .0
                .iter()
                .map(|(k, v)| (k.as_str(), v.to_string()))
                .collect::<Vec<_>>(),
        )
    }
}

/// One reading of a setting against a method's parameters: typed values (given, else the
/// parameter's default), the keys read remembered, and the setting as run recorded (every key
/// read with the value used).
pub struct Reader<'p> {
    method: &'static str,
    specs: &'static [Param],
    params: &'p Params,
    read: BTreeSet<&'static str>,
    ran: Setting,
}

/// What a value of `T` is, in words, for the types settings are read as; `None` for others
/// (their own parse error says it).
fn expected<T>() -> Option<&'static str> {
    Some(match std::any::type_name::<T>() {
        "f64" | "f32" => "a number",
        "u8" | "u16" | "u32" | "u64" | "usize" => "a whole number, 0 or more",
        "i8" | "i16" | "i32" | "i64" | "isize" => "a whole number",
        "bool" => "true or false",
        _ => return None,
    })
}

fn parsed<T: FromStr>(key: &str, text: &str) -> Result<T>
where
    T::Err: fmt::Display,
{
    text.parse::<T>().map_err(|e| Error::BadValue {
        key: key.to_owned(),
        value: text.to_owned(),
        reason: match expected::<T>() {
            Some(what) => format!("expected {what} ({e})"),
            None => e.to_string(),
        },
    })
}

impl<'p> Reader<'p> {
    /// A reading of `params` for `method`, whose parameters are `specs`.
    pub fn new(method: &'static str, specs: &'static [Param], params: &'p Params) -> Self {
        Self {
            method,
            specs,
            params,
            read: BTreeSet::new(),
            ran: Setting::default(),
        }
    }

    /// The method read for.
    pub fn method(&self) -> &'static str {
        self.method
    }

    /// The default text of `p` in this setting (a [`ParamDefault::Per`] resolved against the
    /// other parameter's given or default value); `None` for a rule.
    fn default_text(&self, p: &Param) -> Option<&'static str> {
        match p.default {
            ParamDefault::Value(v) => Some(v),
            ParamDefault::Rule(_) => None,
            ParamDefault::Per { key, values } => {
                let other = self.specs.iter().find(|s| s.key == key)?;
                let at = match self.params.get(key) {
                    Some(given) => given.to_owned(),
                    None => self.default_text(other)?.to_owned(),
                };
                values.iter().find(|(when, _)| *when == at).map(|(_, v)| *v)
            }
        }
    }

    /// Marks `p` read (it must be one of the method's parameters: a programming error else).
    fn mark(&mut self, p: &Param) -> Result<()> {
        let spec = self.specs.iter().find(|s| s.key == p.key).ok_or_else(|| {
            Error::Unsupported(format!(
                "method {} reads a parameter its card does not declare: {}",
                self.method, p.key
            ))
        })?;
        self.read.insert(spec.key);
        Ok(())
    }

    /// The text given for `p`, if any (read, and recorded as run when given).
    pub fn given_text(&mut self, p: &Param) -> Result<Option<String>> {
        self.mark(p)?;
        let given = self.params.get(p.key).map(str::to_owned);
        if let Some(v) = &given {
            self.ran.0.insert(p.key.to_owned(), Value::parse(v));
        }
        Ok(given)
    }

    /// The value given for `p`, if any, as `T`.
    pub fn given<T: FromStr>(&mut self, p: &Param) -> Result<Option<T>>
    where
        T::Err: fmt::Display,
    {
        self.given_text(p)?
            .map(|text| parsed(p.key, &text))
            .transpose()
    }

    /// The text of `p`: given, else its default value; `None` when neither (a rule's
    /// parameter left out). Recorded as run.
    pub fn text(&mut self, p: &Param) -> Result<Option<String>> {
        if let Some(given) = self.given_text(p)? {
            return Ok(Some(given));
        }
        let default = self.default_text(p);
        if let Some(v) = default {
            self.ran.0.insert(p.key.to_owned(), Value::parse(v));
        }
        Ok(default.map(str::to_owned))
    }

    /// The value of `p` as `T`: given, else its default; `None` when neither.
    pub fn opt<T: FromStr>(&mut self, p: &Param) -> Result<Option<T>>
    where
        T::Err: fmt::Display,
    {
        self.text(p)?.map(|text| parsed(p.key, &text)).transpose()
    }

    /// The value of `p` as `T`: given, else its default (a parameter with neither is an error
    /// naming it).
    pub fn get<T: FromStr>(&mut self, p: &Param) -> Result<T>
    where
        T::Err: fmt::Display,
    {
        let method = self.method;
        self.opt(p)?.ok_or_else(|| {
            Error::Unsupported(format!(
                "method {method}: parameter {} has no value here and no default",
                p.key
            ))
        })
    }

    /// A parameter error in the registry's words: `p` at `value`, and why.
    pub fn bad(&self, p: &Param, value: impl fmt::Display, reason: impl Into<String>) -> Error {
        Error::BadValue {
            key: p.key.to_owned(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// Ends the reading: a given key the method did not read is an error naming the keys it
    /// knows; else the setting as run (every key read with the value used, given or default).
    pub fn finish(self) -> Result<Setting> {
        let unknown: Vec<&str> = self
            .params
            .keys()
            .filter(|k| !self.read.contains(k))
            .collect();
        if !unknown.is_empty() {
            return Err(Error::UnknownParams {
                plural: if unknown.len() > 1 { "s" } else { "" },
                keys: unknown.join(", "),
                method: self.method.to_owned(),
                accepted: self
                    .specs
                    .iter()
                    .map(|s| s.key)
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        Ok(self.ran)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KERNEL: Param = Param::value("kernel", "linear", "the kernel");
    const GAMMA: Param = Param::per(
        "gamma",
        "kernel",
        &[("linear", "auto"), ("exp", "-0.05")],
        "the kernel's parameter",
    );
    const HULL: Param = Param::implied("hull", "own", "the hull");
    const RADIUS: Param = Param::rule("radius", "-", "an absolute radius");
    const SPECS: &[Param] = &[KERNEL, GAMMA, HULL, RADIUS];

    #[test]
    fn typed_values_defaults_and_the_setting_as_run() {
        let p = Params::parse(&["gamma=2.5", "hull = qhull"]).unwrap();
        let mut r = Reader::new("hpr", SPECS, &p);
        assert_eq!(r.get::<f64>(&GAMMA).unwrap(), 2.5);
        assert_eq!(r.get::<String>(&HULL).unwrap(), "qhull");
        assert_eq!(r.get::<String>(&KERNEL).unwrap(), "linear");
        assert_eq!(r.opt::<f64>(&RADIUS).unwrap(), None);
        assert_eq!(p.canonical(), "gamma=2.5;hull=qhull");
        assert_eq!(
            r.finish().unwrap().label(),
            "gamma=2.5;hull=qhull;kernel=linear"
        );
        // A default that depends on another parameter, given or defaulted.
        for (set, gamma) in [(&[][..], "auto"), (&["kernel=exp"], "-0.05")] {
            let p = Params::parse(set).unwrap();
            let mut r = Reader::new("hpr", SPECS, &p);
            assert_eq!(r.text(&GAMMA).unwrap().as_deref(), Some(gamma));
            r.get::<String>(&KERNEL).unwrap();
            r.finish().unwrap();
        }
        assert_eq!(
            GAMMA.default.to_string(),
            "auto (kernel=linear), -0.05 (kernel=exp)"
        );
    }

    #[test]
    fn errors() {
        // In the registry's words: parameter names and values, no command-line flag.
        let message = |pairs: &[&str]| Params::parse(pairs).unwrap_err().to_string();
        assert_eq!(
            message(&["novalue"]),
            "parameter \"novalue\": expected NAME=VALUE"
        );
        assert_eq!(message(&["=3"]), "parameter \"=3\": empty name");
        assert_eq!(message(&["a=1", "a=2"]), "parameter \"a=2\": a given twice");
        let p = Params::parse(&["gamma=abc"]).unwrap();
        let mut r = Reader::new("hpr", SPECS, &p);
        assert_eq!(
            r.get::<f64>(&GAMMA).unwrap_err().to_string(),
            "parameter gamma=abc: expected a number (invalid float literal)"
        );
        assert_eq!(
            r.given::<u32>(&GAMMA).unwrap_err().to_string(),
            "parameter gamma=abc: expected a whole number, 0 or more (invalid digit found in string)"
        );
        // A key given and never read: refused at the end, naming the known keys.
        let p = Params::parse(&["gama=3"]).unwrap();
        let mut r = Reader::new("hpr", SPECS, &p);
        let _ = r.get::<String>(&GAMMA);
        let err = r.finish().unwrap_err().to_string();
        assert!(err.contains("gama") && err.contains("gamma"), "{err}");
        // A parameter the card does not declare is a programming error, said so.
        let p = Params::default();
        let mut r = Reader::new("hpr", &[], &p);
        assert!(
            r.get::<String>(&KERNEL)
                .unwrap_err()
                .to_string()
                .contains("does not declare")
        );
    }
}
