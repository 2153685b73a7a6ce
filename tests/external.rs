//! External methods (methods/README.md): the plain-Python examples (protocols 1 and 3) through
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

/// A methods folder holding the example `name` (its `files`) and the protocol helper it
/// imports, where it looks for it (a methods folder's `_shared/`).
fn example(dir: &Path, name: &str, files: &[&str]) {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../methods");
    let folder = dir.join(name);
    std::fs::create_dir_all(&folder).expect("test setup");
    for f in files {
        std::fs::copy(example.join(name).join(f), folder.join(f)).expect("test setup");
    }
    let shared = dir.join("_shared");
    std::fs::create_dir_all(&shared).expect("test setup");
    std::fs::copy(
        example.join("_shared/pointsight_protocol.py"),
        shared.join("pointsight_protocol.py"),
    )
    .expect("test setup");
}

/// `pointsight visible` of `method` at `scale` on view 2 of sphere-20000: the indices.
fn example_visible(methods: &Path, method: &str, scale: &str) -> Vec<usize> {
    let out = methods.join(format!("{method}-{scale}.txt"));
    let run = pointsight(
        methods,
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "2",
            "--method",
            method,
            "--set",
            &format!("scale={scale}"),
            "--out",
            out.to_str().expect("test setup"),
        ],
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    let last = stdout.lines().last().expect("test setup");
    assert!(
        last.starts_with(&format!("method={method} points=20000 visible=")),
        "{last}"
    );
    std::fs::read_to_string(&out)
        .expect("test setup")
        .lines()
        .map(|l| l.parse().expect("test setup"))
        .collect()
}

#[test]
fn the_example_methods_keep_the_visible_contract() {
    let dir = tempfile::tempdir().unwrap();
    example(
        dir.path(),
        "example-zbuffer",
        &["method.toml", "zbuffer.py"],
    );
    example(dir.path(), "example-warm", &["method.toml", "warm.py"]);
    let listing = pointsight(dir.path(), &["methods"]);
    let text = String::from_utf8_lossy(&listing.stdout);
    assert!(
        text.contains("example-zbuffer")
            && text.contains("example-warm")
            && text.contains("--set scale="),
        "{text}"
    );
    let indices = example_visible(dir.path(), "example-zbuffer", "2");
    assert!(indices.len() > 5_000 && indices.windows(2).all(|w| w[0] < w[1]));
    // The protocol 3 example is the same z-buffer, its setting sent with the request.
    assert_eq!(example_visible(dir.path(), "example-warm", "2"), indices);
    assert_ne!(example_visible(dir.path(), "example-warm", "1"), indices);
    // A key the manifest does not declare is refused, as for built-in methods.
    for method in ["example-zbuffer", "example-warm"] {
        let bad = pointsight(
            dir.path(),
            &[
                "visible",
                "--dataset",
                "sphere-20000",
                "--method",
                method,
                "--set",
                "gamma=3",
                "--out",
                dir.path().join("bad.txt").to_str().unwrap(),
            ],
        );
        assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown parameter gamma"));
    }
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
    // A check that leaves a mark: whether a command ran it.
    method(
        d,
        "marked",
        "",
        "check = [\"sh\", \"-c\", \"touch checked\"]\n",
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
    // The crash's stderr is quoted (the end of it, kept in memory).
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
    // The listing runs no check (it takes no time); `--check` says what is not installed and
    // how to install it.
    let listing = String::from_utf8_lossy(&pointsight(d, &["methods"]).stdout).into_owned();
    assert!(
        !listing.contains("not installed") && listing.contains("methods --check"),
        "{listing}"
    );
    assert!(
        !d.join("marked/checked").exists(),
        "the listing ran a check"
    );
    let listing =
        String::from_utf8_lossy(&pointsight(d, &["methods", "--check"]).stdout).into_owned();
    assert!(listing.contains("not installed") && listing.contains("pip install nothing"));
    assert!(d.join("marked/checked").exists());
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

/// A protocol-2 method folder with `script` as its Python program.
fn method2(dir: &Path, name: &str, script: &str, extra: &str) {
    let folder = dir.join(name);
    std::fs::create_dir_all(&folder).expect("folder");
    std::fs::write(folder.join("m.py"), script).expect("script");
    std::fs::write(
        folder.join("method.toml"),
        format!("protocol = 2\nsummary = \"{name}\"\ncommand = [\"python3\", \"m.py\"]\n{extra}"),
    )
    .expect("manifest");
}

fn visible(d: &Path, name: &str, view: &str, out: &Path) -> Output {
    pointsight(
        d,
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            view,
            "--method",
            name,
            "--out",
            out.to_str().expect("utf-8 path"),
        ],
    )
}

#[test]
fn protocol_2_sends_normals_spacing_and_the_view_index() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Checks the PLY header and the arguments, then answers the view's index as its set.
    let script = r#"
import sys, json
args = sys.argv[1:]
points = args[args.index("--points") + 1]
assert args[args.index("--protocol") + 1] == "2", args
assert args[args.index("--normals") + 1] in ("dataset", "estimated"), args
spacing = float(args[args.index("--spacing") + 1])
assert 0 < spacing < 1, spacing
header = open(points, "rb").read(400).split(b"end_header")[0].decode()
assert "property float nx" in header and "property double x" in header, header
for line in sys.stdin:
    req = json.loads(line)
    print(json.dumps({"visible": [req["view"]], "seconds": 0.5}), flush=True)
"#;
    method2(d, "echo-view", script, "peer_of = \"raycast\"\n");
    let out = d.join("v.txt");
    for view in ["2", "5"] {
        let run = visible(d, "echo-view", view, &out);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        // The request's view is the dataset's view index, not a count of calls.
        assert_eq!(std::fs::read_to_string(&out).unwrap(), format!("{view}\n"));
    }
    // Repeats ask the same view again.
    let run = pointsight(
        d,
        &[
            "visible",
            "--dataset",
            "sphere-20000",
            "--view",
            "3",
            "--repeat",
            "3",
            "--method",
            "echo-view",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "3\n");
    // Protocol 1 is still accepted: no normals, no --normals, positions only.
    let v1 = r#"
import sys, json
assert "--normals" not in sys.argv and "--spacing" not in sys.argv, sys.argv
header = open(sys.argv[sys.argv.index("--points") + 1], "rb").read(400).split(b"end_header")[0]
assert b"nx" not in header, header
for line in sys.stdin:
    print(json.dumps({"visible": [json.loads(line)["view"]]}), flush=True)
"#;
    method(d, "old", v1, "");
    let run = visible(d, "old", "4", &out);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "4\n");
}

#[test]
fn floods_are_refused_with_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // An endless answer line (it would be gigabytes): refused after the limit, unread.
    method2(
        d,
        "flood-line",
        "import sys\nsys.stdin.readline()\nsys.stdout.write('{\"visible\": [')\nwhile True:\n    sys.stdout.write('1, ' * 100000)\n",
        "",
    );
    // A 4 GiB (sparse) visible_file.
    method2(
        d,
        "flood-file",
        "import sys, json, os\nos.chdir(os.environ['TMPDIR'])\nfor line in sys.stdin:\n    with open('big.txt', 'wb') as f:\n        f.truncate(4 << 30)\n    print(json.dumps({'visible_file': 'big.txt'}), flush=True)\n",
        "",
    );
    // More indices than points, as a list and as a file within the size limit.
    method2(
        d,
        "too-many",
        &ANSWER.replace("ANSWER", "{'visible': list(range(20001))}"),
        "",
    );
    method2(
        d,
        "too-many-file",
        "import sys, json, os\nos.chdir(os.environ['TMPDIR'])\nfor line in sys.stdin:\n    open('many.txt', 'w').write('0 ' * 20001)\n    print(json.dumps({'visible_file': 'many.txt'}), flush=True)\n",
        "",
    );
    method2(
        d,
        "negative",
        &ANSWER.replace("ANSWER", "{'visible': [4, -1]}"),
        "",
    );
    let out = d.join("v.txt");
    for (name, needle) in [
        ("flood-line", "longer than 2008576 bytes"),
        (
            "flood-file",
            "is 4294967296 bytes, more than the 2008576 bytes",
        ),
        (
            "too-many",
            "it answered 20001 indices, more than the cloud's 20000 points",
        ),
        ("too-many-file", "index 0 is repeated"),
        ("negative", "index -1 is outside 0..20000"),
    ] {
        let run = visible(d, name, "0", &out);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{name} should fail");
        assert!(err.contains(needle), "{name}: {err}");
        assert!(
            err.contains(&format!("external method {name}")),
            "{name}: {err}"
        );
        assert!(!out.exists(), "{name}: no output file on error");
    }
}

#[test]
fn manifest_keys_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    method2(d, "bad-peer", "", "peer_of = \"Ray Cast\"\n");
    let run = pointsight(d, &["methods"]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("peer_of = \"Ray Cast\""),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    method(d, "old-lod", "", "kind = \"lod\"\n");
    let run = pointsight(d, &["methods"]);
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("kind = \"lod\" needs protocol = 2"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let folder = d.join("future");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(
        folder.join("method.toml"),
        "protocol = 4\ncommand = [\"true\"]\n",
    )
    .unwrap();
    let run = pointsight(d, &["methods"]);
    assert!(
        String::from_utf8_lossy(&run.stderr)
            .contains("protocol 4 (this pointsight speaks 1, 2 and 3)"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// Whether process `pid` runs (a zombie does not), waiting up to 5 s for it to end.
fn still_running(pid: u32) -> bool {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
    loop {
        let running = std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
            stat.rsplit(')')
                .next()
                .is_some_and(|s| !s.trim_start().starts_with('Z'))
        });
        if !running || std::time::Instant::now() > deadline {
            return running;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// What a hanging program noted once `pointsight visible` had started it: its id, its
/// child's, its escaped grandchild's (a double fork with `setsid`), its points file.
struct Hanging {
    run: std::process::Child,
    program: u32,
    child: u32,
    escaped: u32,
    points: std::path::PathBuf,
}

/// `pointsight visible` of a method (in `d`) that starts a child and an escaped grandchild,
/// notes their ids and hangs on its first view, with `tmp` as the temporary folder.
fn start_hanging(d: &Path, tmp: &Path) -> Hanging {
    let script = r#"
import sys, os, subprocess, time
args = sys.argv[1:]
p = subprocess.Popen(["sleep", "60"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                     stderr=subprocess.DEVNULL)
first = os.fork()
if first == 0:
    os.setsid()
    if os.fork() == 0:
        null = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        open("escaped.tmp", "w").write(str(os.getpid()))
        os.rename("escaped.tmp", "escaped")
        os.execvp("sleep", ["sleep", "60"])
    os._exit(0)
os.waitpid(first, 0)
while not os.path.exists("escaped"):
    time.sleep(0.01)
open("ids.tmp", "w").write("%d %d %s" % (os.getpid(), p.pid, args[args.index("--points") + 1]))
os.rename("ids.tmp", "ids")
for line in sys.stdin:
    time.sleep(60)
"#;
    method2(d, "hangs", script, "timeout_seconds = 100\n");
    let out = d.join("v.txt");
    let run = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(["visible", "--dataset", "sphere-20000", "--view", "0"])
        .args([
            "--method",
            "hangs",
            "--out",
            out.to_str().expect("test setup"),
        ])
        .env("POINTSIGHT_METHODS", d)
        .env("POINTSIGHT_DATA", "/nonexistent")
        .env("TMPDIR", tmp)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("the pointsight binary runs");
    let ids = d.join("hangs/ids");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    while !ids.exists() {
        assert!(
            std::time::Instant::now() < deadline,
            "the program never started"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let ids = std::fs::read_to_string(ids).expect("test setup");
    let mut words = ids.split(' ');
    let program: u32 = words
        .next()
        .expect("test setup")
        .parse()
        .expect("test setup");
    let child: u32 = words
        .next()
        .expect("test setup")
        .parse()
        .expect("test setup");
    let points = Path::new(words.next().expect("test setup")).to_owned();
    let escaped = std::fs::read_to_string(d.join("hangs/escaped"))
        .expect("test setup")
        .parse()
        .expect("test setup");
    assert!(points.exists());
    // Its first request is on its way: pointsight waits for the answer.
    std::thread::sleep(std::time::Duration::from_millis(300));
    Hanging {
        run,
        program,
        child,
        escaped,
        points,
    }
}

/// A process id above the kernel's maximum: no process has it.
fn dead_pid() -> u32 {
    std::fs::read_to_string("/proc/sys/kernel/pid_max")
        .ok()
        .and_then(|s| s.trim().parse::<u32>().ok())
        .map_or(u32::MAX - 1, |m| m + 1)
}

/// The processes of `ids` still running, each killed (not left behind by the test either).
fn left_running(ids: &[u32]) -> Vec<u32> {
    let left: Vec<u32> = ids.iter().copied().filter(|&p| still_running(p)).collect();
    for p in &left {
        let _ = Command::new("kill")
            .args(["-KILL", &p.to_string()])
            .status();
    }
    left
}

#[test]
fn a_signal_ends_the_program_its_children_and_its_points_file() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut h = start_hanging(d, tmp.path());
    // The program's folder is in the temporary folder, named with pointsight's host and id.
    let folder = h.points.parent().unwrap().to_owned();
    let name = folder.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        folder.starts_with(tmp.path()) && name.starts_with(".pointsight.program-"),
        "{}",
        folder.display()
    );
    assert!(name.contains(&format!("-{}-", h.run.id())), "{name}");
    let term = Command::new("kill")
        .args(["-TERM", &h.run.id().to_string()])
        .status()
        .unwrap();
    assert!(term.success());
    let status = h.run.wait().unwrap();
    let left = left_running(&[h.program, h.child, h.escaped]);
    assert_eq!(status.code(), Some(128 + 15), "{status:?}");
    assert!(
        left.is_empty(),
        "left running: {left:?} (program {}, child {}, escaped grandchild {})",
        h.program,
        h.child,
        h.escaped
    );
    assert!(!folder.exists(), "{} left behind", folder.display());
    assert!(!d.join("v.txt").exists());
}

#[test]
fn after_a_kill_9_clean_reclaims_the_programs_folder() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut h = start_hanging(d, tmp.path());
    let folder = h.points.parent().unwrap().to_owned();
    h.run.kill().unwrap();
    h.run.wait().unwrap();
    // Nothing ran: the folder is left, and its owner is gone.
    assert!(folder.exists());
    let _ = left_running(&[h.program, h.child, h.escaped]);
    let clean = |remove: bool| {
        let mut args = vec!["clean"];
        if remove {
            args.push("--remove");
        }
        args.push(d.to_str().unwrap());
        let o = Command::new(env!("CARGO_BIN_EXE_pointsight"))
            .args(&args)
            .env("POINTSIGHT_DATA", "/nonexistent")
            .env("TMPDIR", tmp.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let listed = clean(false);
    assert!(
        listed.contains(&format!("{} kind=program", folder.display()))
            && listed.contains("state=stale"),
        "{listed}"
    );
    assert!(folder.exists(), "a dry run removes nothing");
    let removed = clean(true);
    assert!(removed.contains("state=removed"), "{removed}");
    // And a run after a kill -9 reclaims it first: a folder of a dead process of this host.
    let dead = folder.with_file_name(format!(
        ".pointsight.program-{}-{}-0",
        cloud::scratch::host(),
        dead_pid()
    ));
    std::fs::create_dir(&dead).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(["visible", "--dataset", "sphere-20000", "--method", "hpr"])
        .args(["--out", d.join("after.txt").to_str().unwrap()])
        .env("POINTSIGHT_DATA", "/nonexistent")
        .env("TMPDIR", tmp.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !dead.exists(),
        "the next run reclaims a killed run's folder"
    );
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        0,
        "the temporary folder holds nothing of pointsight's"
    );
}

#[test]
fn views_answered_before_a_program_dies_are_written_and_counted() {
    // Answers views 0..8, dies at view 9 (and again at every later view, restarted).
    let script = r#"
import sys, json
for line in sys.stdin:
    k = json.loads(line)["view"]
    if k >= 9:
        sys.stderr.write("dying at view %d\n" % k)
        sys.exit(3)
    print(json.dumps({"visible": [k], "seconds": 0.0}), flush=True)
"#;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    method2(d, "dies-at-9", script, "");
    let out = d.join("views");
    let run = visible(d, "dies-at-9", "all", &out);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        err.contains("view 9: external method dies-at-9: view 9: the program exited")
            && err.contains("dying at view 9"),
        "{err}"
    );
    assert!(
        err.contains("9 of the ") && err.contains("views were answered and written to"),
        "{err}"
    );
    let n = std::fs::read_dir(&out).map_or(0, |entries| {
        entries
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("view-"))
            .count()
    });
    assert!(err.contains("views 9, 10"), "{err}");
    assert_eq!(n, 9, "the answered views are written: {err}");
    // With the metadata that lists them (the folder is pointsight's).
    assert!(out.join("metadata.json").is_file());
    for k in 0..9 {
        assert_eq!(
            std::fs::read_to_string(out.join(format!("view-{k}.txt"))).unwrap(),
            format!("{k}\n")
        );
    }
    assert!(!out.join("view-9.txt").exists());
}

/// `--methods-dir DIR` adds DIR's methods to the installed ones (`POINTSIGHT_METHODS` here),
/// `--no-installed-methods` leaves those out, and a name both folders use is an error naming
/// both.
#[test]
fn methods_dir_adds_to_the_installed_methods() {
    let installed = tempfile::tempdir().unwrap();
    let mine = tempfile::tempdir().unwrap();
    let answer = ANSWER.replace("ANSWER", "{'visible': [0], 'seconds': 0}");
    method(installed.path(), "installed-one", &answer, "");
    method(mine.path(), "my-own", &answer, "");
    let mine_dir = mine.path().to_str().unwrap();
    let listing = |extra: &[&str]| {
        let mut args = vec!["methods", "--methods-dir", mine_dir];
        args.extend(extra);
        let out = pointsight(installed.path(), &args);
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, text, err) = listing(&[]);
    assert!(ok, "{err}");
    assert!(
        text.contains("installed-one") && text.contains("my-own") && text.contains("hpr"),
        "{text}"
    );
    let (ok, text, err) = listing(&["--no-installed-methods"]);
    assert!(ok, "{err}");
    assert!(
        !text.contains("installed-one") && text.contains("my-own") && text.contains("hpr"),
        "{text}"
    );
    method(mine.path(), "installed-one", &answer, "");
    let (ok, _, err) = listing(&[]);
    assert!(!ok);
    assert!(
        err.contains("method installed-one of")
            && err.contains(mine_dir)
            && err.contains(installed.path().to_str().unwrap())
            && err.contains("--no-installed-methods"),
        "{err}"
    );
}
