//! The built-in datasets: one table ([`REGISTRY`]) and how each entry loads.
//!
//! Adding a built-in dataset is one entry in [`REGISTRY`]. Real datasets come from meshes that
//! `pointsight fetch` puts in `bench-data/meshes/` (the catalogue is [`crate::fetch`]'s);
//! synthetic ones are generated in code and need nothing. Every dataset has the points methods
//! see, the mesh the ground truth renders, and its viewpoint set (`cloud::views`, 16 views,
//! 1280 × 720, eyes at 1.5 box diagonals from the centre of the mesh's bounding box). Real
//! datasets keep the source mesh's coordinates: no recentring, no scaling.
//!
//! Each entry has a [`Role`] (the tuning/evaluation protocol): the **tuning** datasets are the ones a
//! method's "best" setting is chosen on; the **evaluation** datasets (four further meshes of the
//! same Debian package, area-weighted samples) are never used to choose a setting, so a score
//! there at the tuned setting is an out-of-sample figure. How the tuned setting is computed is
//! `experiments::visibility::tuning`'s.

use std::path::Path;

use anyhow::{Context, Result, bail};
use cloud::degrade::{Degradation, Unit};
use cloud::glam::{DVec3, Vec3};
use cloud::synth::{Scene, sphere_plane_scene, sphere_scene, torus_scene};
use cloud::views::{ViewSpec, fibonacci_views};
use cloud::{PointCloud, TriMesh};
use serde::{Deserialize, Serialize};

use super::Dataset;
use super::degraded::degrade;
use super::files::read_mesh;
use crate::fetch::{
    ARMADILLO_MESH, BUNNY_MESH, CAMEL_MESH, DRAGON_MESH, ELEPHANT_MESH, MANNEQUIN_MESH, MeshFile,
    TRICERATOPS_MESH, mesh_path,
};

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
    /// A simulated scan (`truth::scan`): scanners placed by `rig`, each a `width × height`
    /// grid, range noise `sigma` diagonals, range at most 5 diagonals.
    Scanned {
        /// The mesh.
        mesh: MeshFile,
        /// Where the scanners stand.
        rig: Rig,
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

/// Where a simulated scan's scanners stand (diagonals: the mesh's bounding-box diagonal D).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rig {
    /// Terrestrial: this many scanners on a horizontal ring at 1.5 D from the mesh's centre,
    /// 0.5 D up (`truth::scan::ring`); the dataset's views are the standard 16.
    Ring(usize),
    /// Mobile mapping: this many profile scanners (width 2: the plane across the direction of
    /// travel) evenly along a straight pass at 1 D beside the mesh's centre (along +x, from
    /// −1.2 D to +1.2 D, offset −D in y), as a vehicle's scanner sweeps one profile per step;
    /// the density falls with range across the pass and is fixed by the speed along it. Its
    /// views are 16 cameras on the vehicle ([`mobile_views`]).
    Line(usize),
}

/// What a dataset is for in the tuning/evaluation protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Settings are chosen on it ("best" means best over these); scores on it are in-sample.
    Tuning,
    /// Never used to choose a setting: scores at the tuned setting are out-of-sample.
    Evaluation,
    /// Not a built-in dataset (a user's files or manifest): neither, unless a run says so.
    Own,
}

impl Role {
    /// The word used in tables and listings.
    pub fn word(self) -> &'static str {
        match self {
            Role::Tuning => "tuning",
            Role::Evaluation => "evaluation",
            Role::Own => "own",
        }
    }
}

/// The role of the dataset named `name`: its registry entry's, else [`Role::Own`].
pub fn role(name: &str) -> Role {
    REGISTRY
        .iter()
        .find(|d| d.name == name)
        .map_or(Role::Own, |d| d.role)
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
    /// Tuning or evaluation ([`Role`]).
    pub role: Role,
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
        role: Role::Tuning,
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
        role: Role::Tuning,
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
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "sphere-20000",
        n_points: 20_000,
        description: "synthetic: Fibonacci lattice on the unit sphere (analytic visibility), icosphere mesh",
        source: Source::Synthetic(sphere),
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "sphere-plane-24000",
        n_points: 24_000,
        description: "synthetic: a ball (8,000 points) in front of a square (16,000), analytic occlusion",
        source: Source::Synthetic(sphere_plane),
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "torus-22321",
        n_points: 22_321,
        description: "synthetic: area-weighted samples of a torus with texture coordinates",
        source: Source::Synthetic(torus),
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "vase-7171",
        n_points: 7_171,
        description: "synthetic: area-weighted samples of a vase-like surface of revolution with texture coordinates, seed 003's vase size",
        source: Source::Synthetic(vase),
        role: Role::Tuning,
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
        role: Role::Tuning,
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
        role: Role::Tuning,
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
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "bunny-scan-4",
        n_points: BUNNY_SCAN_POINTS,
        description: "simulated scan of bunny00.off from 4 scanners (2048x1024 directions each, range noise 1e-4 diagonals)",
        source: Source::Scanned {
            mesh: BUNNY_MESH,
            rig: Rig::Ring(4),
            width: 2048,
            height: 1024,
            sigma: 1e-4,
            seed: 4,
        },
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "dragon-scan-4",
        n_points: DRAGON_SCAN_POINTS,
        description: "simulated scan of ChineseDragon-10kv.off from 4 scanners (4096x2048 directions each, range noise 1e-4 diagonals)",
        source: Source::Scanned {
            mesh: DRAGON_MESH,
            rig: Rig::Ring(4),
            width: 4096,
            height: 2048,
            sigma: 1e-4,
            seed: 4,
        },
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "bunny-mobile",
        n_points: BUNNY_MOBILE_POINTS,
        description: "simulated mobile-mapping pass beside bunny00.off: 400 profiles of 4096 directions along a line, range noise 1e-4 diagonals; views from the vehicle",
        source: Source::Scanned {
            mesh: BUNNY_MESH,
            rig: Rig::Line(400),
            width: 2,
            height: 4096,
            sigma: 1e-4,
            seed: 5,
        },
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "dragon-mobile",
        n_points: DRAGON_MOBILE_POINTS,
        description: "simulated mobile-mapping pass beside ChineseDragon-10kv.off: 800 profiles of 8192 directions along a line, range noise 1e-4 diagonals; views from the vehicle",
        source: Source::Scanned {
            mesh: DRAGON_MESH,
            rig: Rig::Line(800),
            width: 2,
            height: 8192,
            sigma: 1e-4,
            seed: 5,
        },
        role: Role::Tuning,
    },
    DatasetInfo {
        name: "elephant-50000",
        n_points: 50_000,
        description: "area-weighted samples of CGAL's elephant.off (seed 50001)",
        source: Source::MeshSamples {
            mesh: ELEPHANT_MESH,
            n: 50_000,
            seed: 50_001,
        },
        role: Role::Evaluation,
    },
    DatasetInfo {
        name: "camel-50000",
        n_points: 50_000,
        description: "area-weighted samples of CGAL's camel.off (seed 50002)",
        source: Source::MeshSamples {
            mesh: CAMEL_MESH,
            n: 50_000,
            seed: 50_002,
        },
        role: Role::Evaluation,
    },
    DatasetInfo {
        name: "triceratops-50000",
        n_points: 50_000,
        description: "area-weighted samples of CGAL's triceratops.off (seed 50003)",
        source: Source::MeshSamples {
            mesh: TRICERATOPS_MESH,
            n: 50_000,
            seed: 50_003,
        },
        role: Role::Evaluation,
    },
    DatasetInfo {
        name: "mannequin-50000",
        n_points: 50_000,
        description: "area-weighted samples of CGAL's mannequin-devil.off, a bust open at the neck (seed 50004)",
        source: Source::MeshSamples {
            mesh: MANNEQUIN_MESH,
            n: 50_000,
            seed: 50_004,
        },
        role: Role::Evaluation,
    },
];

/// Points of `bunny-scan-4` (checked on loading: the capture is deterministic).
const BUNNY_SCAN_POINTS: usize = 36_070;
/// Points of `dragon-scan-4`.
const DRAGON_SCAN_POINTS: usize = 159_472;
/// Points of `bunny-mobile`.
const BUNNY_MOBILE_POINTS: usize = 46_179;
/// Points of `dragon-mobile`.
const DRAGON_MOBILE_POINTS: usize = 172_965;

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
            rig,
            width,
            height,
            sigma,
            seed,
        } => {
            let mesh = load_mesh(data_dir, &file)?;
            let capture = scan_mesh(&mesh, rig, width, height, sigma, seed)?;
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
    let views = match info.source {
        Source::Scanned {
            rig: Rig::Line(_), ..
        } => mobile_views(&bbox)?,
        _ => fibonacci_views(&bbox, &ViewSpec::default())?,
    };
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
        mesh_fit: None,
        allow_off_surface: false,
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

/// The pass of a [`Rig::Line`]: `count` positions from −1.2 D to +1.2 D along x, at −D in y
/// from the centre of `bbox` (D its diagonal).
fn pass(bbox: &cloud::Aabb, count: usize) -> Vec<DVec3> {
    let d = bbox.diagonal();
    let start = bbox.center() + DVec3::new(-1.2 * d, -d, 0.0);
    let end = bbox.center() + DVec3::new(1.2 * d, -d, 0.0);
    (0..count)
        .map(|k| start.lerp(end, (k as f64 + 0.5) / count.max(1) as f64))
        .collect()
}

/// The views of a mobile pass: 16 pinhole cameras (1280 × 720) on the vehicle, 0.05 D above
/// the scanner's line, evenly along its middle 2 D, each looking at the mesh's centre with a
/// field of view that frames the bounding sphere (5 % margin, as `fibonacci_views`).
pub fn mobile_views(bbox: &cloud::Aabb) -> Result<Vec<cloud::Camera>> {
    let d = bbox.diagonal();
    let spec = ViewSpec::default();
    let centre = bbox.center();
    (0..spec.n_views)
        .map(|k| {
            let t = -1.0 + 2.0 * (k as f64 + 0.5) / spec.n_views as f64;
            let eye = centre + DVec3::new(t * d, -d, 0.05 * d);
            let half = (0.5 * d / (eye - centre).length()).asin();
            let fov = (2.0 * half).to_degrees() * (1.0 + spec.margin);
            Ok(cloud::Camera::new(
                eye,
                centre,
                DVec3::Z,
                fov,
                spec.width,
                spec.height,
            )?)
        })
        .collect()
}

/// A simulated scan of `mesh` ([`Source::Scanned`]).
pub fn scan_mesh(
    mesh: &TriMesh,
    rig: Rig,
    width: u32,
    height: u32,
    sigma: f64,
    seed: u64,
) -> Result<truth::scan::Capture> {
    let bbox = mesh.bbox().context("the mesh has no vertices")?;
    let diagonal = bbox.diagonal();
    let surface = truth::ExactVisibility::new(mesh)?;
    let positions = match rig {
        Rig::Ring(n) => truth::scan::ring(bbox.center(), 1.5 * diagonal, 0.5 * diagonal, n),
        Rig::Line(n) => pass(&bbox, n),
    };
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

    fn unit_box() -> cloud::Aabb {
        cloud::Aabb {
            min: DVec3::new(-0.5, -0.5, -0.5),
            max: DVec3::new(1.5, 0.5, 0.5),
        }
    }

    #[test]
    fn evaluation_datasets_share_no_mesh_with_the_tuning_datasets() {
        let meshes = |role: Role| -> Vec<&str> {
            REGISTRY
                .iter()
                .filter(|d| d.role == role)
                .filter_map(|d| d.mesh_file().map(|m| m.file))
                .collect()
        };
        let (tuning, evaluation) = (meshes(Role::Tuning), meshes(Role::Evaluation));
        assert!(evaluation.len() >= 4, "{evaluation:?}");
        for m in &evaluation {
            assert!(!tuning.contains(m), "{m} is tuning data too");
        }
        assert_eq!(role("elephant-50000"), Role::Evaluation);
        assert_eq!(role("bunny-69451"), Role::Tuning);
        assert_eq!(role("my-scan"), Role::Own);
    }

    #[test]
    fn evaluation_datasets_load_with_their_points_and_sixteen_views() {
        // Needs the fetched meshes (`just test` fetches first).
        if std::env::var_os("POINTSIGHT_REAL_DATA").is_none() {
            return;
        }
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench-data");
        for info in REGISTRY.iter().filter(|d| d.role == Role::Evaluation) {
            let ds = load(info, &data).unwrap_or_else(|e| panic!("{}: {e:#}", info.name));
            assert_eq!(ds.cloud.len(), info.n_points, "{}", info.name);
            assert_eq!(ds.views.len(), 16, "{}", info.name);
            let mesh = ds.mesh.as_ref().unwrap();
            assert!(mesh.triangles.len() > 5_000, "{}", info.name);
        }
    }

    #[test]
    fn a_mobile_pass_runs_straight_beside_the_mesh_at_one_diagonal() {
        let b = unit_box();
        let d = b.diagonal();
        let p = pass(&b, 5);
        assert_eq!(p.len(), 5);
        for w in p.windows(2) {
            // Evenly spaced along +x, at a fixed offset in y and z.
            assert!(((w[1] - w[0]) - DVec3::new(2.4 * d / 5.0, 0.0, 0.0)).length() < 1e-12);
        }
        for q in &p {
            assert!((q.y - (b.center().y - d)).abs() < 1e-12 && (q.z - b.center().z).abs() < 1e-12);
        }
        // The profile scanner's two azimuths (width 2: ±y) sweep the plane across the travel.
        let s = truth::scan::Scanner {
            position: p[0],
            width: 2,
            height: 8,
            max_range: 1.0,
            range_sigma: 0.0,
        };
        let cam = s.camera().unwrap();
        for (x, y) in [(0.5, 0.5), (1.5, 3.5), (0.5, 7.5)] {
            let (_, dir) = cam.ray(x, y);
            assert!(
                dir.normalize().x.abs() < 1e-9,
                "ray {dir:?} leaves the profile plane"
            );
        }
    }

    #[test]
    fn mobile_views_ride_the_vehicle_and_frame_the_mesh() {
        let b = unit_box();
        let d = b.diagonal();
        let views = mobile_views(&b).unwrap();
        assert_eq!(views.len(), 16);
        for v in &views {
            assert!((v.eye.y - (b.center().y - d)).abs() < 1e-12);
            assert!(
                (v.eye - b.center()).length() > 0.5 * d,
                "inside the bounding sphere"
            );
            let c = v.project(b.center()).unwrap();
            assert!((c.x - 640.0).abs() < 1e-6 && (c.y - 360.0).abs() < 1e-6);
            for corner in [b.min, b.max] {
                assert!(
                    v.project(corner).unwrap().pixel(1280, 720).is_some(),
                    "{corner:?} out of frame"
                );
            }
        }
    }
}
