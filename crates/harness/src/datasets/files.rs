//! The frame for a user's files: a dataset made of a point file (or samples of a mesh file),
//! read, recentred without loss (`cloud::recentre`), rescaled by an exact power of two where
//! its coordinates sit at the ends of the f64 range, degraded when asked, and recorded with
//! its files' SHA-256. Manifests ([`super::manifest`]) and `visible --cloud` describe such
//! datasets as a [`FileDataset`].

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::degrade::Degradation;
use cloud::glam::DVec3;
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{Camera, TriMesh};

use super::degraded::degrade;
use super::{Dataset, SourceFile};

/// Reads a mesh file (any format with faces) and checks it.
pub fn read_mesh(path: &Path) -> Result<TriMesh> {
    let loaded = cloud::io::read(path)?;
    if loaded.triangles.is_empty() {
        bail!(
            "{} has no faces: a mesh file is needed here",
            path.display()
        );
    }
    let mesh = loaded.mesh();
    mesh.validate()
        .with_context(|| format!("{} is not a usable mesh", path.display()))?;
    Ok(mesh)
}

fn sha256_of(path: &Path) -> Result<SourceFile> {
    Ok(SourceFile {
        path: path.to_owned(),
        sha256: crate::fetch::sha256_file(path)?,
    })
}

/// Where a dataset made of files gets its views.
#[derive(Debug, Clone, PartialEq)]
pub enum ViewsFrom {
    /// The Fibonacci set of this spec around the mesh (or the cloud).
    Spec(ViewSpec),
    /// A views file or COLMAP model (world coordinates).
    File(PathBuf),
    /// The scanners of an E57 file (spherical cameras, 2048 × 1024).
    Scanners,
}

/// A dataset made of user files.
#[derive(Debug, Clone, PartialEq)]
pub struct FileDataset {
    /// Its name.
    pub name: String,
    /// One line for listings.
    pub description: String,
    /// The point file, or `None` to sample the mesh.
    pub cloud: Option<PathBuf>,
    /// Sampling of the mesh (n, seed) when there is no cloud.
    pub sample: Option<(usize, u64)>,
    /// The mesh file.
    pub mesh: Option<PathBuf>,
    /// How to read the cloud.
    pub read: cloud::io::ReadOptions,
    /// Its views.
    pub views: ViewsFrom,
    /// Off-surface tolerance.
    pub surface_tolerance: Option<f64>,
    /// Degradations applied after loading (`cloud::degrade`), with their seed.
    pub degrade: (Vec<Degradation>, u64),
    /// Score against a mesh that does not fit the points anyway ([`super::fit`]).
    pub allow_off_surface: bool,
}

/// Largest coordinate of a mesh whose samples [`plain_sample`] streams: far below the
/// 2^100 where [`load_files`] would rescale them (the recentred samples stay within twice it).
const PLAIN_SAMPLE_MAX_COORD: f64 = (1u128 << 90) as f64;

/// The mesh and the sample `(n, seed)` of `spec` when it is a plain sample of a mesh file (no
/// point file, no degradation, at least one point, coordinates within 2^90): [`load_files`]
/// then gives the sampler's draws (`cloud::sample::SurfaceSampler`) exactly, in world
/// coordinates, but for `-0.0`, which comes back as `0.0` (its recentring is lossless and
/// undone exactly; a rescaling, only ever upwards here, is exact too), so they can be written
/// as they are drawn instead of held (`pointsight export`). `None` otherwise; an error when
/// the mesh cannot be read.
pub fn plain_sample(spec: &FileDataset) -> Result<Option<(TriMesh, usize, u64)>> {
    let (None, Some((n, seed)), Some(path)) = (&spec.cloud, spec.sample, &spec.mesh) else {
        return Ok(None);
    };
    if n == 0 || !spec.degrade.0.is_empty() {
        return Ok(None);
    }
    let mesh = read_mesh(path)?;
    let largest = mesh
        .vertices
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if !(largest <= PLAIN_SAMPLE_MAX_COORD) {
        return Ok(None);
    }
    Ok(Some((mesh, n, seed)))
}

/// The mesh of `spec` alone, with its file's checksum for the run's record, without reading
/// the cloud file or drawing the sample (which may be far larger than memory): recentred by its
/// own lossless offset and rescaled by a power of two where its coordinates are at the ends of
/// the f64 range, as [`load_files`] treats a dataset's mesh. Its frame may differ from the
/// loaded dataset's by that exact translation (the dataset's offset comes from its points) and,
/// at the ends of the f64 range only, by a power-of-two scale (chosen here from the mesh alone,
/// there from the points and the mesh); never in shape. An error when the dataset has no mesh
/// or the mesh cannot be read.
pub fn load_mesh(spec: &FileDataset) -> Result<(TriMesh, SourceFile)> {
    let path = spec
        .mesh
        .as_ref()
        .with_context(|| format!("dataset {} has no mesh", spec.name))?;
    let file = sha256_of(path)?;
    let mut mesh = read_mesh(path)?;
    let origin = cloud::recentre::exact_offset(&mesh.vertices);
    cloud::recentre::shift(&mut mesh.vertices, origin);
    rescale_exactly(&spec.name, &mut [&mut mesh.vertices])?;
    Ok((mesh, file))
}

/// Rescales every point of `sets` by the one power-of-two factor pair `hull::exact_rescale`
/// chooses over all their coordinates (where they are at the ends of the f64 range; exact),
/// and returns it (`(1, 1)`: unchanged).
fn rescale_exactly(name: &str, sets: &mut [&mut [DVec3]]) -> Result<(f64, f64)> {
    let coords = sets
        .iter()
        .flat_map(|s| s.iter())
        .flat_map(|p| p.to_array());
    let scale = hull::exact_rescale(coords)
        .with_context(|| format!("dataset {name}"))?
        .unwrap_or((1.0, 1.0));
    if scale != (1.0, 1.0) {
        for p in sets.iter_mut().flat_map(|s| s.iter_mut()) {
            *p = *p * scale.0 * scale.1;
        }
    }
    Ok(scale)
}

/// Loads a dataset made of user files, recentred without loss.
pub fn load_files(spec: &FileDataset) -> Result<Dataset> {
    let mut files = Vec::new();
    let mesh = match &spec.mesh {
        Some(p) => {
            files.push(sha256_of(p)?);
            Some(read_mesh(p)?)
        }
        None => None,
    };
    let (mut cloud, scanners) = match (&spec.cloud, spec.sample) {
        (Some(p), _) => {
            files.push(sha256_of(p)?);
            let loaded = cloud::io::read_with(p, &spec.read)?;
            (loaded.cloud, loaded.scanners)
        }
        (None, Some((n, seed))) => {
            let mesh = mesh.as_ref().context("sampling needs a mesh")?;
            (cloud::sample::sample_surface(mesh, n, seed)?, Vec::new())
        }
        (None, None) => bail!("dataset {} has neither a cloud nor a sample", spec.name),
    };
    if cloud.is_empty() {
        bail!("dataset {}: the cloud has no points", spec.name);
    }
    cloud.validate()?;
    // Recentre: one lossless offset for the cloud and the mesh together.
    let mut origin = cloud::recentre::exact_offset(&cloud.positions);
    if let Some(m) = &mesh
        && !cloud::recentre::is_exact_for(&m.vertices, origin)
    {
        origin = DVec3::ZERO;
    }
    cloud::recentre::shift(&mut cloud.positions, origin);
    let mut mesh = mesh.map(|mut m| {
        cloud::recentre::shift(&mut m.vertices, origin);
        m
    });
    // Rescale: coordinates at the ends of the f64 range, by a power of two, exactly.
    let mut sets: Vec<&mut [DVec3]> = vec![&mut cloud.positions];
    if let Some(m) = mesh.as_mut() {
        sets.push(&mut m.vertices);
    }
    let scale = rescale_exactly(&spec.name, &mut sets)?;
    let from_world = |c: &Camera| c.translated(origin).scaled(scale.0).scaled(scale.1);
    // Degrade (after rescaling: the steps' lengths are relative to the cloud).
    let (mut truth_positions, mut outliers) = (None, None);
    if !spec.degrade.0.is_empty() {
        let d = degrade(&cloud, &spec.degrade.0, spec.degrade.1)?;
        truth_positions = Some(d.truth_positions);
        outliers = Some(d.outliers);
        cloud = d.cloud;
    }
    let views = match &spec.views {
        ViewsFrom::Spec(vs) => {
            let bbox = match &mesh {
                Some(m) => m.bbox(),
                None => cloud.bbox(),
            }
            .context("no points for a bounding box")?;
            fibonacci_views(&bbox, vs)?
        }
        ViewsFrom::File(p) => {
            files.push(sha256_of(p).or_else(|_| -> Result<SourceFile> {
                // A COLMAP folder: hash its images.txt.
                sha256_of(&p.join("images.txt"))
            })?);
            cloud::io::views::read_views(p)?
                .iter()
                .map(from_world)
                .collect()
        }
        ViewsFrom::Scanners => {
            if scanners.is_empty() {
                bail!(
                    "dataset {}: views = \"scanners\" needs an E57 file with scan poses",
                    spec.name
                );
            }
            scanners
                .iter()
                .map(|s| Ok(from_world(&s.camera(2048, 1024)?)))
                .collect::<Result<_>>()?
        }
    };
    Ok(Dataset {
        name: spec.name.clone(),
        description: spec.description.clone(),
        cloud,
        mesh,
        views,
        files,
        origin,
        scale,
        // A tolerance in world units, in the scaled frame.
        surface_tolerance: spec.surface_tolerance.map(|t| t * scale.0 * scale.1),
        truth_positions,
        outliers,
        mesh_fit: None,
        allow_off_surface: spec.allow_off_surface,
    })
}
