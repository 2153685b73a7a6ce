//! The tuning/evaluation protocol: which setting of a method
//! (family) stands for it in the visibility tables and findings.
//!
//! Every dataset has a role ([`crate::datasets::Role`]): the built-in datasets of before the
//! protocol are the **tuning** set, four further meshes of the same Debian package are the
//! **evaluation** set, a user's own data are neither. The full sweep runs on every dataset.
//!
//! **The tuned setting** of a family is chosen on the tuning datasets of the run alone:
//!
//! 1. `F(s, d)`: the mean F1 of setting `s` over the views of tuning dataset `d` (rows with
//!    status `ok` and a finite F1);
//! 2. the candidates are the settings the family has on *every* tuning dataset it ran on (a
//!    setting missing from one, e.g. failed there, cannot win on the others alone); fixed
//!    settings only, unless the family has nothing but automatic ones (`robust`, `hpr-approx`:
//!    the same rule as the per-dataset best);
//! 3. `T(s)` = the mean of `F(s, d)` over those tuning datasets: each tuning dataset weighs the
//!    same, whatever its number of views;
//! 4. the tuned setting is the candidate with the highest `T(s)` (ties: the first label in
//!    byte order).
//!
//! No row of an evaluation (or own) dataset enters it, so a score on an evaluation dataset at
//! the tuned setting is out-of-sample; on a tuning dataset it is in-sample, and the tables say
//! so. **The oracle** of a dataset is the setting with the highest mean F1 over that dataset's
//! own views: shown beside the tuned one as a labelled column, never as "best". A run without
//! tuning rows for a family (a user's own data, `--datasets` with evaluation datasets alone)
//! has no tuned setting: it falls back to the oracle and says so ([`Chosen::Oracle`]).
//!
//! The roles of a run's datasets are written into its `metadata.json` (`dataset_roles`) by
//! the experiment; tables and findings read them there, else look the names up in the
//! registry ([`roles_of`]).

use std::collections::BTreeMap;

use crate::datasets::{Role, role};

/// One scored observation: a family at a setting on one view of a dataset.
#[derive(Debug, Clone, Copy)]
pub struct Obs<'a> {
    /// Dataset.
    pub dataset: &'a str,
    /// Family (or method).
    pub family: &'a str,
    /// Setting label.
    pub params: &'a str,
    /// F1 on that view.
    pub f1: f64,
    /// Row status (`ok`, or an error).
    pub ok: bool,
}

/// The observations of the visibility experiment's rows.
pub fn observations(rows: &[super::Row]) -> impl Iterator<Item = Obs<'_>> {
    rows.iter().map(|r| Obs {
        dataset: &r.dataset,
        family: &r.family,
        params: &r.params,
        f1: r.f1,
        ok: r.status == "ok",
    })
}

fn is_auto(params: &str) -> bool {
    registry::Setting::parse(params).is_auto()
}

/// Each family's tuned setting over the observations of the datasets `is_tuning` accepts, with
/// its `T(s)` (the module's definition). Families without a tuning observation are absent.
pub fn tune<'a>(
    obs: impl IntoIterator<Item = Obs<'a>>,
    is_tuning: impl Fn(&str) -> bool,
) -> BTreeMap<String, (String, f64)> {
    // family -> setting -> dataset -> (sum, n)
    type PerSetting<'a> = BTreeMap<&'a str, BTreeMap<&'a str, (f64, usize)>>;
    let mut by: BTreeMap<&str, PerSetting<'_>> = BTreeMap::new();
    for o in obs {
        if !o.ok || !o.f1.is_finite() || !is_tuning(o.dataset) {
            continue;
        }
        let e = by
            .entry(o.family)
            .or_default()
            .entry(o.params)
            .or_default()
            .entry(o.dataset)
            .or_default();
        e.0 += o.f1;
        e.1 += 1;
    }
    let mut out = BTreeMap::new();
    for (family, settings) in by {
        let datasets: std::collections::BTreeSet<&str> =
            settings.values().flat_map(|d| d.keys().copied()).collect();
        let complete = |fixed_only: bool| {
            settings
                .iter()
                .filter(|(p, per)| (!fixed_only || !is_auto(p)) && per.len() == datasets.len())
                .map(|(p, per)| {
                    let t =
                        per.values().map(|(s, n)| s / *n as f64).sum::<f64>() / per.len() as f64;
                    (*p, t)
                })
                .fold(None::<(&str, f64)>, |best, (p, t)| match best {
                    Some((_, b)) if b >= t => best,
                    _ => Some((p, t)),
                })
        };
        let has_fixed = settings.keys().any(|p| !is_auto(p));
        let chosen = if has_fixed {
            complete(true)
        } else {
            complete(false)
        };
        if let Some((p, t)) = chosen {
            out.insert(family.to_owned(), (p.to_owned(), t));
        }
    }
    out
}

/// The roles of `datasets`: from the run's `metadata.json` parameter `dataset_roles` where it
/// names the dataset, else the registry's ([`role`]: [`Role::Own`] for a name it lacks).
pub fn roles_of(datasets: &[String], meta: &serde_json::Value) -> BTreeMap<String, Role> {
    let recorded: BTreeMap<String, Role> =
        serde_json::from_value(meta["dataset_roles"].clone()).unwrap_or_default();
    datasets
        .iter()
        .map(|d| {
            (
                d.clone(),
                recorded.get(d).copied().unwrap_or_else(|| role(d)),
            )
        })
        .collect()
}

/// Where a reported setting comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chosen {
    /// Tuned on the tuning datasets; the dataset reported is an evaluation (or own) one.
    Tuned,
    /// Tuned on the tuning datasets, and the dataset reported is one of them: in-sample.
    InSample,
    /// No tuned setting for the family in this run: the best on the reported data itself.
    Oracle,
}

impl Chosen {
    /// How tables and findings label it.
    pub fn word(self) -> &'static str {
        match self {
            Chosen::Tuned => "tuned",
            Chosen::InSample => "in-sample",
            Chosen::Oracle => "oracle",
        }
    }
}

/// A run's protocol: the roles of its datasets and each family's tuned setting.
#[derive(Debug, Clone, Default)]
pub struct Protocol {
    /// Role per dataset.
    pub roles: BTreeMap<String, Role>,
    /// Family → (tuned setting, its mean F1 over the tuning datasets).
    pub tuned: BTreeMap<String, (String, f64)>,
}

impl Protocol {
    /// The protocol of `obs` under `roles`.
    pub fn new<'a>(obs: impl IntoIterator<Item = Obs<'a>>, roles: BTreeMap<String, Role>) -> Self {
        let tuned = tune(obs, |d| roles.get(d) == Some(&Role::Tuning));
        Protocol { roles, tuned }
    }

    /// The role of `dataset` ([`Role::Own`] when unknown).
    pub fn role(&self, dataset: &str) -> Role {
        self.roles.get(dataset).copied().unwrap_or(Role::Own)
    }

    /// The tuning datasets, in name order.
    pub fn tuning_datasets(&self) -> Vec<&str> {
        self.roles
            .iter()
            .filter(|(_, r)| **r == Role::Tuning)
            .map(|(d, _)| d.as_str())
            .collect()
    }

    /// The setting that stands for `family` on `dataset`: its tuned setting when it has one,
    /// else `oracle` (the caller's best on that dataset), with where it comes from.
    pub fn choose(
        &self,
        dataset: &str,
        family: &str,
        oracle: Option<String>,
    ) -> Option<(String, Chosen)> {
        match self.tuned.get(family) {
            Some((p, _)) if self.role(dataset) == Role::Tuning => {
                Some((p.clone(), Chosen::InSample))
            }
            Some((p, _)) => Some((p.clone(), Chosen::Tuned)),
            None => oracle.map(|p| (p, Chosen::Oracle)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs<'a>(dataset: &'a str, params: &'a str, f1: f64) -> Obs<'a> {
        Obs {
            dataset,
            family: "f",
            params,
            f1,
            ok: true,
        }
    }

    /// Two tuning datasets (`t1` with 4 views, `t2` with 2) and an evaluation dataset.
    fn rows(eval_a: f64, eval_b: f64) -> Vec<Obs<'static>> {
        let mut v = Vec::new();
        for _ in 0..4 {
            v.push(obs("t1", "k=a", 0.90));
            v.push(obs("t1", "k=b", 0.80));
        }
        for _ in 0..2 {
            v.push(obs("t2", "k=a", 0.65));
            v.push(obs("t2", "k=b", 0.80));
        }
        for _ in 0..3 {
            v.push(obs("e", "k=a", eval_a));
            v.push(obs("e", "k=b", eval_b));
        }
        v
    }

    fn tuning(d: &str) -> bool {
        d.starts_with('t')
    }

    #[test]
    fn each_tuning_dataset_weighs_the_same() {
        // Pooled over the views k=a would win, (4·0.90 + 2·0.65)/6 = 0.817 against 0.80; the
        // mean of the per-dataset means decides: a = (0.90 + 0.65)/2 = 0.775, b = 0.80.
        let t = tune(rows(0.5, 0.5), tuning);
        assert_eq!(t["f"].0, "k=b");
        assert!((t["f"].1 - 0.80).abs() < 1e-12);
    }

    #[test]
    fn evaluation_rows_cannot_change_the_tuned_setting() {
        let base = tune(rows(0.1, 0.1), tuning);
        for (a, b) in [(1.0, 0.0), (0.0, 1.0), (0.99, 0.2), (f64::NAN, 0.3)] {
            assert_eq!(tune(rows(a, b), tuning), base, "evaluation F1 {a}, {b}");
        }
        // Counted as tuning data, the same evaluation rows do change it: the test can fail.
        assert_eq!(tune(rows(1.0, 0.0), |_| true)["f"].0, "k=a");
    }

    #[test]
    fn a_setting_missing_from_a_tuning_dataset_is_no_candidate_and_auto_only_as_a_last_resort() {
        let mut v = rows(0.5, 0.5);
        // k=c is perfect on t1 but never ran on t2.
        v.push(obs("t1", "k=c", 1.0));
        // The automatic setting beats every fixed one, but fixed settings exist.
        v.push(obs("t1", "gamma=auto", 1.0));
        v.push(obs("t2", "gamma=auto", 1.0));
        assert_eq!(tune(v, tuning)["f"].0, "k=b");
        let only_auto = vec![
            obs("t1", "gamma=auto;k=1", 0.5),
            obs("t1", "gamma=auto;k=2", 0.7),
        ];
        assert_eq!(tune(only_auto, tuning)["f"].0, "gamma=auto;k=2");
        // No tuning rows: no tuned setting, and the protocol falls back to the oracle.
        let p = Protocol::new(
            rows(0.5, 0.5),
            BTreeMap::from([("e".to_owned(), Role::Evaluation)]),
        );
        assert!(p.tuned.is_empty());
        assert_eq!(
            p.choose("e", "f", Some("k=a".into())),
            Some(("k=a".to_owned(), Chosen::Oracle))
        );
    }

    #[test]
    fn roles_come_from_the_metadata_else_the_registry() {
        let names = [
            "bunny".to_owned(),
            "elephant-50000".to_owned(),
            "mine".to_owned(),
        ];
        let r = roles_of(&names, &serde_json::json!({}));
        assert_eq!(
            r.values().copied().collect::<Vec<_>>(),
            [Role::Tuning, Role::Evaluation, Role::Own]
        );
        let r = roles_of(
            &names,
            &serde_json::json!({"dataset_roles": {"bunny": "own"}}),
        );
        assert_eq!(r["bunny"], Role::Own);
    }
}
