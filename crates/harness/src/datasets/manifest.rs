//! Dataset manifests: a TOML file that names datasets made of the user's files.
//!
//! `--manifest FILE`, or `pointsight.toml` in the working directory when present. Paths are
//! relative to the manifest's folder. Each `[datasets.NAME]` table:
//!
//! ```toml
//! [datasets.office-scan]
//! cloud = "scans/office.laz"        # a point file (ply, off, obj, xyz, las, laz, e57, pcd) ...
//! mesh = "meshes/office.obj"        # ... optional: the surface the ground truth renders
//! description = "office, 2 scans"
//! format = "laz"                    # optional: the format, when the extension does not say
//! classes = [2, 6]                  # optional, LAS/LAZ: keep these classifications
//! scan = 0                          # optional, E57: one scan (all merged by default)
//! columns = "x,y,z,r,g,b"           # optional, XYZ: what each column holds (cloud::io::xyz)
//! views = "views.jsonl"             # optional: a views file, a COLMAP model, or "scanners"
//! surface_tolerance = 0.002         # optional: off-surface distance (default: 1 spacing)
//! allow_off_surface = true          # optional: score against a mesh that does not fit the
//!                                   # points (refused by default: datasets::fit)
//!
//! [datasets.my-bunny-50000]
//! mesh = "bunny.obj"
//! sample = { n = 50000, seed = 7 }  # points sampled from the mesh instead of a cloud file
//! view_spec = { count = 8, distance = 2.0, width = 1280, height = 720 }
//!
//! [datasets.statue-qsplat]
//! lod_file = "statue.qsplat"        # a QSplat file `pointsight lod-build` wrote: the `lod`
//!                                   # experiment selects from it without loading it
//! ```
//!
//! Without `views` or `view_spec` a dataset gets the Fibonacci views of the built-in datasets
//! around its mesh (or its cloud). Names must not shadow built-in datasets. An entry becomes a
//! [`FileDataset`] ([`manifest_dataset`]), which [`super::files`] loads.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::degrade::Degradation;
use cloud::views::ViewSpec;
use serde::Deserialize;

use super::files::{FileDataset, ViewsFrom};

/// A manifest: datasets by name.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The datasets.
    #[serde(default)]
    pub datasets: BTreeMap<String, Entry>,
    /// The manifest's folder (paths are relative to it).
    #[serde(skip)]
    pub base: PathBuf,
    /// The manifest file.
    #[serde(skip)]
    pub path: PathBuf,
}

/// Sampling a mesh.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Sample {
    /// Number of points.
    pub n: usize,
    /// Seed.
    #[serde(default)]
    pub seed: u64,
}

/// A Fibonacci view set.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ViewSpecEntry {
    /// Number of views.
    pub count: usize,
    /// Eye distance in box diagonals.
    #[serde(default = "default_distance")]
    pub distance: f64,
    /// Image width.
    #[serde(default = "default_width")]
    pub width: u32,
    /// Image height.
    #[serde(default = "default_height")]
    pub height: u32,
}

fn default_distance() -> f64 {
    1.5
}
fn default_width() -> u32 {
    1280
}
fn default_height() -> u32 {
    720
}

/// One dataset of a manifest.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// The point file.
    pub cloud: Option<PathBuf>,
    /// The mesh file.
    pub mesh: Option<PathBuf>,
    /// A QSplat file built by `pointsight lod-build`, instead of a cloud: only the `lod`
    /// experiment reads it, selecting from the file without loading it.
    pub lod_file: Option<PathBuf>,
    /// Sample the mesh instead of reading a cloud.
    pub sample: Option<Sample>,
    /// One line for `pointsight datasets`.
    #[serde(default)]
    pub description: String,
    /// Format of the cloud file.
    pub format: Option<String>,
    /// LAS/LAZ classifications to keep.
    pub classes: Option<Vec<u8>>,
    /// E57 scan to read.
    pub scan: Option<usize>,
    /// XYZ columns (`x,y,z,r,g,b`; `cloud::io::xyz::Columns`).
    pub columns: Option<String>,
    /// Views file, COLMAP model, or `scanners`.
    pub views: Option<PathBuf>,
    /// Fibonacci views.
    pub view_spec: Option<ViewSpecEntry>,
    /// Off-surface distance tolerance, world units.
    pub surface_tolerance: Option<f64>,
    /// E57 with several scans: one dataset of all scans merged (default: one dataset per
    /// scan, named `NAME-scan-K`, viewed from its scanner).
    #[serde(default)]
    pub merge_scans: bool,
    /// Degradations applied after loading (`cloud::degrade`'s `KIND:key=value,...` form, in
    /// order), e.g. `["noise:sigma=0.5", "outliers:fraction=0.01"]`; the truth stays the clean
    /// points'.
    #[serde(default)]
    pub degrade: Vec<String>,
    /// Seed of the degradations (default 1).
    pub degrade_seed: Option<u64>,
    /// Score against a mesh that does not fit the points anyway (`super::fit`).
    #[serde(default)]
    pub allow_off_surface: bool,
}

impl Manifest {
    /// Reads a manifest file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read the manifest {}", path.display()))?;
        let mut m: Manifest = match toml::from_str(&text) {
            Ok(m) => m,
            Err(e) => {
                // The dataset whose entry failed, when the file parses as TOML at all: each
                // entry read on its own (the error itself keeps its line and column).
                let dataset = toml::from_str::<toml::Table>(&text).ok().and_then(|t| {
                    let datasets = t.get("datasets")?.as_table()?.clone();
                    datasets
                        .into_iter()
                        .find(|(_, v)| v.clone().try_into::<Entry>().is_err())
                        .map(|(name, _)| name)
                });
                return Err(match dataset {
                    Some(name) => {
                        anyhow::anyhow!("{}: dataset {name}: malformed entry: {e}", path.display())
                    }
                    None => anyhow::anyhow!("{}: malformed manifest: {e}", path.display()),
                });
            }
        };
        m.base = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_owned();
        m.path = path.to_owned();
        for (name, e) in &m.datasets {
            if super::builtin::REGISTRY.iter().any(|d| d.name == name) {
                bail!(
                    "{}: dataset {name} shadows a built-in dataset; choose another name",
                    path.display()
                );
            }
            if e.lod_file.is_some() {
                if e.cloud.is_some() || e.sample.is_some() || e.mesh.is_some() {
                    bail!(
                        "{}: dataset {name}: lod_file is the whole dataset; give no cloud, \
                         mesh or sample with it",
                        path.display()
                    );
                }
                if e.views
                    .as_deref()
                    .is_some_and(|v| v.as_os_str() == "scanners")
                {
                    bail!(
                        "{}: dataset {name}: views = \"scanners\" needs an E57 cloud, not a \
                         lod_file",
                        path.display()
                    );
                }
            } else {
                match (&e.cloud, &e.sample, &e.mesh) {
                    (Some(_), None, _) | (None, Some(_), Some(_)) => {}
                    (Some(_), Some(_), _) => {
                        bail!(
                            "{}: dataset {name}: give cloud or sample, not both",
                            path.display()
                        )
                    }
                    (None, Some(_), None) => {
                        bail!("{}: dataset {name}: sample needs a mesh", path.display())
                    }
                    (None, None, _) => bail!(
                        "{}: dataset {name} needs a cloud file, a mesh and sample = {{ n = ... }}, \
                     or a lod_file",
                        path.display()
                    ),
                }
            }
            if e.views.is_some() && e.view_spec.is_some() {
                bail!(
                    "{}: dataset {name}: give views or view_spec, not both",
                    path.display()
                );
            }
            // The values read later (format, columns, degradations), checked now.
            read_values(name, e).with_context(|| format!("{}", path.display()))?;
        }
        // An E57 file with several scans is one dataset per scan unless merged.
        let mut expanded = BTreeMap::new();
        for (name, e) in std::mem::take(&mut m.datasets) {
            let is_e57 = e.cloud.as_ref().is_some_and(|c| {
                e.format.as_deref().map_or_else(
                    || cloud::io::Format::of_path(c) == Some(cloud::io::Format::E57),
                    |f| f.eq_ignore_ascii_case("e57"),
                )
            });
            let scans = match (&e.cloud, is_e57 && e.scan.is_none() && !e.merge_scans) {
                (Some(c), true) => cloud::io::e57::scan_count(&m.resolve(c))?,
                _ => 1,
            };
            if scans > 1 {
                for k in 0..scans {
                    let mut one = e.clone();
                    one.scan = Some(k);
                    if one.views.is_none() && one.view_spec.is_none() {
                        one.views = Some(PathBuf::from("scanners"));
                    }
                    expanded.insert(format!("{name}-scan-{k}"), one);
                }
            } else {
                expanded.insert(name, e);
            }
        }
        m.datasets = expanded;
        Ok(m)
    }

    /// The manifest to use: `explicit`, else `pointsight.toml` in the working directory when it
    /// exists, else none.
    pub fn discover(explicit: Option<&Path>) -> Result<Option<Self>> {
        match explicit {
            Some(p) => Ok(Some(Self::read(p)?)),
            None => {
                let default = Path::new("pointsight.toml");
                if default.exists() {
                    Ok(Some(Self::read(default)?))
                } else {
                    Ok(None)
                }
            }
        }
    }

    /// A path of the manifest resolved against its folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_owned()
        } else {
            self.base.join(p)
        }
    }
}

/// Where entry `e`'s views come from.
pub fn views_from(m: &Manifest, e: &Entry) -> ViewsFrom {
    match (&e.views, &e.view_spec) {
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
    }
}

/// How entry `name` reads its cloud and what degrades it: its `format`, `classes`, `scan` and
/// `columns`, and its `degrade` steps with their seed; the errors name the dataset.
fn read_values(name: &str, e: &Entry) -> Result<(cloud::io::ReadOptions, (Vec<Degradation>, u64))> {
    let format = match &e.format {
        Some(f) => Some(cloud::io::Format::from_name(f).with_context(|| {
            format!(
                "dataset {name}: unknown format {f:?}; known: {}",
                cloud::io::Format::NAMES
            )
        })?),
        None => None,
    };
    let read = cloud::io::ReadOptions {
        format,
        classes: e.classes.clone(),
        scan: e.scan,
        columns: e
            .columns
            .as_deref()
            .map(str::parse)
            .transpose()
            .map_err(|why: String| anyhow::anyhow!("dataset {name}: columns: {why}"))?,
    };
    let degrade = e
        .degrade
        .iter()
        .map(|d| d.parse::<Degradation>())
        .collect::<cloud::Result<Vec<_>>>()
        .with_context(|| format!("dataset {name}: degrade"))?;
    Ok((read, (degrade, e.degrade_seed.unwrap_or(1))))
}

/// The file dataset a manifest entry describes.
pub fn manifest_dataset(m: &Manifest, name: &str, e: &Entry) -> Result<FileDataset> {
    let (read, degrade) = read_values(name, e).with_context(|| format!("{}", m.path.display()))?;
    let views = views_from(m, e);
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
        read,
        views,
        surface_tolerance: e.surface_tolerance,
        degrade,
        allow_off_surface: e.allow_off_surface,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.toml");
        std::fs::write(&p, text).unwrap();
        (dir, p)
    }

    #[test]
    fn reads_entries_and_resolves_paths() {
        let (dir, p) = write(
            "[datasets.scan]\ncloud = \"a/scan.ply\"\nmesh = \"m.off\"\n\
             [datasets.s]\nmesh = \"m.off\"\nsample = { n = 100, seed = 3 }\n\
             view_spec = { count = 4 }\n",
        );
        let m = Manifest::read(&p).unwrap();
        assert_eq!(m.datasets.len(), 2);
        assert_eq!(
            m.resolve(m.datasets["scan"].cloud.as_ref().unwrap()),
            dir.path().join("a/scan.ply")
        );
        assert_eq!(m.datasets["s"].sample, Some(Sample { n: 100, seed: 3 }));
        assert_eq!(m.datasets["s"].view_spec.unwrap().width, 1280);
    }

    #[test]
    fn mistakes_are_named() {
        for (text, needle) in [
            ("[datasets.x]\nclud = \"a.ply\"\n", "unknown field"),
            ("[datasets.x]\nmesh = \"a.off\"\n", "needs a cloud"),
            ("[datasets.x]\nsample = { n = 3 }\n", "sample needs a mesh"),
            (
                "[datasets.bunny]\ncloud = \"a.ply\"\n",
                "shadows a built-in",
            ),
            (
                "[datasets.x]\ncloud = \"a.ply\"\nviews = \"v\"\nview_spec = { count = 2 }\n",
                "not both",
            ),
            ("datasets = 3\n", "malformed"),
        ] {
            let (_d, p) = write(text);
            let err = format!("{:#}", Manifest::read(&p).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
        }
    }

    #[test]
    fn every_mistake_names_the_file_and_the_dataset() {
        for (text, needle) in [
            (
                "[datasets.ok]\ncloud = \"a.ply\"\n[datasets.x]\nclud = \"a.ply\"\n",
                "malformed entry: TOML parse error at line 4",
            ),
            (
                "[datasets.x]\nmesh = \"m.off\"\nsample = { n = 3, sed = 1 }\n",
                "unknown field `sed`",
            ),
            (
                "[datasets.x]\ncloud = \"a.ply\"\nformat = \"xyzz\"\n",
                "unknown format",
            ),
            (
                "[datasets.x]\ncloud = \"a.ply\"\ndegrade = [\"noise:sigm=1\"]\n",
                "degrade",
            ),
            (
                "[datasets.x]\ncloud = \"a.xyz\"\ncolumns = \"x,y\"\n",
                "columns:",
            ),
            ("[datasets.x]\nmesh = \"a.off\"\n", "needs a cloud"),
        ] {
            let (_d, p) = write(text);
            let err = format!("{:#}", Manifest::read(&p).unwrap_err());
            assert!(
                err.starts_with(&format!("{}: dataset x", p.display())) && err.contains(needle),
                "{text}: {err}"
            );
        }
    }

    /// Writes `mesh`, moved by `shift`, as an OFF file (each coordinate's shortest exact text).
    fn write_off(path: &Path, mesh: &cloud::TriMesh, shift: cloud::glam::DVec3) {
        let mut off = format!("OFF\n{} {} 0\n", mesh.vertices.len(), mesh.triangles.len());
        for v in &mesh.vertices {
            let w = *v + shift;
            off.push_str(&format!("{} {} {}\n", w.x, w.y, w.z));
        }
        for t in &mesh.triangles {
            off.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
        }
        std::fs::write(path, off).expect("the OFF file is written");
    }

    #[test]
    fn a_manifest_degrades_its_dataset_and_keeps_the_truth_clean() {
        use crate::datasets::files::load_files;
        use cloud::glam::DVec3;
        let dir = tempfile::tempdir().unwrap();
        let mesh = cloud::synth::sphere_scene(100).mesh;
        write_off(&dir.path().join("ball.off"), &mesh, DVec3::ZERO);
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
        // Refused as the manifest is read, naming the file and the dataset.
        let err = format!("{:#}", Manifest::read(&path).unwrap_err());
        assert!(
            err.contains("unknown degradation \"blur\"")
                && err.starts_with(&format!("{}: dataset x: degrade", path.display())),
            "{err}"
        );
    }

    #[test]
    fn a_datasets_mesh_is_read_alone_without_its_sample_or_cloud() {
        use crate::datasets::files::{load_files, load_mesh};
        use cloud::glam::DVec3;
        let dir = tempfile::tempdir().unwrap();
        // A georeferenced mesh: every shift below must be exact for the shapes to be equal.
        let at = DVec3::new(512_000.0, 4_194_304.0, 96.0);
        write_off(
            &dir.path().join("ball.off"),
            &cloud::synth::icosphere(2),
            at,
        );
        let file = crate::datasets::files::read_mesh(&dir.path().join("ball.off")).unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(
            &path,
            "[datasets.huge]\nmesh = \"ball.off\"\nsample = { n = 1000000000000, seed = 1 }\n\
             [datasets.scan]\nmesh = \"ball.off\"\ncloud = \"missing.ply\"\n\
             [datasets.small]\nmesh = \"ball.off\"\nsample = { n = 2000, seed = 1 }\n\
             [datasets.points]\ncloud = \"missing.ply\"\n",
        )
        .unwrap();
        let m = Manifest::read(&path).unwrap();
        let spec = |name: &str| manifest_dataset(&m, name, &m.datasets[name]).unwrap();
        // The same shape as the file's, recentred: only a translation apart.
        let same_shape = |got: &cloud::TriMesh| {
            assert_eq!(got.triangles, file.triangles);
            let d = file.vertices[0] - got.vertices[0];
            assert!(d.length() > 1e6, "recentred: {d}");
            assert!(
                got.vertices
                    .iter()
                    .zip(&file.vertices)
                    .all(|(g, f)| *g + d == *f)
            );
        };
        // 10^12 points would be refused by the memory guard; the mesh alone is not.
        let (huge, file_record) = load_mesh(&spec("huge")).unwrap();
        same_shape(&huge);
        assert_eq!(file_record.sha256.len(), 64);
        // Its cloud file is never opened.
        same_shape(&load_mesh(&spec("scan")).unwrap().0);
        // The loaded dataset's mesh has the same shape.
        let small = load_files(&spec("small")).unwrap();
        same_shape(&load_mesh(&spec("small")).unwrap().0);
        same_shape(small.mesh.as_ref().unwrap());
        let err = format!("{:#}", load_mesh(&spec("points")).unwrap_err());
        assert!(err.contains("dataset points has no mesh"), "{err}");
    }
}
