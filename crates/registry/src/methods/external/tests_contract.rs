//! External programs held to account: their process group ended on timeout, on
//! error and when the caller is done (no child left running, nor a grandchild that left the
//! group), their stderr kept as a bounded
//! tail in memory and quoted, one answer line per request, `seconds` a number from 0 to the
//! timeout, and `visible_file` confined to the program's own scratch folder.

use std::path::Path;
use std::time::{Duration, Instant};

use cloud::glam::Vec3;

use super::tests::{card_in, folder, run_cell, small_cloud, test_camera};
use crate::kernel;
use crate::lod::LodInput;
use crate::params::Params;

/// Whether process `pid` runs (a zombie does not), waiting up to 5 s for it to end.
pub(super) fn still_running(pid: u32) -> bool {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let running = std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
            stat.rsplit(')')
                .next()
                .map(str::trim_start)
                .is_some_and(|s| !s.starts_with('Z'))
        });
        if !running || Instant::now() > deadline {
            return running;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The process id a program wrote to `file` in its folder.
fn pid_in(dir: &Path, file: &str) -> u32 {
    std::fs::read_to_string(dir.join(file))
        .unwrap_or_else(|e| panic!("{file}: {e}"))
        .trim()
        .parse()
        .unwrap()
}

/// Starts a child (`sleep 60`) that writes nothing, notes its id in `child`; starts a
/// grandchild that leaves the process group (a double fork with `setsid`, then `sleep 60`),
/// notes its id in `escaped`; then does `then` for each request.
fn with_a_child(then: &str) -> String {
    format!(
        "import sys, json, os, subprocess, time\n\
         p = subprocess.Popen(['sleep', '60'], stdin=subprocess.DEVNULL, \
         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)\n\
         open('child', 'w').write(str(p.pid))\n\
         first = os.fork()\n\
         if first == 0:\n    \
             os.setsid()\n    \
             if os.fork() == 0:\n        \
                 null = os.open(os.devnull, os.O_RDWR)\n        \
                 for fd in (0, 1, 2):\n            os.dup2(null, fd)\n        \
                 open('escaped.tmp', 'w').write(str(os.getpid()))\n        \
                 os.rename('escaped.tmp', 'escaped')\n        \
                 os.execvp('sleep', ['sleep', '60'])\n    \
             os._exit(0)\n\
         os.waitpid(first, 0)\n\
         while not os.path.exists('escaped'):\n    time.sleep(0.01)\n\
         for line in sys.stdin:\n    {then}\n"
    )
}

#[test]
fn a_program_is_ended_with_its_children_on_timeout_error_and_exit() {
    let cloud = small_cloud();
    let views = kernel::View::all(&[test_camera()]);
    for (name, manifest_extra, then, needle) in [
        (
            "timeout",
            "timeout_seconds = 1\n",
            "import time; time.sleep(60)",
            "no answer within 1.0 s",
        ),
        ("error", "", "print('not json', flush=True)", "not JSON"),
        (
            "exit",
            "",
            "print(json.dumps({'visible': [0], 'seconds': 0}), flush=True)",
            "",
        ),
    ] {
        let dir = folder(
            &format!("protocol = 2\ncommand = [\"python3\", \"m.py\"]\n{manifest_extra}"),
            &with_a_child(then),
        );
        let (prepared, answers) = run_cell(&dir, &cloud, &views);
        prepared.unwrap();
        match &answers[0].1 {
            Ok(_) => assert!(needle.is_empty(), "{name}: answered"),
            Err(e) => assert!(!needle.is_empty() && e.contains(needle), "{name}: {e}"),
        }
        for (who, file) in [("child", "child"), ("escaped grandchild", "escaped")] {
            let pid = pid_in(dir.path(), file);
            let alive = still_running(pid);
            if alive {
                // Not left behind by the test either.
                let _ = std::process::Command::new("kill")
                    .arg(pid.to_string())
                    .status();
            }
            assert!(!alive, "{name}: the program's {who} {pid} outlived it");
        }
    }
}

#[test]
fn stderr_is_a_bounded_tail_in_memory_quoted_in_the_error() {
    // A megabyte of stderr, then its last line; then it looks for files beside its points
    // (a log there would be the stderr on disk) and says what it found as its error.
    let script = r#"
import sys, json, os
args = sys.argv[1:]
scratch = os.path.dirname(args[args.index("--points") + 1])
for k in range(20000):
    sys.stderr.write("noise line %d %s\n" % (k, "x" * 40))
sys.stderr.write("LAST-WORDS before the error\n")
sys.stderr.flush()
for line in sys.stdin:
    others = sum(os.path.getsize(os.path.join(scratch, f)) for f in os.listdir(scratch)
                 if f != "points.ply")
    print(json.dumps({"error": "other files: %d bytes" % others}), flush=True)
"#;
    let dir = folder("protocol = 2\ncommand = [\"python3\", \"m.py\"]\n", script);
    let views = kernel::View::all(&[test_camera()]);
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    let err = answers[0].1.as_ref().unwrap_err();
    assert!(
        err.contains("other files: 0 bytes"),
        "stderr on disk: {err}"
    );
    assert!(err.contains("LAST-WORDS before the error"), "{err}");
    assert!(err.contains("the last 64 KiB kept"), "{err}");
    assert!(!err.contains("noise line 0 "), "{err}");
    assert!(!err.contains(".log"), "no log named: {err}");
    assert!(err.len() < 4000, "{} bytes", err.len());
}

#[test]
fn a_second_answer_line_is_an_error_not_the_next_views_answer() {
    // Answers each view with its index; view 1 twice (in one write).
    let script = r#"
import sys, json
for line in sys.stdin:
    k = json.loads(line)["view"]
    a = json.dumps({"visible": [k], "seconds": 0.0}) + "\n"
    sys.stdout.write(a + a if k == 1 else a)
    sys.stdout.flush()
"#;
    let dir = folder("protocol = 2\ncommand = [\"python3\", \"m.py\"]\n", script);
    let camera = test_camera();
    let views = kernel::View::all(&[camera, camera, camera, camera]);
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    let visible = |k: usize| answers[k].1.as_ref().map(|a| a.output.visible.clone());
    assert_eq!(visible(0), Ok(vec![0]));
    let err = visible(1).unwrap_err();
    assert!(
        err.contains("view 1: more than one answer line to view 1")
            && err.contains("external method"),
        "{err}"
    );
    // A fresh program answers the next views.
    assert_eq!(visible(2), Ok(vec![2]));
    assert_eq!(visible(3), Ok(vec![3]));
}

#[test]
fn seconds_must_be_a_number_from_zero_to_the_timeout() {
    let views = kernel::View::all(&[test_camera()]);
    let answer = |seconds: &str, built: &str| {
        format!(
            "import sys, json\n{built}\nfor line in sys.stdin:\n    \
             print('{{\"visible\": [1], \"seconds\": {seconds}}}', flush=True)\n"
        )
    };
    let manifest = "protocol = 2\ncommand = [\"python3\", \"m.py\"]\ntimeout_seconds = 60\n";
    for (seconds, built, needle) in [
        (
            "-5",
            "",
            "\"seconds\" -5 is not a number >= 0 and at most its timeout of 60 s",
        ),
        ("1e308", "", "\"seconds\" 1e+308 is not"),
        ("\"fast\"", "", "\"seconds\" \"fast\" is not"),
        (
            "0.5",
            "print('{\"built\": true, \"seconds\": 1e308}', flush=True)",
            "its built line's \"seconds\" 1e+308 is not",
        ),
    ] {
        let dir = folder(manifest, &answer(seconds, built));
        let (_, answers) = run_cell(&dir, &small_cloud(), &views);
        let err = answers[0].1.as_ref().unwrap_err();
        assert!(
            err.contains(needle) && err.contains("external method"),
            "{seconds}: {err}"
        );
    }
    let dir = folder(manifest, &answer("59.5", ""));
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    assert_eq!(answers[0].1.as_ref().unwrap().timing.median, 59.5);

    // The LOD form's answers too.
    let script = r#"
import sys, json
print(json.dumps({"built": True, "seconds": 0.5, "nodes": 1, "bytes": 8}), flush=True)
for line in sys.stdin:
    print(json.dumps({"visible": [0], "radius": 1.0, "seconds": -5}), flush=True)
"#;
    let dir = folder(
        "protocol = 2\nkind = \"lod\"\ncommand = [\"python3\", \"m.py\"]\n",
        script,
    );
    let m = card_in(dir.path());
    let cloud = small_cloud();
    let n = cloud.len();
    let (normals, albedo, uvs) = (
        vec![Vec3::Z; n],
        vec![Vec3::ONE; n],
        vec![cloud::glam::Vec2::ZERO; n],
    );
    let input = LodInput {
        cloud: &cloud,
        normals: &normals,
        albedo: &albedo,
        uvs: &uvs,
        texture: None,
        radius: 0.1,
        seed: 0,
    };
    let crate::card::Kind::Lod(lod) = m.kind else {
        panic!("an LOD card")
    };
    let built = lod.build(&input).unwrap();
    let (args, _) = m.lod_args(&Params::default()).unwrap();
    let mut sel = built.selector(&input, &args).unwrap();
    let err = sel.select_at(0, &test_camera()).unwrap_err().to_string();
    assert!(err.contains("\"seconds\" -5 is not a number >= 0"), "{err}");
}

#[test]
fn visible_file_is_confined_to_the_programs_scratch_folder() {
    // Answers view K with the path its request K asks for: a file in its scratch folder (by
    // name, by absolute path, in its TMPDIR), then paths elsewhere.
    let script = r#"
import sys, json, os, tempfile
args = sys.argv[1:]
scratch = os.path.dirname(args[args.index("--points") + 1])
open(os.path.join(scratch, "mine.txt"), "w").write("3 1\n")
t = tempfile.NamedTemporaryFile("w", delete=False)
t.write("2\n"); t.close()
if not os.path.lexists(os.path.join(scratch, "link.txt")):
    os.symlink("/etc/passwd", os.path.join(scratch, "link.txt"))
open("outside.txt", "w").write("root:x:0:0\n")
paths = ["mine.txt", os.path.join(scratch, "mine.txt"), t.name, "/etc/passwd", "link.txt",
         os.path.relpath("/etc/passwd", scratch), os.path.abspath("outside.txt")]
for line in sys.stdin:
    k = json.loads(line)["view"]
    print(json.dumps({"visible_file": paths[k], "seconds": 0}), flush=True)
"#;
    let dir = folder("protocol = 2\ncommand = [\"python3\", \"m.py\"]\n", script);
    let camera = test_camera();
    let views = kernel::View::all(&[camera; 7]);
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    let visible = |k: usize| answers[k].1.as_ref().map(|a| a.output.visible.clone());
    assert_eq!(visible(0), Ok(vec![1, 3]));
    assert_eq!(visible(1), Ok(vec![1, 3]));
    assert_eq!(visible(2), Ok(vec![2]), "its TMPDIR is its scratch folder");
    for k in 3..7 {
        let err = visible(k).unwrap_err();
        assert!(
            err.contains("is outside its scratch folder") && err.contains("refused unread"),
            "view {k}: {err}"
        );
        assert!(!err.contains("root:"), "view {k} quotes the file: {err}");
    }
}

#[test]
fn a_program_that_closes_its_output_and_lingers_is_not_waited_for() {
    let script = "import sys, os, time\nsys.stdin.readline()\nos.close(1)\ntime.sleep(60)\n";
    let dir = folder("protocol = 2\ncommand = [\"python3\", \"m.py\"]\n", script);
    let views = kernel::View::all(&[test_camera()]);
    let start = Instant::now();
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    let err = answers[0].1.as_ref().unwrap_err();
    assert!(err.contains("closed its output without an answer"), "{err}");
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{:?}",
        start.elapsed()
    );
    // And one that exits says how.
    let dir = folder(
        "protocol = 2\ncommand = [\"python3\", \"m.py\"]\n",
        "import sys\nsys.stdin.readline()\nsys.exit(3)\n",
    );
    let (_, answers) = run_cell(&dir, &small_cloud(), &views);
    let err = answers[0].1.as_ref().unwrap_err();
    assert!(
        err.contains("the program exited (exit status: 3) without an answer"),
        "{err}"
    );
}
