//! One number per claim: every measured number the README's headline section quotes (and the
//! headline of `docs/benchmarks.md`) is a value of the one table of ratios against the peers
//! (`harness::experiments::ratios`) or of the findings, both computed here from the committed
//! `reports/` as `pointsight report` computes them. A number counts when it has a decimal point
//! (`13.65`, `0.948`, `-0.003`) and stands outside a code span (settings and levels are written as
//! code: `gamma=4`); it must equal one of those values printed with as many decimals. The
//! comparison of `docs/lod-out-of-core.md` is held to the same rule against the scale results.

use std::path::Path;

use harness::experiments::{EXPERIMENTS, findings, ratios};

/// The text of the section of `markdown` whose heading is `heading`, up to the next heading of
/// the same or a higher level.
fn section<'a>(markdown: &'a str, heading: &str) -> &'a str {
    let start = markdown
        .find(heading)
        .unwrap_or_else(|| panic!("no section {heading:?}"));
    let level = heading.chars().take_while(|c| *c == '#').count();
    let body = &markdown[start + heading.len()..];
    let end = body
        .match_indices('\n')
        .map(|(i, _)| i + 1)
        .find(|&i| {
            let rest = &body[i..];
            let hashes = rest.chars().take_while(|c| *c == '#').count();
            hashes > 0 && hashes <= level && rest[hashes..].starts_with(' ')
        })
        .unwrap_or(body.len());
    &body[..end]
}

/// The decimal numbers of `text` outside code spans, as written (sign included).
fn decimals(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_code = false;
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '`' {
            in_code = !in_code;
            i += 1;
            continue;
        }
        let starts = c.is_ascii_digit() && (i == 0 || !chars[i - 1].is_ascii_alphanumeric());
        if in_code || !starts {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < chars.len() && (chars[j].is_ascii_digit() || chars[j] == '.') {
            j += 1;
        }
        let token: String = chars[i..j].iter().collect::<String>();
        let token = token.trim_end_matches('.').to_owned();
        if token.contains('.') {
            let sign = match i.checked_sub(1).map(|k| chars[k]) {
                Some('-') | Some('−') => "-",
                _ => "",
            };
            out.push(format!("{sign}{token}"));
        }
        i = j;
    }
    out
}

/// Every value the tables hold, for the committed reports.
fn values(reports: &Path) -> Vec<f64> {
    let mut v = Vec::new();
    for r in ratios::all(reports).expect("the ratios of the committed reports") {
        v.extend([r.ratio, r.min, r.max]);
        v.extend(r.low.into_iter().chain(r.high).chain(r.jaccard_min));
    }
    let names: Vec<&str> = EXPERIMENTS.iter().map(|e| e.name()).collect();
    for f in findings::findings(reports, &names).expect("the findings of the committed reports") {
        v.extend([f.value, f.cost, f.margin]);
        v.extend(
            [
                f.low,
                f.high,
                f.runner_up_value,
                f.difference,
                f.difference_low,
                f.difference_high,
                f.cheapest_value,
                f.cheapest_cost,
                f.tolerance,
            ]
            .into_iter()
            .flatten(),
        );
    }
    v.into_iter().filter(|x| x.is_finite()).collect()
}

/// The numbers of `text` that no value of `values` prints as.
fn unknown(text: &str, values: &[f64]) -> Vec<String> {
    decimals(text)
        .into_iter()
        .filter(|n| {
            let places = n.split_once('.').map_or(0, |(_, d)| d.len());
            let bare = n.trim_start_matches('-');
            !values
                .iter()
                .any(|v| format!("{v:.places$}") == *n || format!("{:.places$}", v.abs()) == bare)
        })
        .collect()
}

#[test]
fn every_number_of_the_headline_is_in_the_ratios_or_the_findings() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let values = values(&root.join("reports"));
    assert!(!values.is_empty(), "the committed reports give no values");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let headline = section(&readme, "## Headline results");
    assert!(
        decimals(headline).len() >= 5,
        "the headline quotes numbers: {headline}"
    );
    let missing = unknown(headline, &values);
    assert!(
        missing.is_empty(),
        "README.md's headline quotes numbers that are in no table computed from reports/ \
         (ratios.csv, findings.csv): {missing:?}"
    );
    let benchmarks =
        std::fs::read_to_string(root.join("docs/benchmarks.md")).expect("docs/benchmarks.md");
    let full = section(&benchmarks, "## Headline results, in full");
    let missing = unknown(full, &values);
    assert!(
        missing.is_empty(),
        "docs/benchmarks.md's headline quotes numbers in no table: {missing:?}"
    );
}

/// The values `docs/lod-out-of-core.md`'s comparison may quote besides the ratios: every scale
/// cell's seconds, angle errors and sign agreement (in per cent), and end to end at each size, Open3D's normals plus copc_converter's build and
/// that sum over each of our out-of-core builds from the plain LAZ.
fn scale_values(reports: &Path) -> Vec<f64> {
    let rows: Vec<harness::experiments::scale::row::Row> =
        harness::output::read_csv(&reports.join("scale/results.csv"))
            .expect("the committed scale results");
    let ok = |method: &str, n: u64| {
        rows.iter()
            .find(|r| r.method == method && r.n_points == n && r.status == "ok")
            .map(|r| r.seconds)
    };
    let mut v: Vec<f64> = rows
        .iter()
        .flat_map(|r| {
            [
                r.seconds,
                r.angle_median_deg,
                r.angle_p95_deg,
                100.0 * r.sign_agreement,
            ]
        })
        .collect();
    for r in rows.iter().filter(|r| r.method == "normals-open3d") {
        let Some(sum) = ok("normals-open3d", r.n_points)
            .zip(ok("copc_converter-build-ooc", r.n_points))
            .map(|(a, b)| a + b)
        else {
            continue;
        };
        v.push(sum);
        for ours in ["qsplat-build-ooc", "spt-build-ooc"] {
            v.extend(ok(ours, r.n_points).map(|s| sum / s));
        }
    }
    v.into_iter().filter(|x| x.is_finite()).collect()
}

#[test]
fn every_number_of_the_out_of_core_comparison_is_in_the_scale_results_or_the_ratios() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let reports = root.join("reports");
    let mut values = values(&reports);
    values.extend(scale_values(&reports));
    let doc = std::fs::read_to_string(root.join("docs/lod-out-of-core.md"))
        .expect("docs/lod-out-of-core.md");
    let table = section(&doc, "## Against the field's tools");
    assert!(
        !table.contains("{{"),
        "docs/lod-out-of-core.md's comparison has an unfilled placeholder"
    );
    assert!(
        decimals(table).len() >= 10,
        "the comparison quotes its numbers: {table}"
    );
    let missing = unknown(table, &values);
    assert!(
        missing.is_empty(),
        "docs/lod-out-of-core.md's comparison quotes numbers in neither reports/scale/results.csv \
         nor the ratios: {missing:?}"
    );
}

#[test]
fn the_check_reads_decimals_outside_code_and_compares_them_as_printed() {
    let text = "ours 13.65× [12.76, 14.51] at `gamma=4.5`, F1 −0.003 and 7 views.";
    assert_eq!(decimals(text), ["13.65", "12.76", "14.51", "-0.003"]);
    assert_eq!(
        unknown(text, &[13.6549, 12.757, 14.51, 0.0031]),
        Vec::<String>::new()
    );
    assert_eq!(unknown(text, &[13.66, 12.76, 14.51, 0.003]), ["13.65"]);
    let md = "# t\n## A\nin a\n### sub\nstill a\n## B\nnot a\n";
    assert_eq!(section(md, "## A"), "\nin a\n### sub\nstill a\n");
}
