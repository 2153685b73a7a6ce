//! External methods (protocol 1, methods/README.md): the plain-Python example through
//! `pointsight visible`, and broken programs (crash, hang, garbage, out-of-range and repeated
//! indices, a reported error, a failing check) each turned into a clear error.

use std::path::Path;
use std::process::{Command, Output};

fn pointsight(methods: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(args)
        .env("POINTSIGHT_METHODS", methods)
        .env("POINTSIGHT_DATA", "/nonexistent")
        .output()
        .expect("the pointsight binary runs")
}

/// A method folder with `script` as its Python program.
fn method(dir: &Path, name: &str, script: &str, extra: &str) {
    let folder = dir.join(name);
    std::fs::create_dir_all(&folder).expect("folder");
    std::fs::write(folder.join("m.py"), script).expect("script");
    std::fs::write(
        folder.join("method.toml"),
        format!("protocol = 1\nsummary = \"{name}\"\ncommand = [\"python3\", \"m.py\"]\n{extra}"),
    )
    .expect("manifest");
}

const ANSWER: &str =
    "import sys, json\nfor line in sys.stdin:\n    print(json.dumps(ANSWER), flush=True)\n";

#[test]
fn the_example_method_keeps_the_visible_contract() {
    let dir = tempfile::tempdir().unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../methods/example-zbuffer");
    let folder = dir.path().join("example-zbuffer");
    std::fs::create_dir_all(&folder).unwrap();
    for f in ["method.toml", "zbuffer.py"] {
        std::fs::copy(example.join(f), folder.join(f)).unwrap();
    }
    let listing = pointsight(dir.path(), &["methods"]);
    let text = String::from_utf8_lossy(&listing.stdout);
    assert!(
        text.contains("example-zbuffer") && text.contains("--set scale="),
        "{text}"
    );
    let out = dir.path().join("v.txt");
    let run = pointsight(
        dir.path(),
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "2",
            "--method",
            "example-zbuffer",
            "--set",
            "scale=2",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    let last = stdout.lines().last().unwrap();
    assert!(
        last.starts_with("method=example-zbuffer points=20000 visible="),
        "{last}"
    );
    let indices: Vec<usize> = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert!(indices.len() > 5_000 && indices.windows(2).all(|w| w[0] < w[1]));
    // A key the manifest does not declare is refused, as for built-in methods.
    let bad = pointsight(
        dir.path(),
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--method",
            "example-zbuffer",
            "--set",
            "gamma=3",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown parameter gamma"));
}

#[test]
fn broken_programs_are_errors_not_crashes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    method(
        d,
        "crash",
        "import sys\nsys.stdin.readline()\nsys.stderr.write('boom: segfault\\n')\nsys.exit(3)\n",
        "",
    );
    method(
        d,
        "hang",
        "import sys, time\nsys.stdin.readline()\ntime.sleep(60)\n",
        "timeout_seconds = 1\n",
    );
    method(
        d,
        "garbage",
        "import sys\nfor line in sys.stdin:\n    print('hello', flush=True)\n",
        "",
    );
    method(
        d,
        "out-of-range",
        &ANSWER.replace("ANSWER", "{'visible': [0, 999999999]}"),
        "",
    );
    method(
        d,
        "repeated",
        &ANSWER.replace("ANSWER", "{'visible': [3, 1, 3]}"),
        "",
    );
    method(
        d,
        "says-error",
        &ANSWER.replace("ANSWER", "{'error': 'no GPU here'}"),
        "",
    );
    method(
        d,
        "missing",
        "",
        "check = [\"false\"]\ninstall = \"pip install nothing\"\n",
    );
    method(
        d,
        "good",
        &ANSWER.replace("ANSWER", "{'visible': [5, 2], 'seconds': 0.25}"),
        "",
    );
    let out = d.join("v.txt");
    for (name, needle) in [
        ("crash", "exited"),
        ("hang", "no answer within 1.0 s"),
        ("garbage", "not JSON"),
        ("out-of-range", "index 999999999 is outside 0..20000"),
        ("repeated", "index 3 is repeated"),
        ("says-error", "no GPU here"),
        ("missing", "not installed"),
    ] {
        let run = pointsight(
            d,
            &[
                "visible",
                "--dataset",
                "sphere-20000",
                "--method",
                name,
                "--out",
                out.to_str().unwrap(),
            ],
        );
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{name} should fail");
        assert!(err.contains(needle), "{name}: {err}");
        assert!(
            err.contains(&format!("external method {name}")),
            "{name}: {err}"
        );
        assert!(!out.exists(), "{name}: no output file on error");
    }
    // The crash's stderr is quoted from its log.
    let run = pointsight(
        d,
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--method",
            "crash",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(String::from_utf8_lossy(&run.stderr).contains("boom: segfault"));
    // The listing says what is not installed and how to install it.
    let listing = String::from_utf8_lossy(&pointsight(d, &["methods"]).stdout).into_owned();
    assert!(listing.contains("not installed") && listing.contains("pip install nothing"));
    // A good answer: sorted, and the program's own seconds are the reported time.
    let run = pointsight(
        d,
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--method",
            "good",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "2\n5\n");
    assert!(
        String::from_utf8_lossy(&run.stdout).contains("visible=2 seconds=0.250000"),
        "{}",
        String::from_utf8_lossy(&run.stdout)
    );
}
