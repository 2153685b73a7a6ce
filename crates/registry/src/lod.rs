//! The level-of-detail form of a method: a [`LodMethod`] builds once per cloud ([`LodBuilt`])
//! and reads each setting into its own typed struct ([`LodArgs`]); the built structure makes a
//! [`LodSelector`] per setting, asked per view for the splats to draw. The caller renders and
//! scores them (PSNR, SSIM, holes against the full-cloud render); methods never see an image.
//! [`LodData`] is the coloured cloud with normals and the full-detail radius every LOD caller
//! builds on.
//!
//! Timing: [`LodSelector::select`] is the part a renderer pays per frame (the traversal, cut or
//! test, into the selector's buffers) and is what callers time; [`LodSelector::splats`] turns
//! the last selection into drawable splats and is not timed.

use std::any::Any;

use cloud::glam::{Vec2, Vec3};
use cloud::{Camera, PointCloud};
use splat::render::Splat;
use srn::texture::Texture;

use crate::error::{Error, Result};
use crate::params::Reader;

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

/// A level-of-detail method's setting read into its own typed struct ([`LodMethod::parse`]),
/// which its built structure's selectors take back ([`args_of`]).
pub type LodArgs = Box<dyn Any + Send + Sync>;

/// A level-of-detail method.
pub trait LodMethod: Sync {
    /// Reads a setting (through `args`, which remembers the keys read) into the method's own
    /// typed struct, checking every value, before any work.
    fn parse(&self, args: &mut Reader<'_>) -> Result<LodArgs>;
    /// Builds the per-cloud structure.
    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>>;
}

/// A setting read by [`LodMethod::parse`] as the method's own struct `T`; an error when it is
/// another's.
pub fn args_of<'a, T: Any>(args: &'a LodArgs, method: &str) -> Result<&'a T> {
    args.downcast_ref::<T>().ok_or_else(|| {
        Error::Unsupported(format!(
            "{method} was given a setting read by another method"
        ))
    })
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
/// k-nearest-neighbour estimates: 16 neighbours, oriented by Hoppe's spanning tree
/// (`cloud::orient`), as a scan
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
                    cloud::normals::Orientation::Propagated,
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
    /// `crate::lod_file`): no points, whose selectors read nothing from it.
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
    /// A selector for one setting (read by the method's [`LodMethod::parse`]) on the input
    /// the structure was built from.
    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        args: &'s LodArgs,
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
