//! The one command-line syntax of a setting, read by every command that runs a method
//! (`visible`, `view`, `run`, `bench`): `[METHOD.]KEY=VALUE`, repeatable, where `KEY=A,B,C` is a
//! list of values (a sweep). Without `METHOD` a pair applies to every method run that has
//! `KEY`; with it, to that method alone.
//!
//! [`Assignments::parse`] reads the pairs as given; [`Assignments::check_targets`] refuses a
//! pair that no method run takes (an unknown method, or a key none of them has), naming what
//! they accept; [`Assignments::one_setting`] refuses a list where one setting runs; then
//! [`Assignments::over_params`] lays the pairs over one method's parameters (one setting) and
//! [`Assignments::over_sweep`] over its sweep (the settings a run measures). The values stay as
//! given here: each method's card types them ([`crate::Card::check`]) before any data is read.

use crate::card::Card;
use crate::error::{Error, Result};
use crate::params::Params;
use crate::setting::{Setting, Value};
use crate::sweep::MethodSweep;

/// One `[METHOD.]KEY=VALUE` pair as given.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// The pair as written (for messages).
    pub text: String,
    /// The method it is for; `None`: every method run that has the key.
    pub method: Option<String>,
    /// The key.
    pub key: String,
    /// Its value, or its values for a list (`A,B,C`).
    pub values: Vec<String>,
}

impl Assignment {
    /// Reads `[METHOD.]KEY=VALUE` or `[METHOD.]KEY=A,B,C`.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = |reason: &str| Error::BadPair {
            pair: text.to_owned(),
            reason: reason.to_owned(),
        };
        let (name, value) = text
            .split_once('=')
            .ok_or_else(|| bad("expected [METHOD.]KEY=VALUE"))?;
        let (method, key) = match name.trim().split_once('.') {
            Some((m, k)) => (Some(m.trim()), k.trim()),
            None => (None, name.trim()),
        };
        if key.is_empty() {
            return Err(bad("empty name"));
        }
        if method.is_some_and(str::is_empty) {
            return Err(bad("empty method name before the dot"));
        }
        let value = value.trim();
        let values: Vec<String> = if value.contains(',') {
            let items: Vec<String> = value.split(',').map(|v| v.trim().to_owned()).collect();
            if items.iter().any(String::is_empty) {
                return Err(bad("an empty value in the list A,B,C"));
            }
            items
        } else {
            vec![value.to_owned()]
        };
        Ok(Self {
            text: text.to_owned(),
            method: method.map(str::to_owned),
            key: key.to_owned(),
            values,
        })
    }

    /// True when the pair is for `card`: its method, or no method and a key the card has.
    pub fn is_for(&self, card: &Card) -> bool {
        self.method.as_deref().is_none_or(|m| m == card.name) && card.param(&self.key).is_some()
    }

    /// True for a list of values (a sweep).
    pub fn is_sweep(&self) -> bool {
        self.values.len() > 1
    }
}

/// The pairs of one command line, in the order given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Assignments(pub Vec<Assignment>);

impl Assignments {
    /// Reads the pairs; the same key given twice for the same methods is an error.
    pub fn parse<S: AsRef<str>>(pairs: &[S]) -> Result<Self> {
        let mut out: Vec<Assignment> = Vec::with_capacity(pairs.len());
        for pair in pairs {
            let a = Assignment::parse(pair.as_ref())?;
            if out.iter().any(|o| o.method == a.method && o.key == a.key) {
                return Err(Error::BadPair {
                    pair: a.text,
                    reason: format!("{} given twice", a.key),
                });
            }
            out.push(a);
        }
        Ok(Self(out))
    }

    /// True when no pair was given.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Refuses a list of values: `command` runs one setting (`visible`, `view`).
    pub fn one_setting(&self, command: &str) -> Result<()> {
        match self.0.iter().find(|a| a.is_sweep()) {
            Some(a) => Err(Error::BadPair {
                pair: a.text.clone(),
                reason: format!(
                    "a list of values is a sweep, and sweeps are for `run` and `bench`; \
                     `{command}` runs one setting: give one value"
                ),
            }),
            None => Ok(()),
        }
    }

    /// Refuses a pair no method of `cards` (the methods run, of `catalogue`) takes: an unknown
    /// method, a method not run, a key its method does not have, or a key no method run has.
    /// Each error names what is accepted.
    pub fn check_targets(&self, catalogue: &crate::Catalogue, cards: &[&Card]) -> Result<()> {
        let names = || cards.iter().map(|c| c.name).collect::<Vec<_>>().join(", ");
        let unknown_key = |a: &Assignment, card: &Card| Error::UnknownParams {
            plural: "",
            keys: a.key.clone(),
            method: card.name.to_owned(),
            accepted: card
                .params
                .iter()
                .map(|p| p.key)
                .collect::<Vec<_>>()
                .join(", "),
        };
        for a in &self.0 {
            match &a.method {
                Some(m) => {
                    let card = match cards.iter().find(|c| c.name == m) {
                        Some(card) => *card,
                        None => {
                            // Unknown: the catalogue's error lists every method.
                            catalogue.card(m)?;
                            return Err(Error::BadPair {
                                pair: a.text.clone(),
                                reason: format!(
                                    "method {m} is not run here (the chosen: {})",
                                    names()
                                ),
                            });
                        }
                    };
                    if card.param(&a.key).is_none() {
                        return Err(unknown_key(a, card));
                    }
                }
                None if cards.iter().any(|c| c.param(&a.key).is_some()) => {}
                None if cards.len() == 1 => return Err(unknown_key(a, cards[0])),
                None => {
                    let mut keys: Vec<&str> = cards
                        .iter()
                        .flat_map(|c| c.params.iter().map(|p| p.key))
                        .collect();
                    keys.sort_unstable();
                    keys.dedup();
                    return Err(Error::BadPair {
                        pair: a.text.clone(),
                        reason: format!(
                            "no chosen method ({}) has the parameter {:?}; their parameters: {}",
                            names(),
                            a.key,
                            keys.join(", ")
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// `base` with the pairs for `card` over it, in the order given (one value each: see
    /// [`Assignments::one_setting`]; a list's first value otherwise).
    pub fn over_params(&self, card: &Card, base: &Params) -> Params {
        let mut out = base.clone();
        for a in self.0.iter().filter(|a| a.is_for(card)) {
            out.insert(&a.key, &a.values[0]);
        }
        out
    }

    /// The pairs for `card`, if any, over its sweep: the settings it is measured at become its
    /// default setting (after any `--config`) with each key given at each of its values (the
    /// lists' product, the first pair varying slowest), full and quick alike; its default
    /// setting takes each key's first value, and its robustness grid is this grid. Returns
    /// whether the sweep changed.
    pub fn over_sweep(&self, card: &Card, sweep: &mut MethodSweep) -> bool {
        let mine: Vec<&Assignment> = self.0.iter().filter(|a| a.is_for(card)).collect();
        if mine.is_empty() {
            return false;
        }
        let mut base = sweep
            .default_setting()
            .unwrap_or_else(|| card.default_setting());
        let mut grid = vec![base.clone()];
        for a in &mine {
            base.0.insert(a.key.clone(), Value::parse(&a.values[0]));
            grid = grid
                .iter()
                .flat_map(|s| {
                    a.values.iter().map(|v| {
                        let mut s: Setting = s.clone();
                        s.0.insert(a.key.clone(), Value::parse(v));
                        s
                    })
                })
                .collect();
        }
        sweep.grid = grid;
        sweep.quick_grid.clear();
        sweep.robustness.clear();
        sweep.default = Some(base);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn card(name: &str) -> &'static Card {
        crate::builtin_card(name).unwrap()
    }

    #[test]
    fn pairs_methods_and_lists() {
        let a =
            Assignments::parse(&["gamma=3", "hpr.kernel = exp", "splat.radius_px=1,2, 3"]).unwrap();
        assert_eq!(a.0[0].method, None);
        assert_eq!(a.0[1].method.as_deref(), Some("hpr"));
        assert_eq!(a.0[1].values, ["exp"]);
        assert_eq!(a.0[2].values, ["1", "2", "3"]);
        assert!(a.0[2].is_sweep());
        let e = a.one_setting("visible").unwrap_err().to_string();
        assert!(
            e.contains("splat.radius_px=1,2, 3") && e.contains("`run` and `bench`"),
            "{e}"
        );
        for (bad, why) in [
            ("gamma", "expected [METHOD.]KEY=VALUE"),
            ("=3", "empty name"),
            (".gamma=3", "empty method name"),
            ("gamma=1,,2", "an empty value"),
        ] {
            let e = Assignments::parse(&[bad]).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
        let e = Assignments::parse(&["gamma=1", "gamma=2"]).unwrap_err();
        assert!(e.to_string().contains("gamma given twice"), "{e}");
        // The same key for another method is another pair.
        Assignments::parse(&["gamma=1", "hpr.gamma=2"]).unwrap();
    }

    #[test]
    fn targets_name_what_is_accepted() {
        let (hpr, splat) = (card("hpr"), card("splat"));
        let check = |pairs: &[&str], cards: &[&Card]| {
            Assignments::parse(pairs)
                .unwrap()
                .check_targets(&crate::Catalogue::builtin(), cards)
                .map_err(|e| e.to_string())
        };
        check(&["gamma=3", "splat.radius_px=2"], &[hpr, splat]).unwrap();
        let e = check(&["gama=3"], &[hpr]).unwrap_err();
        assert!(
            e.contains("unknown parameter gama for method hpr") && e.contains("gamma"),
            "{e}"
        );
        let e = check(&["gama=3"], &[hpr, splat]).unwrap_err();
        assert!(
            e.contains("no chosen method (hpr, splat)") && e.contains("radius_px"),
            "{e}"
        );
        let e = check(&["nosuch.gamma=3"], &[hpr]).unwrap_err();
        assert!(
            e.contains("unknown method \"nosuch\"") && e.contains("raycast"),
            "{e}"
        );
        let e = check(&["splat.radius_px=3"], &[hpr]).unwrap_err();
        assert!(e.contains("not run here (the chosen: hpr)"), "{e}");
        let e = check(&["hpr.radius_px=3"], &[hpr, splat]).unwrap_err();
        assert!(
            e.contains("unknown parameter radius_px for method hpr"),
            "{e}"
        );
    }

    #[test]
    fn over_params_and_over_sweeps() {
        let (hpr, splat) = (card("hpr"), card("splat"));
        let a = Assignments::parse(&["gamma=3", "hpr.kernel=linear", "radius_px=2"]).unwrap();
        let base = Params::parse(&["gamma=auto", "seed=1"]).unwrap();
        assert_eq!(
            a.over_params(hpr, &base).canonical(),
            "gamma=3;kernel=linear;seed=1"
        );
        assert_eq!(
            a.over_params(splat, &base).canonical(),
            "gamma=auto;radius_px=2;seed=1"
        );
        // A sweep: the default setting with each key at each value, the first pair slowest.
        let a = Assignments::parse(&["hpr.gamma=2,3", "perturb=0,1e-5"]).unwrap();
        let mut sweep = crate::Catalogue::builtin().sweeps(None).unwrap().methods["hpr"].clone();
        assert!(a.over_sweep(hpr, &mut sweep));
        let labels: Vec<String> = sweep.settings(true).iter().map(Setting::label).collect();
        assert_eq!(
            labels,
            [
                "gamma=2;kernel=linear;perturb=0;seed=2007",
                "gamma=2;kernel=linear;perturb=0.00001;seed=2007",
                "gamma=3;kernel=linear;perturb=0;seed=2007",
                "gamma=3;kernel=linear;perturb=0.00001;seed=2007",
            ]
        );
        assert_eq!(sweep.default.unwrap().label(), labels[0]);
        let mut other = MethodSweep::default();
        assert!(!a.over_sweep(splat, &mut other));
    }
}
