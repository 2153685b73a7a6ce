//! The automatic rules (HPR's `gamma=auto`, the ray cast's `radius=auto`) against the best
//! fixed setting of the same family, view by view: fixed settings that agree with the rule's
//! setting on every fixed key both have (the ray cast at the same resolution, HPR without
//! perturbation). The mean gap's interval is over views: a family with one rule row per
//! resolution (the ray cast) averages its rows per view first, so a view counts once.

use std::collections::BTreeMap;

use registry::Setting;

use super::{Row, is_auto};

/// True when a fixed setting `o` agrees with the automatic `rule` on every key both set,
/// the rule's own `auto` keys aside.
fn comparable(rule: &Setting, o: &Setting) -> bool {
    rule.0
        .iter()
        .all(|(k, v)| *v == registry::Value::Text("auto".into()) || o.get(k).is_none_or(|w| w == v))
}

/// The view-by-view table (dataset, view, family, rule, F1, oracle fixed F1, gap) and one line
/// per (dataset, family): its worst gap against the 0.02 goal and its mean gap over the views.
pub(super) fn gaps(rows: &[Row]) -> (Vec<Vec<String>>, Vec<String>) {
    let mut auto_table = Vec::new();
    let mut worst: BTreeMap<(String, &str), f64> = BTreeMap::new();
    // Per (dataset, family), per view, the gaps of its rule's rows (the ray cast has one per
    // resolution): the mean gap is bootstrapped over views, each view's gaps averaged first.
    let mut gaps: BTreeMap<(String, &str), BTreeMap<usize, Vec<f64>>> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| is_auto(&r.params) && r.status == "ok" && !r.f1.is_nan())
    {
        let rule = Setting::parse(&r.params);
        let best = rows
            .iter()
            .filter(|o| {
                o.dataset == r.dataset
                    && o.view == r.view
                    && o.family == r.family
                    && o.status == "ok"
                    && !is_auto(&o.params)
                    && comparable(&rule, &Setting::parse(&o.params))
            })
            .map(|o| o.f1)
            .fold(f64::NEG_INFINITY, f64::max);
        if best == f64::NEG_INFINITY {
            continue;
        }
        let gap = best - r.f1;
        let key = (r.dataset.clone(), r.family.as_str());
        gaps.entry(key.clone())
            .or_default()
            .entry(r.view)
            .or_default()
            .push(gap);
        let w = worst.entry(key).or_insert(f64::NEG_INFINITY);
        *w = w.max(gap);
        auto_table.push(vec![
            r.dataset.clone(),
            r.view.to_string(),
            r.family.clone(),
            format!(
                "{}{}",
                r.params.replace(';', " "),
                if r.detail.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", r.detail.replace(';', " "))
                }
            ),
            format!("{:.4}", r.f1),
            format!("{best:.4}"),
            format!("{gap:+.4}"),
        ]);
    }
    let worst_lines: Vec<String> = worst
        .iter()
        .map(|((d, fam), g)| {
            let per_view: Vec<f64> = gaps
                .get(&(d.clone(), *fam))
                .map(|views| {
                    views
                        .values()
                        .map(|g| g.iter().sum::<f64>() / g.len() as f64)
                        .collect()
                })
                .unwrap_or_default();
            let mean = crate::stats::bootstrap_mean(&per_view, 2007).map_or(String::new(), |e| {
                format!("; mean gap {}", e.text(|x| format!("{x:+.4}"), ""))
            });
            format!(
                "- {d}, {fam}: worst gap {g:.4} ({}){mean}",
                if *g <= 0.02 {
                    "within 0.02"
                } else {
                    "**over 0.02**"
                }
            )
        })
        .collect();
    (auto_table, worst_lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(view: usize, params: &str, f1: f64) -> Row {
        Row {
            dataset: "d".into(),
            n_points: 10,
            view,
            method: "raycast".into(),
            family: "raycast".into(),
            params: params.into(),
            detail: String::new(),
            seconds: 1.0,
            rays: 0,
            n_visible: 0,
            precision: f1,
            recall: f1,
            f1,
            off_surface_visible: 0,
            seconds_min: 1.0,
            seconds_max: 1.0,
            samples: 1,
            status: "ok".into(),
            made_for: "pixels".into(),
            visible_sha256: String::new(),
            mesh_fit: String::new(),
            wall_seconds: f64::NAN,
        }
    }

    #[test]
    fn the_mean_gap_counts_views_not_resolutions() {
        // Two views, three resolutions each: six rule rows, two views. It said "indicative:
        // 6 views", and from 5 rows on it printed an interval.
        let mut rows = Vec::new();
        for view in 0..2 {
            for w in [640, 1280, 1920] {
                rows.push(row(view, &format!("radius=auto;width={w}"), 0.9));
                rows.push(row(view, &format!("radius_factor=2;width={w}"), 0.95));
            }
        }
        let (table, lines) = gaps(&rows);
        assert_eq!(table.len(), 6);
        assert_eq!(lines.len(), 1);
        assert!(
            lines[0].contains("mean gap +0.0500 (indicative: 2 views)"),
            "{}",
            lines[0]
        );
    }
}
