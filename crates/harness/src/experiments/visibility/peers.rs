//! The peers' pairing: a peer (a method whose `peer_of` names one of ours: `hpr`, `raycast`,
//! `splat`...) at one of its settings against the method it names at the setting that stands
//! for it, per view.
//!
//! The partner's setting comes from the peer's: each key the peer translates (`peer_keys` in
//! its `method.toml`: VTK's `point_size` is 2 × our splat's `radius_px`) becomes the partner's
//! key at the factor times the value; a key both methods take (the partner's `params`) is taken
//! as it is; a key only the peer knows (point-cloud-utils' `subdivs`) is left out. Among the
//! partner's own settings (its sweep: grid, quick grid, default), the first that has every
//! translated pair and, for its other keys, the values of the partner's default setting (HPR's
//! linear kernel, no perturbation) is the partner's; when there is none, it is the default
//! setting with the translated pairs in place of its own (and of its `auto` values), and the
//! experiment runs ours at it too. Nothing here names a method.

use registry::{Card, MethodSweep, Setting, Value};

/// Two values equal as numbers (relative 1e-9) when both read as numbers, else as text.
fn same(a: &Value, b: &Value) -> bool {
    let number = |v: &Value| Value::parse(&v.to_string()).as_f64();
    match (number(a), number(b)) {
        (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1.0),
        _ => a.to_string() == b.to_string(),
    }
}

/// The peer's setting in the partner's keys (see the module's documentation).
pub(super) fn translate(peer: &Card, setting: &Setting, partner: &Card) -> Setting {
    let mut out = Setting::default();
    for (k, v) in &setting.0 {
        if let Some(pk) = peer.peer_keys.iter().find(|pk| pk.peer == k) {
            let value = match Value::parse(&v.to_string()).as_f64() {
                Some(x) => Value::Float(x * pk.factor),
                None => v.clone(),
            };
            out.0.insert(pk.ours.to_owned(), value);
        } else if partner.params.iter().any(|p| p.key == k) {
            out.0.insert(k.clone(), Value::parse(&v.to_string()));
        }
    }
    out
}

/// The partner's setting for the peer's `setting`, and whether it is one of the partner's own
/// (`sweep`'s settings); see the module's documentation.
pub(super) fn partner_setting(
    peer: &Card,
    setting: &Setting,
    partner: &Card,
    sweep: Option<&MethodSweep>,
) -> Setting {
    let wanted = translate(peer, setting, partner);
    let default = sweep
        .and_then(MethodSweep::default_setting)
        .unwrap_or_default();
    let candidates = sweep
        .into_iter()
        .flat_map(|s| s.grid.iter().chain(&s.quick_grid))
        .chain(std::iter::once(&default));
    for c in candidates {
        let has_wanted = wanted
            .0
            .iter()
            .all(|(k, v)| c.get(k).is_some_and(|x| same(x, v)));
        let rest_default =
            c.0.iter()
                .filter(|(k, _)| !wanted.0.contains_key(*k))
                .all(|(k, v)| default.get(k).is_some_and(|d| same(d, v)));
        if has_wanted && rest_default {
            return c.clone();
        }
    }
    let mut out = default;
    out.0.retain(|_, v| *v != Value::Text("auto".into()));
    out.0.extend(wanted.0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use registry::{Family, Kind, Memory, Method, Param, PeerKey, Reader, Result, Setup};

    /// A method that reads nothing (the pairing only reads cards).
    struct Nothing;
    impl Method for Nothing {
        fn parse(&self, _: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
            Err(registry::Error::Unsupported("test".into()))
        }
    }

    /// A peer of splat with `keys` params, translating `point_size` into `radius_px` × 0.5.
    fn peer(keys: &[&'static str]) -> &'static Card {
        let params: Vec<Param> = keys.iter().map(|k| Param::rule(k, "-", "test")).collect();
        Box::leak(Box::new(Card {
            name: "peer",
            summary: "peer: test",
            params: Box::leak(params.into_boxed_slice()),
            family: Family::Name,
            memory: Memory::Unknown,
            parallel_views: false,
            peer_of: Some("splat"),
            peer_keys: &[PeerKey {
                peer: "point_size",
                ours: "radius_px",
                factor: 0.5,
            }],
            compared_in: &[],
            bare_node_bytes: None,
            sweep: None,
            program: None,
            made_for: registry::Metric::Points,
            exact: false,
            kind: Kind::Visibility(&Nothing),
        }))
    }

    fn sweep_of(name: &str) -> MethodSweep {
        registry::Sweeps::builtin().methods[name].clone()
    }

    #[test]
    fn an_hpr_peer_pairs_with_linear_hpr_at_its_gamma() {
        let hpr = registry::builtin_card("hpr").expect("hpr");
        let peer = peer(&["gamma", "radius"]);
        for g in ["2", "3", "4"] {
            let s = partner_setting(
                peer,
                &Setting::parse(&format!("gamma={g}")),
                hpr,
                Some(&sweep_of("hpr")),
            );
            assert_eq!(s.text("kernel").as_deref(), Some("linear"), "{}", s.label());
            assert_eq!(s.number("perturb"), Some(0.0), "{}", s.label());
            assert_eq!(s.number("gamma"), g.parse().ok(), "{}", s.label());
            assert!(
                sweep_of("hpr").grid.contains(&s),
                "{} is in hpr's grid",
                s.label()
            );
        }
        // A γ outside the grid: the default setting with that γ (not `auto`).
        let s = partner_setting(
            peer,
            &Setting::parse("gamma=3.25"),
            hpr,
            Some(&sweep_of("hpr")),
        );
        assert_eq!(s.number("gamma"), Some(3.25));
        assert_eq!(s.text("kernel").as_deref(), Some("linear"));
    }

    #[test]
    fn translated_and_shared_keys_pick_the_partners_setting() {
        let splat = registry::builtin_card("splat").expect("splat");
        let peer = peer(&["point_size", "depth_tolerance", "only_mine"]);
        let s = partner_setting(
            peer,
            &Setting::parse("depth_tolerance=0.03;only_mine=7;point_size=6"),
            splat,
            Some(&sweep_of("splat")),
        );
        assert_eq!(s.number("radius_px"), Some(3.0), "{}", s.label());
        assert_eq!(s.number("depth_tolerance"), Some(0.03), "{}", s.label());
        assert!(s.get("only_mine").is_none());
        let raycast = registry::builtin_card("raycast").expect("raycast");
        let peer = self::peer(&["radius_factor", "width", "height", "subdivs"]);
        let s = partner_setting(
            peer,
            &Setting::parse("height=360;radius_factor=1.5;subdivs=7;width=640"),
            raycast,
            Some(&sweep_of("raycast")),
        );
        assert_eq!(s.label(), "height=360;radius_factor=1.5;width=640");
        // Not in the grid: the default without its `auto` radius, the peer's pairs in.
        let s = partner_setting(
            peer,
            &Setting::parse("height=240;radius_factor=1;width=320"),
            raycast,
            Some(&sweep_of("raycast")),
        );
        assert_eq!(s.label(), "height=240;radius_factor=1;width=320");
    }

    #[test]
    fn ours_runs_at_the_paired_settings_its_sweep_lacks() {
        let splat = registry::builtin_card("splat").expect("splat");
        let peer = peer(&["point_size", "depth_tolerance"]);
        let peer_sweep = MethodSweep {
            grid: vec![
                Setting::parse("depth_tolerance=0.01;point_size=4"),
                Setting::parse("depth_tolerance=0.01;point_size=5"),
            ],
            ..Default::default()
        };
        let sweeps = registry::Sweeps::builtin();
        let mut methods: Vec<(&'static Card, MethodSweep)> =
            vec![(peer, peer_sweep.clone()), (splat, sweep_of("splat"))];
        let before = methods[1].1.grid.len();
        let pairing = super::super::pair_peers(
            &registry::Catalogue::builtin(),
            &mut methods,
            &sweeps,
            false,
        );
        let partner = |label: &str| {
            pairing[&("peer".to_owned(), label.to_owned())]
                .clone()
                .expect("paired")
        };
        assert_eq!(
            partner("depth_tolerance=0.01;point_size=4"),
            ("splat".into(), "depth_tolerance=0.01;radius_px=2".into())
        );
        assert_eq!(
            partner("depth_tolerance=0.01;point_size=5"),
            ("splat".into(), "depth_tolerance=0.01;radius_px=2.5".into())
        );
        // radius_px = 2.5 is not in splat's grid: added for this run, once.
        assert_eq!(methods[1].1.grid.len(), before + 1);
        // Without ours in the run, ours joins with the paired settings alone.
        let mut alone: Vec<(&'static Card, MethodSweep)> = vec![(peer, peer_sweep)];
        super::super::pair_peers(&registry::Catalogue::builtin(), &mut alone, &sweeps, false);
        assert_eq!(alone.len(), 2);
        assert_eq!(alone[1].0.name, "splat");
        assert_eq!(alone[1].1.grid.len(), 2);
    }

    fn peer_row(view: usize, peer_s: f64, ours_s: f64, jaccard: f64) -> super::super::PeerRow {
        super::super::PeerRow {
            dataset: "bunny".into(),
            view,
            peer: "cgal-hpr".into(),
            peer_params: "gamma=3".into(),
            peer_of: "hpr".into(),
            partner: "hpr".into(),
            partner_params: "gamma=3;kernel=linear;perturb=0;seed=2007".into(),
            peer_seconds: peer_s,
            partner_seconds: ours_s,
            peer_f1: 0.9,
            partner_f1: 0.8,
            jaccard,
            peer_build_seconds: f64::NAN,
            partner_build_seconds: 0.25 * (view + 1) as f64,
            claims_exact: true,
        }
    }

    #[test]
    fn the_peers_table_pairs_and_says_what_was_not_run() {
        let mut rows = vec![peer_row(0, 2.0, 1.0, 1.0), peer_row(1, 8.0, 2.0, 0.5)];
        let mut lonely = peer_row(0, 1.0, f64::NAN, f64::NAN);
        (
            lonely.peer,
            lonely.peer_of,
            lonely.partner,
            lonely.partner_params,
        ) = (
            "pcl-voxel".into(),
            "voxel".into(),
            String::new(),
            String::new(),
        );
        rows.push(lonely);
        let md = super::super::render::peers_summary(
            &rows,
            &["vtk-zbuffer: not installed (its check exited with 1); install it with `just peers`"
                .into()],
        );
        let line = md
            .lines()
            .find(|l| l.contains("cgal-hpr"))
            .expect("a cgal-hpr row");
        // Paired with hpr at its setting, two views, Jaccard median 0.75 and min 0.5, the
        // ratio's geometric mean sqrt(2 x 4), per view 2 to 4, ΔF1 +0.1; ours built in 0.25 s
        // and 0.5 s (the upper median), the peer reported no build.
        for part in [
            "hpr gamma=3;kernel=linear;perturb=0;seed=2007",
            "| 2 |",
            "0.7500",
            "0.5000",
            "2.83×",
            "2.00–4.00",
            "+0.1000",
            "| 0.5000 | - |",
        ] {
            assert!(line.contains(part), "{part} in {line}");
        }
        let line = md
            .lines()
            .find(|l| l.contains("pcl-voxel"))
            .expect("a pcl-voxel row");
        assert!(line.contains("none (no method `voxel` of ours)"), "{line}");
        assert!(md.contains("- not run: vtk-zbuffer: not installed"), "{md}");
    }
}
