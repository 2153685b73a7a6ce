//! The visibility summary's tuned-setting table: per dataset and family, the setting
//! [`super::tuning`] chose (tuned on the tuning datasets; in-sample on one of them; the oracle
//! where the run has no tuning data) with its F1 and bootstrap interval, and the oracle, the
//! setting best on that dataset itself, in labelled columns beside it.

use super::Row;
use super::papers::{best_setting, chosen};
use super::tuning::{Chosen, Protocol};

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// The rows of the tuned-setting table: per dataset and family, the setting that stands for
/// it ([`chosen`]: tuned, in-sample on a tuning dataset, else the oracle) with its mean F1
/// over the views and bootstrap 95 % interval (none from fewer than 5 views), precision,
/// recall and seconds, then the oracle (the setting best on this dataset) and its F1.
pub(super) fn tuned_table(
    rows: &[Row],
    datasets: &[String],
    families: &[String],
    protocol: &Protocol,
) -> Vec<Vec<String>> {
    let mut table = Vec::new();
    for d in datasets {
        for fam in families {
            let Some((p, how)) = chosen(rows, protocol, d, fam) else {
                continue;
            };
            let rs: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.dataset == *d && r.params == p && r.family == *fam && r.status == "ok"
                })
                .collect();
            if rs.is_empty() {
                // The tuned setting did not run (or failed) on this dataset.
                table.push(vec![
                    d.clone(),
                    protocol.role(d).word().to_owned(),
                    fam.clone(),
                    format!("{} ({}): no rows here", p.replace(';', " "), how.word()),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                    "-".into(),
                ]);
                continue;
            }
            let f1: Vec<f64> = rs.iter().map(|r| r.f1).collect();
            let estimate = crate::stats::bootstrap_mean(&f1, 2007).map_or_else(
                || format!("{:.4}", mean(f1.iter().copied())),
                |e| e.text(|x| format!("{x:.4}"), ""),
            );
            let (oracle, oracle_f1) = best_setting(rows, d, fam)
                .map_or(("-".to_owned(), "-".to_owned()), |(o, f)| {
                    (o.replace(';', " "), format!("{f:.4}"))
                });
            let role = match how {
                Chosen::InSample => "tuning (in-sample)".to_owned(),
                Chosen::Tuned => protocol.role(d).word().to_owned(),
                Chosen::Oracle => format!("{} (oracle)", protocol.role(d).word()),
            };
            let setting = match how {
                Chosen::Oracle => format!("{} (oracle)", p.replace(';', " ")),
                _ => p.replace(';', " "),
            };
            table.push(vec![
                d.clone(),
                role,
                fam.clone(),
                setting,
                estimate,
                format!("{:.4}", mean(rs.iter().map(|r| r.precision))),
                format!("{:.4}", mean(rs.iter().map(|r| r.recall))),
                format!("{:.4}", mean(rs.iter().map(|r| r.seconds))),
                oracle,
                oracle_f1,
            ]);
        }
    }
    table
}

/// The tuned table (`tuned_table`'s rows) as the papers print it: one row per family, one column
/// per dataset, each cell its F1 with its 95 % interval, the best of each dataset in bold (ties
/// at four decimals all bold; a family of `never_best`, whose answers are wrong, never is).
pub(super) fn by_dataset(
    table: &[Vec<String>],
    datasets: &[String],
    families: &[String],
    never_best: &[&str],
) -> String {
    let cell = |d: &str, fam: &str| {
        table
            .iter()
            .find(|r| r[0] == d && r[2] == fam)
            .map(|r| r[4].clone())
    };
    let value = |text: &str| {
        text.split_whitespace()
            .next()
            .and_then(|v| v.parse::<f64>().ok())
    };
    let best: Vec<Option<String>> = datasets
        .iter()
        .map(|d| {
            families
                .iter()
                .filter(|f| !never_best.contains(&f.as_str()))
                .filter_map(|f| cell(d, f).as_deref().and_then(value))
                .max_by(f64::total_cmp)
                .map(|v| format!("{v:.4}"))
        })
        .collect();
    let mut rows = Vec::new();
    for fam in families {
        let mut row = vec![fam.clone()];
        let mut any = false;
        for (d, best) in datasets.iter().zip(&best) {
            let text = cell(d, fam).unwrap_or_else(|| "-".into());
            let is_best = !never_best.contains(&fam.as_str())
                && value(&text).is_some_and(|v| Some(format!("{v:.4}")) == *best);
            any |= text != "-";
            row.push(if is_best { format!("**{text}**") } else { text });
        }
        if any {
            rows.push(row);
        }
    }
    if rows.is_empty() {
        return String::new();
    }
    let mut header = vec!["method"];
    header.extend(datasets.iter().map(String::as_str));
    format!(
        "F1 at the tuned setting [95 % interval over the views], methods by datasets; the best of \
         each dataset in bold{}:\n\n{}\n",
        if never_best.is_empty() {
            String::new()
        } else {
            format!(" (never {}: wrong answers)", never_best.join(", "))
        },
        crate::experiments::markdown_table(&header, &rows)
    )
}

/// What the tuned-setting table's settings are, for the summary.
pub(super) fn protocol_text(protocol: &Protocol) -> String {
    let tuning = protocol.tuning_datasets();
    if protocol.tuned.is_empty() {
        return "**No tuning dataset in this run**: each method's setting below is the **oracle**, \
                the setting with the highest mean F1 on the very data reported (an optimistic \
                figure, not a tuned one). Run with tuning datasets (the built-in ones marked \
                `tuning` in `pointsight datasets`) for settings chosen apart from these data.\n\n"
            .to_owned();
    }
    format!(
        "Each method at its **tuned** setting: the setting with the highest mean F1 over the \
         tuning datasets of this run ({}; the mean over those datasets of each one's mean F1 \
         over its views, `experiments::visibility::tuning`). On an **evaluation** dataset no \
         setting was chosen on it: its F1 is out-of-sample. On a tuning dataset the figure is \
         **in-sample** (labelled). `F1 [95 % CI]`: mean over the views with its bootstrap \
         interval (views resampled; none from fewer than 5 views). The **oracle** columns give \
         the setting best on that dataset itself and its F1, an upper bound no user could \
         pick in advance; the gap between the two columns is what tuning elsewhere costs.\n\n",
        tuning
            .iter()
            .map(|d| format!("`{d}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

#[cfg(test)]
mod table_tests {
    use super::super::Row;
    use super::super::tuning::{observations, roles_of};
    use super::*;

    /// A results.csv over a tuning dataset (`bunny`, 6 views) and an evaluation dataset
    /// (`camel-50000`, 6 views): `hpr-linear` at γ 2 and 3; γ 3 is best on bunny, γ 2 on the
    /// camel.
    fn results_csv() -> String {
        let mut s = String::from(
            "dataset,n_points,view,method,family,params,detail,seconds,rays,n_visible,precision,recall,f1,off_surface_visible,seconds_min,seconds_max,samples,status\n",
        );
        for v in 0..6 {
            let w = 0.01 * (v % 2) as f64;
            for (d, g, f1) in [
                ("bunny", 2, 0.90 + w),
                ("bunny", 3, 0.95 + w),
                ("camel-50000", 2, 0.85 + w),
                ("camel-50000", 3, 0.80 + w),
            ] {
                s.push_str(&format!(
                    "{d},100,{v},hpr,hpr-linear,gamma={g};kernel=linear,,0.5,0,40,{f1},{f1},{f1},0,0.5,0.5,1,ok\n"
                ));
            }
        }
        s
    }

    #[test]
    fn the_evaluation_table_reports_the_tuned_setting_beside_the_oracle() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.csv");
        std::fs::write(&path, results_csv()).unwrap();
        let rows: Vec<Row> = crate::output::read_csv(&path).unwrap();
        let datasets = vec!["bunny".to_owned(), "camel-50000".to_owned()];
        let protocol = Protocol::new(
            observations(&rows),
            roles_of(&datasets, &serde_json::json!({})),
        );
        assert_eq!(protocol.tuned["hpr-linear"].0, "gamma=3;kernel=linear");
        let table = tuned_table(&rows, &datasets, &["hpr-linear".to_owned()], &protocol);
        assert_eq!(table.len(), 2);
        let (bunny, camel) = (&table[0], &table[1]);
        assert_eq!(bunny[1], "tuning (in-sample)");
        assert_eq!(bunny[3], "gamma=3 kernel=linear");
        // The camel at γ 3, tuned on bunny: mean 0.805 with its interval over 6 views; the
        // oracle γ 2 (0.855) beside it.
        assert_eq!(camel[1], "evaluation");
        assert_eq!(camel[3], "gamma=3 kernel=linear");
        assert!(camel[4].starts_with("0.8050 ["), "{}", camel[4]);
        assert_eq!(camel[8], "gamma=2 kernel=linear");
        assert_eq!(camel[9], "0.8550");
        // Without the tuning dataset the camel's setting is the oracle, and says so.
        let camel_rows: Vec<Row> = rows
            .iter()
            .filter(|r| r.dataset != "bunny")
            .cloned()
            .collect();
        let alone = Protocol::new(
            observations(&camel_rows),
            roles_of(&datasets[1..], &serde_json::json!({})),
        );
        let table = tuned_table(
            &camel_rows,
            &datasets[1..],
            &["hpr-linear".to_owned()],
            &alone,
        );
        assert_eq!(table[0][1], "evaluation (oracle)");
        assert_eq!(table[0][3], "gamma=2 kernel=linear (oracle)");
    }

    #[test]
    fn the_papers_table_bolds_each_datasets_best_and_never_a_wrong_one() {
        let row = |d: &str, fam: &str, f1: &str| {
            let mut r = vec![String::new(); 10];
            r[0] = d.into();
            r[2] = fam.into();
            r[4] = f1.into();
            r
        };
        let table = vec![
            row("a", "hpr", "0.9500 [0.9400, 0.9600]"),
            row("a", "raycast", "0.9500 [0.9300, 0.9700]"),
            row("a", "peer", "0.9900 [0.9800, 0.9950]"),
            row("b", "hpr", "0.8000 [0.7000, 0.9000]"),
            row("b", "raycast", "0.9000 [0.8500, 0.9500]"),
        ];
        let ds = ["a".to_owned(), "b".to_owned()];
        let fams = ["hpr", "raycast", "peer", "absent"].map(String::from);
        let md = by_dataset(&table, &ds, &fams, &["peer"]);
        // Ties are both bold; the wrong peer's higher value is not; a family without cells is
        // left out.
        assert!(
            md.contains("| hpr | **0.9500 [0.9400, 0.9600]** | 0.8000 [0.7000, 0.9000] |"),
            "{md}"
        );
        assert!(
            md.contains("| raycast | **0.9500 [0.9300, 0.9700]** | **0.9000 [0.8500, 0.9500]** |"),
            "{md}"
        );
        assert!(
            md.contains("| peer | 0.9900 [0.9800, 0.9950] | - |"),
            "{md}"
        );
        assert!(!md.contains("absent"));
        assert!(md.contains("never peer: wrong answers"));
        assert_eq!(by_dataset(&[], &ds, &fams, &[]), "");
    }
}
