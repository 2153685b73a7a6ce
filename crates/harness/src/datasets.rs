//! The dataset registry: one table, names that say what they are.
//!
//! Adding a dataset is one entry in [`REGISTRY`]. Real datasets come from meshes that
//! `pointsight fetch` puts in `bench-data/meshes/` (Debian's `libcgal-demo`, checksummed);
//! synthetic ones are generated in code and need nothing. Every dataset has the points methods
//! see, the mesh the ground truth renders, and its viewpoint set (`cloud::views`, 16 views,
//! 1280 × 720, eyes at 1.5 box diagonals from the centre of the mesh's bounding box). Real
//! datasets keep the source mesh's coordinates: no recentring, no scaling.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::glam::Vec3;
use cloud::synth::{Scene, sphere_plane_scene, sphere_scene, torus_scene};
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{Camera, PointCloud, TriMesh};

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
            Source::MeshVertices(m) | Source::MeshSamples { mesh: m, .. } => Some(m),
            Source::Synthetic(_) => None,
        }
    }
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
];

/// Looks a dataset up by name.
pub fn info(name: &str) -> Result<&'static DatasetInfo> {
    REGISTRY.iter().find(|d| d.name == name).with_context(|| {
        format!(
            "unknown dataset {name:?}; known datasets: {}",
            REGISTRY
                .iter()
                .map(|d| d.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// A dataset in memory: points, mesh and views.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Its registry entry.
    pub info: &'static DatasetInfo,
    /// The points methods see.
    pub cloud: PointCloud,
    /// The surface the ground truth renders.
    pub mesh: TriMesh,
    /// Its viewpoint set.
    pub views: Vec<Camera>,
}

impl Dataset {
    /// The dataset's name.
    pub fn name(&self) -> &'static str {
        self.info.name
    }

    /// View `k`, or an error naming the valid range.
    pub fn view(&self, k: usize) -> Result<&Camera> {
        self.views.get(k).with_context(|| {
            format!(
                "view {k} does not exist: dataset {} has views 0..{}",
                self.name(),
                self.views.len() - 1
            )
        })
    }
}

/// Path of a fetched mesh under `data_dir`.
pub fn mesh_path(data_dir: &Path, mesh: &MeshFile) -> PathBuf {
    data_dir.join("meshes").join(mesh.file)
}

fn load_mesh(data_dir: &Path, mesh: &MeshFile) -> Result<TriMesh> {
    let path = mesh_path(data_dir, mesh);
    if !path.exists() {
        bail!(
            "{} is missing: run `pointsight fetch` (it downloads Debian's libcgal-demo into {})",
            path.display(),
            data_dir.display()
        );
    }
    let loaded = cloud::io::read(&path)?;
    let mesh = loaded.mesh();
    mesh.validate()?;
    Ok(mesh)
}

/// Loads a dataset by name; real datasets need `data_dir` to hold the fetched meshes.
pub fn load(name: &str, data_dir: &Path) -> Result<Dataset> {
    let info = info(name)?;
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
        info,
        cloud,
        mesh,
        views,
    })
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
