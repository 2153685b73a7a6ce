//! Datasets: what the experiments and `visible` load by name, and the dataset in memory.
//!
//! A name is a built-in dataset ([`builtin`]: one table, names that say what they are) or one
//! of the process's manifest ([`manifest`]: datasets made of the user's files, loaded through
//! the frame of [`files`]: read, recentred without loss, rescaled exactly, degraded,
//! recorded with their SHA-256). Degraded clouds keep their truth bookkeeping through
//! [`degrade`], the one place that does it. A user's mesh is checked against the points before
//! it becomes a ground truth ([`fit`]). The real meshes and `pointsight fetch` are
//! [`crate::fetch`]'s.
//!
//! A manifest dataset may instead be a built LOD file ([`lod_file`], the `lod` experiment's
//! alone).
//!
//! Layers: `manifest` → `builtin`, `files` → `degraded`; this module looks names up over
//! them; none of them imports it back but for the [`Dataset`] type.

pub mod builtin;
pub mod degraded;
pub mod eyes;
pub mod files;
pub mod fit;
pub mod lod_file;
pub mod manifest;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::glam::DVec3;
use cloud::{Camera, PointCloud, TriMesh};

pub use builtin::{DatasetInfo, REGISTRY, Role, Source, role};
pub use degraded::{Degraded, degrade};
pub use files::{FileDataset, ViewsFrom, load_files, read_mesh};
pub use lod_file::LodFileDataset;
use manifest::{Manifest, manifest_dataset, views_from};

/// The datasets a run knows: the built-in ones and its manifest's (`--manifest`, or
/// `pointsight.toml`). A value of the run ([`crate::run::Run`]), not process state.
#[derive(Debug, Clone, Default)]
pub struct Datasets {
    manifest: Option<Manifest>,
}

impl Datasets {
    /// The built-in datasets and, when given, `manifest`'s.
    pub fn new(manifest: Option<Manifest>) -> Self {
        Self { manifest }
    }

    /// The manifest, if any.
    pub fn manifest(&self) -> Option<&Manifest> {
        self.manifest.as_ref()
    }

    /// The manifest's file, as given (`None` without one): what a child process of the same
    /// run must read too (the `scale` experiment's cells).
    pub fn manifest_path(&self) -> Option<&Path> {
        self.manifest.as_ref().map(|m| m.path.as_path())
    }

    /// The names of every dataset: built-in, then the manifest's.
    pub fn names(&self) -> Vec<String> {
        let mut out: Vec<String> = REGISTRY.iter().map(|d| d.name.to_owned()).collect();
        if let Some(m) = &self.manifest {
            out.extend(m.datasets.keys().cloned());
        }
        out
    }

    /// Looks a built-in dataset up by name (the error lists every name, the manifest's too).
    pub fn info(&self, name: &str) -> Result<&'static DatasetInfo> {
        REGISTRY.iter().find(|d| d.name == name).with_context(|| {
            format!(
                "unknown dataset {name:?}; known datasets: {}",
                self.names().join(", ")
            )
        })
    }

    /// Fails unless `name` is a built-in or manifest dataset.
    pub fn check(&self, name: &str) -> Result<()> {
        if self
            .manifest
            .as_ref()
            .is_some_and(|m| m.datasets.contains_key(name))
        {
            return Ok(());
        }
        self.info(name).map(|_| ())
    }
}

/// Looks a built-in dataset up by name (the error lists the built-in names).
pub fn info(name: &str) -> Result<&'static DatasetInfo> {
    Datasets::default().info(name)
}

/// A user file a dataset was made from: its path and SHA-256 (for the run metadata).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SourceFile {
    /// The path as given.
    pub path: PathBuf,
    /// SHA-256 of its bytes, hex.
    pub sha256: String,
}

/// A dataset in memory: points, the mesh the ground truth needs (when there is one), views.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Name used on the command line.
    pub name: String,
    /// One line for listings.
    pub description: String,
    /// The points methods see (recentred: world = `origin` + position).
    pub cloud: PointCloud,
    /// The surface the ground truth renders, in the same frame; `None` for a bare scan.
    pub mesh: Option<TriMesh>,
    /// Its viewpoint set, in the same frame.
    pub views: Vec<Camera>,
    /// User files it was read from.
    pub files: Vec<SourceFile>,
    /// The lossless offset subtracted from user files' coordinates (`cloud::recentre`); zero
    /// for built-in datasets, which keep their source coordinates.
    pub origin: DVec3,
    /// The power of two, as two factors applied in turn, the recentred coordinates were
    /// multiplied by when they lay outside [2^-100, 2^100] (`hull::exact_rescale`: exact, and
    /// every visibility answer is invariant under it); (1, 1) otherwise. Position = (world −
    /// origin) × scale.
    pub scale: (f64, f64),
    /// Points farther than this from the mesh are off-surface (scored apart); `None`: one
    /// density spacing.
    pub surface_tolerance: Option<f64>,
    /// For degraded and scanned datasets: per point, where it truly lies on the surface (the
    /// clean sample a noisy point came from, the noise-free hit of a scanner ray); its ground
    /// truth is that position's visibility. `None`: the points themselves.
    pub truth_positions: Option<Vec<DVec3>>,
    /// For degraded datasets: per point, whether it is an added outlier (scored apart, with
    /// the off-surface points).
    pub outliers: Option<Vec<bool>>,
    /// How far the points lie from the mesh, once checked ([`fit::check`]: a user's dataset
    /// with a mesh); `None`: not checked (built-in datasets, no mesh).
    pub mesh_fit: Option<fit::MeshFit>,
    /// True when a mesh that does not fit may be used anyway (a manifest entry's
    /// `allow_off_surface`; `--allow-off-surface` adds it for every dataset of a command).
    pub allow_off_surface: bool,
}

impl Dataset {
    /// The positions whose visibility is the ground truth ([`Dataset::truth_positions`], else
    /// the points).
    pub fn truth_points(&self) -> &[DVec3] {
        self.truth_positions
            .as_deref()
            .unwrap_or(&self.cloud.positions)
    }

    /// A camera given in world coordinates, in the dataset's frame.
    pub fn camera_from_world(&self, camera: &Camera) -> Camera {
        camera
            .translated(self.origin)
            .scaled(self.scale.0)
            .scaled(self.scale.1)
    }

    /// The points in world coordinates (both steps undone exactly).
    pub fn world_positions(&self) -> Vec<DVec3> {
        let (f1, f2) = self.scale;
        self.cloud
            .positions
            .iter()
            .map(|&p| p / f2 / f1 + self.origin)
            .collect()
    }

    /// The dataset's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What the methods prepare on.
    pub fn input(&self) -> registry::Input<'_> {
        registry::Input {
            cloud: &self.cloud,
            mesh: self.mesh.as_ref(),
        }
    }

    /// The mesh, or an error saying that `what` needs one.
    pub fn mesh(&self, what: &str) -> Result<&TriMesh> {
        self.mesh.as_ref().with_context(|| {
            format!(
                "{what} needs a mesh (the ground truth renders it); dataset {} has none: add \
                 `mesh = ...` to its manifest entry or `--mesh FILE`",
                self.name
            )
        })
    }

    /// Fails unless every view can look at the cloud (`cloud::Camera::check_view_of`: no eye
    /// on a point, none so far that the cloud is below its coordinates' precision), naming the
    /// view: the one check the ground truth and every method share, made wherever a dataset
    /// gets its views (its own, a views file, the camera flags).
    pub fn check_views(&self) -> Result<()> {
        for (k, camera) in self.views.iter().enumerate() {
            camera
                .check_view_of(&self.cloud.positions)
                .with_context(|| format!("view {k} of dataset {}", self.name))?;
        }
        Ok(())
    }

    /// View `k`, or an error naming the valid range.
    pub fn view(&self, k: usize) -> Result<&Camera> {
        self.views.get(k).with_context(|| {
            format!(
                "view {k} does not exist: dataset {} has views 0..{}",
                self.name(),
                self.views.len().saturating_sub(1)
            )
        })
    }

    /// The `mesh_fit` of rows scored against this dataset's mesh: `off-surface` for a mesh
    /// that does not fit, used anyway ([`fit::MeshFit::mark`]), else `ok` (a built-in dataset
    /// is a sample of its own mesh); empty without a mesh.
    pub fn mesh_fit_mark(&self) -> &'static str {
        match (&self.mesh, &self.mesh_fit) {
            (None, _) => "",
            (Some(_), Some(fit)) => fit.mark(),
            (Some(_), None) => "ok",
        }
    }

    /// Which points lie farther than the surface tolerance from the mesh (`None` without a
    /// mesh); the tolerance used.
    pub fn off_surface(&self) -> Result<Option<(Vec<bool>, f64)>> {
        let Some(mesh) = &self.mesh else {
            return Ok(None);
        };
        let tolerance = match self.surface_tolerance {
            Some(t) => t,
            None => cloud::spacing::density_spacing(&self.cloud.positions, 8, 20_000, 1)?,
        };
        let d = truth::ExactVisibility::new(mesh)?.distances(self.truth_points())?;
        let outlier = |i: usize| self.outliers.as_ref().is_some_and(|o| o[i]);
        Ok(Some((
            d.iter()
                .enumerate()
                .map(|(i, &d)| d > tolerance || outlier(i))
                .collect(),
            tolerance,
        )))
    }
}

impl Datasets {
    /// Loads a dataset by name: the manifest's, else a built-in one (real datasets need
    /// `data_dir` to hold the fetched meshes).
    pub fn load(&self, name: &str, data_dir: &Path) -> Result<Dataset> {
        if let Some(m) = self.manifest.as_ref()
            && let Some(e) = m.datasets.get(name)
        {
            if e.lod_file.is_some() {
                bail!(
                    "dataset {name} of {} is a built QSplat file (lod_file), not points: only the \
                     lod experiment selects from it",
                    m.path.display()
                );
            }
            let ds = load_files(&manifest_dataset(m, name, e)?)
                .with_context(|| format!("dataset {name} of {}", m.path.display()))?;
            ds.check_views()?;
            return Ok(ds);
        }
        let ds = builtin::load(self.info(name)?, data_dir)?;
        ds.check_views()?;
        Ok(ds)
    }

    /// The mesh file of manifest dataset `name` (resolved against the manifest's folder); `None`
    /// for any other dataset or one without a mesh.
    pub fn manifest_mesh(&self, name: &str) -> Option<PathBuf> {
        let m = self.manifest.as_ref()?;
        m.datasets.get(name)?.mesh.as_ref().map(|p| m.resolve(p))
    }

    /// The built LOD file of dataset `name` when the manifest gives it one (`lod_file`), opened
    /// with its views; `None` for a dataset of points.
    pub fn lod_file(&self, name: &str) -> Result<Option<LodFileDataset>> {
        let Some(m) = self.manifest.as_ref() else {
            return Ok(None);
        };
        let Some(e) = m.datasets.get(name) else {
            return Ok(None);
        };
        let Some(path) = &e.lod_file else {
            return Ok(None);
        };
        lod_file::open(name, &m.resolve(path), &views_from(m, e))
            .with_context(|| format!("dataset {name} of {}", m.path.display()))
            .map(Some)
    }

    /// The mesh and the sample `(n, seed)` of dataset `name` when it is a manifest's plain sample
    /// of a mesh ([`files::plain_sample`]): its points are the sampler's draws, which a command
    /// may write as they come instead of loading the dataset. `None` for any other dataset.
    pub fn plain_sample(&self, name: &str) -> Result<Option<(TriMesh, usize, u64)>> {
        let Some(m) = self.manifest.as_ref() else {
            return Ok(None);
        };
        let Some(e) = m.datasets.get(name) else {
            return Ok(None);
        };
        if e.lod_file.is_some() {
            return Ok(None);
        }
        let spec = manifest_dataset(m, name, e)?;
        files::plain_sample(&spec)
            .with_context(|| format!("dataset {name} of {}", m.path.display()))
    }

    /// The mesh of dataset `name` alone, with the user's file it came from (none for a built-in
    /// dataset): neither its cloud file nor its sample is read or drawn, so a `scale` cell's peak
    /// holds only what it measures and a sample larger than memory is no obstacle. A manifest's
    /// mesh comes from [`files::load_mesh`] (recentred by its own exact offset), a built-in
    /// dataset's as its file has it.
    pub fn load_mesh_of(&self, name: &str, data_dir: &Path) -> Result<(TriMesh, Vec<SourceFile>)> {
        if let Some(m) = self.manifest.as_ref()
            && let Some(e) = m.datasets.get(name)
        {
            if e.lod_file.is_some() {
                bail!(
                    "dataset {name} of {} is a built QSplat file (lod_file), not a mesh",
                    m.path.display()
                );
            }
            return files::load_mesh(&manifest_dataset(m, name, e)?)
                .map(|(mesh, file)| (mesh, vec![file]))
                .with_context(|| format!("dataset {name} of {}", m.path.display()));
        }
        Ok((
            builtin::load_mesh_of(self.info(name)?, data_dir)?,
            Vec::new(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_datasets_load_with_their_registered_sizes() {
        for info in REGISTRY.iter().filter(|d| !d.needs_fetch()) {
            let ds = Datasets::default()
                .load(info.name, Path::new("/nonexistent"))
                .unwrap();
            assert_eq!(ds.cloud.len(), info.n_points, "{}", info.name);
            assert_eq!(ds.views.len(), 16);
        }
    }

    #[test]
    fn real_dataset_without_data_says_to_fetch() {
        let err = Datasets::default()
            .load("bunny", Path::new("/nonexistent"))
            .unwrap_err();
        assert!(format!("{err:#}").contains("pointsight fetch"), "{err:#}");
    }

    #[test]
    fn unknown_dataset_lists_the_known_ones() {
        let err = info("teapot").unwrap_err().to_string();
        assert!(
            err.contains("bunny-69451") && err.contains("sphere-20000"),
            "{err}"
        );
    }

    #[test]
    fn names_are_unique_and_end_with_the_size_where_sampled() {
        for (i, a) in REGISTRY.iter().enumerate() {
            assert!(REGISTRY[i + 1..].iter().all(|b| b.name != a.name));
            if let Source::MeshSamples { n, .. } = a.source {
                assert!(a.name.ends_with(&n.to_string()));
                assert_eq!(n, a.n_points);
            }
        }
    }
}
