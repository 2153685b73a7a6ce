//! Level-of-detail methods behind one trait: built once per cloud, asked per view for the
//! splats to draw at one setting. The caller renders and scores them (PSNR, SSIM, holes against
//! the full-cloud render); methods never see an image.
//!
//! Entries ([`LOD_METHODS`]): `qsplat` (Rusinkiewicz & Levoy 2000, seed 002: the bounding-sphere
//! tree cut at a projected-size threshold, `threshold_px`), `spt` (Dachsbacher et al. 2003, seed
//! 002: the sequential list cut at a screen-space error ε of `epsilon_px` pixels), `srn` (seed
//! 003: each point kept when its random number is below its importance times `scale`, splats
//! grown by 1/√I) and `random` (each point kept when its seeded uniform number is below
//! `fraction`, splats grown by 1/√f), the baseline any LOD method must beat. The sweeps are in
//! `sweeps.toml` like the visibility methods'. Adding one: an adapter implementing [`LodMethod`]
//! and a line in [`LOD_METHODS`] (or [`register_lod`] at run time).
//!
//! Timing: [`LodSelector::select`] is the part a renderer pays per frame (the traversal, cut or
//! test, into the selector's buffers) and is what callers time; [`LodSelector::splats`] turns
//! the last selection into drawable splats and is not timed.

use cloud::glam::{Vec2, Vec3};
use cloud::rng::{RngExt, seeded};
use cloud::{Camera, PointCloud};
use splat::render::Splat;
use srn::texture::Texture;
use srn::{MaskingParams, Srn, SrnParams, masking_map};

use crate::error::{Error, Result};
use crate::{ParamSpec, Params};

/// What an LOD method builds on.
#[derive(Clone, Copy)]
pub struct LodInput<'a> {
    /// The cloud, with 8-bit colours.
    pub cloud: &'a PointCloud,
    /// A unit normal per point.
    pub normals: &'a [Vec3],
    /// Colour per point, in [0, 1]³.
    pub albedo: &'a [Vec3],
    /// Texture coordinates per point.
    pub uvs: &'a [Vec2],
    /// The texture the colours come from, if any (SRN's masking importance is computed on it,
    /// so SRN needs one).
    pub texture: Option<&'a Texture>,
    /// Radius of a full-detail splat, world units.
    pub radius: f64,
    /// Seed of every random choice.
    pub seed: u64,
}

impl LodInput<'_> {
    /// Point `i` as a splat of `radius`.
    pub fn point_splat(&self, i: usize, radius: f64) -> Splat {
        Splat {
            center: self.cloud.positions[i],
            radius: radius as f32,
            normal: self.normals[i],
            albedo: self.albedo[i],
        }
    }
}

/// Size of a built structure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LodSize {
    /// Nodes or entries.
    pub nodes: usize,
    /// Bytes (0 when not meaningful).
    pub bytes: f64,
}

/// An LOD method.
pub trait LodMethod: Sync {
    /// Name (CSV `method`, sweeps table).
    fn name(&self) -> &'static str;
    /// One line for listings.
    fn summary(&self) -> &'static str;
    /// The keys a setting may set.
    fn params(&self) -> &'static [ParamSpec];
    /// Builds the per-cloud structure.
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>>;
    /// `Ok` when the method can run here; else why not (an external method's environment is
    /// missing).
    fn availability(&self) -> std::result::Result<(), String> {
        Ok(())
    }
    /// How the scale experiment may run it on large clouds (default: memory not known).
    fn scale(&self) -> crate::Scale {
        crate::Scale::Unknown
    }
    /// Its own sweep, for methods that carry one (a method registered at run time); `None`:
    /// the built-in grids say, if anything.
    fn sweep(&self) -> Option<crate::MethodSweep> {
        None
    }
    /// For a peer: the family of ours it pairs with (`lod`); `None` for our own.
    fn peer_of(&self) -> Option<&'static str> {
        None
    }
    /// The version of the program behind it (an external method's `version` command).
    fn version(&self) -> Option<String> {
        None
    }
}

/// Sets each point's colour from `texture` through the cloud's texture coordinates (else the
/// spherical parameterisation of `srn::param` about the bounding box's centre, so colour
/// detail counts in an image comparison); returns the coordinates used.
pub fn colorize(cloud: &mut PointCloud, texture: &Texture) -> Vec<Vec2> {
    let uvs = texture_coords(cloud);
    cloud.colors = Some(
        uvs.iter()
            .map(|&uv| {
                let c = texture.sample(uv) * 255.0;
                [c.x as u8, c.y as u8, c.z as u8]
            })
            .collect(),
    );
    uvs
}

/// The cloud's texture coordinates, else the spherical parameterisation of `srn::param` about
/// the bounding box's centre.
fn texture_coords(cloud: &PointCloud) -> Vec<Vec2> {
    cloud.uvs.clone().unwrap_or_else(|| {
        let center = cloud::Aabb::from_points(&cloud.positions)
            .map(|b| b.center())
            .unwrap_or_default();
        srn::param::spherical_uvs(&cloud.positions, center)
    })
}

/// The owned data an LOD method builds on, made from a cloud once: with a texture, a colour per
/// point from it through the cloud's texture coordinates (else the spherical parameterisation
/// of `srn::param` about the bounding box's centre; without one, the cloud's own colours, else
/// a grey of 200/255, and those coordinates), a unit normal per point (the cloud's, else
/// k-nearest-neighbour estimates: 16 neighbours, oriented away from the centroid, as a scan
/// file often has none), and the full-detail splat radius `radius_spacings` density spacings
/// (`cloud::spacing::density_spacing`, k = 8, 20,000 samples).
pub struct LodData {
    /// The cloud, its colours set from the texture.
    pub cloud: PointCloud,
    /// Unit normal per point.
    pub normals: Vec<Vec3>,
    /// Colour per point in [0, 1]³.
    pub albedo: Vec<Vec3>,
    /// Texture coordinates per point.
    pub uvs: Vec<Vec2>,
    /// The texture, if any.
    pub texture: Option<Texture>,
    /// Full-detail splat radius, world units.
    pub radius: f64,
    /// Seed of every random choice.
    pub seed: u64,
}

impl LodData {
    /// Prepares `cloud` (see the type's documentation).
    pub fn prepare(
        mut cloud: PointCloud,
        texture: Option<Texture>,
        radius_spacings: f64,
        seed: u64,
    ) -> Result<Self> {
        let uvs = match &texture {
            Some(t) => colorize(&mut cloud, t),
            None => texture_coords(&cloud),
        };
        let albedo = match &cloud.colors {
            Some(c) => c.iter().map(|&c| albedo(c)).collect(),
            None => vec![albedo([200; 3]); cloud.len()],
        };
        let spacing = cloud::spacing::density_spacing(&cloud.positions, 8, 20_000, 1)?;
        let normals = match cloud.normals.clone() {
            Some(n) => n,
            None => {
                let n = cloud::normals::estimate_normals(
                    &cloud.positions,
                    16.min(cloud.len()),
                    cloud::normals::Orientation::AwayFromCentroid,
                )?;
                // The methods that read the cloud's own normals (QSplat, SPT) get these too.
                cloud.normals = Some(n.clone());
                n
            }
        };
        Ok(Self {
            cloud,
            normals,
            albedo,
            uvs,
            texture,
            radius: radius_spacings * spacing,
            seed,
        })
    }

    /// The data of a structure not built from points in memory (a built file,
    /// [`crate::lod_file`]): no points, whose selectors read nothing from it.
    pub fn none(seed: u64) -> Self {
        Self {
            cloud: PointCloud::default(),
            normals: Vec::new(),
            albedo: Vec::new(),
            uvs: Vec::new(),
            texture: None,
            radius: 0.0,
            seed,
        }
    }

    /// The borrowed view the methods build on.
    pub fn input(&self) -> LodInput<'_> {
        LodInput {
            cloud: &self.cloud,
            normals: &self.normals,
            albedo: &self.albedo,
            uvs: &self.uvs,
            texture: self.texture.as_ref(),
            radius: self.radius,
            seed: self.seed,
        }
    }

    /// Every point as a splat of the full-detail radius (the reference render's splats).
    pub fn full_splats(&self) -> Vec<Splat> {
        let input = self.input();
        (0..self.cloud.len())
            .map(|i| input.point_splat(i, self.radius))
            .collect()
    }
}

/// A built structure.
pub trait LodBuilt: Sync + Send {
    /// Its size.
    fn size(&self) -> LodSize;
    /// The build's own seconds, for structures built by a program that reports its own
    /// compute time (an external method); `None`: the caller's timing is the time.
    fn reported_build_seconds(&self) -> Option<f64> {
        None
    }
    /// A selector for one setting on the input the structure was built from.
    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>>;
}

/// One setting's selection, view by view.
pub trait LodSelector {
    /// The timed part for `camera`: traversal, cut or test, into the selector's buffers.
    fn select(&mut self, camera: &Camera) -> Result<()>;
    /// [`LodSelector::select`] for view `view` of the dataset (its index among the dataset's
    /// views); the default ignores the index.
    fn select_at(&mut self, view: usize, camera: &Camera) -> Result<()> {
        let _ = view;
        self.select(camera)
    }
    /// The last selection's own compute seconds, for selectors that report it (an external
    /// program, whose wall time includes the protocol); `None`: the caller's timing.
    fn reported_seconds(&self) -> Option<f64> {
        None
    }
    /// What the last selection read from storage, for selectors that read a file as they go
    /// (`crate::lod_file`); `None`: everything is in memory.
    fn reads(&self) -> Option<Reads> {
        None
    }
    /// The last selection as splats (not timed).
    fn splats(&self) -> Vec<Splat>;
}

/// What a selection from a file read and held.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Reads {
    /// Bytes read from the file by the selection.
    pub bytes_read: u64,
    /// Bytes of file pages the selector's cache holds after it.
    pub cache_bytes: u64,
    /// Bytes of the selection itself (the method's splats).
    pub selection_bytes: u64,
}

/// An 8-bit colour as an albedo in [0, 1]³.
pub fn albedo(c: [u8; 3]) -> Vec3 {
    Vec3::new(f32::from(c[0]), f32::from(c[1]), f32::from(c[2])) / 255.0
}

/// Reads a setting, then checks that every key was read.
fn read<T>(
    params: &Params,
    method: &str,
    specs: &[ParamSpec],
    f: impl FnOnce(&Params) -> Result<T>,
) -> Result<T> {
    let out = f(params)?;
    params.check_all_read(method, specs)?;
    Ok(out)
}

struct QsplatMethod;
struct QsplatBuilt(qsplat::QTree);
struct QsplatSel<'s> {
    tree: &'s qsplat::QTree,
    params: qsplat::TraverseParams,
    last: Vec<qsplat::traverse::Splat>,
}

const QSPLAT_PARAMS: &[ParamSpec] = &[ParamSpec {
    key: "threshold_px",
    default: "2",
    help: "a node is drawn when its projected diameter is below this many pixels",
}];

impl LodMethod for QsplatMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points (build and selection, with
        // the normals, colours and texture coordinates of `LodData`), less the cloud's 48.
        crate::Scale::PerPoint(382)
    }
    fn name(&self) -> &'static str {
        "qsplat"
    }
    fn summary(&self) -> &'static str {
        "QSplat (Rusinkiewicz & Levoy 2000): bounding-sphere tree, projected-size cut (seed 002)"
    }
    fn params(&self) -> &'static [ParamSpec] {
        QSPLAT_PARAMS
    }
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let tree = qsplat::build_tree(input.cloud, input.radius)
            .map_err(|e| Error::Unsupported(format!("qsplat: {e}")))?;
        Ok(Box::new(QsplatBuilt(tree)))
    }
}

impl LodBuilt for QsplatBuilt {
    fn size(&self) -> LodSize {
        // Bytes as the original counts them (node words and colours, offsets included).
        LodSize {
            nodes: 1 + self.0.words.len(),
            bytes: self.0.payload_bytes() as f64,
        }
    }
    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(QsplatSel {
            tree: &self.0,
            params: qsplat_params(params)?,
            last: Vec::new(),
        }))
    }
}

/// The traversal a `qsplat` setting asks for (the in-memory tree's and a built file's).
pub(crate) fn qsplat_params(params: &Params) -> Result<qsplat::TraverseParams> {
    let threshold_px = read(params, "qsplat", QSPLAT_PARAMS, |p| {
        p.get("threshold_px", 2.0)
    })?;
    Ok(qsplat::TraverseParams {
        threshold_px,
        ..Default::default()
    })
}

impl LodSelector for QsplatSel<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        self.last = qsplat::traverse(self.tree, camera, &self.params);
        Ok(())
    }
    fn splats(&self) -> Vec<Splat> {
        self.last.iter().map(qsplat_splat).collect()
    }
}

/// A QSplat splat as a splat to render.
pub(crate) fn qsplat_splat(s: &qsplat::Splat) -> Splat {
    Splat {
        center: s.center,
        radius: s.radius as f32,
        normal: s.normal.as_vec3(),
        albedo: albedo(s.color),
    }
}

struct SptMethod;
struct SptBuilt(spt::Spt);
struct SptSel<'s> {
    spt: &'s spt::Spt,
    pixels: f64,
    entries: Vec<u32>,
}

const SPT_PARAMS: &[ParamSpec] = &[ParamSpec {
    key: "epsilon_px",
    default: "1",
    help: "screen-space error ε in pixels (spt::epsilon_for_pixels)",
}];

impl LodMethod for SptMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points (build and selection, with
        // the normals, colours and texture coordinates of `LodData`), less the cloud's 48.
        crate::Scale::PerPoint(392)
    }
    fn name(&self) -> &'static str {
        "spt"
    }
    fn summary(&self) -> &'static str {
        "Sequential Point Trees (Dachsbacher et al. 2003): sorted list cut at an error (seed 002)"
    }
    fn params(&self) -> &'static [ParamSpec] {
        SPT_PARAMS
    }
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let s = spt::build(input.cloud, 2.0 * input.radius)
            .map_err(|e| Error::Unsupported(format!("spt: {e}")))?;
        Ok(Box::new(SptBuilt(s)))
    }
}

impl LodBuilt for SptBuilt {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.0.len(),
            bytes: 0.0,
        }
    }
    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let pixels = spt_pixels(params)?;
        Ok(Box::new(SptSel {
            spt: &self.0,
            pixels,
            entries: Vec::new(),
        }))
    }
}

/// The error in pixels an `spt` setting asks for (the in-memory tree's and a built file's).
pub(crate) fn spt_pixels(params: &Params) -> Result<f64> {
    read(params, "spt", SPT_PARAMS, |p| p.get("epsilon_px", 1.0))
}

/// A sequential point tree's splat as the renderer's.
pub(crate) fn spt_splat(s: &spt::Splat) -> Splat {
    Splat {
        center: s.center,
        radius: s.radius as f32,
        normal: s.normal,
        albedo: s.color,
    }
}

impl LodSelector for SptSel<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let eps = spt::epsilon_for_pixels(camera, self.pixels);
        self.spt
            .cut_into(camera.eye, eps, &mut self.entries)
            .map(|_| ())
            .map_err(|e| Error::Unsupported(format!("spt: {e}")))
    }
    fn splats(&self) -> Vec<Splat> {
        self.spt
            .splats(&self.entries)
            .iter()
            .map(spt_splat)
            .collect()
    }
}

struct SrnMethod;
struct SrnBuilt(Srn);
struct SrnSel<'s> {
    srn: &'s Srn,
    input: &'s LodInput<'s>,
    params: SrnParams,
    kept: Vec<u32>,
}

const SRN_PARAMS: &[ParamSpec] = &[ParamSpec {
    key: "scale",
    default: "1",
    help: "density scale: a point is kept when its random number is below scale × importance (1: the paper)",
}];

impl LodMethod for SrnMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points (build and selection, with
        // the normals, colours and texture coordinates of `LodData`), less the cloud's 48.
        crate::Scale::PerPoint(72)
    }
    fn name(&self) -> &'static str {
        "srn"
    }
    fn summary(&self) -> &'static str {
        "SRN (seed 003): random numbers against a JPEG2000 visual-masking importance"
    }
    fn params(&self) -> &'static [ParamSpec] {
        SRN_PARAMS
    }
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let err = |e: srn::Error| Error::Unsupported(format!("srn: {e}"));
        let texture = input.texture.ok_or_else(|| {
            Error::Unsupported(
                "srn needs a texture: its importance is the texture's visual masking".into(),
            )
        })?;
        let map = masking_map(texture, &MaskingParams::default()).map_err(err)?;
        Ok(Box::new(SrnBuilt(
            Srn::new(input.uvs, &map, input.seed).map_err(err)?,
        )))
    }
}

impl LodBuilt for SrnBuilt {
    fn size(&self) -> LodSize {
        let n = self.0.len();
        LodSize {
            nodes: n,
            bytes: 8.0 * n as f64,
        }
    }
    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let scale = read(params, "srn", SRN_PARAMS, |p| p.get("scale", 1.0f32))?;
        Ok(Box::new(SrnSel {
            srn: &self.0,
            input,
            params: SrnParams {
                scale,
                ..SrnParams::default()
            },
            kept: Vec::new(),
        }))
    }
}

impl LodSelector for SrnSel<'_> {
    fn select(&mut self, _camera: &Camera) -> Result<()> {
        self.srn
            .select_into(&self.params, &mut self.kept)
            .map_err(|e| Error::Unsupported(format!("srn: {e}")))
    }
    fn splats(&self) -> Vec<Splat> {
        self.kept
            .iter()
            .map(|&i| {
                let i = i as usize;
                let grow = f64::from(self.srn.radius_factor(i, &self.params));
                self.input.point_splat(i, self.input.radius * grow)
            })
            .collect()
    }
}

struct RandomMethod;
struct RandomBuilt(Vec<f32>);
struct RandomSel<'s> {
    numbers: &'s [f32],
    input: &'s LodInput<'s>,
    fraction: f64,
    kept: Vec<u32>,
}

const RANDOM_PARAMS: &[ParamSpec] = &[ParamSpec {
    key: "fraction",
    default: "0.5",
    help: "share of the points kept (each by its seeded uniform number)",
}];

impl LodMethod for RandomMethod {
    fn scale(&self) -> crate::Scale {
        // 1.25 times the peak per point measured at 10^7 points (build and selection, with
        // the normals, colours and texture coordinates of `LodData`), less the cloud's 48.
        crate::Scale::PerPoint(72)
    }
    fn name(&self) -> &'static str {
        "random"
    }
    fn summary(&self) -> &'static str {
        "baseline: a seeded uniform random subset, splats grown by 1/sqrt(fraction)"
    }
    fn params(&self) -> &'static [ParamSpec] {
        RANDOM_PARAMS
    }
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let mut rng = seeded(input.seed, "lod-random-baseline");
        Ok(Box::new(RandomBuilt(
            (0..input.cloud.len())
                .map(|_| rng.random::<f32>())
                .collect(),
        )))
    }
}

impl LodBuilt for RandomBuilt {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.0.len(),
            bytes: 4.0 * self.0.len() as f64,
        }
    }
    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        params: &Params,
    ) -> Result<Box<dyn LodSelector + 's>> {
        let fraction: f64 = read(params, "random", RANDOM_PARAMS, |p| p.get("fraction", 0.5))?;
        if !(fraction > 0.0 && fraction <= 1.0) {
            return Err(Error::BadValue {
                key: "fraction".into(),
                value: fraction.to_string(),
                reason: "expected 0 < fraction <= 1".into(),
            });
        }
        Ok(Box::new(RandomSel {
            numbers: &self.0,
            input,
            fraction,
            kept: Vec::new(),
        }))
    }
}

impl LodSelector for RandomSel<'_> {
    fn select(&mut self, _camera: &Camera) -> Result<()> {
        self.kept.clear();
        self.kept.extend(
            self.numbers
                .iter()
                .enumerate()
                .filter(|(_, r)| f64::from(**r) < self.fraction)
                .map(|(i, _)| i as u32),
        );
        Ok(())
    }
    fn splats(&self) -> Vec<Splat> {
        let radius = self.input.radius / self.fraction.sqrt();
        self.kept
            .iter()
            .map(|&i| self.input.point_splat(i as usize, radius))
            .collect()
    }
}

/// The built-in LOD methods, in listing order.
pub static LOD_METHODS: &[&dyn LodMethod] = &[&QsplatMethod, &SptMethod, &SrnMethod, &RandomMethod];

static EXTRA: crate::plugins::Plugins<dyn LodMethod> = crate::plugins::Plugins::new();

/// Adds an LOD method for every later lookup in this process; its name must be new (among
/// visibility and LOD methods alike: one sweeps file names both).
pub fn register_lod(method: &'static dyn LodMethod) -> Result<()> {
    EXTRA.add(method.name(), method)
}

/// Every LOD method: built-in, then registered.
pub fn all() -> Vec<&'static dyn LodMethod> {
    EXTRA.after(LOD_METHODS)
}

/// Looks an LOD method up by name.
pub fn method(name: &str) -> Option<&'static dyn LodMethod> {
    all().into_iter().find(|m| m.name() == name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{self, LodCell, View};
    use crate::sweep::Setting;

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
    fn every_builtin_method_builds_on_a_cloud_without_normals_or_texture() {
        let data = LodData::prepare(bare_sphere(3000), None, 1.0, 7).expect("prepared");
        let n = data
            .cloud
            .normals
            .as_ref()
            .expect("estimated normals in the cloud");
        assert_eq!(n, &data.normals);
        // Oriented away from the centroid: outward on a sphere.
        assert!(
            data.cloud
                .positions
                .iter()
                .zip(n)
                .all(|(p, n)| p.as_vec3().dot(*n) > 0.5)
        );
        let views = View::all(&[camera()]);
        for m in LOD_METHODS {
            let settings = [Setting::default()];
            let cell = LodCell {
                method: *m,
                settings: &settings,
                views: &views,
                repeats: 1,
                build_repeats: 1,
            };
            let mut got = Vec::new();
            let built = kernel::run_lod(&cell, &data.input(), |_, _, s| {
                got.push(s.map(|s| s.splats.len()).map_err(|e| e.to_string()))
            });
            if m.name() == "srn" {
                let e = built.err().map(|e| e.to_string()).unwrap_or_default();
                assert!(e.contains("srn needs a texture"), "{e}");
                continue;
            }
            assert!(built.is_ok(), "{}: {:?}", m.name(), built.err());
            assert_eq!(got.len(), 1);
            let k = got[0].clone().expect("a selection");
            assert!(k > 0 && k <= 3000, "{}: {k}", m.name());
        }
    }

    #[test]
    fn the_split_kernel_selects_as_run_lod_does() {
        let texture = Texture::new(2, 2, vec![[10, 200, 30], [0, 0, 0], [255; 3], [90; 3]])
            .expect("a texture");
        let data = LodData::prepare(bare_sphere(2000), Some(texture), 1.0, 3).expect("prepared");
        let input = data.input();
        let views = View::all(&[camera()]);
        let settings = [
            Setting::parse("threshold_px=1"),
            Setting::parse("threshold_px=60"),
        ];
        let m = method("qsplat").expect("qsplat");
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
    }
}
