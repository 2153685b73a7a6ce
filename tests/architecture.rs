//! ARCHITECTURE.md's dependency invariants, checked from the crates' manifests: method crates
//! depend on `cloud` only (and `hpr` and `robustvis` on `hull`), the registry and the Python
//! package never on the harness, and only the harness does command lines, plots, CSV and
//! progress bars; from the harness's sources: which of its modules may name method crates
//! ([`MAY_NAME`]); and from every workspace crate's sources: that its modules import each
//! other without circles, and that no source file outside tests is over [`MAX_LINES`] lines
//! (both but for [`EXEMPT_CYCLES`] and [`EXEMPT_LONG`]); and from every source file of the
//! repository: that no comment cites an issue, stop, round or session by number.

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
    "neuralvis",
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
    for method in [
        "raycast",
        "qsplat",
        "spt",
        "srn",
        "splat",
        "screenspace",
        "neuralvis",
    ] {
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
    "hpr",
    "hull",
    "raycast",
    "qsplat",
    "spt",
    "srn",
    "splat",
    "truth",
    "neuralvis",
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
        "datasets/eyes.rs",
        "truth",
        "an eye inside a user's mesh: rays from it crossing the mesh",
    ),
    (
        "datasets/fit.rs",
        "truth",
        "the mesh check: each point's distance to a user's mesh",
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
        "records raycast::auto's rule in the metadata",
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
        "experiments/robustness/measure.rs",
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
        "lod_build/mod.rs",
        "qsplat",
        "pointsight lod-build writes QSplat files out of core (qsplat::ooc, after the \
         method-neutral cloud::ooc::prepare)",
    ),
    (
        "lod_build/mod.rs",
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
    scan(text).0
}

/// [`code_only`]'s text, and the contents of the file's string literals (raw ones too), each
/// with its offset in that text.
fn scan(text: &str) -> (String, Vec<(usize, String)>) {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut literals = Vec::new();
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
            let start = j;
            let mut end = c.len();
            while j < c.len() {
                if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                    end = j;
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            literals.push((out.len(), c[start..end].iter().collect()));
            for &ch in &c[i..j.min(c.len())] {
                blank(&mut out, ch);
            }
            i = j;
        } else if c[i] == '"' {
            let at = out.len();
            let mut literal = String::new();
            blank(&mut out, c[i]);
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    literal.push(c[i]);
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    literal.push(c[i]);
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            if i < c.len() {
                blank(&mut out, c[i]);
                i += 1;
            }
            literals.push((at, literal));
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
    (out, literals)
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

/// A crate's source file: its path under `src/` and its module path (`experiments::lod` for
/// `experiments/lod/mod.rs`; empty for `lib.rs`).
#[derive(Clone)]
struct Source {
    file: String,
    module: Vec<String>,
    code: String,
    /// Lines of the file as written.
    lines: usize,
    /// The string literals outside the file's `#[cfg(test)]` modules.
    literals: Vec<String>,
}

fn harness_sources() -> Vec<Source> {
    crate_sources("harness")
}

/// Every source file under `crates/NAME/src/`, tests included.
fn crate_sources(name: &str) -> Vec<Source> {
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
                let (code, literals) = scan(&text);
                let tests = test_modules(&code);
                out.push(Source {
                    module: module_of(&file),
                    file,
                    lines: text.lines().count(),
                    literals: literals
                        .into_iter()
                        .filter(|(at, _)| !tests.iter().any(|&(o, c)| o <= *at && *at <= c))
                        .map(|(_, l)| l)
                        .collect(),
                    code,
                });
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(name)
        .join("src");
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    out
}

/// The spans of `code` (comments and literals blanked) that `#[cfg(test)]` modules take: from
/// the attribute to the module's closing brace.
fn test_modules(code: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (at, _) in code.match_indices("#[cfg(test)]") {
        let rest = &code[at..];
        let Some(m) = rest.find("mod ") else { continue };
        let Some(open) = rest[m..].find(['{', ';']).map(|k| at + m + k) else {
            continue;
        };
        if code.as_bytes()[open] == b';' {
            continue; // `mod tests;`: a file of its own
        }
        let mut depth = 0;
        for (k, ch) in code[open..].char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        out.push((at, open + k));
                        break;
                    }
                }
                _ => {}
            }
        }
    }
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

/// Every cycle of `edges` as the set of its modules (`crate` for the root): the strongly
/// connected components of more than one module.
fn cycles(edges: &BTreeSet<(Vec<String>, Vec<String>)>) -> BTreeSet<BTreeSet<String>> {
    let nodes: BTreeSet<&Vec<String>> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    let reach = |from: &Vec<String>| -> BTreeSet<Vec<String>> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(n) = stack.pop() {
            for (_, m) in edges.iter().filter(|(a, _)| *a == n) {
                if seen.insert(m.clone()) {
                    stack.push(m.clone());
                }
            }
        }
        seen
    };
    let reachable: BTreeMap<&Vec<String>, BTreeSet<Vec<String>>> =
        nodes.iter().map(|&n| (n, reach(n))).collect();
    let name = |m: &Vec<String>| {
        if m.is_empty() {
            "crate".to_owned()
        } else {
            m.join("::")
        }
    };
    nodes
        .iter()
        .map(|&n| {
            nodes
                .iter()
                .filter(|&&m| m == n || (reachable[n].contains(m) && reachable[m].contains(n)))
                .map(|m| name(m))
                .collect::<BTreeSet<String>>()
        })
        .filter(|c| c.len() > 1)
        .collect()
}

/// `sources` without their tests: the files of modules declared `#[cfg(test)] mod NAME;` (and
/// the modules below them) dropped, inline `#[cfg(test)] mod NAME { ... }` blanked. A test
/// module's imports are no dependency of the code it tests.
fn without_tests(sources: Vec<Source>) -> Vec<Source> {
    const ATTR: &str = "#[cfg(test)]";
    let mut test_modules: Vec<Vec<String>> = Vec::new();
    let mut out = Vec::new();
    for mut src in sources {
        let mut code = src.code.clone();
        let mut from = 0;
        while let Some(k) = code[from..].find(ATTR) {
            let at = from + k;
            from = at + ATTR.len();
            let rest = code[from..].trim_start();
            let rest = rest
                .strip_prefix("pub(crate) ")
                .or_else(|| rest.strip_prefix("pub "))
                .unwrap_or(rest);
            let Some(decl) = rest.strip_prefix("mod ") else {
                continue;
            };
            let name = ident_at(decl, 0);
            let after = decl[name.len()..].trim_start();
            if after.starts_with(';') {
                let mut m = src.module.clone();
                m.push(name.to_owned());
                test_modules.push(m);
            } else if after.starts_with('{') {
                let open = code.len() - after.len();
                let mut depth = 0;
                let mut close = code.len();
                for (i, ch) in code[open..].char_indices() {
                    match ch {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                close = open + i + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                let blank: String = code[at..close]
                    .chars()
                    .map(|c| if c == '\n' { '\n' } else { ' ' })
                    .collect();
                code.replace_range(at..close, &blank);
            }
        }
        src.code = code;
        out.push(src);
    }
    out.retain(|s| !test_modules.iter().any(|t| s.module.starts_with(t)));
    out
}

/// The workspace's crates (the folders of `crates/`).
fn workspace_crates() -> Vec<String> {
    dependencies().into_keys().collect()
}

/// The import circles a crate may have while it is being reshaped, each the modules of one
/// circle: none today. A circle
/// listed here must exist (a listed circle that is gone fails the test).
const EXEMPT_CYCLES: &[(&str, &[&str])] = &[];

/// The longest a source file may be: one concept per module.
const MAX_LINES: usize = 900;

/// Files over [`MAX_LINES`] while they are being split, with their crate: none today. A file
/// listed here must be long (a
/// listed file that is no longer long fails the test).
const EXEMPT_LONG: &[(&str, &str)] = &[];

/// The files of `sources` outside tests over `max` lines: (file, lines).
fn long_files(sources: Vec<Source>, max: usize) -> Vec<(String, usize)> {
    without_tests(sources)
        .into_iter()
        .filter(|s| s.lines > max)
        .map(|s| (s.file, s.lines))
        .collect()
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

#[test]
fn no_crate_has_an_import_circle_between_its_modules() {
    let mut found: BTreeSet<(String, BTreeSet<String>)> = BTreeSet::new();
    let crates = workspace_crates();
    assert!(
        crates.len() >= 14 && crates.contains(&"cloud".to_owned()),
        "{crates:?}"
    );
    for krate in &crates {
        let sources = without_tests(crate_sources(krate));
        assert!(!sources.is_empty(), "{krate} has sources");
        for cycle in cycles(&sibling_edges(&sources)) {
            found.insert((krate.clone(), cycle));
        }
    }
    let exempt: BTreeSet<(String, BTreeSet<String>)> = EXEMPT_CYCLES
        .iter()
        .map(|(k, c)| (k.to_string(), c.iter().map(|m| m.to_string()).collect()))
        .collect();
    let new: Vec<_> = found.difference(&exempt).collect();
    let gone: Vec<_> = exempt.difference(&found).collect();
    assert!(
        new.is_empty(),
        "modules import each other in a circle (crate, modules): {new:?}"
    );
    assert!(
        gone.is_empty(),
        "EXEMPT_CYCLES lists circles that are gone: {gone:?}"
    );
}

#[test]
fn no_source_file_outside_tests_is_over_the_limit() {
    let mut found: BTreeSet<(String, String)> = BTreeSet::new();
    let mut counted = 0;
    for krate in workspace_crates() {
        let sources = crate_sources(&krate);
        counted += sources.len();
        for (file, lines) in long_files(sources, MAX_LINES) {
            println!("{krate}/src/{file}: {lines} lines");
            found.insert((krate.clone(), file));
        }
    }
    assert!(counted > 100, "{counted} files");
    let exempt: BTreeSet<(String, String)> = EXEMPT_LONG
        .iter()
        .map(|(k, f)| (k.to_string(), f.to_string()))
        .collect();
    let new: Vec<_> = found.difference(&exempt).collect();
    let gone: Vec<_> = exempt.difference(&found).collect();
    assert!(
        new.is_empty(),
        "source files over {MAX_LINES} lines (split them along their concepts; a test \
         module of a long file can go to a tests.rs of its own): {new:?}"
    );
    assert!(
        gone.is_empty(),
        "EXEMPT_LONG lists files that are no longer long: {gone:?}"
    );
}

/// The scanners on made-up sources: they find what they must, so the checks above can fail.
#[test]
fn the_module_checks_catch_violations() {
    let source = |file: &str, text: &str| Source {
        file: file.to_owned(),
        module: module_of(file),
        code: code_only(text),
        lines: text.lines().count(),
        literals: Vec::new(),
    };
    // String literals, raw ones too, and where test modules are.
    let text =
        "let a = \"hpr\"; // \"srn\"\nlet b = r#\"spt\"#;\n#[cfg(test)]\nmod tests { \"qsplat\" }";
    let (code, literals) = scan(text);
    let texts: Vec<&str> = literals.iter().map(|(_, l)| l.as_str()).collect();
    assert_eq!(texts, ["hpr", "spt", "qsplat"]);
    let tests = test_modules(&code);
    assert_eq!(tests.len(), 1);
    assert!(tests[0].0 < literals[2].0 && literals[2].0 < tests[0].1);
    assert!(literals[1].0 < tests[0].0);
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
    // Every circle, as its modules.
    let three = [
        source("lib.rs", "mod a; mod b; mod c; mod d;"),
        source("a.rs", "use crate::b::X;"),
        source("b.rs", "use crate::c::Y;"),
        source("c.rs", "use crate::a::Z; use crate::d::W;"),
        source("d.rs", "pub struct W;"),
    ];
    let set = |names: &[&str]| names.iter().map(|n| n.to_string()).collect::<BTreeSet<_>>();
    assert_eq!(
        cycles(&sibling_edges(&three)),
        BTreeSet::from([set(&["a", "b", "c"])])
    );
    // Tests are no dependency: a test module's file and an inline test module import freely.
    let tested = [
        source("lib.rs", "mod a; mod b;"),
        source(
            "a.rs",
            "use crate::b::X;\n#[cfg(test)]\nmod tests;\nfn f() {}",
        ),
        source("a/tests.rs", "use crate::b::Y;"),
        source(
            "b.rs",
            "pub struct X;\n#[cfg(test)]\nmod tests {\n    use crate::a::f;\n}\n",
        ),
    ];
    let with_tests = sibling_edges(&tested);
    assert_eq!(
        cycles(&with_tests),
        BTreeSet::from([set(&["a", "b"])]),
        "{with_tests:?}"
    );
    let kept = without_tests(tested.to_vec());
    assert_eq!(kept.len(), 3);
    assert!(cycles(&sibling_edges(&kept)).is_empty());
    assert!(kept[2].code.contains("pub struct X;") && !kept[2].code.contains("use"));
    // Long files: counted as written, tests' files left out.
    let long = [
        source("lib.rs", &"fn f() {}\n".repeat(901)),
        source("ok.rs", &"fn f() {}\n".repeat(900)),
        source("x.rs", "#[cfg(test)]\nmod tests;"),
        source("x/tests.rs", &"fn f() {}\n".repeat(2000)),
    ];
    assert_eq!(
        long_files(long.to_vec(), MAX_LINES),
        vec![("lib.rs".to_owned(), 901)]
    );
}

// ---------------------------------------------------------------------------------------------
// String literals: a generic module reaches a method through its card (a property on it), never
// through its name.

/// Harness modules that may name one of our methods in a string literal (outside their tests),
/// and why: the paper replications and the tools of one method. A new literal equal to a
/// method's name fails the test until its file is listed here with the reason; a listed file
/// that names none fails it too, so the table stays true.
const MAY_NAME_IN_STRINGS: &[(&str, &str)] = &[
    (
        "cli.rs",
        "pointsight lod-build --method's default: the command builds QSplat or SPT files",
    ),
    (
        "experiments/background.rs",
        "replication: hpr::background's update, against HPR's own answer",
    ),
    (
        "experiments/lod/peer_notes.rs",
        "explains one named peer's flat curve by its wrapper's drawing rule \
         (methods/py3dtiles-lod/lod.py), written only when the rows show it",
    ),
    (
        "experiments/lod/srn_table.rs",
        "replication: seed 003's Table 1 (SRN), its output folder named after it",
    ),
    (
        "experiments/reference.rs",
        "the ground truth's own experiment: its variants are the z-buffer and the reference",
    ),
    (
        "experiments/rules/curve.rs",
        "the BD-PSNR anchor: the random subsample every LOD curve is measured against, as the \
         field's rate-distortion comparisons name their baseline",
    ),
    (
        "experiments/hull.rs",
        "replication: Katz et al.'s hull inside HPR, and CGAL's (the cgal-hpr peer) beside ours",
    ),
    (
        "experiments/visibility/papers.rs",
        "replication: Machado e Silva et al.'s approximate HPR and Katz & Tal's kernel family and \
         confidence score, each against exact HPR",
    ),
    (
        "lod_build/mod.rs",
        "pointsight lod-build: the QSplat and SPT files built out of core (MAY_NAME)",
    ),
    (
        "output/style.rs",
        "the report's one style table: each family's colour, dash and peer marker \
         assigned in one place, so a method looks the same in every figure and page",
    ),
    (
        "view/mod.rs",
        "\"reference\" titles the ground truth's panel (truth::Reference), not a method run",
    ),
    (
        "view/page.rs",
        "\"reference\" says the page's classes are the ground truth's, not a method run",
    ),
];

/// The names of our methods: the registry's cards, with the repository's `methods/` folders.
fn method_names() -> BTreeSet<String> {
    let methods = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../methods");
    let mut catalogue = registry::Catalogue::builtin();
    catalogue
        .add_external(&methods)
        .expect("the methods folder loads");
    catalogue
        .cards()
        .iter()
        .map(|c| c.name.to_owned())
        .collect()
}

#[test]
fn harness_modules_name_methods_in_strings_only_where_listed() {
    let names = method_names();
    assert!(
        names.contains("hpr") && names.contains("cgal-hpr"),
        "{names:?}"
    );
    let mut found: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    // Test modules in files of their own are tests: they may name what they test.
    for src in without_tests(harness_sources()) {
        for l in src.literals.iter().filter(|l| names.contains(*l)) {
            found.entry(src.file.clone()).or_default().insert(l.clone());
        }
    }
    let unlisted: Vec<_> = found
        .iter()
        .filter(|(file, _)| !MAY_NAME_IN_STRINGS.iter().any(|(f, _)| f == file))
        .collect();
    assert!(
        unlisted.is_empty(),
        "harness modules name methods in string literals (ask the method's card for the \
         property instead, or list the file in MAY_NAME_IN_STRINGS with its reason): {unlisted:?}"
    );
    let stale: Vec<&str> = MAY_NAME_IN_STRINGS
        .iter()
        .map(|(f, _)| *f)
        .filter(|f| !found.contains_key(*f))
        .collect();
    assert!(
        stale.is_empty(),
        "MAY_NAME_IN_STRINGS lists files that name no method: {stale:?}"
    );
}

/// The comment part of `line` in a file of extension `ext` (`//` in Rust, JavaScript and C++;
/// `#` in Python, shell and TOML), empty when it has none. A marker inside a string counts as
/// a comment too: the check errs towards reading more, never less.
fn comment_of<'a>(line: &'a str, ext: &str) -> &'a str {
    let marker = match ext {
        "rs" | "js" | "cpp" | "hpp" | "h" => "//",
        _ => "#",
    };
    line.find(marker).map_or("", |at| &line[at..])
}

/// The places in `comment` where an issue, stop, round or session is cited by number
/// (the word, a space, an optional `#`, a digit): history, which belongs in commit messages.
fn narrations(comment: &str) -> Vec<String> {
    let lower = comment.to_lowercase();
    let mut out = Vec::new();
    for word in ["issue", "stop", "round", "session"] {
        let mut from = 0;
        while let Some(pos) = lower[from..].find(word) {
            let at = from + pos;
            from = at + word.len();
            let before = lower[..at].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric()) {
                continue;
            }
            let rest = lower[from..]
                .trim_start_matches(' ')
                .trim_start_matches('#');
            if lower[from..].starts_with(' ') && rest.starts_with(|c: char| c.is_ascii_digit()) {
                out.push(comment[at..].chars().take(40).collect());
            }
        }
    }
    out
}

/// Every source file of the repository a comment could narrate in: Rust, Python, shell,
/// JavaScript, C++ and TOML under the crates, tests, methods, scripts, examples and the web
/// sources (build outputs, installed packages and test data files left out).
fn commented_sources() -> Vec<std::path::PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        let Ok(read) = std::fs::read_dir(dir) else {
            return;
        };
        let mut entries: Vec<_> = read.map(|e| e.expect("entry").path()).collect();
        entries.sort();
        for path in entries {
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            if path.is_dir() {
                if !matches!(
                    name.as_deref(),
                    Some("target" | "node_modules" | "dist" | ".venv" | "__pycache__")
                ) {
                    walk(&path, out);
                }
            } else if path.extension().is_some_and(|e| {
                ["rs", "py", "sh", "js", "cpp", "hpp", "h", "toml"]
                    .contains(&e.to_string_lossy().as_ref())
            }) {
                out.push(path);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    for dir in [
        "crates", "tests", "methods", "scripts", "examples", "web/src", "web/test",
    ] {
        walk(&root.join(dir), &mut out);
    }
    out
}

#[test]
fn comments_explain_instead_of_narrating() {
    // The cases are built at run time, so that this file's own lines cite nothing.
    let cite = |word: &str, n: u32| format!("{word} {n}");
    assert_eq!(
        narrations(&format!("// ({}: under 250 lines)", cite("issue", 39))),
        ["issue 39: under 250 lines)"]
    );
    assert_eq!(
        narrations("# at stop 58, round #2"),
        ["stop 58, round #2", "round #2"]
    );
    assert!(narrations("// three rounds 3 times; tissue 4; issue tracker").is_empty());
    let line = format!("let a = 1; // {}", cite("issue", 4));
    assert_eq!(comment_of(&line, "rs"), format!("// {}", cite("issue", 4)));
    assert_eq!(comment_of("x = 1  # stop 2", "py"), "# stop 2");
    let files = commented_sources();
    assert!(files.len() > 100, "{} source files found", files.len());
    let mut found = Vec::new();
    for path in files {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        for (k, line) in text.lines().enumerate() {
            for n in narrations(comment_of(line, &ext)) {
                found.push(format!("{}:{}: {n}", path.display(), k + 1));
            }
        }
    }
    assert!(
        found.is_empty(),
        "comments that narrate history (it belongs in commit messages, docs/ and reports/):\n{}",
        found.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// ARCHITECTURE.md itself: its dependency block equals the manifests, and what it names exists.

/// The repository's root.
fn repo_root() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn architecture_doc() -> String {
    std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md")
}

/// The ```text block of `crate: dep, dep` lines in `doc`, as a map.
fn doc_dependencies(doc: &str) -> BTreeMap<String, Vec<String>> {
    let mut out = BTreeMap::new();
    let mut inside = false;
    for line in doc.lines() {
        if line.trim() == "```text" {
            inside = true;
            continue;
        }
        if inside && line.trim() == "```" {
            break;
        }
        if let Some((name, deps)) = line.split_once(':').filter(|_| inside) {
            let mut deps: Vec<String> = deps
                .split(',')
                .map(|d| d.trim().to_owned())
                .filter(|d| !d.is_empty())
                .collect();
            deps.sort();
            out.insert(name.trim().to_owned(), deps);
        }
    }
    out
}

#[test]
fn the_architecture_doc_lists_the_dependencies() {
    let manifests: BTreeMap<String, Vec<String>> = dependencies()
        .into_iter()
        .map(|(name, deps)| {
            let mut local: Vec<String> = deps
                .into_iter()
                .filter(|d| LOCAL.contains(&d.as_str()))
                .collect();
            local.sort();
            (name, local)
        })
        .collect();
    let doc = doc_dependencies(&architecture_doc());
    assert_eq!(
        doc, manifests,
        "ARCHITECTURE.md's dependency block (left) differs from crates/*/Cargo.toml (right)"
    );
    // The parser reads what it is shown, so a wrong block fails.
    let wrong = doc_dependencies("x\n```text\ncloud:\nhpr: hull, cloud\n```\nhpr: y\n");
    assert_eq!(wrong["hpr"], ["cloud", "hull"]);
    assert_eq!(wrong.len(), 2);
}

/// Every file and folder of the repository (relative, with `/`), build outputs and installed
/// packages left out, folders with a trailing `/`.
fn repository_paths() -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        let Ok(read) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in read {
            let path = entry.expect("entry").path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            let rel = path
                .strip_prefix(root)
                .expect("under the root")
                .to_string_lossy()
                .replace('\\', "/");
            if path.is_dir() {
                if matches!(
                    name.as_deref(),
                    Some(
                        "target"
                            | "node_modules"
                            | ".venv"
                            | ".git"
                            | ".tools"
                            | "bench-data"
                            | "__pycache__"
                    )
                ) {
                    continue;
                }
                out.push(format!("{rel}/"));
                walk(root, &path, out);
            } else {
                out.push(rel);
            }
        }
    }
    let root = repo_root().canonicalize().expect("root");
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    out
}

/// Whether `name`, a path as the doc writes it (from the root, or from a crate's or a source
/// folder's level: `methods/hpr.rs`, `output/style.rs`), is the end of some repository path.
fn names_a_path(paths: &[String], name: &str) -> bool {
    let name = name.trim_end_matches('/');
    paths.iter().any(|p| {
        let p = p.trim_end_matches('/');
        p == name || p.ends_with(&format!("/{name}"))
    })
}

/// The spans in backticks of `doc`.
fn code_spans(doc: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in doc.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let mut parts = line.split('`');
        parts.next();
        while let (Some(inside), Some(_)) = (parts.next(), parts.next()) {
            out.push(inside);
        }
        // A span left open at the end of a line continues on the next; such spans are rare and
        // left unchecked.
    }
    out
}

/// Whether `span` looks like a file or folder the doc names (not a placeholder like
/// `methods/NAME.rs`, a glob, a command line or a Rust path).
fn is_path_span(span: &str) -> bool {
    if span.contains(char::is_whitespace)
        || span.contains(['*', '{', '<', '(', '='].as_slice())
        || span.contains("NAME")
        || span.contains("::")
        || span.starts_with('.')
    {
        return false;
    }
    let file = [
        ".rs", ".toml", ".md", ".py", ".sh", ".hpp", ".js", ".json", ".tsv", ".csv",
    ]
    .iter()
    .any(|e| span.ends_with(e));
    file || (span.ends_with('/') && span.len() > 1)
}

/// Whether `text` defines `name` (a function, type, constant, static or module) or re-exports
/// it (`pub use`).
fn defines(text: &str, name: &str) -> bool {
    let whole = |line: &str, at: usize| {
        let before = line[..at].chars().next_back();
        let after = line[at + name.len()..].chars().next();
        !before.is_some_and(is_ident) && !after.is_some_and(is_ident)
    };
    text.lines().any(|line| {
        let line = line.trim_start();
        [
            "fn ", "struct ", "enum ", "trait ", "type ", "const ", "static ", "mod ",
        ]
        .iter()
        .any(|kw| {
            line.match_indices(&format!("{kw}{name}"))
                .any(|(at, _)| whole(line, at + kw.len()))
        })
    }) || text.match_indices("pub use ").any(|(at, _)| {
        // A re-export, on one line or several: the statement up to its `;`.
        let statement = text[at..].split(';').next().unwrap_or_default();
        statement
            .match_indices(name)
            .any(|(k, _)| whole(statement, k))
    })
}

/// Whether the Rust path `span` (`crate::module[::item]`) names a module or an item of a
/// workspace crate: each segment a module file or folder under the previous one, the last one
/// a module or an item its module defines or re-exports. `None` when `span` does not start
/// with a workspace crate.
fn names_a_rust_item(span: &str) -> Option<bool> {
    let span = span.split('(').next().unwrap_or(span);
    let segments: Vec<&str> = span.split("::").collect();
    let krate = *segments.first()?;
    if segments.len() < 2 || !LOCAL.contains(&krate) {
        return None;
    }
    let mut dir = repo_root().join("crates").join(krate).join("src");
    let mut files = vec![dir.join("lib.rs")];
    for (k, segment) in segments[1..].iter().enumerate() {
        let as_file = dir.join(format!("{segment}.rs"));
        let as_dir = dir.join(segment);
        if as_file.exists() || as_dir.join("mod.rs").exists() {
            files = vec![as_file, as_dir.join("mod.rs")];
            dir = as_dir;
            continue;
        }
        if k + 2 < segments.len() {
            // A type's associated item (`Card::setup`): the type must be defined here.
            let ty = segment;
            return Some(
                files
                    .iter()
                    .any(|f| std::fs::read_to_string(f).is_ok_and(|text| defines(&text, ty))),
            );
        }
        return Some(
            files
                .iter()
                .any(|f| std::fs::read_to_string(f).is_ok_and(|text| defines(&text, segment))),
        );
    }
    Some(true)
}

#[test]
fn the_architecture_doc_names_what_exists() {
    let paths = repository_paths();
    assert!(names_a_path(&paths, "crates/registry/src/kernel.rs"));
    assert!(names_a_path(&paths, "output/style.rs"));
    assert!(!names_a_path(&paths, "output/colours.rs"));
    assert!(is_path_span("methods/_shared/"));
    assert!(!is_path_span("methods/NAME.rs"));
    assert_eq!(names_a_rust_item("registry::kernel"), Some(true));
    assert_eq!(names_a_rust_item("cloud::ooc::prepare"), Some(true));
    assert_eq!(names_a_rust_item("hull::incremental"), Some(true));
    assert_eq!(names_a_rust_item("hull::own"), Some(false));
    assert_eq!(names_a_rust_item("cloud::nowhere::prepare"), Some(false));
    assert_eq!(names_a_rust_item("std::fs"), None);
    assert_eq!(names_a_rust_item("registry::Card"), Some(true));
    assert_eq!(names_a_rust_item("registry::Cardboard"), Some(false));
    assert!(defines("pub use m::{\n    a, b_c,\n    d,\n};", "b_c"));
    assert!(!defines("pub use m::{\n    a, b_cd,\n};", "b_c"));
    let doc = architecture_doc();
    let mut missing = Vec::new();
    for span in code_spans(&doc) {
        if is_path_span(span) && !names_a_path(&paths, span) {
            missing.push(format!("path `{span}`"));
        }
        if names_a_rust_item(span) == Some(false) {
            missing.push(format!("Rust path `{span}`"));
        }
    }
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names what does not exist:\n{}",
        missing.join("\n")
    );
}

#[test]
fn the_lod_crates_share_one_file_layer() {
    // One error type and one positional reader for both LOD crates' files (and the out-of-core
    // preparation): neither crate declares an error enum of its own or opens a file to read it
    // by position itself.
    for name in ["qsplat", "spt"] {
        for src in without_tests(crate_sources(name)) {
            for twin in ["pub enum Error", "read_exact_at", "impl From<cloud::"] {
                assert!(
                    !src.code.contains(twin),
                    "crates/{name}/src/{} has `{twin}`: use cloud::lod_file",
                    src.file
                );
            }
        }
    }
    let layer = crate_sources("cloud");
    assert!(layer.iter().any(|s| s.file == "lod_file.rs"));
    assert!(
        layer
            .iter()
            .filter(|s| s.code.contains("pub enum Error"))
            .all(|s| s.file == "lod_file.rs" || s.file == "error.rs"),
        "one error type per concern in cloud"
    );
}

/// The process-wide state the workspace keeps, each with its reason: (crate, file, name). None
/// of it is a run's state (the catalogue, the datasets, the methods folders), which lives in
/// the run's value (`harness::run::Run`, `registry::Catalogue`) and reaches a scale cell as one
/// file. A listed item that is gone fails the test, as does any other.
const PROCESS_STATE: &[(&str, &str, &str, &str)] = &[
    (
        "harness",
        "progress.rs",
        "QUIET",
        "the progress display's --quiet, one terminal a process",
    ),
    (
        "harness",
        "progress.rs",
        "ACTIVE",
        "the progress display: one terminal a process",
    ),
    (
        "harness",
        "progress.rs",
        "SAID",
        "warnings said once a process, on its one terminal",
    ),
    (
        "harness",
        "output/figure.rs",
        "REGISTERED",
        "the embedded font, registered once with plotters",
    ),
    (
        "python",
        "bindings.rs",
        "POOL",
        "the thread pool of set_num_threads, one a Python process",
    ),
    ("qsplat", "build.rs", "RIGHT", "a thread's scratch buffer"),
    (
        "qsplat",
        "quant.rs",
        "TABLE",
        "constant quantisation tables, computed once",
    ),
    ("spt", "hierarchy.rs", "LOCAL", "a thread's scratch buffers"),
    (
        "spt",
        "hierarchy.rs",
        "TABLE",
        "constant direction table, computed once",
    ),
    (
        "neuralvis",
        "lib.rs",
        "FOLDED",
        "the committed weights, decoded once (constant)",
    ),
    ("cloud", "scratch.rs", "HOST", "the host name, read once"),
    (
        "cloud",
        "scratch.rs",
        "COUNTER",
        "unique scratch names within a process",
    ),
    (
        "cloud",
        "scratch.rs",
        "LIVE",
        "the scratch reaper: paths a signal must remove",
    ),
    (
        "cloud",
        "io/atomic.rs",
        "INPUTS",
        "the files this process read, which no output may replace: recorded by the readers \
         where they read; not yet part of the run's value",
    ),
    (
        "cloud",
        "orient.rs",
        "GUIDES",
        "ids of guides, so thread buffers know their owner",
    ),
    ("cloud", "orient.rs", "QUERIES", "a thread's query buffers"),
    (
        "cloud",
        "ooc/partition.rs",
        "SUBSET_POINTS",
        "a test hook (cfg(test) only)",
    ),
];

/// Every `static` holding mutable or lazily set state (a lock, a once-cell, an atomic, a cell,
/// a thread-local) in the workspace's sources outside test modules: (crate, file, name).
fn process_state() -> BTreeSet<(String, String, String)> {
    const KINDS: [&str; 6] = ["Mutex", "RwLock", "OnceLock", "Atomic", "Cell<", "LazyLock"];
    let mut out = BTreeSet::new();
    for krate in workspace_crates() {
        for src in without_tests(crate_sources(&krate)) {
            for line in src.code.lines() {
                let t = line.trim_start();
                let Some(rest) = t
                    .strip_prefix("pub(super) static ")
                    .or_else(|| t.strip_prefix("pub(crate) static "))
                    .or_else(|| t.strip_prefix("pub static "))
                    .or_else(|| t.strip_prefix("static "))
                else {
                    continue;
                };
                let rest = rest.strip_prefix("mut ").unwrap_or(rest);
                let Some((name, ty)) = rest.split_once(':') else {
                    continue;
                };
                if KINDS.iter().any(|k| ty.contains(k)) {
                    out.insert((krate.clone(), src.file.clone(), name.trim().to_owned()));
                }
            }
        }
    }
    out
}

#[test]
fn no_run_state_in_process_globals() {
    let found = process_state();
    let listed: BTreeSet<(String, String, String)> = PROCESS_STATE
        .iter()
        .map(|(k, f, n, _)| (k.to_string(), f.to_string(), n.to_string()))
        .collect();
    let unlisted: Vec<_> = found.difference(&listed).collect();
    assert!(
        unlisted.is_empty(),
        "process-wide state without a listed reason (run state belongs in the run's value): \
         {unlisted:?}"
    );
    let gone: Vec<_> = listed.difference(&found).collect();
    assert!(gone.is_empty(), "listed but gone: {gone:?}");
    // The scanner sees what it must.
    assert!(found.contains(&("cloud".into(), "scratch.rs".into(), "LIVE".into())));
    // The scale cells receive the run as one file: no variable passes it.
    let child = crate_sources("harness")
        .into_iter()
        .find(|s| s.file == "experiments/scale/child.rs")
        .expect("the scale cells' runner");
    assert!(
        !child.code.contains(".env(") && !child.code.contains("env::var"),
        "scale cells get their run from the --run file, not environment variables"
    );
}
