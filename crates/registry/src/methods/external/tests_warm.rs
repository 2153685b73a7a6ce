//! Protocol 3 against small Python programs: one program per cloud serving every setting, a
//! new one for new points, none left once the catalogue ends them; answers that do not echo
//! their request's id (wrong, missing, twice, late) are errors naming both ids; the cold call
//! and a setting's own build reported apart from the views' seconds.

use super::tests::{card_in, folder, small_cloud, test_camera};
use super::tests_contract::still_running;
use crate::card::Card;
use crate::kernel;
use crate::setting::Setting;
use crate::visibility::Input;

const MANIFEST: &str = "protocol = 3\ncommand = [\"python3\", \"m.py\"]\n\
                        [params.k]\ndefault = \"0\"\nhelp = \"the index answered\"\n";

/// Answers each request with point `k` of its setting and its own process id (as `seconds`
/// is reported, the pid goes into a file named by the request's id).
const ECHO: &str = "import sys, json, os\n\
for line in sys.stdin:\n    \
r = json.loads(line)\n    \
open('pid-%d' % r['id'], 'w').write(str(os.getpid()))\n    \
print(json.dumps({'id': r['id'], 'visible': [int(r['params']['k'])], 'seconds': 0.25}), flush=True)\n";

/// One cell of `card` at `setting` over two views of `cloud`.
fn cell(
    card: &Card,
    setting: &str,
    cloud: &cloud::PointCloud,
) -> (crate::error::Result<kernel::Preparation>, kernel::Answers) {
    let camera = test_camera();
    let views = kernel::View::all(&[camera, camera]);
    let cell = kernel::Cell::new(card, &Setting::parse(setting), &views, 1);
    kernel::collect(&cell, Input { cloud, mesh: None })
}

/// Ends `card`'s warm program.
fn end(card: &Card) {
    if let crate::card::Kind::Visibility(m) = card.kind {
        m.end();
    }
}

fn pid(dir: &tempfile::TempDir, id: u64) -> u32 {
    std::fs::read_to_string(dir.path().join(format!("pid-{id}")))
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn one_program_serves_every_setting_of_a_cloud_and_a_new_cloud_gets_a_new_one() {
    let dir = folder(MANIFEST, ECHO);
    let card = card_in(dir.path());
    let cloud = small_cloud();
    let mut catalogue = crate::Catalogue::builtin();
    catalogue.add(card).unwrap();
    let visible = |answers: &kernel::Answers| -> Vec<Vec<u32>> {
        answers
            .iter()
            .map(|(_, a)| a.as_ref().unwrap().output.visible.clone())
            .collect()
    };
    let (first, answers) = cell(card, "k=3", &cloud);
    assert_eq!(visible(&answers), [vec![3], vec![3]]);
    let first = first.unwrap();
    assert!(
        first.cold_call_seconds.is_some_and(|s| s > 0.0),
        "the setting that started it has its cold call: {first:?}"
    );
    let (second, answers) = cell(card, "k=5", &cloud);
    assert_eq!(
        visible(&answers),
        [vec![5], vec![5]],
        "the setting per request"
    );
    assert_eq!(
        second.unwrap().cold_call_seconds,
        None,
        "a warm program has no cold call"
    );
    // Requests 1 to 4 went to one process; the views' times are the program's own.
    let warm = pid(&dir, 1);
    assert!((2..=4).all(|id| pid(&dir, id) == warm));
    assert!(
        answers
            .iter()
            .all(|(_, a)| a.as_ref().unwrap().timing.median == 0.25)
    );
    // New points: the old program ends and a new one starts, its ids from 1 again.
    let mut other = small_cloud();
    other.positions[0].z = 2.0;
    std::fs::remove_file(dir.path().join("pid-1")).unwrap();
    let (third, answers) = cell(card, "k=1", &other);
    assert_eq!(visible(&answers), [vec![1], vec![1]]);
    assert!(third.unwrap().cold_call_seconds.is_some());
    let fresh = pid(&dir, 1);
    assert_ne!(fresh, warm);
    assert!(!still_running(warm), "the old cloud's program ended");
    assert!(
        still_running(fresh),
        "the warm program waits for the next setting"
    );
    catalogue.end_programs();
    assert!(!still_running(fresh), "the catalogue ended it");
}

#[test]
fn answers_that_do_not_echo_their_request_are_errors_naming_both_ids() {
    let cloud = small_cloud();
    let answer = "print(json.dumps({'id': %s, 'visible': [0], 'seconds': 0.0}), flush=True)";
    let program = |body: &str| {
        format!(
            "import sys, json, threading, time\nfor line in sys.stdin:\n    \
             r = json.loads(line)\n    i = r['id']\n{body}\n"
        )
    };
    let indent = |s: &str| {
        s.lines()
            .map(|l| format!("    {l}"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    for (name, body, needle) in [
        (
            "wrong id",
            indent(&answer.replace("%s", "i + 1")),
            "the answer carries id 2 while request 1 is the one outstanding",
        ),
        (
            "no id",
            indent("print(json.dumps({'visible': [0], 'seconds': 0.0}), flush=True)"),
            "the answer has no \"id\" (a protocol 3 answer echoes its request's id, 1 here)",
        ),
        (
            "twice",
            indent(&format!(
                "{}\n{}",
                answer.replace("%s", "i"),
                answer.replace("%s", "i")
            )),
            "request 1",
        ),
        (
            // Request 1's second answer comes after request 2 was sent, before its answer.
            "late",
            indent(&format!(
                "if i == 1:\n    {}\n    threading.Timer(0.3, lambda: {}).start()\nelse:\n    \
                 time.sleep(1.0)\n    {}",
                answer.replace("%s", "i"),
                answer.replace("%s", "1"),
                answer.replace("%s", "i"),
            )),
            "the answer carries id 1 while request 2 is the one outstanding",
        ),
    ] {
        let dir = folder(MANIFEST, &program(&body));
        let card = card_in(dir.path());
        let (_, answers) = cell(card, "", &cloud);
        let errors: Vec<&String> = answers
            .iter()
            .filter_map(|(_, a)| a.as_ref().err())
            .collect();
        assert!(
            errors.iter().any(|e| e.contains(needle)),
            "{name}: {answers:?}"
        );
        // Never a shifted result: every answer taken is its own request's.
        for (_, a) in &answers {
            if let Ok(a) = a {
                assert_eq!(a.output.visible, [0], "{name}");
            }
        }
        end(card);
    }
}

#[test]
fn a_settings_own_build_is_its_build_and_the_cold_call_is_apart() {
    // The program builds once per cloud (its built line) and once per setting (the answer's
    // built_seconds, on the setting's first request only).
    let dir = folder(
        MANIFEST,
        "import sys, json\nprint(json.dumps({'built': True, 'seconds': 1.5}), flush=True)\n\
         seen = set()\nfor line in sys.stdin:\n    r = json.loads(line)\n    \
         k = r['params']['k']\n    a = {'id': r['id'], 'visible': [int(k)], 'seconds': 0.5}\n    \
         if k not in seen:\n        seen.add(k)\n        a['built_seconds'] = 0.25\n    \
         print(json.dumps(a), flush=True)\n",
    );
    let card = card_in(dir.path());
    let cloud = small_cloud();
    let (first, _) = cell(card, "k=1", &cloud);
    let first = first.unwrap();
    assert_eq!(
        first.reported_seconds,
        Some(1.75),
        "the cloud's and the setting's"
    );
    let (second, _) = cell(card, "k=2", &cloud);
    assert_eq!(
        second.unwrap().reported_seconds,
        Some(0.25),
        "the setting's alone"
    );
    let (again, _) = cell(card, "k=2", &cloud);
    assert_eq!(again.unwrap().reported_seconds, None, "nothing built");
    end(card);
    // A built_seconds that is not a number of seconds is refused.
    let dir = folder(
        MANIFEST,
        "import sys, json\nfor line in sys.stdin:\n    r = json.loads(line)\n    \
         print(json.dumps({'id': r['id'], 'visible': [0], 'seconds': 0.5, \
         'built_seconds': -2}), flush=True)\n",
    );
    let card = card_in(dir.path());
    let (_, answers) = cell(card, "", &cloud);
    let err = answers[0].1.as_ref().unwrap_err();
    assert!(
        err.contains("\"built_seconds\" -2 is not a number >= 0"),
        "{err}"
    );
    end(card);
}
