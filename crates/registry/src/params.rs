//! A method's parameters (`NAME=VALUE` pairs: the command line's `--set`, Python's keyword
//! arguments, a sweep's setting): parsed once, read with typed getters, and checked so that a
//! name no method reads is an error rather than silently ignored.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};

/// A parameter a method accepts, for `--help`-style listings and validation.
#[derive(Debug, Clone, Copy)]
pub struct ParamSpec {
    /// Key.
    pub key: &'static str,
    /// Default, as text.
    pub default: &'static str,
    /// One line of help.
    pub help: &'static str,
}

/// A method's parameters by name, remembering which names were read.
#[derive(Debug, Default)]
pub struct Params {
    values: BTreeMap<String, String>,
    read: RefCell<BTreeSet<String>>,
}

impl Clone for Params {
    fn clone(&self) -> Self {
        Self {
            values: self.values.clone(),
            read: RefCell::new(self.read.borrow().clone()),
        }
    }
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
        Ok(Self {
            values,
            read: RefCell::default(),
        })
    }

    /// Builds parameters from key/value pairs (for experiments).
    pub fn from_pairs(pairs: &[(&str, String)]) -> Self {
        Self {
            values: pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.clone()))
                .collect(),
            read: RefCell::default(),
        }
    }

    /// The value of `key` parsed as `T`, or `default` when absent.
    pub fn get<T: FromStr>(&self, key: &str, default: T) -> Result<T>
    where
        T::Err: fmt::Display,
    {
        self.read.borrow_mut().insert(key.to_owned());
        match self.values.get(key) {
            None => Ok(default),
            Some(v) => v.parse::<T>().map_err(|e| Error::BadValue {
                key: key.to_owned(),
                value: v.clone(),
                reason: e.to_string(),
            }),
        }
    }

    /// The value of `key` parsed as `T`, or `None` when absent.
    pub fn get_opt<T: FromStr>(&self, key: &str) -> Result<Option<T>>
    where
        T::Err: fmt::Display,
    {
        self.read.borrow_mut().insert(key.to_owned());
        self.values
            .get(key)
            .map(|v| {
                v.parse::<T>().map_err(|e| Error::BadValue {
                    key: key.to_owned(),
                    value: v.clone(),
                    reason: e.to_string(),
                })
            })
            .transpose()
    }

    /// Fails if a given key was never read, naming the keys the method knows.
    pub fn check_all_read(&self, method: &str, specs: &[ParamSpec]) -> Result<()> {
        let read = self.read.borrow();
        let unknown: Vec<&str> = self
            .values
            .keys()
            .filter(|k| !read.contains(*k))
            .map(String::as_str)
            .collect();
        if !unknown.is_empty() {
            return Err(Error::UnknownParams {
                plural: if unknown.len() > 1 { "s" } else { "" },
                keys: unknown.join(", "),
                method: method.to_owned(),
                accepted: specs.iter().map(|s| s.key).collect::<Vec<_>>().join(", "),
            });
        }
        Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_getters_and_defaults() {
        let p = Params::parse(&["gamma=2.5", "hull = qhull"]).unwrap();
        assert_eq!(p.get("gamma", 3.0).unwrap(), 2.5);
        assert_eq!(p.get("hull", String::from("own")).unwrap(), "qhull");
        assert_eq!(p.get("perturb", 0.0).unwrap(), 0.0);
        assert_eq!(p.canonical(), "gamma=2.5;hull=qhull");
        p.check_all_read("hpr", &[]).unwrap();
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
        assert_eq!(
            p.get("gamma", 3.0).unwrap_err().to_string(),
            "parameter gamma=abc: invalid float literal"
        );
        assert_eq!(
            p.get_opt::<u32>("gamma").unwrap_err().to_string(),
            "parameter gamma=abc: invalid digit found in string"
        );
        let p = Params::parse(&["gama=3"]).unwrap();
        let _ = p.get("gamma", 3.0);
        let err = p
            .check_all_read(
                "hpr",
                &[ParamSpec {
                    key: "gamma",
                    default: "3",
                    help: "",
                }],
            )
            .unwrap_err()
            .to_string();
        assert!(err.contains("gama") && err.contains("gamma"), "{err}");
    }
}
