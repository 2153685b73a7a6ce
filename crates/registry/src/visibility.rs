//! The visibility form of a method: a [`Method`] reads its setting into a [`Setup`] (its own
//! typed struct), which prepares on an [`Input`] (the cloud and, for the ground truth, the mesh)
//! whatever it keeps per cloud (a BVH, a k-d tree) as a [`Prepared`] that answers one view at a
//! time with an [`Output`]: indices, which callers, not methods, score (ann-benchmarks' rule).

use cloud::{Camera, PointCloud, TriMesh};

use crate::error::{Error, Result};
use crate::params::Reader;

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

/// A visibility method: what reads its setting.
pub trait Method: Sync {
    /// Reads the setting (through `args`, which remembers the keys read) into the method's own
    /// typed struct, checking every value, before any work.
    fn parse(&self, args: &mut Reader<'_>) -> Result<Box<dyn Setup>>;
    /// Ends what it keeps running between preparations (an external method's protocol 3
    /// program, warm for its last cloud), if anything; a later preparation starts afresh.
    fn end(&self) {}
}

/// A visibility method's setting, read: it prepares on a cloud.
pub trait Setup: Send + Sync {
    /// Builds the per-cloud state (a k-d tree, a BVH).
    fn prepare<'a>(&'a self, input: Input<'a>) -> Result<Box<dyn Prepared + 'a>>;
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
    /// The cold call of an external program these views started: wall seconds from starting
    /// it to its first answer (its start-up, imports, build and first view), which its
    /// views' own seconds leave out; asked after the views. `None` for methods that start no
    /// program, and for views answered by a program already running (protocol 3's warm one).
    fn cold_call_seconds(&self) -> Option<f64> {
        None
    }
}

/// Indices of the true entries of `flags`.
pub fn indices_of(flags: &[bool]) -> Vec<u32> {
    flags
        .iter()
        .enumerate()
        .filter_map(|(i, &f)| f.then_some(i as u32))
        .collect()
}

/// The camera at the resolution a setting asks for (`width`, `height`), else the view's.
pub fn camera_with_resolution(
    camera: &Camera,
    width: Option<u32>,
    height: Option<u32>,
) -> Result<Camera> {
    let (w, h) = (
        width.unwrap_or(camera.width),
        height.unwrap_or(camera.height),
    );
    if (w, h) == (camera.width, camera.height) {
        return Ok(*camera);
    }
    Ok(camera.with_resolution(w, h)?)
}
