//! The built-in datasets: one table ([`REGISTRY`]) and how each entry loads.
//!
//! Adding a built-in dataset is one entry in [`REGISTRY`]. Real datasets come from meshes that
//! `pointsight fetch` puts in `bench-data/meshes/` (the catalogue is [`crate::fetch`]'s);
//! synthetic ones are generated in code and need nothing. Every dataset has the points methods
//! see, the mesh the ground truth renders, and its viewpoint set (`cloud::views`, 16 views,
//! 1280 × 720, eyes at 1.5 box diagonals from the centre of the mesh's bounding box). Real
//! datasets keep the source mesh's coordinates: no recentring, no scaling.

use std::path::Path;

use anyhow::{Context, Result, bail};
use cloud::degrade::{Degradation, Unit};
use cloud::glam::{DVec3, Vec3};
use cloud::synth::{Scene, sphere_plane_scene, sphere_scene, torus_scene};
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{PointCloud, TriMesh};

use super::Dataset;
use super::degraded::degrade;
use super::files::read_mesh;
use crate::fetch::{ARMADILLO_MESH, BUNNY_MESH, DRAGON_MESH, MeshFile, mesh_path};

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

/// Loads the built-in dataset `info` (real datasets need `data_dir` to hold the fetched
/// meshes).
pub fn load(info: &DatasetInfo, data_dir: &Path) -> Result<Dataset> {
    let name = info.name;
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
            let d = degrade(&clean, &steps(), seed)?;
            truth_positions = Some(d.truth_positions);
            outliers = Some(d.outliers);
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

/// The mesh of the built-in dataset `info` alone (without sampling its cloud).
pub fn load_mesh_of(info: &DatasetInfo, data_dir: &Path) -> Result<TriMesh> {
    match info.source {
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
