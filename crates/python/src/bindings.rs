//! The PyO3 module `pointsight._native`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

use cloud::glam::{DVec3, Vec2, Vec3};
use cloud::{Model, PointCloud, TriMesh};
use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The thread pool every call runs in (`set_num_threads`); rayon's global pool by default.
static POOL: OnceLock<Mutex<Option<std::sync::Arc<rayon::ThreadPool>>>> = OnceLock::new();

fn pool() -> Option<std::sync::Arc<rayon::ThreadPool>> {
    POOL.get_or_init(|| Mutex::new(None))
        .lock()
        .ok()
        .and_then(|p| p.clone())
}

/// Runs `f` without the GIL, in the chosen pool, turning panics into `RuntimeError`.
fn run<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, String> + Send) -> PyResult<T> {
    let pool = pool();
    let out = py.detach(move || {
        catch_unwind(AssertUnwindSafe(|| match pool {
            Some(p) => p.install(f),
            None => f(),
        }))
    });
    match out {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(msg)) => Err(PyValueError::new_err(msg)),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error (please report it): {msg}"
            )))
        }
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The registry's errors with Python's framing: a parameter is a keyword argument of `method`.
fn registry_err(method: &str, e: &registry::Error) -> String {
    match e {
        registry::Error::BadValue { key, value, reason } => {
            format!("{method}: keyword argument {key}={value:?}: {reason}")
        }
        registry::Error::UnknownParams {
            plural,
            keys,
            accepted,
            ..
        } => {
            format!("{method}: unexpected keyword argument{plural} {keys}; it accepts: {accepted}")
        }
        other => other.to_string(),
    }
}

/// An (N, 3) float64 array as points (copied).
fn points_of(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<DVec3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "expected an (N, 3) array, got shape {:?}",
            v.shape()
        )));
    }
    Ok(v.rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

fn cloud_of(points: Vec<DVec3>) -> Result<PointCloud, String> {
    if points.is_empty() {
        return Err("the point array is empty".into());
    }
    PointCloud::from_positions(points).map_err(err)
}

fn mesh_of(
    vertices: &PyReadonlyArray2<'_, f64>,
    faces: &PyReadonlyArray2<'_, i64>,
) -> PyResult<TriMesh> {
    let vertices = points_of(vertices)?;
    let f = faces.as_array();
    if f.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "faces: expected an (M, 3) integer array, got shape {:?}",
            f.shape()
        )));
    }
    let mut triangles = Vec::with_capacity(f.nrows());
    for (k, r) in f.rows().into_iter().enumerate() {
        let mut t = [0u32; 3];
        for (c, &v) in t.iter_mut().zip(r.iter()) {
            if v < 0 || v as usize >= vertices.len() {
                return Err(PyValueError::new_err(format!(
                    "face {k} refers to vertex {v} but there are {} vertices",
                    vertices.len()
                )));
            }
            *c = v as u32;
        }
        triangles.push(t);
    }
    TriMesh::new(vertices, triangles).map_err(|e| PyValueError::new_err(e.to_string()))
}

fn indices_array<'py>(py: Python<'py>, v: Vec<u32>) -> Bound<'py, PyArray1<i64>> {
    v.into_iter()
        .map(i64::from)
        .collect::<Vec<_>>()
        .into_pyarray(py)
}

fn vec3_array<'py, T: Copy>(
    py: Python<'py>,
    rows: &[T],
    f: impl Fn(T) -> [f64; 3],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flat_map(|&r| f(r)).collect();
    Array2::from_shape_vec((rows.len(), 3), flat)
        .map(|a| a.into_pyarray(py))
        .unwrap_or_else(|_| Array2::<f64>::zeros((0, 3)).into_pyarray(py))
}

/// A camera: pinhole, orthographic or spherical, with a pose (see `cloud::camera`).
#[pyclass(module = "pointsight._native", frozen, from_py_object)]
#[derive(Clone)]
pub struct Camera {
    inner: cloud::Camera,
}

#[pymethods]
impl Camera {
    /// Parses the camera's JSON form (one line of a views file).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        cloud::Camera::from_json(text)
            .map(|inner| Self { inner })
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// A look-at camera of any model.
    #[staticmethod]
    #[pyo3(signature = (model, eye, target, up, width, height, fov_y_deg=None, fx=None, fy=None, cx=None, cy=None, view_width=None, view_height=None))]
    #[allow(clippy::too_many_arguments)]
    fn look_at(
        model: &str,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        width: u32,
        height: u32,
        fov_y_deg: Option<f64>,
        fx: Option<f64>,
        fy: Option<f64>,
        cx: Option<f64>,
        cy: Option<f64>,
        view_width: Option<f64>,
        view_height: Option<f64>,
    ) -> PyResult<Self> {
        let bad = |e: cloud::Error| PyValueError::new_err(e.to_string());
        let m = match model {
            "pinhole" => match (fx, fy, cx, cy, fov_y_deg) {
                (Some(fx), Some(fy), cx, cy, _) => Model::Pinhole {
                    fx,
                    fy,
                    cx: cx.unwrap_or(0.5 * width as f64),
                    cy: cy.unwrap_or(0.5 * height as f64),
                },
                (None, None, None, None, Some(f)) => {
                    Model::pinhole_fov(f, width, height).map_err(bad)?
                }
                _ => {
                    return Err(PyValueError::new_err(
                        "a pinhole camera needs fov_y_deg, or fx and fy (cx, cy default to the centre)",
                    ));
                }
            },
            "orthographic" => match (view_width, view_height) {
                (Some(view_width), Some(view_height)) => Model::Orthographic {
                    view_width,
                    view_height,
                },
                _ => {
                    return Err(PyValueError::new_err(
                        "an orthographic camera needs view_width and view_height",
                    ));
                }
            },
            "spherical" => Model::Spherical,
            other => {
                return Err(PyValueError::new_err(format!(
                    "unknown camera model {other:?}: expected pinhole, orthographic or spherical"
                )));
            }
        };
        cloud::Camera::look_at(
            DVec3::from_array(eye),
            DVec3::from_array(target),
            DVec3::from_array(up),
            m,
            width,
            height,
        )
        .map(|inner| Self { inner })
        .map_err(bad)
    }

    /// The JSON form (what views files hold and external methods read).
    fn to_json(&self) -> String {
        self.inner.to_json()
    }

    /// The projection model's name.
    #[getter]
    fn model(&self) -> &'static str {
        self.inner.model().name()
    }

    /// The eye.
    #[getter]
    fn eye(&self) -> [f64; 3] {
        self.inner.eye.to_array()
    }

    /// Image width.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.width
    }

    /// Image height.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.height
    }

    /// Projects (N, 3) points: (N, 3) array of pixel x, pixel y, depth (NaN where a point is
    /// not in front of the camera).
    fn project<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pts = points_of(&points)?;
        let c = self.inner;
        let out: Vec<[f64; 3]> = pts
            .iter()
            .map(|&p| c.project(p).map_or([f64::NAN; 3], |q| [q.x, q.y, q.depth]))
            .collect();
        Ok(vec3_array(py, &out, |r| r))
    }

    fn __repr__(&self) -> String {
        format!("Camera({})", self.inner.to_json())
    }
}

/// Runs registry method `method` with `params` (the `--set` keys) on `points` for each camera;
/// `vertices`/`faces` give the mesh for `reference`. One index array per camera.
#[pyfunction]
#[pyo3(signature = (method, points, cameras, params, vertices=None, faces=None, catalogue=None))]
#[allow(clippy::too_many_arguments)]
fn visible<'py>(
    py: Python<'py>,
    method: &str,
    points: PyReadonlyArray2<'py, f64>,
    cameras: Vec<Camera>,
    params: Vec<(String, String)>,
    vertices: Option<PyReadonlyArray2<'py, f64>>,
    faces: Option<PyReadonlyArray2<'py, i64>>,
    catalogue: Option<PyRef<'py, Catalogue>>,
) -> PyResult<Vec<Bound<'py, PyArray1<i64>>>> {
    let catalogue = catalogue.map_or_else(registry::Catalogue::builtin, |c| c.inner.clone());
    // No program outlives the call (no subreaper in a user's process: docs/python.md).
    let _programs = catalogue.end_programs_on_drop();
    let pts = points_of(&points)?;
    let mesh = match (vertices, faces) {
        (Some(v), Some(f)) => Some(mesh_of(&v, &f)?),
        (None, None) => None,
        _ => return Err(PyValueError::new_err("give vertices and faces together")),
    };
    let method = method.to_owned();
    let cams: Vec<cloud::Camera> = cameras.iter().map(|c| c.inner).collect();
    let results = run(py, move || {
        let m = catalogue.card(&method).map_err(err)?;
        let p = registry::Params::from_pairs(
            &params
                .iter()
                .map(|(k, v)| (k.as_str(), v.clone()))
                .collect::<Vec<_>>(),
        );
        // The keyword arguments typed by the method's card, as the command line's `--set`,
        // before the cloud is made.
        m.check(&p).map_err(|e| registry_err(&method, &e))?;
        let cloud = cloud_of(pts)?;
        let input = registry::Input {
            cloud: &cloud,
            mesh: mesh.as_ref(),
        };
        // One cell of the measurement kernel: prepared once, every camera (its position in
        // the list is its view index).
        let views = registry::kernel::View::all(&cams);
        let cell = registry::kernel::Cell {
            method: m,
            params: p,
            views: &views,
            repeats: 1,
            budget: None,
            parallel: m.parallel_views && views.len() > 1,
        };
        let (prepared, answers) = registry::kernel::collect(&cell, input);
        prepared.map_err(|e| registry_err(&method, &e))?;
        answers
            .into_iter()
            .map(|(_, a)| a.map(|a| a.output.visible))
            .collect::<Result<Vec<_>, _>>()
    })?;
    Ok(results.into_iter().map(|v| indices_array(py, v)).collect())
}

/// Precision, recall, F1 and Jaccard of `visible` (indices) against `truth` (indices) among
/// `n` points.
#[pyfunction]
fn score<'py>(
    py: Python<'py>,
    visible: PyReadonlyArray1<'py, i64>,
    truth: PyReadonlyArray1<'py, i64>,
    n: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let to_set = |a: &PyReadonlyArray1<'py, i64>, what: &str| -> PyResult<Vec<u32>> {
        let mut v: Vec<u32> = Vec::with_capacity(a.len()?);
        for &i in a.as_array().iter() {
            if i < 0 || i as usize >= n {
                return Err(PyValueError::new_err(format!(
                    "{what}: index {i} is outside 0..{n}"
                )));
            }
            v.push(i as u32);
        }
        v.sort_unstable();
        v.dedup();
        Ok(v)
    };
    let (p, t) = (to_set(&visible, "visible")?, to_set(&truth, "truth")?);
    let s = registry::scoring::Score::of_sets(&p, &t);
    let d = PyDict::new(py);
    d.set_item("precision", s.precision())?;
    d.set_item("recall", s.recall())?;
    d.set_item("f1", s.f1())?;
    d.set_item("jaccard", s.jaccard())?;
    Ok(d)
}

/// Indices of the convex hull's vertices, ascending (`impl_`: own, qhull, parry, quickhull,
/// chull).
#[pyfunction]
fn convex_hull_vertices<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    impl_: &str,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let pts: Vec<[f64; 3]> = points_of(&points)?.iter().map(|p| p.to_array()).collect();
    let name = impl_.to_owned();
    let v = run(py, move || {
        let h = hull::by_name(&name).map_err(err)?;
        h.vertices(&pts).map_err(err)
    })?;
    Ok(indices_array(py, v))
}

/// Reads a point or mesh file: a dict of arrays (`positions`, and where the file has them
/// `normals`, `colors`, `intensity`, `classification`, `scan`, `faces`, `scanner_positions`).
#[pyfunction]
#[pyo3(signature = (path, format=None, classes=None, scan=None))]
fn read<'py>(
    py: Python<'py>,
    path: PathBuf,
    format: Option<String>,
    classes: Option<Vec<u8>>,
    scan: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let format = match format {
        Some(f) => Some(cloud::io::Format::from_name(&f).ok_or_else(|| {
            PyValueError::new_err(format!(
                "unknown format {f:?}; known: {}",
                cloud::io::Format::NAMES
            ))
        })?),
        None => None,
    };
    let loaded = run(py, move || {
        cloud::io::read_with(
            &path,
            &cloud::io::ReadOptions {
                format,
                classes,
                scan,
                ..Default::default()
            },
        )
        .map_err(err)
    })?;
    let c = loaded.cloud;
    let d = PyDict::new(py);
    d.set_item("positions", vec3_array(py, &c.positions, |p| p.to_array()))?;
    if let Some(n) = &c.normals {
        d.set_item(
            "normals",
            vec3_array(py, n, |v: Vec3| v.as_dvec3().to_array()),
        )?;
    }
    if let Some(colors) = &c.colors {
        let flat: Vec<u8> = colors.iter().flatten().copied().collect();
        let a = Array2::from_shape_vec((colors.len(), 3), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("colors", a.into_pyarray(py))?;
    }
    if let Some(v) = c.intensity {
        d.set_item("intensity", v.into_pyarray(py))?;
    }
    if let Some(v) = c.classification {
        d.set_item("classification", v.into_pyarray(py))?;
    }
    if let Some(v) = c.scan {
        d.set_item("scan", v.into_pyarray(py))?;
    }
    if !loaded.triangles.is_empty() {
        let flat: Vec<i64> = loaded
            .triangles
            .iter()
            .flatten()
            .map(|&v| i64::from(v))
            .collect();
        let a = Array2::from_shape_vec((loaded.triangles.len(), 3), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        d.set_item("faces", a.into_pyarray(py))?;
    }
    if !loaded.scanners.is_empty() {
        d.set_item(
            "scanner_positions",
            vec3_array(py, &loaded.scanners, |s| s.position.to_array()),
        )?;
    }
    Ok(d)
}

/// Sets the number of threads every later call uses (a pool of that size; 0: rayon's default).
#[pyfunction]
fn set_num_threads(n: usize) -> PyResult<()> {
    let slot = POOL.get_or_init(|| Mutex::new(None));
    let mut guard = slot
        .lock()
        .map_err(|_| PyRuntimeError::new_err("thread pool lock poisoned"))?;
    *guard = if n == 0 {
        None
    } else {
        Some(std::sync::Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?,
        ))
    };
    Ok(())
}

fn splats_dict<'py>(
    py: Python<'py>,
    centers: Vec<[f64; 3]>,
    radii: Vec<f64>,
    normals: Vec<[f64; 3]>,
    colors: Vec<[f64; 3]>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("centers", vec3_array(py, &centers, |r| r))?;
    d.set_item("radii", radii.into_pyarray(py))?;
    d.set_item("normals", vec3_array(py, &normals, |r| r))?;
    d.set_item("colors", vec3_array(py, &colors, |r| r))?;
    Ok(d)
}

/// A level-of-detail method of the registry (`qsplat`, `spt`, `srn`, `random` or one registered
/// at run time), built once on a cloud through the measurement kernel, selected per view.
#[pyclass(module = "pointsight._native", frozen)]
pub struct Lod {
    method: &'static registry::Card,
    data: registry::lod::LodData,
    built: Box<dyn registry::lod::LodBuilt>,
    build: registry::kernel::Built,
}

/// Colours (N, 3) in [0, 1] as 8-bit colours.
fn colors_of(c: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[u8; 3]>> {
    let q = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    Ok(points_of(c)?
        .iter()
        .map(|v| [q(v.x), q(v.y), q(v.z)])
        .collect())
}

/// An (H, W, 3) uint8 image as a texture.
fn texture_of(image: &PyReadonlyArray3<'_, u8>) -> PyResult<srn::Texture> {
    let img = image.as_array();
    let shape = img.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "texture: expected an (H, W, 3) uint8 array, got shape {shape:?}"
        )));
    }
    let rgb: Vec<[u8; 3]> = img.rows().into_iter().map(|p| [p[0], p[1], p[2]]).collect();
    srn::Texture::new(shape[1], shape[0], rgb).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// (N, 2) texture coordinates.
fn uvs_of(uvs: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Vec2>> {
    let u = uvs.as_array();
    if u.ncols() != 2 {
        return Err(PyValueError::new_err(format!(
            "uvs: expected an (N, 2) array, got shape {:?}",
            u.shape()
        )));
    }
    Ok(u.rows()
        .into_iter()
        .map(|r| Vec2::new(r[0] as f32, r[1] as f32))
        .collect())
}

#[pymethods]
impl Lod {
    /// Builds `method` on points (N, 3) with optional unit normals (N, 3; else k-nearest-
    /// neighbour estimates), colours (N, 3) in [0, 1], texture coordinates (N, 2) and a
    /// texture (H, W, 3) uint8 (colours then come from it; SRN needs it), full-detail splats of
    /// `radius` (else `radius_spacings` density spacings), every random choice from `seed`.
    #[new]
    #[pyo3(signature = (method, points, normals=None, colors=None, uvs=None, texture=None, radius=None, radius_spacings=1.0, seed=0, catalogue=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        method: &str,
        points: PyReadonlyArray2<'_, f64>,
        normals: Option<PyReadonlyArray2<'_, f64>>,
        colors: Option<PyReadonlyArray2<'_, f64>>,
        uvs: Option<PyReadonlyArray2<'_, f64>>,
        texture: Option<PyReadonlyArray3<'_, u8>>,
        radius: Option<f64>,
        radius_spacings: f64,
        seed: u64,
        catalogue: Option<PyRef<'_, Catalogue>>,
    ) -> PyResult<Self> {
        let catalogue = catalogue.map_or_else(registry::Catalogue::builtin, |c| c.inner.clone());
        let m = catalogue
            .card_named(method)
            .filter(|m| m.is_lod())
            .ok_or_else(|| {
                let known: Vec<&str> = catalogue.lod_cards().iter().map(|m| m.name).collect();
                PyValueError::new_err(format!(
                    "unknown level-of-detail method {method:?}; known: {}",
                    known.join(", ")
                ))
            })?;
        if colors.is_some() && texture.is_some() {
            return Err(PyValueError::new_err(
                "give colors or a texture, not both (with a texture the colours come from it)",
            ));
        }
        let size_ok = |x: f64| x.is_finite() && x > 0.0;
        if let Some(r) = radius.filter(|&r| !size_ok(r)) {
            return Err(PyValueError::new_err(format!(
                "radius must be a positive number, got {r}"
            )));
        }
        if !size_ok(radius_spacings) {
            return Err(PyValueError::new_err(format!(
                "radius_spacings must be a positive number, got {radius_spacings}"
            )));
        }
        let cloud = PointCloud {
            positions: points_of(&points)?,
            normals: normals
                .map(|n| points_of(&n).map(|v| v.iter().map(|x| x.as_vec3()).collect()))
                .transpose()?,
            colors: colors.map(|c| colors_of(&c)).transpose()?,
            uvs: uvs.map(|u| uvs_of(&u)).transpose()?,
            ..PointCloud::default()
        };
        let texture = texture.map(|t| texture_of(&t)).transpose()?;
        let (data, built, build) = run(py, move || {
            if cloud.is_empty() {
                return Err("the point array is empty".into());
            }
            cloud.validate().map_err(err)?;
            let mut data = registry::lod::LodData::prepare(cloud, texture, radius_spacings, seed)
                .map_err(|e| registry_err(m.name, &e))?;
            if let Some(r) = radius {
                data.radius = r;
            }
            let (built, build) = registry::kernel::build_lod(m, &data.input(), 1)
                .map_err(|e| registry_err(m.name, &e))?;
            Ok((data, built, build))
        })?;
        Ok(Self {
            method: m,
            data,
            built,
            build,
        })
    }

    /// A QSplat file written by `pointsight lod-build`, opened for selection without loading
    /// it (`registry::lod_file`): each selection reads the pages its view needs through a
    /// cache of at most `cache_bytes`; `build_seconds` is the time to open it.
    #[staticmethod]
    #[pyo3(signature = (path, cache_bytes=64 << 20))]
    fn open_qsplat_file(py: Python<'_>, path: PathBuf, cache_bytes: u64) -> PyResult<Self> {
        let m = registry::builtin_card("qsplat")
            .ok_or_else(|| PyRuntimeError::new_err("qsplat is not built in"))?;
        let (built, timing) = run(py, move || {
            registry::timing::measure(1, || {
                registry::lod_file::open_qsplat_file(&path, cache_bytes)
            })
            .map_err(|e| registry_err(m.name, &e))
        })?;
        let size = built.size();
        Ok(Self {
            method: m,
            data: registry::lod::LodData::none(0),
            built,
            build: registry::kernel::Built { timing, size },
        })
    }

    /// A built LOD file written by `pointsight lod-build` (QSplat or sequential point tree, told
    /// by its magic), opened for selection without loading it (`registry::lod_file`); `method`
    /// says which.
    #[staticmethod]
    #[pyo3(signature = (path, cache_bytes=64 << 20))]
    fn open_file(py: Python<'_>, path: PathBuf, cache_bytes: u64) -> PyResult<Self> {
        let (built, timing, name) = run(py, move || {
            let info =
                registry::lod_file::file_info(&path).map_err(|e| registry_err("lod file", &e))?;
            let (built, timing) =
                registry::timing::measure(1, || registry::lod_file::open_file(&path, cache_bytes))
                    .map_err(|e| registry_err(info.method, &e))?;
            Ok((built, timing, info.method))
        })?;
        let m = registry::builtin_card(name)
            .ok_or_else(|| PyRuntimeError::new_err(format!("{name} is not built in")))?;
        let size = built.size();
        Ok(Self {
            method: m,
            data: registry::lod::LodData::none(0),
            built,
            build: registry::kernel::Built { timing, size },
        })
    }

    /// The splats drawn for each camera at one setting (`params`: the registry's KEY=VALUE
    /// pairs): per camera a dict of `centers`, `radii`, `normals`, `colors` arrays and the
    /// selection's `seconds` (median of `repeats` timed selections).
    #[pyo3(signature = (cameras, params, repeats=1))]
    fn select<'py>(
        &self,
        py: Python<'py>,
        cameras: Vec<Camera>,
        params: Vec<(String, String)>,
        repeats: usize,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let cams: Vec<cloud::Camera> = cameras.iter().map(|c| c.inner).collect();
        let setting = registry::Setting(
            params
                .iter()
                .map(|(k, v)| (k.clone(), registry::Value::parse(v)))
                .collect(),
        );
        let selections = run(py, || {
            let views = registry::kernel::View::all(&cams);
            let settings = [setting];
            let cell = registry::kernel::LodCell {
                method: self.method,
                settings: &settings,
                views: &views,
                repeats: repeats.max(1),
                build_repeats: 1,
            };
            let mut out = Vec::with_capacity(views.len());
            let input = self.data.input();
            registry::kernel::select_lod(&cell, self.built.as_ref(), &input, |_, _, s| {
                out.push(s.map_err(|e| registry_err(self.method.name, e)));
            });
            out.into_iter().collect::<Result<Vec<_>, String>>()
        })?;
        selections
            .into_iter()
            .map(|s| {
                let d = splats_dict(
                    py,
                    s.splats.iter().map(|s| s.center.to_array()).collect(),
                    s.splats.iter().map(|s| f64::from(s.radius)).collect(),
                    s.splats
                        .iter()
                        .map(|s| s.normal.as_dvec3().to_array())
                        .collect(),
                    s.splats
                        .iter()
                        .map(|s| s.albedo.as_dvec3().to_array())
                        .collect(),
                )?;
                d.set_item("seconds", s.timing.median)?;
                if let Some(r) = s.reads {
                    d.set_item("bytes_read", r.bytes_read)?;
                    d.set_item("cache_bytes", r.cache_bytes)?;
                }
                Ok(d)
            })
            .collect()
    }

    /// The method's name.
    #[getter]
    fn method(&self) -> &'static str {
        self.method.name
    }

    /// Nodes or entries of the built structure.
    fn __len__(&self) -> usize {
        self.build.size.nodes
    }

    /// Bytes of the built structure (0 when not meaningful).
    #[getter]
    fn bytes(&self) -> f64 {
        self.build.size.bytes
    }

    /// Seconds the build took.
    #[getter]
    fn build_seconds(&self) -> f64 {
        self.build.timing.median
    }

    /// The full-detail splat radius, world units.
    #[getter]
    fn radius(&self) -> f64 {
        self.data.radius
    }
}

/// ε (world units per unit distance) for a screen-space error of `px` pixels through `camera`
/// (what `spt`'s `epsilon_px` means).
#[pyfunction]
fn spt_epsilon_for_pixels(camera: &Camera, px: f64) -> f64 {
    spt::epsilon_for_pixels(&camera.inner, px)
}

/// Kept indices and their radius factors.
type IndicesAndFactors<'py> = (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<f64>>);

/// A method's name, summary and parameters (key, default, help).
type MethodListing = (String, String, Vec<(String, String, String)>);

/// SRN (seed 003): the points kept at density `scale` with the JPEG2000 masking importance of
/// `image` (H, W, 3) uint8, through texture coordinates `uvs` (N, 2): their indices and the
/// radius factor 1/sqrt(I) of each kept point.
#[pyfunction]
#[pyo3(signature = (uvs, image, scale=1.0, seed=0))]
fn srn_select<'py>(
    py: Python<'py>,
    uvs: PyReadonlyArray2<'py, f64>,
    image: PyReadonlyArray3<'py, u8>,
    scale: f32,
    seed: u64,
) -> PyResult<IndicesAndFactors<'py>> {
    let uv = uvs_of(&uvs)?;
    let texture = texture_of(&image)?;
    let (kept, factors) = run(py, move || {
        let map = srn::masking_map(&texture, &srn::MaskingParams::default()).map_err(err)?;
        let s = srn::Srn::new(&uv, &map, seed).map_err(err)?;
        let params = srn::SrnParams {
            scale,
            ..srn::SrnParams::default()
        };
        let kept = s.select(&params).map_err(err)?;
        let factors: Vec<f64> = kept
            .iter()
            .map(|&i| f64::from(s.radius_factor(i as usize, &params)))
            .collect();
        Ok((kept, factors))
    })?;
    Ok((indices_array(py, kept), factors.into_pyarray(py)))
}

/// Every method of `catalogue` (default: the built-in ones), visibility then level of
/// detail: name, one-line summary, and its parameters (key, default, help).
#[pyfunction]
#[pyo3(signature = (catalogue=None))]
fn methods(catalogue: Option<PyRef<'_, Catalogue>>) -> Vec<MethodListing> {
    let catalogue = catalogue.map_or_else(registry::Catalogue::builtin, |c| c.inner.clone());
    catalogue
        .visibility_cards()
        .iter()
        .chain(&catalogue.lod_cards())
        .map(|m| {
            (
                m.name.to_owned(),
                m.summary.to_owned(),
                m.params
                    .iter()
                    .map(|p| (p.key.to_owned(), p.default.to_string(), p.help.to_owned()))
                    .collect(),
            )
        })
        .collect()
}

/// The methods a caller runs: the built-in ones and the external folders it loaded. A value:
/// two catalogues side by side know only their own folders; nothing is process state.
#[pyclass(module = "pointsight._native")]
#[derive(Clone, Default)]
struct Catalogue {
    inner: registry::Catalogue,
}

#[pymethods]
impl Catalogue {
    /// The built-in methods alone.
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Loads the external methods under `dir` (`NAME/method.toml` each; see the repository's
    /// `methods/README.md`) into this catalogue; returns their names.
    fn load(&mut self, dir: PathBuf) -> PyResult<Vec<String>> {
        if !dir.is_dir() {
            return Err(PyValueError::new_err(format!(
                "methods folder {} does not exist",
                dir.display()
            )));
        }
        let before: Vec<&str> = self.inner.cards().iter().map(|m| m.name).collect();
        self.inner
            .add_external(&dir)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(self
            .inner
            .cards()
            .iter()
            .map(|m| m.name)
            .filter(|n| !before.contains(n))
            .map(str::to_owned)
            .collect())
    }

    /// Every method's name, visibility and level of detail.
    fn names(&self) -> Vec<String> {
        self.inner
            .cards()
            .iter()
            .map(|m| m.name.to_owned())
            .collect()
    }
}

/// The module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Camera>()?;
    m.add_class::<Lod>()?;
    m.add_function(wrap_pyfunction!(spt_epsilon_for_pixels, m)?)?;
    m.add_class::<Catalogue>()?;
    m.add_function(wrap_pyfunction!(visible, m)?)?;
    m.add_function(wrap_pyfunction!(score, m)?)?;
    m.add_function(wrap_pyfunction!(convex_hull_vertices, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(srn_select, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    Ok(())
}
