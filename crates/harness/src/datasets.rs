//! The dataset registry: one table, names that say what they are.
//!
//! Adding a built-in dataset is one entry in [`REGISTRY`]; a user's files become datasets
//! through a manifest ([`crate::manifest`]) or `visible --cloud` ([`load_files`]), recentred
//! without loss (`cloud::recentre`) and recorded with their SHA-256. Real datasets come from meshes that
//! `pointsight fetch` puts in `bench-data/meshes/` (Debian's `libcgal-demo`, checksummed);
//! synthetic ones are generated in code and need nothing. Every dataset has the points methods
//! see, the mesh the ground truth renders, and its viewpoint set (`cloud::views`, 16 views,
//! 1280 × 720, eyes at 1.5 box diagonals from the centre of the mesh's bounding box). Real
//! datasets keep the source mesh's coordinates: no recentring, no scaling.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result, bail};
use cloud::degrade::{Degradation, Unit};
use cloud::glam::{DVec3, Vec3};
use cloud::synth::{Scene, sphere_plane_scene, sphere_scene, torus_scene};
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{Camera, PointCloud, TriMesh};

use crate::manifest::{Entry, Manifest};

/// A mesh file of the fetched data set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshFile {
    /// File name under `bench-data/meshes/`.
    pub file: &'static str,
    /// Path inside `data.tar.gz` of `libcgal-demo`.
    pub archive_path: &'static str,
    /// SHA-256 of the file.
    pub sha256: &'static str,
}

/// The Stanford Bunny as CGAL ships it (37,706 vertices, 75,408 triangles, closed).
pub const BUNNY_MESH: MeshFile = MeshFile {
    file: "bunny00.off",
    archive_path: "data/meshes/bunny00.off",
    sha256: "ab651cb04955c161efaeb079035a1e5e1f0e0d1f816a2df67beaea68f393ff2b",
};

/// The Chinese Dragon as CGAL ships it (10,000 vertices, 19,994 triangles).
pub const DRAGON_MESH: MeshFile = MeshFile {
    file: "ChineseDragon-10kv.off",
    archive_path: "data/meshes/ChineseDragon-10kv.off",
    sha256: "f633bdfaac7a0f99e0fab668c34862f0c26f341cfdb4665bab282d79b788db02",
};

/// The Armadillo as CGAL ships it (26,002 vertices, 52,000 triangles): the real mesh standing
/// in for seed 003's gargoyle.
pub const ARMADILLO_MESH: MeshFile = MeshFile {
    file: "armadillo.off",
    archive_path: "data/meshes/armadillo.off",
    sha256: "6f7f3ca1abc506569466b72f2f59d49493a284e7376d7a7e23c08115ec8cec4e",
};

/// Every mesh `pointsight fetch` provides.
pub const MESH_FILES: &[MeshFile] = &[BUNNY_MESH, DRAGON_MESH, ARMADILLO_MESH];

/// Where a dataset's points come from.
#[derive(Debug, Clone, Copy)]
pub enum Source {
    /// The vertices of a fetched mesh.
    MeshVertices(MeshFile),
    /// Area-weighted samples of a fetched mesh (`cloud::sample`), reproducible from the seed.
    MeshSamples {
        /// The mesh.
        mesh: MeshFile,
        /// Number of samples.
        n: usize,
        /// Sampling seed.
        seed: u64,
    },
    /// Generated in code.
    Synthetic(fn() -> Result<Scene>),
    /// Samples of a mesh, degraded (`cloud::degrade`, seeded).
    Degraded {
        /// The mesh.
        mesh: MeshFile,
        /// Samples before degrading.
        n: usize,
        /// Seed of the sampling and of the degradations.
        seed: u64,
        /// The steps.
        steps: fn() -> Vec<Degradation>,
    },
    /// A simulated scan (`truth::scan`): `scanners` on a ring at 1.5 bounding-box diagonals
    /// from the mesh's centre, 0.5 diagonals up, each a `width × height` grid, range noise
    /// `sigma` diagonals, range at most 5 diagonals.
    Scanned {
        /// The mesh.
        mesh: MeshFile,
        /// Number of scanners.
        scanners: usize,
        /// Directions around, per scanner.
        width: u32,
        /// Directions from zenith to nadir, per scanner.
        height: u32,
        /// Range noise, bounding-box diagonals.
        sigma: f64,
        /// Seed of the range noise.
        seed: u64,
    },
}

/// A registry entry.
#[derive(Debug, Clone, Copy)]
pub struct DatasetInfo {
    /// Name used on the command line.
    pub name: &'static str,
    /// Number of points.
    pub n_points: usize,
    /// One line for `pointsight datasets`.
    pub description: &'static str,
    /// Where the points come from.
    pub source: Source,
}

impl DatasetInfo {
    /// True when the dataset needs `pointsight fetch`.
    pub fn needs_fetch(&self) -> bool {
        !matches!(self.source, Source::Synthetic(_))
    }

    /// The mesh file a real dataset needs.
    pub fn mesh_file(&self) -> Option<MeshFile> {
        match self.source {
            Source::MeshVertices(m)
            | Source::MeshSamples { mesh: m, .. }
            | Source::Degraded { mesh: m, .. }
            | Source::Scanned { mesh: m, .. } => Some(m),
            Source::Synthetic(_) => None,
        }
    }
}

fn noise_half_spacing() -> Vec<Degradation> {
    vec![Degradation::Noise {
        sigma: 0.5,
        unit: Unit::Spacing,
        along_normal: false,
    }]
}

fn outliers_five_percent() -> Vec<Degradation> {
    vec![Degradation::Outliers {
        fraction: 0.05,
        near_surface: None,
        unit: Unit::Spacing,
    }]
}

fn sphere() -> Result<Scene> {
    Ok(sphere_scene(20_000))
}

fn sphere_plane() -> Result<Scene> {
    Ok(sphere_plane_scene(8_000, 16_000, 24_000).0)
}

fn torus() -> Result<Scene> {
    Ok(torus_scene(22_321, 22_321)?)
}

fn vase() -> Result<Scene> {
    Ok(cloud::synth::vase_scene(7_171, 7_171)?)
}

/// Every dataset, in listing order.
pub const REGISTRY: &[DatasetInfo] = &[
    DatasetInfo {
        name: "bunny",
        n_points: 37_706,
        description: "Stanford Bunny, the vertices of CGAL's bunny00.off",
        source: Source::MeshVertices(BUNNY_MESH),
    },
    DatasetInfo {
        name: "bunny-69451",
        n_points: 69_451,
        description: "area-weighted samples of bunny00.off (seed 69451), seed 000's Bunny size",
        source: Source::MeshSamples {
            mesh: BUNNY_MESH,
            n: 69_451,
            seed: 69_451,
        },
    },
    DatasetInfo {
        name: "dragon-871414",
        n_points: 871_414,
        description: "area-weighted samples of ChineseDragon-10kv.off (seed 871414), seed 000's Dragon size",
        source: Source::MeshSamples {
            mesh: DRAGON_MESH,
            n: 871_414,
            seed: 871_414,
        },
    },
    DatasetInfo {
        name: "sphere-20000",
        n_points: 20_000,
        description: "synthetic: Fibonacci lattice on the unit sphere (analytic visibility), icosphere mesh",
        source: Source::Synthetic(sphere),
    },
    DatasetInfo {
        name: "sphere-plane-24000",
        n_points: 24_000,
        description: "synthetic: a ball (8,000 points) in front of a square (16,000), analytic occlusion",
        source: Source::Synthetic(sphere_plane),
    },
    DatasetInfo {
        name: "torus-22321",
        n_points: 22_321,
        description: "synthetic: area-weighted samples of a torus with texture coordinates",
        source: Source::Synthetic(torus),
    },
    DatasetInfo {
        name: "vase-7171",
        n_points: 7_171,
        description: "synthetic: area-weighted samples of a vase-like surface of revolution with texture coordinates, seed 003's vase size",
        source: Source::Synthetic(vase),
    },
    DatasetInfo {
        name: "armadillo-200004",
        n_points: 200_004,
        description: "area-weighted samples of CGAL's armadillo.off (seed 200004), seed 003's gargoyle size",
        source: Source::MeshSamples {
            mesh: ARMADILLO_MESH,
            n: 200_004,
            seed: 200_004,
        },
    },
    DatasetInfo {
        name: "bunny-noise-0.5",
        n_points: 69_451,
        description: "bunny-69451 with isotropic Gaussian noise, sigma 0.5 density spacings (truth: the clean samples)",
        source: Source::Degraded {
            mesh: BUNNY_MESH,
            n: 69_451,
            seed: 69_451,
            steps: noise_half_spacing,
        },
    },
    DatasetInfo {
        name: "bunny-outliers-0.05",
        n_points: 72_924,
        description: "bunny-69451 plus 5 % outliers uniform in the bounding box (scored apart)",
        source: Source::Degraded {
            mesh: BUNNY_MESH,
            n: 69_451,
            seed: 69_451,
            steps: outliers_five_percent,
        },
    },
    DatasetInfo {
        name: "bunny-scan-4",
        n_points: BUNNY_SCAN_POINTS,
        description: "simulated scan of bunny00.off from 4 scanners (2048x1024 directions each, range noise 1e-4 diagonals)",
        source: Source::Scanned {
            mesh: BUNNY_MESH,
            scanners: 4,
            width: 2048,
            height: 1024,
            sigma: 1e-4,
            seed: 4,
        },
    },
    DatasetInfo {
        name: "dragon-scan-4",
        n_points: DRAGON_SCAN_POINTS,
        description: "simulated scan of ChineseDragon-10kv.off from 4 scanners (4096x2048 directions each, range noise 1e-4 diagonals)",
        source: Source::Scanned {
            mesh: DRAGON_MESH,
            scanners: 4,
            width: 4096,
            height: 2048,
            sigma: 1e-4,
            seed: 4,
        },
    },
];

/// Points of `bunny-scan-4` (checked on loading: the capture is deterministic).
const BUNNY_SCAN_POINTS: usize = 36_070;
/// Points of `dragon-scan-4`.
const DRAGON_SCAN_POINTS: usize = 159_472;

/// The manifest of this process (`--manifest`, or `pointsight.toml`), set once at start.
static MANIFEST: OnceLock<Option<Manifest>> = OnceLock::new();

/// Uses `manifest` for every later lookup (call once, before loading anything).
pub fn use_manifest(manifest: Option<Manifest>) {
    // A second call keeps the first manifest: the process has one.
    let _ = MANIFEST.set(manifest);
}

fn manifest() -> Option<&'static Manifest> {
    MANIFEST.get().and_then(Option::as_ref)
}

/// The names of every dataset: built-in, then the manifest's.
pub fn names() -> Vec<String> {
    let mut out: Vec<String> = REGISTRY.iter().map(|d| d.name.to_owned()).collect();
    if let Some(m) = manifest() {
        out.extend(m.datasets.keys().cloned());
    }
    out
}

/// Looks a built-in dataset up by name.
pub fn info(name: &str) -> Result<&'static DatasetInfo> {
    REGISTRY.iter().find(|d| d.name == name).with_context(|| {
        format!(
            "unknown dataset {name:?}; known datasets: {}",
            names().join(", ")
        )
    })
}

/// Fails unless `name` is a built-in or manifest dataset.
pub fn check(name: &str) -> Result<()> {
    if manifest().is_some_and(|m| m.datasets.contains_key(name)) {
        return Ok(());
    }
    info(name).map(|_| ())
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

/// Path of a fetched mesh under `data_dir`.
pub fn mesh_path(data_dir: &Path, mesh: &MeshFile) -> PathBuf {
    data_dir.join("meshes").join(mesh.file)
}

/// Reads a fetched mesh (checksummed by `pointsight fetch`), or says to fetch it.
pub fn load_mesh(data_dir: &Path, mesh: &MeshFile) -> Result<TriMesh> {
    let path = mesh_path(data_dir, mesh);
    if !path.exists() {
        bail!(
            "{} is missing: run `pointsight fetch` (it downloads Debian's libcgal-demo into {})",
            path.display(),
            data_dir.display()
        );
    }
    read_mesh(&path)
}

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
    let coords = cloud
        .positions
        .iter()
        .chain(mesh.iter().flat_map(|m| m.vertices.iter()))
        .flat_map(|p| p.to_array());
    let scale = hull::exact_rescale(coords)
        .with_context(|| format!("dataset {}", spec.name))?
        .unwrap_or((1.0, 1.0));
    if scale != (1.0, 1.0) {
        let (f1, f2) = scale;
        for p in &mut cloud.positions {
            *p = *p * f1 * f2;
        }
        if let Some(m) = mesh.as_mut() {
            for p in &mut m.vertices {
                *p = *p * f1 * f2;
            }
        }
    }
    let from_world = |c: &Camera| c.translated(origin).scaled(scale.0).scaled(scale.1);
    // Degrade (after rescaling: the steps' lengths are relative to the cloud).
    let (mut truth_positions, mut outliers) = (None, None);
    if !spec.degrade.0.is_empty() {
        let d = cloud::degrade::apply(&cloud, &spec.degrade.0, spec.degrade.1)?;
        truth_positions = Some(d.truth_positions(&cloud.positions));
        outliers = Some(d.outliers());
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
    })
}

/// The file dataset a manifest entry describes.
pub fn manifest_dataset(m: &Manifest, name: &str, e: &Entry) -> Result<FileDataset> {
    let format = match &e.format {
        Some(f) => Some(cloud::io::Format::from_name(f).with_context(|| {
            format!(
                "dataset {name}: unknown format {f:?}; known: {}",
                cloud::io::Format::NAMES
            )
        })?),
        None => None,
    };
    let views = match (&e.views, &e.view_spec) {
        (Some(v), _) if v.as_os_str() == "scanners" => ViewsFrom::Scanners,
        (Some(v), _) => ViewsFrom::File(m.resolve(v)),
        (None, Some(vs)) => ViewsFrom::Spec(ViewSpec {
            n_views: vs.count,
            distance_factor: vs.distance,
            width: vs.width,
            height: vs.height,
            ..ViewSpec::default()
        }),
        (None, None) => ViewsFrom::Spec(ViewSpec::default()),
    };
    Ok(FileDataset {
        name: name.to_owned(),
        description: if e.description.is_empty() {
            format!("from {}", m.path.display())
        } else {
            e.description.clone()
        },
        cloud: e.cloud.as_ref().map(|p| m.resolve(p)),
        sample: e.sample.map(|s| (s.n, s.seed)),
        mesh: e.mesh.as_ref().map(|p| m.resolve(p)),
        read: cloud::io::ReadOptions {
            format,
            classes: e.classes.clone(),
            scan: e.scan,
        },
        views,
        surface_tolerance: e.surface_tolerance,
        degrade: (
            e.degrade
                .iter()
                .map(|d| d.parse::<Degradation>())
                .collect::<cloud::Result<Vec<_>>>()
                .with_context(|| format!("dataset {name}: degrade"))?,
            e.degrade_seed.unwrap_or(1),
        ),
    })
}

/// Loads a dataset by name: the manifest's, else a built-in one (real datasets need
/// `data_dir` to hold the fetched meshes).
pub fn load(name: &str, data_dir: &Path) -> Result<Dataset> {
    if let Some(m) = manifest()
        && let Some(e) = m.datasets.get(name)
    {
        return load_files(&manifest_dataset(m, name, e)?)
            .with_context(|| format!("dataset {name} of {}", m.path.display()));
    }
    let info = info(name)?;
    let mut truth_positions = None;
    let mut outliers = None;
    let (cloud, mesh) = match info.source {
        Source::MeshVertices(file) => {
            let mesh = load_mesh(data_dir, &file)?;
            let normals: Vec<Vec3> = mesh.vertex_normals().iter().map(|n| n.as_vec3()).collect();
            let cloud = PointCloud {
                positions: mesh.vertices.clone(),
                normals: Some(normals),
                ..PointCloud::default()
            };
            (cloud, mesh)
        }
        Source::MeshSamples {
            mesh: file,
            n,
            seed,
        } => {
            let mesh = load_mesh(data_dir, &file)?;
            let cloud = cloud::sample::sample_surface(&mesh, n, seed)?;
            (cloud, mesh)
        }
        Source::Synthetic(make) => {
            let scene = make()?;
            (scene.cloud, scene.mesh)
        }
        Source::Degraded {
            mesh: file,
            n,
            seed,
            steps,
        } => {
            let mesh = load_mesh(data_dir, &file)?;
            let clean = cloud::sample::sample_surface(&mesh, n, seed)?;
            let d = cloud::degrade::apply(&clean, &steps(), seed)?;
            truth_positions = Some(d.truth_positions(&clean.positions));
            outliers = Some(d.outliers());
            (d.cloud, mesh)
        }
        Source::Scanned {
            mesh: file,
            scanners,
            width,
            height,
            sigma,
            seed,
        } => {
            let mesh = load_mesh(data_dir, &file)?;
            let capture = scan_mesh(&mesh, scanners, width, height, sigma, seed)?;
            truth_positions = Some(capture.clean);
            (capture.cloud, mesh)
        }
    };
    if cloud.len() != info.n_points {
        bail!(
            "dataset {name} has {} points where the registry says {}",
            cloud.len(),
            info.n_points
        );
    }
    cloud.validate()?;
    let bbox = mesh.bbox().context("the dataset's mesh has no vertices")?;
    let views = fibonacci_views(&bbox, &ViewSpec::default())?;
    Ok(Dataset {
        name: info.name.to_owned(),
        description: info.description.to_owned(),
        cloud,
        mesh: Some(mesh),
        views,
        files: Vec::new(),
        origin: DVec3::ZERO,
        scale: (1.0, 1.0),
        surface_tolerance: None,
        truth_positions,
        outliers,
    })
}

/// The mesh of dataset `name` alone (without sampling its cloud, where that can be avoided).
pub fn load_mesh_of(name: &str, data_dir: &Path) -> Result<TriMesh> {
    if manifest().is_some_and(|m| m.datasets.contains_key(name)) {
        return load(name, data_dir)?
            .mesh
            .with_context(|| format!("dataset {name} has no mesh"));
    }
    match info(name)?.source {
        Source::MeshVertices(file)
        | Source::MeshSamples { mesh: file, .. }
        | Source::Degraded { mesh: file, .. }
        | Source::Scanned { mesh: file, .. } => load_mesh(data_dir, &file),
        Source::Synthetic(make) => Ok(make()?.mesh),
    }
}

/// A simulated scan of `mesh` ([`Source::Scanned`]).
pub fn scan_mesh(
    mesh: &TriMesh,
    scanners: usize,
    width: u32,
    height: u32,
    sigma: f64,
    seed: u64,
) -> Result<truth::scan::Capture> {
    let bbox = mesh.bbox().context("the mesh has no vertices")?;
    let diagonal = bbox.diagonal();
    let surface = truth::ExactVisibility::new(mesh)?;
    let positions = truth::scan::ring(bbox.center(), 1.5 * diagonal, 0.5 * diagonal, scanners);
    let scanners: Vec<truth::scan::Scanner> = positions
        .into_iter()
        .map(|position| truth::scan::Scanner {
            position,
            width,
            height,
            max_range: 5.0 * diagonal,
            range_sigma: sigma * diagonal,
        })
        .collect();
    Ok(truth::scan::capture(
        &surface,
        (bbox.center(), 0.5 * diagonal * 1.0001),
        &scanners,
        seed,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_datasets_load_with_their_registered_sizes() {
        for info in REGISTRY.iter().filter(|d| !d.needs_fetch()) {
            let ds = load(info.name, Path::new("/nonexistent")).unwrap();
            assert_eq!(ds.cloud.len(), info.n_points, "{}", info.name);
            assert_eq!(ds.views.len(), 16);
        }
    }

    #[test]
    fn real_dataset_without_data_says_to_fetch() {
        let err = load("bunny", Path::new("/nonexistent")).unwrap_err();
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
    fn a_manifest_degrades_its_dataset_and_keeps_the_truth_clean() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = sphere_scene(100).mesh;
        let mut off = format!("OFF\n{} {} 0\n", mesh.vertices.len(), mesh.triangles.len());
        for v in &mesh.vertices {
            off.push_str(&format!("{} {} {}\n", v.x, v.y, v.z));
        }
        for t in &mesh.triangles {
            off.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
        }
        std::fs::write(dir.path().join("ball.off"), off).unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(
            &path,
            "[datasets.noisy]\nmesh = \"ball.off\"\nsample = { n = 5000, seed = 2 }\n\
             degrade = [\"noise:sigma=0.5\", \"outliers:fraction=0.1\"]\ndegrade_seed = 3\n",
        )
        .unwrap();
        let m = Manifest::read(&path).unwrap();
        let spec = manifest_dataset(&m, "noisy", &m.datasets["noisy"]).unwrap();
        let ds = load_files(&spec).unwrap();
        assert_eq!(ds.cloud.len(), 5_500);
        let outliers = ds.outliers.as_ref().unwrap();
        assert_eq!(outliers.iter().filter(|&&o| o).count(), 500);
        let truth = ds.truth_positions.as_ref().unwrap();
        // Surface points' truth positions lie on the mesh; the points themselves do not.
        let exact = truth::ExactVisibility::new(ds.mesh.as_ref().unwrap()).unwrap();
        let on = |p: DVec3| exact.distance(p) < 1e-9;
        assert!((0..5_000).all(|i| on(truth[i])));
        assert!((0..5_000).filter(|&i| on(ds.cloud.positions[i])).count() < 100);
        let bad = "[datasets.x]\nmesh = \"ball.off\"\nsample = { n = 10, seed = 1 }\ndegrade = [\"blur:sigma=1\"]\n";
        std::fs::write(&path, bad).unwrap();
        let m = Manifest::read(&path).unwrap();
        let err = format!(
            "{:#}",
            manifest_dataset(&m, "x", &m.datasets["x"]).unwrap_err()
        );
        assert!(err.contains("unknown degradation \"blur\""), "{err}");
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
