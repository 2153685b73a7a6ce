//! Tests of the visibility report's drawing: a peer whose answers are wrong is drawn apart
//! and kept off the Pareto front, from the committed results.

use std::path::PathBuf;

/// The committed visibility results, their peers' rows claiming exactness, one of
/// open3d-hpr's sets made wrong (Jaccard 0.5): redrawn, open3d-hpr is drawn in the
/// wrong-answer style in the Pareto and parameter figures and is never on the front, while
/// cgal-hpr (right answers) keeps its own style.
#[test]
fn a_peer_with_wrong_answers_is_drawn_apart_and_left_off_the_front() {
    let committed = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../reports/visibility");
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "results.csv",
        "pixels.csv",
        "agreement.csv",
        "metadata.json",
    ] {
        std::fs::copy(committed.join(f), dir.path().join(f)).unwrap();
    }
    let peers = std::fs::read_to_string(committed.join("peers.csv")).unwrap();
    let mut lines = peers.lines();
    let header = lines.next().unwrap();
    let jaccard = header.split(',').position(|c| c == "jaccard").unwrap();
    // Results written before the column existed get it; newer ones have it set.
    let claims = header.split(',').position(|c| c == "claims_exact");
    let mut out = match claims {
        Some(_) => format!("{header}\n"),
        None => format!("{header},claims_exact\n"),
    };
    let mut made_wrong = false;
    for line in lines {
        let mut cols: Vec<String> = line.split(',').map(str::to_owned).collect();
        let exact = matches!(cols[2].as_str(), "open3d-hpr" | "cgal-hpr");
        if cols[2] == "open3d-hpr" && !made_wrong {
            cols[jaccard] = "0.5".into();
            made_wrong = true;
        }
        match claims {
            Some(c) => cols[c] = exact.to_string(),
            None => cols.push(exact.to_string()),
        }
        out.push_str(&format!("{}\n", cols.join(",")));
    }
    assert!(made_wrong, "the committed peers.csv has no open3d-hpr row");
    std::fs::write(dir.path().join("peers.csv"), out).unwrap();
    crate::experiments::experiment("visibility")
        .unwrap()
        .render(&registry::Catalogue::builtin(), dir.path())
        .unwrap();
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(name)).unwrap()).unwrap()
    };
    let series = |fig: &serde_json::Value| -> Vec<serde_json::Value> {
        fig["panels"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| p["series"].as_array().unwrap().clone())
            .collect()
    };
    let wrong = crate::output::style::WRONG;
    let pareto = read("pareto_bunny.json");
    let all = series(&pareto);
    let of = |m: &str| -> Vec<&serde_json::Value> {
        all.iter()
            .filter(|s| s["method"] == m && s["context"] == false)
            .collect()
    };
    assert!(!of("open3d-hpr").is_empty());
    for s in of("open3d-hpr") {
        assert_eq!(s["variant"], wrong, "{s}");
        assert!(
            s["label"].as_str().unwrap().contains("wrong answers"),
            "{s}"
        );
    }
    assert!(!of("cgal-hpr").is_empty());
    assert!(of("cgal-hpr").iter().all(|s| s["variant"] != wrong));
    let front = all.iter().find(|s| s["draw"] == "front").unwrap();
    let names: Vec<&str> = front["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(!names.is_empty());
    assert!(
        names.iter().all(|n| !n.starts_with("open3d-hpr")),
        "{names:?}"
    );
    let param = read("f1_open3d-hpr.json");
    assert!(series(&param).iter().all(|s| s["variant"] == wrong));
    let summary = std::fs::read_to_string(dir.path().join("summary.md")).unwrap();
    assert!(summary.starts_with("**Wrong answers**"), "{summary}");
}
