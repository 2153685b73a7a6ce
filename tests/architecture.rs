//! ARCHITECTURE.md's dependency invariants, checked from the crates' manifests: method crates
//! depend on `cloud` only (and `hpr` and `robustvis` on `hull`), the registry and the Python
//! package never on the harness, and only the harness does command lines, plots, CSV and
//! progress bars; and from the harness's sources: which of its modules may name method crates
//! ([`MAY_NAME`]), and that its modules import each other without cycles.

use std::collections::{BTreeMap, BTreeSet};
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
    "screenspace",
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
    for method in ["raycast", "qsplat", "spt", "srn", "splat", "screenspace"] {
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

// ---------------------------------------------------------------------------------------------
// Module level: which harness modules name method crates, and how harness modules import each
// other. Both are computed from the sources (comments and string literals blanked).

/// The method crates (and the ground truth's): the harness reaches them through the registry,
/// except where a module measures a crate itself (the paper replications) or needs a crate's
/// tool that is not a method (exact rescaling, simulated scans, a rendering).
const METHOD_CRATES: &[&str] = &[
    "hpr", "hull", "raycast", "qsplat", "spt", "srn", "splat", "truth",
];

/// Every harness module (file under `crates/harness/src/`) that names a method crate, the crate,
/// and why. A new use fails the test until it is listed here with its reason; a use that goes
/// away fails it too, so the table stays true.
const MAY_NAME: &[(&str, &str, &str)] = &[
    // The datasets' tools that are no methods.
    (
        "datasets/mod.rs",
        "truth",
        "off-surface points: distances to the mesh",
    ),
    (
        "datasets/builtin.rs",
        "truth",
        "the scanned datasets: truth::scan's simulated scanners",
    ),
    (
        "datasets/files.rs",
        "hull",
        "hull::exact_rescale: user coordinates rescaled exactly",
    ),
    (
        "datasets/manifest.rs",
        "truth",
        "its test: degraded points' truth lies on the mesh",
    ),
    // The ground truth every score is computed against.
    (
        "experiments/reference.rs",
        "truth",
        "the ground truth's own experiment",
    ),
    (
        "experiments/visibility/mod.rs",
        "truth",
        "scores against the ground truth",
    ),
    (
        "experiments/visibility/mod.rs",
        "hpr",
        "records hpr::auto's rule in the metadata",
    ),
    (
        "experiments/visibility/mod.rs",
        "raycast",
        "raycast::NONE pixels; raycast::auto's rule",
    ),
    (
        "experiments/visibility/render.rs",
        "truth",
        "the ground truth of the rendered views",
    ),
    (
        "experiments/visibility/render.rs",
        "hpr",
        "prints hpr::auto's constant",
    ),
    (
        "experiments/visibility/render.rs",
        "raycast",
        "prints raycast::auto's constant",
    ),
    (
        "experiments/robustness.rs",
        "truth",
        "scores against the ground truth",
    ),
    (
        "visible.rs",
        "truth",
        "`visible --score` against the ground truth",
    ),
    // Paper replications: they measure a crate's internals, not a registered method.
    (
        "experiments/hull.rs",
        "hpr",
        "replication: the hull inside HPR, timed per hull",
    ),
    (
        "experiments/hull.rs",
        "hull",
        "replication: every hull implementation",
    ),
    (
        "experiments/hull.rs",
        "truth",
        "replication: scored against the ground truth",
    ),
    (
        "experiments/background.rs",
        "hpr",
        "replication: hpr::background's update",
    ),
    (
        "experiments/background.rs",
        "hull",
        "replication: the hull hpr::background runs",
    ),
    (
        "experiments/background.rs",
        "truth",
        "replication: scored against the ground truth",
    ),
    (
        "experiments/lod/srn_table.rs",
        "srn",
        "replication: seed 003's Table 1 (SRN masking)",
    ),
    (
        "experiments/lod/srn_table.rs",
        "splat",
        "replication: renders Table 1's splats",
    ),
    // Rendering the LOD methods' splats and SRN's textures.
    (
        "experiments/lod/mod.rs",
        "splat",
        "renders every LOD method's splats (splat::render)",
    ),
    (
        "experiments/lod/from_file.rs",
        "splat",
        "renders a built file's leaves and selections (splat::render::Canvas)",
    ),
    (
        "view/lod.rs",
        "splat",
        "the LOD page: each selection rendered by splat::render (PSNR, coverage), as `lod` does",
    ),
    (
        "experiments/lod/noise.rs",
        "splat",
        "renders LOD under noise (splat::render)",
    ),
    (
        "experiments/lod/noise.rs",
        "srn",
        "the clean source's texture coordinates for LOD under noise",
    ),
    (
        "view/page.rs",
        "truth",
        "the viewer colours every method's points against the ground truth",
    ),
    (
        "lod_build.rs",
        "qsplat",
        "pointsight lod-build writes QSplat files out of core (qsplat::ooc, after the \
         method-neutral cloud::ooc::prepare)",
    ),
    (
        "lod_build.rs",
        "spt",
        "pointsight lod-build writes sequential point tree files out of core (spt::ooc, fed by \
         cloud::ooc::prepare)",
    ),
    // Scale's cells.
    (
        "experiments/scale/cell.rs",
        "hull",
        "scale's hull-* cells measure the hulls",
    ),
    (
        "experiments/scale/cell.rs",
        "hpr",
        "scale's hull-* cells: HPR's flip before the hull",
    ),
];

/// A source file's text with comments, string and character literals blanked (newlines kept),
/// so that paths are found in code only.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && (next == Some('"') || next == Some('#'))
            && (i == 0 || !(c[i - 1].is_alphanumeric() || c[i - 1] == '_'))
        {
            // A raw string r"..." or r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len() {
                if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            for &ch in &c[i..j.min(c.len())] {
                blank(&mut out, ch);
            }
            i = j;
        } else if c[i] == '"' {
            blank(&mut out, c[i]);
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            if i < c.len() {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '\'' && (next == Some('\\') || c.get(i + 2) == Some(&'\'')) {
            // A character literal ('x', '\n', '\''); otherwise a lifetime.
            let mut j = i + 1;
            if c.get(j) == Some(&'\\') {
                j += 2;
            } else {
                j += 1;
            }
            while j < c.len() && c[j] != '\'' {
                j += 1;
            }
            for &ch in &c[i..(j + 1).min(c.len())] {
                blank(&mut out, ch);
            }
            i = j + 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

fn is_ident(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// The identifier starting at byte `at` of `s`.
fn ident_at(s: &str, at: usize) -> &str {
    let end = s[at..]
        .find(|ch: char| !is_ident(ch))
        .map_or(s.len(), |e| at + e);
    &s[at..end]
}

/// Byte offsets where `word` starts as a whole path segment (not after an identifier
/// character or `::`) and is followed by `::`.
fn path_starts(code: &str, word: &str) -> Vec<usize> {
    let pattern = format!("{word}::");
    let bytes = code.as_bytes();
    code.match_indices(&pattern)
        .map(|(at, _)| at)
        .filter(|&at| {
            at == 0 || {
                let prev = bytes[at - 1] as char;
                !is_ident(prev) && prev != ':'
            }
        })
        .collect()
}

/// The method crates a file's code names, apart from local modules of the same name (`mod
/// hull;` or `use ...::hull;` in the file).
fn method_crates_named(code: &str) -> Vec<&'static str> {
    METHOD_CRATES
        .iter()
        .copied()
        .filter(|name| {
            let local = code.contains(&format!("mod {name};"))
                || code.contains(&format!("mod {name} {{"))
                || code.contains(&format!("::{name};"));
            !local && !path_starts(code, name).is_empty()
        })
        .collect()
}

/// A harness source file: its path under `src/` and its module path (`experiments::lod` for
/// `experiments/lod/mod.rs`; empty for `lib.rs`).
struct Source {
    file: String,
    module: Vec<String>,
    code: String,
}

fn harness_sources() -> Vec<Source> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<Source>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .expect("readable source folder")
            .map(|e| e.expect("entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, root, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let file = path
                    .strip_prefix(root)
                    .expect("under src")
                    .to_string_lossy()
                    .replace('\\', "/");
                let text = std::fs::read_to_string(&path).expect("readable source");
                out.push(Source {
                    module: module_of(&file),
                    file,
                    code: code_only(&text),
                });
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    out
}

/// `experiments/lod/mod.rs` → `[experiments, lod]`; `lib.rs`, `main.rs` → `[]`.
fn module_of(file: &str) -> Vec<String> {
    let stem = file.strip_suffix(".rs").unwrap_or(file);
    let mut parts: Vec<String> = stem.split('/').map(str::to_owned).collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The modules a file's code imports: every `crate::` and `super::` path, resolved to the
/// longest prefix that is a module of `modules` (a path to an item of a module is an import of
/// that module; `use crate::{a, b}` groups are followed). `super` counts the inline modules
/// (`mod tests { ... }`) it is written in.
fn imports(src: &Source, modules: &BTreeSet<Vec<String>>) -> BTreeSet<Vec<String>> {
    let code = &src.code;
    // Inline modules open at each offset: (offset of `{`, offset of the matching `}`).
    let mut inline: Vec<(usize, usize)> = Vec::new();
    for (at, _) in code.match_indices("mod ") {
        if at > 0 && is_ident(code.as_bytes()[at - 1] as char) {
            continue;
        }
        let name = ident_at(code, at + 4);
        let rest = &code[at + 4 + name.len()..];
        if !name.is_empty() && rest.trim_start().starts_with('{') {
            let open = at + 4 + name.len() + (rest.len() - rest.trim_start().len());
            let mut depth = 0;
            let mut close = code.len();
            for (k, ch) in code[open..].char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            close = open + k;
                            break;
                        }
                    }
                    _ => {}
                }
            }
            inline.push((open, close));
        }
    }
    let mut out = BTreeSet::new();
    let mut starts: Vec<(usize, &str)> = path_starts(code, "crate")
        .into_iter()
        .map(|at| (at, "crate"))
        .chain(
            path_starts(code, "super")
                .into_iter()
                .map(|at| (at, "super")),
        )
        .collect();
    starts.sort();
    for (at, kind) in starts {
        let mut base: Vec<String> = Vec::new();
        let mut rest = &code[at..];
        if kind == "crate" {
            rest = &rest["crate::".len()..];
        } else {
            let depth = inline.iter().filter(|&&(o, c)| o < at && at < c).count();
            let mut up = 0;
            while let Some(r) = rest.strip_prefix("super::") {
                up += 1;
                rest = r;
            }
            if up <= depth {
                continue; // inside the file's own module
            }
            base = src.module.clone();
            for _ in 0..(up - depth) {
                base.pop();
            }
        }
        resolve(base, rest, modules, &mut out);
    }
    out
}

/// Follows `rest` (what comes after `base::`) as far as it names modules.
fn resolve(
    mut base: Vec<String>,
    mut rest: &str,
    modules: &BTreeSet<Vec<String>>,
    out: &mut BTreeSet<Vec<String>>,
) {
    loop {
        let r = rest.trim_start();
        if let Some(group) = r.strip_prefix('{') {
            // Top-level items of the group.
            let mut depth = 0;
            let mut item_start = 0;
            for (k, ch) in group.char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        resolve(base.clone(), &group[item_start..k], modules, out);
                        return;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        resolve(base.clone(), &group[item_start..k], modules, out);
                        item_start = k + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let name = ident_at(r, 0);
        let mut next = base.clone();
        next.push(name.to_owned());
        if name.is_empty() || !modules.contains(&next) {
            out.insert(base);
            return;
        }
        base = next;
        match r[name.len()..].strip_prefix("::") {
            Some(after) => rest = after,
            None => {
                out.insert(base);
                return;
            }
        }
    }
}

/// The import graph lifted to siblings: an import of `a::x::…` by `a::y::…` is an edge `a::y` →
/// `a::x`. A module and its ancestors are not siblings (a parent declares its children, a
/// child uses its parent's frame): those imports are no edges.
fn sibling_edges(sources: &[Source]) -> BTreeSet<(Vec<String>, Vec<String>)> {
    let modules: BTreeSet<Vec<String>> = sources.iter().map(|s| s.module.clone()).collect();
    let mut edges = BTreeSet::new();
    for src in sources.iter().filter(|s| s.file != "main.rs") {
        for target in imports(src, &modules) {
            let common = src
                .module
                .iter()
                .zip(&target)
                .take_while(|(a, b)| a == b)
                .count();
            if common == src.module.len() || common == target.len() {
                continue;
            }
            edges.insert((src.module[..=common].to_vec(), target[..=common].to_vec()));
        }
    }
    edges
}

/// A cycle of `edges` (its modules, the first repeated at the end), if there is one.
fn find_cycle(edges: &BTreeSet<(Vec<String>, Vec<String>)>) -> Option<Vec<String>> {
    let nodes: BTreeSet<&Vec<String>> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    // Depth-first search: 0 unvisited, 1 on the stack, 2 done.
    fn visit<'a>(
        n: &'a Vec<String>,
        edges: &'a BTreeSet<(Vec<String>, Vec<String>)>,
        state: &mut BTreeMap<&'a Vec<String>, u8>,
        stack: &mut Vec<&'a Vec<String>>,
    ) -> Option<Vec<String>> {
        state.insert(n, 1);
        stack.push(n);
        for (_, m) in edges.iter().filter(|(a, _)| a == n) {
            match state.get(m).copied().unwrap_or(0) {
                1 => {
                    let from = stack.iter().position(|x| *x == m).unwrap_or(0);
                    let mut cycle: Vec<String> =
                        stack[from..].iter().map(|x| x.join("::")).collect();
                    cycle.push(m.join("::"));
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(m, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n, 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in nodes {
        if state.get(n).copied().unwrap_or(0) == 0
            && let Some(c) = visit(n, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn harness_modules_name_method_crates_only_where_listed() {
    let mut found: BTreeSet<(String, &str)> = BTreeSet::new();
    for src in harness_sources() {
        for krate in method_crates_named(&src.code) {
            found.insert((src.file.clone(), krate));
        }
    }
    let listed: BTreeSet<(String, &str)> = MAY_NAME
        .iter()
        .map(|&(file, krate, _)| (file.to_owned(), krate))
        .collect();
    let unlisted: Vec<_> = found.difference(&listed).collect();
    let stale: Vec<_> = listed.difference(&found).collect();
    assert!(
        unlisted.is_empty(),
        "harness modules name method crates without a reason in MAY_NAME (go through the \
         registry, or list the use with its reason): {unlisted:?}"
    );
    assert!(
        stale.is_empty(),
        "MAY_NAME lists uses that are gone: {stale:?}"
    );
    for &(_, _, why) in MAY_NAME {
        assert!(!why.is_empty());
    }
}

#[test]
fn harness_modules_import_each_other_without_cycles() {
    let sources = harness_sources();
    let edges = sibling_edges(&sources);
    // The scan sees the imports it must (so that an empty graph cannot pass for acyclic).
    let edge = |a: &str, b: &str| {
        let split = |s: &str| s.split("::").map(str::to_owned).collect::<Vec<_>>();
        edges.contains(&(split(a), split(b)))
    };
    assert!(edge("experiments", "output"), "{edges:?}");
    assert!(edge("datasets", "fetch"), "{edges:?}");
    assert!(
        edge("experiments::robustness", "experiments::lod"),
        "{edges:?}"
    );
    if let Some(cycle) = find_cycle(&edges) {
        panic!(
            "harness modules import each other in a circle: {}",
            cycle.join(" → ")
        );
    }
}

/// The scanners on made-up sources: they find what they must, so the checks above can fail.
#[test]
fn the_module_checks_catch_violations() {
    let source = |file: &str, text: &str| Source {
        file: file.to_owned(),
        module: module_of(file),
        code: code_only(text),
    };
    // Method crates: in code, not in comments, strings or local modules of the same name.
    assert_eq!(
        method_crates_named(&code_only(
            "use hull::HullError; // spt::x\nlet s = \"srn::y\"; /* raycast::z */"
        )),
        vec!["hull"]
    );
    assert_eq!(
        method_crates_named("mod hull;\nlet e = hull::HULL;"),
        Vec::<&str>::new()
    );
    assert_eq!(
        method_crates_named("let x = qsplat::build(); splat::y"),
        vec!["qsplat", "splat"]
    );
    assert_eq!(
        method_crates_named("let t = truth_positions; a::truth::b"),
        Vec::<&str>::new()
    );
    // Cycles: through `crate::` paths, groups and `super::`; a child using its parent is none.
    let cyclic = [
        source("lib.rs", "pub mod a; pub mod b;"),
        source("a/mod.rs", "mod x; mod y; use crate::{b::Thing, c};"),
        source("a/x.rs", "use super::y::f; use super::Frame;"),
        source("a/y.rs", "fn g() { super::super::b::h() }"),
        source("b.rs", "use crate::a::x::Z; // crate::c"),
    ];
    let edges = sibling_edges(&cyclic);
    let split = |s: &str| s.split("::").map(str::to_owned).collect::<Vec<_>>();
    let expected: BTreeSet<_> = [("a", "b"), ("a::x", "a::y"), ("b", "a")]
        .iter()
        .map(|(x, y)| (split(x), split(y)))
        .collect();
    assert_eq!(edges, expected);
    assert_eq!(
        find_cycle(&edges),
        Some(vec!["a".to_owned(), "b".to_owned(), "a".to_owned()])
    );
    // `super` inside an inline module is the file's own module.
    let inline = [
        source("lib.rs", "pub mod a; pub mod b;"),
        source(
            "a.rs",
            "use crate::b::X; #[cfg(test)] mod tests { use super::*; }",
        ),
        source("b.rs", "pub struct X;"),
    ];
    assert_eq!(find_cycle(&sibling_edges(&inline)), None);
}
