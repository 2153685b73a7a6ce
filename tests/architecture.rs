//! ARCHITECTURE.md's dependency invariants, checked from the crates' manifests: method crates
//! depend on `cloud` only (and `hpr` and `robustvis` on `hull`), the registry and the Python package never on
//! the harness, and only the harness does command lines, plots, CSV and progress bars.

use std::collections::BTreeMap;
use std::path::Path;

/// Each workspace crate's normal dependencies (names), from its Cargo.toml.
fn dependencies() -> BTreeMap<String, Vec<String>> {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out = BTreeMap::new();
    for entry in std::fs::read_dir(&crates).expect("crates/") {
        let dir = entry.expect("entry").path();
        let manifest = dir.join("Cargo.toml");
        if !manifest.exists() {
            continue;
        }
        let text = std::fs::read_to_string(&manifest).expect("readable manifest");
        let value: toml::Table = toml::from_str(&text).expect("valid manifest");
        let name = value["package"]["name"]
            .as_str()
            .expect("a name")
            .to_owned();
        let folder = dir
            .file_name()
            .expect("folder")
            .to_string_lossy()
            .into_owned();
        assert_eq!(name, folder, "folder name = crate name");
        let deps = value
            .get("dependencies")
            .and_then(|d| d.as_table())
            .map(|t| t.keys().cloned().collect())
            .unwrap_or_default();
        out.insert(name, deps);
    }
    out
}

const LOCAL: &[&str] = &[
    "cloud",
    "truth",
    "splat",
    "hull",
    "hpr",
    "robustvis",
    "raycast",
    "qsplat",
    "spt",
    "srn",
    "registry",
    "harness",
    "python",
];

#[test]
fn the_dependency_graph_points_one_way() {
    let deps = dependencies();
    let local = |c: &str| -> Vec<String> {
        deps[c]
            .iter()
            .filter(|d| LOCAL.contains(&d.as_str()))
            .cloned()
            .collect()
    };
    for method in ["raycast", "qsplat", "spt", "srn", "splat"] {
        assert_eq!(local(method), vec!["cloud".to_owned()], "{method}");
    }
    // The two exceptions: HPR and the robust operator of Mehra et al. both need an exact
    // convex hull (with facets, for the robust operator's depths), the one `hull` computes.
    for method in ["hpr", "robustvis"] {
        let mut d = local(method);
        d.sort();
        assert_eq!(d, vec!["cloud".to_owned(), "hull".to_owned()], "{method}");
    }
    assert!(local("hull").is_empty(), "hull knows nothing of clouds");
    assert_eq!(local("cloud"), Vec::<String>::new());
    assert_eq!(local("truth"), vec!["cloud".to_owned()]);
    for c in ["registry", "python"] {
        assert!(
            !local(c).contains(&"harness".to_owned()),
            "{c} must not depend on harness"
        );
    }
    // Only the harness parses command lines, plots, writes CSV and draws progress bars.
    for (name, d) in &deps {
        if name == "harness" {
            continue;
        }
        for banned in ["clap", "plotters", "csv", "indicatif"] {
            assert!(
                !d.contains(&banned.to_owned()),
                "{name} depends on {banned}"
            );
        }
    }
}
