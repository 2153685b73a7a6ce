//! A setting: one method's parameters as typed values (parameter key to [`Value`]), and its label,
//! the CSV `params` column: `k=v` pairs sorted by key and joined by `;`, the same text
//! [`crate::params::Params::canonical`] gives; [`Setting::parse`] reads a label back.

use std::collections::BTreeMap;
use std::fmt;

/// A parameter value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// An integer.
    Int(i64),
    /// A real number.
    Float(f64),
    /// A flag.
    Bool(bool),
    /// Text (a name, or a rule such as `auto`).
    Text(String),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Text(s) => f.write_str(s),
        }
    }
}

impl Value {
    /// Reads a value back from its text: an integer, else a real, else a flag, else text.
    pub fn parse(text: &str) -> Self {
        if let Ok(i) = text.parse::<i64>() {
            Value::Int(i)
        } else if let Ok(x) = text.parse::<f64>() {
            Value::Float(x)
        } else if let Ok(b) = text.parse::<bool>() {
            Value::Bool(b)
        } else {
            Value::Text(text.to_owned())
        }
    }

    /// The value as a number (integers and reals).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(i) => Some(*i as f64),
            Value::Float(x) => Some(*x),
            _ => None,
        }
    }
}

/// One setting: parameter key to typed value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Setting(pub BTreeMap<String, Value>);

impl Setting {
    /// Reads a label (`k=v;k=v`) back into typed values; the empty label is the empty setting.
    pub fn parse(label: &str) -> Self {
        Self(
            label
                .split(';')
                .filter(|kv| !kv.is_empty())
                .map(|kv| match kv.split_once('=') {
                    Some((k, v)) => (k.to_owned(), Value::parse(v)),
                    None => (kv.to_owned(), Value::Text(String::new())),
                })
                .collect(),
        )
    }

    /// The label: `k=v` pairs sorted by key, joined by `;`.
    pub fn label(&self) -> String {
        self.0
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(";")
    }

    /// The value of `key`.
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.0.get(key)
    }

    /// The value of `key` as a number.
    pub fn number(&self, key: &str) -> Option<f64> {
        self.get(key).and_then(Value::as_f64)
    }

    /// The value of `key` as text.
    pub fn text(&self, key: &str) -> Option<String> {
        self.get(key).map(Value::to_string)
    }

    /// True when some value is a rule computed from the data (`auto`) rather than fixed.
    pub fn is_auto(&self) -> bool {
        self.0.values().any(|v| *v == Value::Text("auto".into()))
    }

    /// True when `self` has every pair of `other`.
    pub fn contains(&self, other: &Setting) -> bool {
        other.0.iter().all(|(k, v)| self.0.get(k) == Some(v))
    }
}
