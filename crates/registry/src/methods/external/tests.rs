//! The external protocol against small Python programs: bounded answers, versions, the end of
//! input and the kill, the visibility form's optional build line, the LOD form.

use std::io::BufReader;
use std::time::{Duration, Instant};

use cloud::Camera;
use cloud::glam::Vec3;

use super::session::{EXIT_GRACE, read_line_bounded};
use super::{ExternalMethod, Kind, answer_limit, card};
use crate::card::Card;
use crate::error::Result;
use crate::kernel;
use crate::lod::{LodInput, LodSize};
use crate::params::Params;
use crate::setting::Setting;
use crate::visibility::Input;

/// The card of the external method in `folder` (leaked, as registered ones are).
pub(super) fn card_in(folder: &std::path::Path) -> &'static Card {
    card(Box::leak(Box::new(ExternalMethod::load(folder).unwrap())))
}

#[test]
fn a_bounded_line_is_read_and_a_flood_refused_unread() {
    let mut ok = std::io::Cursor::new(b"abc\ndef".to_vec());
    assert_eq!(
        read_line_bounded(&mut ok, 3).unwrap().as_deref(),
        Some("abc")
    );
    assert_eq!(
        read_line_bounded(&mut ok, 3).unwrap().as_deref(),
        Some("def")
    );
    assert_eq!(read_line_bounded(&mut ok, 3).unwrap(), None);
    // A reader of endless bytes without a newline: refused after the limit.
    let mut flood = BufReader::new(std::io::repeat(b'1'));
    let err = read_line_bounded(&mut flood, 1 << 16).unwrap_err();
    assert!(err.contains("longer than 65536 bytes"), "{err}");
}

/// A 64 × 48 pinhole camera 50 units up the z axis, looking at the origin.
pub(super) fn test_camera() -> Camera {
    Camera::new(
        cloud::glam::DVec3::new(0.0, 0.0, 50.0),
        cloud::glam::DVec3::ZERO,
        cloud::glam::DVec3::Y,
        60.0,
        64,
        48,
    )
    .unwrap()
}

pub(super) fn folder(manifest: &str, script: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("method.toml"), manifest).unwrap();
    std::fs::write(dir.path().join("m.py"), script).unwrap();
    dir
}

#[test]
fn the_version_is_run_once_and_peer_of_read() {
    let dir = folder(
        "protocol = 2\ncommand = [\"python3\", \"m.py\"]\npeer_of = \"voxel\"\n\
         version = [\"python3\", \"m.py\"]\n",
        "import os\nprint('tool', len(open('count', 'a+').name))\nopen('count', 'a').write('x')\n",
    );
    let m = card_in(dir.path());
    assert_eq!(m.peer_of, Some("voxel"));
    assert_eq!(m.version().as_deref(), Some("tool 5"));
    assert_eq!(m.version().as_deref(), Some("tool 5"));
    // Run once: the program appended one mark.
    assert_eq!(
        std::fs::read_to_string(dir.path().join("count")).unwrap(),
        "x"
    );
    let none = folder("protocol = 1\ncommand = [\"true\"]\n", "");
    let m = card_in(none.path());
    assert_eq!((m.version(), m.peer_of), (None, None));
    let failing = folder(
        "protocol = 1\ncommand = [\"true\"]\nversion = [\"false\"]\n",
        "",
    );
    let m = card_in(failing.path());
    assert!(
        m.version()
            .unwrap()
            .starts_with("unknown (it printed nothing")
    );
}

#[test]
fn a_passed_check_runs_once_and_a_failed_one_again() {
    // The check appends a mark and passes once the file `ok` exists.
    let dir = folder(
        "protocol = 1\ncommand = [\"true\"]\n\
         check = [\"sh\", \"-c\", \"printf x >> count; test -e ok\"]\n",
        "",
    );
    let m = ExternalMethod::load(dir.path()).unwrap();
    let marks = || std::fs::read_to_string(dir.path().join("count")).unwrap();
    assert!(m.check().unwrap_err().contains("not installed"));
    assert!(m.check().is_err());
    assert_eq!(marks(), "xx", "a failed check is run again");
    std::fs::write(dir.path().join("ok"), "").unwrap();
    assert!(m.check().is_ok());
    assert!(m.check().is_ok());
    assert!(m.check().is_ok());
    assert_eq!(marks(), "xxx", "a passed check is not run again");
}

#[test]
fn made_for_is_read_with_its_defaults_and_a_bad_value_refused() {
    use crate::card::Metric;
    let made = |extra: &str| {
        let dir = folder(&format!("protocol = 2\ncommand = [\"true\"]\n{extra}"), "");
        ExternalMethod::load(dir.path()).map(|m| card(Box::leak(Box::new(m))).made_for)
    };
    assert_eq!(made("").unwrap(), Metric::Points);
    assert_eq!(made("kind = \"lod\"\n").unwrap(), Metric::Pixels);
    assert_eq!(made("made_for = \"pixels\"\n").unwrap(), Metric::Pixels);
    assert_eq!(made("made_for = \"points\"\n").unwrap(), Metric::Points);
    let err = made("made_for = \"voxels\"\n").unwrap_err().to_string();
    assert!(err.contains("made_for = \"voxels\""), "{err}");
}

#[test]
fn an_exactness_claim_is_read_and_absent_means_none() {
    let exact = |extra: &str| {
        let dir = folder(&format!("protocol = 2\ncommand = [\"true\"]\n{extra}"), "");
        ExternalMethod::load(dir.path()).map(|m| card(Box::leak(Box::new(m))).exact)
    };
    assert!(!exact("").unwrap());
    assert!(exact("exact = true\n").unwrap());
    assert!(exact("exact = \"yes\"\n").is_err());
    // Of the built-in cards, exact HPR claims it; the approximations do not.
    assert!(crate::builtin_card("hpr").unwrap().exact);
    assert!(!crate::builtin_card("hpr-approx").unwrap().exact);
}

/// End of input means exit: a program the caller is done with has its input closed and
/// time to clean up (its temporary files), and one that does not exit is killed after
/// [`EXIT_GRACE`].
/// Twenty points, not coplanar.
pub(super) fn small_cloud() -> cloud::PointCloud {
    cloud::PointCloud {
        positions: (0..20)
            .map(|i| cloud::glam::DVec3::new(f64::from(i), f64::from(i * i % 7), 1.0))
            .collect(),
        ..Default::default()
    }
}

/// The external method in `dir` at its default setting over `views`, through the kernel.
pub(super) fn run_cell(
    dir: &tempfile::TempDir,
    cloud: &cloud::PointCloud,
    views: &[kernel::View],
) -> (Result<kernel::Preparation>, kernel::Answers) {
    let m = card_in(dir.path());
    let input = Input { cloud, mesh: None };
    let cell = kernel::Cell::new(m, &Setting::parse(""), views, 1);
    kernel::collect(&cell, input)
}

#[test]
fn a_finished_program_gets_end_of_input_then_a_kill() {
    let script = |after: &str| {
        format!(
            "import sys, json, os, time\nopen('alive', 'w').write('x')\n\
             for line in sys.stdin:\n    json.loads(line)\n    \
             print(json.dumps({{'visible': [0], 'seconds': 0.0}}), flush=True)\n{after}\n"
        )
    };
    let manifest = "protocol = 2\ncommand = [\"python3\", \"m.py\"]\n";
    let cloud = small_cloud();
    let camera = test_camera();
    let views = kernel::View::all(&[camera, camera]);
    let run = |dir: &tempfile::TempDir| {
        let start = Instant::now();
        let (prepared, answers) = run_cell(dir, &cloud, &views);
        prepared.unwrap();
        assert!(answers.iter().all(|(_, a)| a.is_ok()), "{answers:?}");
        start.elapsed()
    };
    // It takes half a second to remove its file at the end of its input; the caller waits.
    let tidy = folder(manifest, &script("time.sleep(0.5)\nos.remove('alive')"));
    run(&tidy);
    assert!(
        !tidy.path().join("alive").exists(),
        "the program was killed before it cleaned up"
    );
    // One that lingers is killed once the grace is over (not after its 60 s).
    let linger = folder(manifest, &script("time.sleep(60)"));
    let took = run(&linger);
    assert!(linger.path().join("alive").exists());
    assert!(
        took >= EXIT_GRACE && took < EXIT_GRACE + Duration::from_secs(20),
        "{took:?}"
    );
}

#[test]
fn a_built_line_before_the_first_answer_is_its_build_time() {
    // One program says how long its set-up took, once, before its first answer; another
    // says nothing; a third sends a `built` line in place of an answer later (an error).
    let script = |first: &str, later: &str| {
        format!(
            "import sys, json\n{first}\nfor k, line in enumerate(sys.stdin):\n    \
             json.loads(line)\n    {later}\n    \
             print(json.dumps({{'visible': [k], 'seconds': 0.5}}), flush=True)\n"
        )
    };
    let built = "print(json.dumps({'built': True, 'seconds': 1.25}), flush=True)";
    let manifest = "protocol = 2\ncommand = [\"python3\", \"m.py\"]\n";
    let cloud = small_cloud();
    let camera = test_camera();
    let views = kernel::View::all(&[camera, camera, camera]);
    let run = |dir: &tempfile::TempDir| run_cell(dir, &cloud, &views);
    let (prep, answers) = run(&folder(manifest, &script(built, "pass")));
    assert_eq!(prep.unwrap().reported_seconds, Some(1.25));
    let visible: Vec<Vec<u32>> = answers
        .iter()
        .map(|(_, a)| a.as_ref().unwrap().output.visible.clone())
        .collect();
    assert_eq!(
        visible,
        [vec![0], vec![1], vec![2]],
        "the built line is no answer"
    );
    assert!(
        answers
            .iter()
            .all(|(_, a)| a.as_ref().unwrap().timing.median == 0.5)
    );
    let (prep, answers) = run(&folder(manifest, &script("", "pass")));
    assert_eq!(prep.unwrap().reported_seconds, None);
    assert!(answers.iter().all(|(_, a)| a.is_ok()));
    // A `built` line where view 1's answer belongs is not an answer.
    let (_, answers) = run(&folder(
        manifest,
        &script(
            built,
            "if k == 1: print(json.dumps({'built': True, 'seconds': 2}), flush=True); continue",
        ),
    ));
    assert!(answers[0].1.is_ok(), "{:?}", answers[0].1);
    let err = answers[1].1.as_ref().unwrap_err();
    assert!(err.contains("neither \"visible\""), "{err}");
    // A build time that is not a number >= 0 is refused, not recorded.
    let lying = "print(json.dumps({'built': True, 'seconds': -1}), flush=True)";
    let (_, answers) = run(&folder(manifest, &script(lying, "pass")));
    let err = answers[0].1.as_ref().unwrap_err();
    assert!(err.contains("not a number >= 0"), "{err}");
}

#[test]
fn the_lod_form_builds_once_and_selects_per_view() {
    let script = r#"
import sys, json
args = sys.argv[1:]
assert "--lod" in args and args[args.index("--protocol") + 1] == "2", args
header = open(args[args.index("--points") + 1], "rb").read(500).split(b"end_header")[0]
assert b"nx" in header and b"red" in header, header
print(json.dumps({"built": True, "seconds": 0.125, "nodes": 7, "bytes": 64}), flush=True)
for line in sys.stdin:
    req = json.loads(line)
    k = int(req["params"]["keep"])
    print(json.dumps({"visible": list(range(k))[::-1], "radius": [0.5 + i for i in range(k)][::-1],
                      "seconds": 0.25 + req["view"]}), flush=True)
"#;
    let dir = folder(
        "protocol = 2\nkind = \"lod\"\ncommand = [\"python3\", \"m.py\"]\n\
         peer_of = \"lod\"\n[params.keep]\ndefault = \"2\"\nhelp = \"points kept\"\n",
        script,
    );
    let m = card_in(dir.path());
    assert!(m.is_lod());
    assert_eq!(ExternalMethod::load(dir.path()).unwrap().kind(), Kind::Lod);
    let positions: Vec<cloud::glam::DVec3> = (0..20)
        .map(|i| cloud::glam::DVec3::new(f64::from(i), f64::from(i * i % 7), 1.0))
        .collect();
    let n = positions.len();
    let cloud = cloud::PointCloud {
        positions,
        colors: Some(vec![[10, 20, 30]; n]),
        ..Default::default()
    };
    let normals = vec![Vec3::Z; n];
    let albedo = vec![Vec3::ONE; n];
    let uvs = vec![cloud::glam::Vec2::ZERO; n];
    let texture = srn::texture::Texture::new(1, 1, vec![[0, 0, 0]]).unwrap();
    let input = LodInput {
        cloud: &cloud,
        normals: &normals,
        albedo: &albedo,
        uvs: &uvs,
        texture: Some(&texture),
        radius: 0.1,
        seed: 0,
    };
    let crate::card::Kind::Lod(lod) = m.kind else {
        panic!("an LOD card")
    };
    let built = lod.build(&input).unwrap();
    assert_eq!(built.reported_build_seconds(), Some(0.125));
    assert_eq!(
        built.size(),
        LodSize {
            nodes: 7,
            bytes: 64.0
        }
    );
    let (args, ran) = m.lod_args(&Params::parse(&["keep=3"]).unwrap()).unwrap();
    assert_eq!(ran.label(), "keep=3");
    let mut sel = built.selector(&input, &args).unwrap();
    let camera = test_camera();
    sel.select_at(4, &camera).unwrap();
    assert_eq!(sel.reported_seconds(), Some(4.25));
    let splats = sel.splats();
    // Sorted by index, each with its own radius (the answer's order was reversed).
    let radii: Vec<f32> = splats.iter().map(|s| s.radius).collect();
    assert_eq!(radii, vec![0.5, 1.5, 2.5]);
    assert_eq!(splats[1].center, cloud.positions[1]);
    // A visibility caller is refused.
    let err = m.setup(&Params::default()).err().unwrap();
    assert!(err.to_string().contains("level-of-detail"), "{err}");
    // Through the kernel: the program's own seconds are the build's and the selections'
    // timings, and each selection is told its view's index (not a call count).
    let settings = [Setting::parse("keep=2")];
    let views = [
        kernel::View { index: 7, camera },
        kernel::View { index: 2, camera },
    ];
    let cell = kernel::LodCell {
        method: m,
        settings: &settings,
        views: &views,
        repeats: 3,
        build_repeats: 1,
    };
    let mut got = Vec::new();
    let built = kernel::run_lod(&cell, &input, |k, v, sel| {
        got.push((
            k,
            v,
            sel.map(|s| (s.splats.len(), s.timing.median, s.timing.samples))
                .map_err(|e| e.to_string()),
        ));
    })
    .unwrap();
    assert_eq!(built.timing.median, 0.125);
    assert_eq!(
        got,
        vec![(0, 0, Ok((2, 7.25, 3))), (0, 1, Ok((2, 2.25, 3)))]
    );
}

#[test]
fn the_limit_grows_with_the_cloud() {
    assert_eq!(answer_limit(0), 1 << 20);
    assert_eq!(answer_limit(10), (1 << 20) + 480);
    assert_eq!(answer_limit(usize::MAX), u64::MAX);
}
