//! The catalogue: one namespace for both kinds, every card's parameters and defaults consistent
//! (the default setting runs as a setting-less call does, and is one of the sweep's settings),
//! the built-in grids name registered methods and keys, and every built-in LOD method builds
//! and selects through the kernel.

use cloud::{Camera, PointCloud};
use srn::texture::Texture;

use super::{BUILT_IN, Catalogue};
use crate::card::{Card, Kind, Memory, Metric};
use crate::error::{Error, Result};
use crate::kernel::{self, LodCell, View};
use crate::lod::{LodArgs, LodBuilt, LodData, LodInput, LodMethod};
use crate::params::{Params, Reader};
use crate::setting::Setting;
use crate::sweep::{BUILTIN, Sweeps};
use crate::visibility::{Method, Setup};

/// A built-in method's card, or the catalogue's error.
fn card(name: &str) -> Result<&'static Card> {
    Catalogue::builtin().card(name)
}

/// A method that only has a name: it reads nothing and prepares nothing.
struct Nothing;

impl Method for Nothing {
    fn parse(&self, _: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
        Err(Error::Unsupported("test".into()))
    }
}

impl LodMethod for Nothing {
    fn parse(&self, _: &mut Reader<'_>) -> Result<LodArgs> {
        Err(Error::Unsupported("test".into()))
    }
    fn build(&self, _: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        Err(Error::Unsupported("test".into()))
    }
}

/// A card called `name` of either kind.
fn named(name: &'static str, lod: bool) -> &'static Card {
    let kind = if lod {
        Kind::Lod(&Nothing)
    } else {
        Kind::Visibility(&Nothing)
    };
    Box::leak(Box::new(Card::new(
        name,
        "test",
        kind,
        &[],
        Memory::Unknown,
    )))
}

#[test]
fn one_namespace_for_visibility_and_lod_methods() {
    let mut catalogue = Catalogue::builtin();
    // Built-in names of either kind are taken for both kinds.
    assert!(catalogue.add(named("srn", false)).is_err());
    assert!(catalogue.add(named("hpr", false)).is_err());
    assert!(catalogue.add(named("hpr", true)).is_err());
    assert!(catalogue.add(named("qsplat", true)).is_err());
    // A new name is added once, for its kind, and is then taken for the other kind too.
    catalogue.add(named("plugins-test-vis", false)).unwrap();
    assert!(
        catalogue
            .card("plugins-test-vis")
            .is_ok_and(|c| !c.is_lod())
    );
    assert!(catalogue.add(named("plugins-test-vis", false)).is_err());
    assert!(catalogue.add(named("plugins-test-vis", true)).is_err());
    catalogue.add(named("plugins-test-lod", true)).unwrap();
    assert!(
        catalogue
            .card_named("plugins-test-lod")
            .is_some_and(|c| c.is_lod())
    );
    assert!(catalogue.add(named("plugins-test-lod", false)).is_err());
    let err = catalogue.card("no-such-method").err().unwrap().to_string();
    assert!(err.contains("hpr") && err.contains("qsplat"), "{err}");
    // Catalogues are values: another one, side by side, knows none of this one's additions.
    let other = Catalogue::builtin();
    assert!(other.card_named("plugins-test-vis").is_none());
    assert_eq!(other.cards().len(), BUILT_IN.len());
    assert_eq!(catalogue.cards().len(), BUILT_IN.len() + 2);
    assert_eq!(
        catalogue
            .lod_cards()
            .iter()
            .filter(|c| c.name == "plugins-test-lod")
            .count(),
        1
    );
    assert!(
        catalogue
            .visibility_cards()
            .iter()
            .any(|c| c.name == "plugins-test-vis")
    );
}

#[test]
fn an_external_method_may_not_take_a_built_in_lod_name() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("spt");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::write(
        folder.join("method.toml"),
        "protocol = 1\nsummary = \"test\"\ncommand = [\"true\"]\n",
    )
    .unwrap();
    let err = Catalogue::builtin()
        .add_external(dir.path())
        .unwrap_err()
        .to_string();
    assert!(err.contains("shadows a built-in method"), "{err}");
}

/// `card`'s setting `params` read, as it runs.
fn ran(card: &Card, params: &Params) -> Result<Setting> {
    match card.kind {
        Kind::Visibility(_) => card.setup(params).map(|(_, ran)| ran),
        Kind::Lod(_) => card.lod_args(params).map(|(_, ran)| ran),
    }
}

#[test]
fn every_cards_defaults_read_and_its_default_setting_is_what_nothing_runs() {
    for c in BUILT_IN {
        // Every key is documented, once.
        for (k, p) in c.params.iter().enumerate() {
            assert!(!p.help.is_empty(), "{}: {}", c.name, p.key);
            assert!(
                c.params[..k].iter().all(|q| q.key != p.key),
                "{}: {} twice",
                c.name,
                p.key
            );
        }
        // Given nothing, a method runs its default setting (every default value parses).
        let nothing = ran(c, &Params::default()).unwrap_or_else(|e| panic!("{}: {e}", c.name));
        let default = c.default_setting();
        let given = ran(c, &default.params()).unwrap_or_else(|e| panic!("{}: {e}", c.name));
        assert_eq!(nothing.label(), given.label(), "{}", c.name);
        assert!(
            Setting::parse(&nothing.label()).contains(&Setting::parse(&default.label())),
            "{}",
            c.name
        );
    }
    // HPR's: γ by rule, the seed of the sweeps; its hull implied.
    let hpr = card("hpr").unwrap();
    assert_eq!(
        hpr.default_setting().label(),
        "gamma=auto;kernel=linear;perturb=0;seed=2007"
    );
    assert_eq!(
        ran(hpr, &Params::default()).unwrap().label(),
        "gamma=auto;hull=own;kernel=linear;perturb=0;seed=2007"
    );
    // A default by kernel.
    assert_eq!(
        ran(hpr, &Params::parse(&["kernel=exp"]).unwrap())
            .unwrap()
            .text("gamma")
            .as_deref(),
        Some("-0.05")
    );
}

#[test]
fn builtin_grids_parse_and_name_registered_methods_and_keys() {
    let s = Sweeps::parse(BUILTIN, "sweeps.toml").unwrap();
    for (name, sweep) in &s.methods {
        let c = card(name).unwrap();
        assert!(!sweep.grid.is_empty(), "{name}");
        assert!(
            sweep.default.is_none(),
            "{name}: its default setting is its card's"
        );
        // Every setting is read by the method.
        for set in sweep.grid.iter().chain(&sweep.quick_grid) {
            ran(c, &set.params()).unwrap_or_else(|e| panic!("{name} at {}: {e}", set.label()));
        }
        // The default setting is one of the grid's (agreement on clouds without a mesh picks
        // its rows).
        let default = Sweeps::builtin().methods[name].default_setting().unwrap();
        assert_eq!(default, c.default_setting(), "{name}");
        assert!(sweep.grid.contains(&default), "{name}: {}", default.label());
    }
    for name in [
        "hpr", "robust", "raycast", "splat", "qsplat", "spt", "srn", "random",
    ] {
        assert!(s.methods.contains_key(name), "{name}");
    }
}

#[test]
fn user_file_replaces_named_methods_only_and_keeps_the_cards_default() {
    let user = Sweeps::parse("[hpr]\n[[hpr.grid]]\ngamma = [2, 3]", "u").unwrap();
    let s = Catalogue::builtin().sweeps(Some(user)).unwrap();
    assert_eq!(s.methods["hpr"].grid.len(), 2);
    assert_eq!(
        s.methods["hpr"].default_setting(),
        Some(card("hpr").unwrap().default_setting())
    );
    assert_eq!(s.methods["raycast"], Sweeps::builtin().methods["raycast"]);
    // A file's own default stands.
    let user = Sweeps::parse("[hpr]\ndefault = {gamma = 3}\n[[hpr.grid]]\ngamma = 3", "u").unwrap();
    let s = Catalogue::builtin().sweeps(Some(user)).unwrap();
    assert_eq!(
        s.methods["hpr"].default_setting().unwrap().label(),
        "gamma=3"
    );
    assert!(
        Catalogue::builtin()
            .sweeps(Some(Sweeps::parse("[nosuch]", "u").unwrap()))
            .is_err()
    );
}

/// A unit sphere of `n` points with no normals and no colours, as a scan file gives.
fn bare_sphere(n: usize) -> PointCloud {
    PointCloud::from_positions(cloud::synth::fibonacci_sphere(n)).expect("a cloud")
}

fn camera() -> Camera {
    Camera::new(
        cloud::glam::DVec3::new(0.0, 0.0, 4.0),
        cloud::glam::DVec3::ZERO,
        cloud::glam::DVec3::Y,
        40.0,
        320,
        240,
    )
    .expect("a camera")
}

#[test]
fn every_builtin_lod_method_builds_on_a_cloud_without_normals_or_texture() {
    let data = LodData::prepare(bare_sphere(3000), None, 1.0, 7).expect("prepared");
    let n = data
        .cloud
        .normals
        .as_ref()
        .expect("estimated normals in the cloud");
    assert_eq!(n, &data.normals);
    // Oriented by the spanning tree from the top point's +z: outward on a sphere.
    assert!(
        data.cloud
            .positions
            .iter()
            .zip(n)
            .all(|(p, n)| p.as_vec3().dot(*n) > 0.5)
    );
    let views = View::all(&[camera()]);
    for m in BUILT_IN.iter().filter(|c| c.is_lod()) {
        let settings = [Setting::default()];
        let cell = LodCell {
            method: m,
            settings: &settings,
            views: &views,
            repeats: 1,
            build_repeats: 1,
        };
        let mut got = Vec::new();
        let built = kernel::run_lod(&cell, &data.input(), |_, _, s| {
            got.push(s.map(|s| s.splats.len()).map_err(|e| e.to_string()))
        });
        if m.name == "srn" {
            let e = built.err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains("srn needs a texture"), "{e}");
            continue;
        }
        assert!(built.is_ok(), "{}: {:?}", m.name, built.err());
        assert_eq!(got.len(), 1);
        let k = got[0].clone().expect("a selection");
        assert!(k > 0 && k <= 3000, "{}: {k}", m.name);
    }
}

#[test]
fn the_split_kernel_selects_as_run_lod_does() {
    let texture =
        Texture::new(2, 2, vec![[10, 200, 30], [0, 0, 0], [255; 3], [90; 3]]).expect("a texture");
    let data = LodData::prepare(bare_sphere(2000), Some(texture), 1.0, 3).expect("prepared");
    let input = data.input();
    let views = View::all(&[camera()]);
    let settings = [
        Setting::parse("threshold_px=1"),
        Setting::parse("threshold_px=60"),
    ];
    let m = card("qsplat").expect("qsplat");
    let cell = LodCell {
        method: m,
        settings: &settings,
        views: &views,
        repeats: 1,
        build_repeats: 1,
    };
    let mut whole = Vec::new();
    kernel::run_lod(&cell, &input, |_, _, s| {
        whole.push(s.expect("selected").splats.len())
    })
    .expect("built");
    let (built, b) = kernel::build_lod(m, &input, 1).expect("built");
    assert!(b.size.nodes > 2000);
    let mut split = Vec::new();
    kernel::select_lod(&cell, built.as_ref(), &input, |_, _, s| {
        split.push(s.expect("selected").splats.len())
    });
    assert_eq!(whole, split);
    assert!(whole[1] < whole[0], "{whole:?}");
    // A bad setting is refused for its views, before the build; the good one still selects.
    let settings = [Setting::parse("threshold_px=x"), Setting::parse("pixels=3")];
    let cell = LodCell {
        settings: &settings,
        ..cell
    };
    let mut errors = Vec::new();
    kernel::run_lod(&cell, &input, |_, _, s| {
        errors.push(s.err().map(ToString::to_string).unwrap_or_default())
    })
    .expect("built");
    assert!(errors[0].contains("threshold_px=x"), "{errors:?}");
    assert!(errors[1].contains("unknown parameter pixels"), "{errors:?}");
    assert_eq!(
        Catalogue::builtin()
            .cards()
            .iter()
            .filter(|c| c.name == "qsplat")
            .count(),
        1
    );
}

#[test]
fn the_image_space_methods_are_made_for_pixels_and_the_point_set_methods_for_points() {
    let made = |name: &str| card(name).expect(name).made_for;
    for name in [
        "hpr-approx",
        "raycast",
        "splat",
        "screenspace",
        "vardensity",
    ] {
        assert_eq!(made(name), Metric::Pixels, "{name}");
    }
    for name in ["hpr", "hpr-confidence", "robust", "reference", "exact"] {
        assert_eq!(made(name), Metric::Points, "{name}");
    }
    assert_eq!(Metric::Pixels.as_str(), "pixels");
    assert_eq!(Metric::Points.as_str(), "points");
}
