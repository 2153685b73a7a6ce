//! One default per method, everywhere: given no setting, `pointsight visible`,
//! `pointsight view` (its choice of each method's setting) and the experiments (the default
//! setting the sweeps resolve to, run through a kernel cell as they run it) run every method at
//! its card's default setting, and give the same visible set on one cloud and view; `view
//! --lod` and the LOD kernel given nothing agree the same way. Python's calls given nothing are
//! compared with `visible`'s in `crates/python/tests` (`test_defaults_are_the_command_lines`).
//! For HPR the default is γ = auto with seed 2007, where `visible` and Python ran γ = 3. An
//! external method's default is its `default` table, else its `[params]` defaults (sent to its
//! program, and printed), the same in every command.

use std::path::Path;
use std::process::Command;

use harness::datasets;
use registry::{Setting, kernel};

const DATASET: &str = "sphere-plane-24000";

/// `pointsight visible` of `method` (with `set`) on view 0: the visible indices and the setting
/// it says it ran.
fn cli_visible(method: &str, set: &[&str]) -> (Vec<u32>, Setting) {
    cli_visible_with(method, set, None)
}

/// [`cli_visible`] with the external methods of `methods` (`--methods-dir`) when given.
fn cli_visible_with(method: &str, set: &[&str], methods: Option<&Path>) -> (Vec<u32>, Setting) {
    let dir = tempfile::tempdir().expect("a folder");
    let out = dir.path().join("visible.txt");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_pointsight"));
    cmd.args([
        "visible",
        "--dataset",
        DATASET,
        "--view",
        "0",
        "--method",
        method,
    ])
    .arg("--out")
    .arg(&out)
    .env("POINTSIGHT_DATA", "/nonexistent/pointsight-data");
    if let Some(dir) = methods {
        cmd.arg("--methods-dir").arg(dir);
    }
    for s in set {
        cmd.args(["--set", s]);
    }
    let o = cmd.output().expect("pointsight runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{method}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    // The setting it ran is the line before the last, which keeps its format.
    let n = lines.len();
    assert!(
        lines[n - 1].starts_with(&format!("method={method} ")),
        "{stdout}"
    );
    let setting = lines[n - 2]
        .strip_prefix("setting=")
        .unwrap_or_else(|| panic!("{method}: no setting line: {stdout}"));
    let visible = std::fs::read_to_string(&out)
        .expect("the indices")
        .lines()
        .map(|l| l.parse().expect("an index"))
        .collect();
    (visible, Setting::parse(setting))
}

/// The visible set of `card` at `setting` on the first of `views`, through one kernel cell as
/// the experiments run it.
fn kernel_visible(
    card: &registry::Card,
    setting: &Setting,
    views: &[kernel::View],
    ds: &datasets::Dataset,
) -> Vec<u32> {
    let (prepared, answers) =
        kernel::collect(&kernel::Cell::new(card, setting, views, 1), ds.input());
    prepared.expect("prepared");
    answers
        .into_iter()
        .next()
        .expect("one view")
        .1
        .expect("an answer")
        .output
        .visible
}

#[test]
fn visible_view_and_the_experiments_run_the_same_default() {
    let ds = datasets::Datasets::default()
        .load(DATASET, Path::new("/nonexistent"))
        .expect("a synthetic dataset");
    let camera = *ds.view(0).expect("view 0");
    let views = [kernel::View { index: 0, camera }];
    let catalogue = registry::Catalogue::builtin();
    let sweeps = catalogue.sweeps(None).expect("the sweeps");
    let mut compared = Vec::new();
    // External methods are compared in the test below.
    for card in catalogue.visibility_cards() {
        let Some(sweep) = sweeps.methods.get(card.name) else {
            continue;
        };
        // The experiments' default setting is the card's.
        let setting = sweep.default_setting().expect("a default setting");
        assert_eq!(
            setting.label(),
            card.default_setting().label(),
            "{}",
            card.name
        );
        let (cli, ran) = cli_visible(card.name, &[]);
        assert!(
            ran.contains(&Setting::parse(&setting.label())),
            "{}: visible ran {}, the default is {}",
            card.name,
            ran.label(),
            setting.label()
        );
        // `view`: its choice for the method, run as it runs it.
        let chosen =
            harness::view::choose(&catalogue, Some(&[card.name.to_owned()]), &[]).expect("chosen");
        assert_eq!(chosen[0].2, setting.label(), "{}", card.name);
        let (page, _) = harness::view::run_method(chosen[0].0, &ds, &chosen[0].1, 0, &camera)
            .expect("view's run");
        // The experiments: one kernel cell at the default setting.
        let experiment = kernel_visible(card, &setting, &views, &ds);
        assert_eq!(cli, page.visible, "{}: visible and view", card.name);
        assert_eq!(
            cli, experiment,
            "{}: visible and the experiments",
            card.name
        );
        assert!(!cli.is_empty(), "{}", card.name);
        compared.push(card.name);
    }
    for name in [
        "hpr",
        "hpr-confidence",
        "hpr-approx",
        "robust",
        "raycast",
        "splat",
        "screenspace",
        "vardensity",
    ] {
        assert!(compared.contains(&name), "{name} compared: {compared:?}");
    }
    // HPR's default is γ = auto, seed 2007; Katz's γ = 3, which `visible` ran given nothing
    // before, is one `--set` away and a different set.
    let (auto, ran) = cli_visible("hpr", &[]);
    assert_eq!(
        ran.label(),
        "gamma=auto;hull=own;kernel=linear;perturb=0;seed=2007"
    );
    let (three, ran) = cli_visible("hpr", &["gamma=3"]);
    assert_eq!(ran.text("gamma").as_deref(), Some("3"));
    assert_ne!(auto, three);
}

#[test]
fn view_lod_and_the_lod_kernel_run_the_same_default() {
    let ds = datasets::Datasets::default()
        .load(DATASET, Path::new("/nonexistent"))
        .expect("a synthetic dataset");
    let views = [kernel::View {
        index: 0,
        camera: *ds.view(0).expect("view 0"),
    }];
    // A texture, which SRN's importance needs.
    let texture =
        srn::texture::Texture::new(2, 2, vec![[10, 200, 30], [0, 0, 0], [255; 3], [90; 3]])
            .expect("a texture");
    let data =
        registry::lod::LodData::prepare(ds.cloud.clone(), Some(texture), 1.0, 7).expect("LOD data");
    let catalogue = registry::Catalogue::builtin();
    let sweeps = catalogue.sweeps(None).expect("the sweeps");
    for card in catalogue.lod_cards() {
        let default = card.default_setting();
        assert_eq!(
            sweeps.methods[card.name].default_setting(),
            Some(default.clone()),
            "{}",
            card.name
        );
        let chosen = harness::view::lod::choose(&catalogue, Some(&[card.name.to_owned()]), &[])
            .expect("chosen");
        assert_eq!(chosen[0].2, default.label(), "{}", card.name);
        // Given nothing, and given the default setting: the same selection.
        let settings = [Setting::default(), default];
        let cell = kernel::LodCell {
            method: card,
            settings: &settings,
            views: &views,
            repeats: 1,
            build_repeats: 1,
        };
        let mut counts = Vec::new();
        kernel::run_lod(&cell, &data.input(), |_, _, s| {
            counts.push(s.expect("a selection").splats.len());
        })
        .expect("built");
        assert_eq!(counts[0], counts[1], "{}", card.name);
        assert!(counts[0] > 0, "{}", card.name);
    }
}

/// An external method's default is its `default` table, else its `[params]` defaults, never
/// its grid's first entry: a program without a default of its own (it fails when `k` is not
/// sent) whose grid starts at k = 2 and whose `[params]` say 3 runs k = 3 given nothing in
/// `visible` (which says so), `view` and the experiments' kernel; the installed peers say the
/// same (open3d-hpr's γ = 3, not its grid's first 2), and each one's sweep default is its
/// card's.
#[test]
fn an_external_method_runs_its_params_default_everywhere() {
    let dir = tempfile::tempdir().expect("a folder");
    let folder = dir.path().join("every-kth");
    std::fs::create_dir_all(&folder).expect("a method folder");
    std::fs::write(
        folder.join("m.py"),
        "import sys, json\n\
         k = int(json.loads(sys.argv[sys.argv.index('--params') + 1])['k'])\n\
         head = open(sys.argv[sys.argv.index('--points') + 1], 'rb').read(4000)\n\
         n = int(head.split(b'element vertex ')[1].split()[0])\n\
         for line in sys.stdin:\n    \
         print(json.dumps({'visible': list(range(0, n, k)), 'seconds': 0.0}), flush=True)\n",
    )
    .expect("its program");
    std::fs::write(
        folder.join("method.toml"),
        "protocol = 1\ncommand = [\"python3\", \"m.py\"]\n\
         grid = [{k = \"2\"}, {k = \"3\"}]\n\
         [params.k]\ndefault = \"3\"\nhelp = \"keep one point in k\"\n\
         [params.note]\ndefault = \"-\"\nhelp = \"left to the program\"\n",
    )
    .expect("its manifest");
    let (cli, ran) = cli_visible_with("every-kth", &[], Some(dir.path()));
    assert_eq!(ran.label(), "k=3");
    assert_eq!(cli.len(), 8_000);
    let (two, ran) = cli_visible_with("every-kth", &["k=2"], Some(dir.path()));
    assert_eq!((ran.label().as_str(), two.len()), ("k=2", 12_000));

    let mut catalogue = registry::Catalogue::builtin();
    catalogue.add_external(dir.path()).expect("added");
    let card = catalogue.card("every-kth").expect("its card");
    assert_eq!(card.default_setting().label(), "k=3");
    let sweeps = catalogue.sweeps(None).expect("the sweeps");
    let setting = sweeps.methods["every-kth"]
        .default_setting()
        .expect("a default");
    assert_eq!(setting.label(), "k=3");
    let ds = datasets::Datasets::default()
        .load(DATASET, Path::new("/nonexistent"))
        .expect("a synthetic dataset");
    let camera = *ds.view(0).expect("view 0");
    let chosen =
        harness::view::choose(&catalogue, Some(&["every-kth".to_owned()]), &[]).expect("chosen");
    assert_eq!(chosen[0].2, "k=3");
    let (page, _) =
        harness::view::run_method(chosen[0].0, &ds, &chosen[0].1, 0, &camera).expect("view");
    assert_eq!(page.visible, cli, "visible and view");
    let views = [kernel::View { index: 0, camera }];
    let experiment = kernel_visible(card, &setting, &views, &ds);
    assert_eq!(experiment, cli, "visible and the experiments");

    // The installed peers: loaded, not run (their programs need `just peers`).
    catalogue
        .add_external(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../methods"))
        .expect("the methods folder");
    let sweeps = catalogue.sweeps(None).expect("the sweeps");
    let open3d = catalogue.card("open3d-hpr").expect("open3d-hpr");
    assert_eq!(open3d.default_setting().label(), "gamma=3");
    assert_eq!(
        sweeps.methods["open3d-hpr"]
            .default_setting()
            .map(|s| s.label()),
        Some("gamma=3".to_owned())
    );
    for card in catalogue.cards().into_iter().filter(|c| c.is_external()) {
        if let Some(sweep) = sweeps.methods.get(card.name) {
            assert_eq!(
                sweep.default_setting().map(|s| s.label()),
                Some(card.default_setting().label()),
                "{}",
                card.name
            );
        }
    }
}
