//! `registry`: the one place a visibility method plugs in, for the harness (`pointsight`) and
//! the Python package alike, so both speak one parameter vocabulary.
//!
//! A method is a [`Method`] (name, typed parameters, and `prepare`, which builds whatever it
//! keeps per cloud: a BVH, a k-d tree) returning a [`Prepared`] that answers one view at a
//! time. Adding a method is one adapter module and one line in [`METHODS`]. Methods return
//! indices; callers, not methods, score them (ann-benchmarks' rule). Every caller measures a
//! method through [`kernel`], the one code path that prepares, times and runs one; `seconds`
//! in every report is the time of [`Prepared::visible_at`] alone, measured by [`timing`]:
//! loading and per-cloud preparation are excluded.
//!
//! This crate knows nothing of the command line, datasets, plots or reports: its input is a
//! cloud and, for the ground truth, a mesh ([`Input`]).

pub mod error;
mod exact;
pub mod external;
pub mod hpr;
pub mod hpr_approx;
pub mod hpr_confidence;
pub mod image_score;
pub mod kernel;
pub mod lod;
pub mod lod_file;
pub mod params;
mod plugins;
pub mod raycast;
mod reference;
pub mod robust;
pub mod score;
mod screenspace;
mod splat;
pub mod sweep;
pub mod timing;
mod vardensity;

use cloud::{Camera, PointCloud, TriMesh};

pub use error::{Error, Result};
pub use params::{ParamSpec, Params};
pub use sweep::{MethodSweep, Setting, Sweeps};

/// What a method prepares on: the points and, for the ground truth, the surface.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// The cloud.
    pub cloud: &'a PointCloud,
    /// The mesh the points came from, if any.
    pub mesh: Option<&'a TriMesh>,
}

impl<'a> Input<'a> {
    /// The mesh, or an error saying that `what` needs one.
    pub fn mesh(&self, what: &str) -> Result<&'a TriMesh> {
        self.mesh.ok_or_else(|| {
            Error::Unsupported(format!(
                "{what} needs a mesh (the ground truth renders it) and there is none"
            ))
        })
    }
}

/// What a method says about one view.
#[derive(Debug, Clone, Default)]
pub struct Output {
    /// Indices of the visible points, ascending, without repeats.
    pub visible: Vec<u32>,
    /// Rays cast (0 for methods that cast none).
    pub rays: u64,
    /// For per-pixel methods: the image size and, per pixel (row-major), the point it shows
    /// (`u32::MAX` for none).
    pub pixels: Option<PixelChoice>,
    /// The method's own compute seconds, for methods that report it (external programs,
    /// whose wall time includes the protocol); `None`: the caller's timing is the time.
    pub reported_seconds: Option<f64>,
    /// What a rule chose for this view (`gamma=2.87` for HPR's `gamma=auto`), `k=v` pairs.
    pub detail: Vec<(String, String)>,
    /// For methods whose visible set is a threshold of a per-point score (a visibility
    /// confidence): the score of every point of the cloud, indexed like the cloud, higher
    /// meaning more visible; `None` for methods that give none.
    pub score: Option<Vec<f32>>,
}

/// The point each pixel of a per-pixel method shows.
#[derive(Debug, Clone)]
pub struct PixelChoice {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Point per pixel, row-major; `u32::MAX` where none.
    pub point: Vec<u32>,
}

/// Per-dataset state of a method, answering views.
pub trait Prepared: Sync {
    /// The visible points from `camera`.
    fn visible(&self, camera: &Camera) -> Result<Output>;
    /// The visible points from view `view` of the dataset (its index among the dataset's
    /// views), whose camera is `camera`. Methods that care which view it is (an external
    /// program told the view's index) override this; the default ignores the index.
    fn visible_at(&self, view: usize, camera: &Camera) -> Result<Output> {
        let _ = view;
        self.visible(camera)
    }
    /// The build of the method's per-cloud structure alone, seconds, when it accounts for it:
    /// an external program's `built` line (its BVH, its render window), the ray caster's k-d
    /// tree (without the normals and density spacing, which a peer is sent ready); asked after
    /// the views.
    fn reported_build_seconds(&self) -> Option<f64> {
        None
    }
}

/// A visibility method.
pub trait Method: Sync {
    /// Name on the command line.
    fn name(&self) -> &'static str;
    /// One line for listings.
    fn summary(&self) -> &'static str;
    /// The `--set` keys it accepts.
    fn params(&self) -> &'static [ParamSpec];
    /// Reads `params` and builds the per-cloud state.
    fn prepare<'a>(&self, input: Input<'a>, params: &Params) -> Result<Box<dyn Prepared + 'a>>;
    /// True when several views are faster answered in parallel (one view per thread) than
    /// one after another (methods whose single view already uses every core say false).
    fn parallel_views(&self) -> bool {
        false
    }
    /// `Ok` when the method can run here; else why not (an external method's environment is
    /// missing).
    fn availability(&self) -> std::result::Result<(), String> {
        Ok(())
    }
    /// The method's own sweep, for methods that carry one (an external method's
    /// `method.toml`); `None`: the built-in grids ([`sweep::BUILTIN`]) say, if anything.
    fn sweep(&self) -> Option<MethodSweep> {
        None
    }
    /// The family a setting's results group under in plots and tables (HPR's two kernels are
    /// two families); default: the method's name.
    fn family(&self, _setting: &Setting) -> String {
        self.name().to_owned()
    }
    /// True for methods loaded from a `method.toml` (external programs).
    fn is_external(&self) -> bool {
        false
    }
    /// For a peer (another project's tool measured beside ours): the family of ours it pairs
    /// with (`hpr`, `raycast`, `splat`, `hull`, `voxel`, `lod`...), from its `method.toml`'s
    /// `peer_of`; `None` for our own methods and for external methods that pair with none.
    fn peer_of(&self) -> Option<&'static str> {
        None
    }
    /// For a peer: how its parameters translate into those of the method it pairs with, where
    /// the names or units differ (VTK's `point_size` is 2 × our splat's `radius_px`); keys of
    /// the same name are taken as they are. Empty for our own methods.
    fn peer_keys(&self) -> &'static [PeerKey] {
        &[]
    }
    /// The version of the program behind the method, for run metadata (an external method's
    /// `version` command, run once); `None`: our own (the build's version says it).
    fn version(&self) -> Option<String> {
        None
    }
    /// How the scale experiment may run it on large clouds (default: its memory is not known,
    /// so it is not run above [`Scale::UNKNOWN_LIMIT`] points).
    fn scale(&self) -> Scale {
        Scale::Unknown
    }
}

/// One translated parameter of a peer (`method.toml`'s `[peer_keys]`): the peer's `peer`
/// at value v stands for the partner's `ours` at `factor` × v.
#[derive(Debug, Clone, PartialEq)]
pub struct PeerKey {
    /// The peer's key.
    pub peer: &'static str,
    /// The partner's key.
    pub ours: &'static str,
    /// The partner's value over the peer's.
    pub factor: f64,
}

/// What the scale experiment may know of a method's memory, so that its guard can refuse a
/// cell that cannot fit before it starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Scale {
    /// Bytes per point the method needs beyond the sampled cloud's own 48 (its peak measured at
    /// 10^7 points, with a margin).
    PerPoint(u64),
    /// Not known: not run above [`Scale::UNKNOWN_LIMIT`] points.
    Unknown,
    /// The method takes no part in the scale experiment, for this reason (the report prints it).
    OptOut(String),
}

impl Scale {
    /// The most points a method of unknown memory is run on.
    pub const UNKNOWN_LIMIT: u64 = 1_000_000;
}

/// Methods registered at run time: external ones ([`register_external`]) and any a program
/// embedding this crate adds ([`register`]).
static EXTRA: plugins::Plugins<dyn Method> = plugins::Plugins::new();

/// Adds `method` for every later lookup in this process (a program embedding the registry, or
/// a test, plugs its own method in here: one adapter, one call). Its name must be new among
/// visibility and LOD methods alike (one sweeps file names both).
pub fn register(method: &'static dyn Method) -> Result<()> {
    EXTRA.add(method.name(), method)
}

/// Loads the external methods under `dir` (`NAME/method.toml` each) for every later lookup:
/// visibility methods with [`register`], those of `kind = "lod"` with [`lod::register_lod`].
/// Names must not shadow built-in methods (visibility or LOD: one namespace); a method already
/// loaded under the same name is kept (loading the same folder twice is harmless).
pub fn register_external(dir: &std::path::Path) -> Result<()> {
    let loaded = external::ExternalMethod::load_dir(dir)?;
    for m in loaded {
        let lod_kind = m.kind() == external::Kind::Lod;
        let builtin = METHODS.iter().map(|b| b.name());
        if builtin
            .chain(lod::LOD_METHODS.iter().map(|b| b.name()))
            .any(|b| b == m.name())
        {
            return Err(Error::Unsupported(format!(
                "external method {} in {} shadows a built-in method",
                m.name(),
                dir.display()
            )));
        }
        if all().iter().any(|b| b.name() == m.name())
            || lod::all().iter().any(|b| b.name() == m.name())
        {
            continue;
        }
        let m: &'static external::ExternalMethod = Box::leak(Box::new(m));
        if lod_kind {
            // The LOD form: a level-of-detail method, which the lod experiment runs.
            lod::register_lod(m)?;
        } else {
            register(m)?;
        }
    }
    Ok(())
}

/// Every method: built-in, then those registered at run time.
pub fn all() -> Vec<&'static dyn Method> {
    EXTRA.after(METHODS)
}

/// Every method, in listing order.
pub static METHODS: &[&dyn Method] = &[
    &reference::ReferenceMethod,
    &exact::ExactMethod,
    &hpr::HprMethod,
    &hpr_confidence::HprConfidenceMethod,
    &hpr_approx::HprApproxMethod,
    &robust::RobustMethod,
    &raycast::RaycastMethod,
    &splat::SplatMethod,
    &screenspace::ScreenspaceMethod,
    &vardensity::VardensityMethod,
];

/// Looks a method up by name.
pub fn method(name: &str) -> Result<&'static dyn Method> {
    all()
        .into_iter()
        .find(|m| m.name() == name)
        .ok_or_else(|| Error::UnknownMethod {
            name: name.to_owned(),
            known: all()
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// Indices of the true entries of `flags`.
pub fn indices_of(flags: &[bool]) -> Vec<u32> {
    flags
        .iter()
        .enumerate()
        .filter_map(|(i, &f)| f.then_some(i as u32))
        .collect()
}

/// The camera at the resolution `params` asks for (`width`, `height`), else the view's.
pub fn camera_with_resolution(
    camera: &Camera,
    width: Option<u32>,
    height: Option<u32>,
) -> Result<Camera> {
    match (width, height) {
        (None, None) => Ok(*camera),
        (w, h) => {
            Ok(camera.with_resolution(w.unwrap_or(camera.width), h.unwrap_or(camera.height))?)
        }
    }
}
