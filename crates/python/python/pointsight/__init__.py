"""pointsight: point-cloud visibility and level of detail on numpy arrays.

The methods of the pointsight benchmark (https://github.com/... see the repository's README),
called in-process from Python: Hidden Point Removal (Katz et al. 2007) with an exact convex
hull, ray-cast point filtering (Jensen 2012), a z-buffer splat baseline, the mesh ground truth
(``reference``), the methods published since (robust HPR, screen-space operators, HPR
confidence, approximate HPR), external methods of any language (``load_methods``), and the
level-of-detail methods QSplat, Sequential Point Trees, SRN and the random baseline (``Lod``).
Every call goes through the registry and its measurement kernel, as the command line's do.

Keyword arguments are the keys of the command line's ``--set KEY=VALUE`` (one parameter
vocabulary). Points are (N, 3) arrays of float64 or float32 (anything else is converted once,
or refused with a TypeError/ValueError saying what was expected); results are sorted int64
indices (``as_mask=True`` gives a boolean mask). NaN, empty input and bad parameters raise
ValueError with the library's message. The computation runs without the GIL on a private copy
of the inputs: another thread may read or even modify the arrays meanwhile; the answer is for
the values at the time of the call.
"""

from __future__ import annotations

import json
import os
from typing import Any, Iterable, Optional, Sequence, Union

import numpy as np

from . import _native
from ._native import Camera

__all__ = [
    "Camera",
    "Catalogue",
    "Lod",
    "QSplat",
    "SequentialPointTree",
    "visible",
    "load_methods",
    "hpr",
    "hpr_many",
    "hidden_point_removal",
    "raycast",
    "splat_visibility",
    "reference",
    "score",
    "convex_hull_vertices",
    "read_cloud",
    "read_mesh",
    "srn_select",
    "set_num_threads",
    "methods",
    "to_mask",
]

ArrayLike = Any


def _points(points: ArrayLike, name: str = "points") -> np.ndarray:
    """An (N, 3) C-contiguous float64 array, or a TypeError/ValueError."""
    if hasattr(points, "points") and not isinstance(points, np.ndarray):
        # An Open3D PointCloud (or anything with a `.points` attribute).
        points = np.asarray(points.points)
    try:
        a = np.asarray(points)
    except Exception as e:  # noqa: BLE001 - numpy raises many kinds
        raise TypeError(f"{name}: expected an (N, 3) array of numbers, got {type(points).__name__}") from e
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == np.bool_):
        raise TypeError(f"{name}: expected an (N, 3) array of numbers, got dtype {a.dtype}")
    if np.issubdtype(a.dtype, np.complexfloating):
        raise TypeError(f"{name}: complex numbers are not coordinates")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (N, 3), got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name}: the array is empty")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if not np.isfinite(a).all():
        bad = int(np.argmax(~np.isfinite(a).all(axis=1)))
        raise ValueError(f"{name}: point {bad} has a non-finite coordinate")
    return a


def _vec3(v: ArrayLike, name: str) -> list:
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name}: expected three finite numbers, got {v!r}")
    return [float(x) for x in a]


def _params(**kwargs: Any) -> list:
    """Keyword arguments as the registry's KEY=VALUE pairs (None: the method's default)."""
    out = []
    for k, v in kwargs.items():
        if v is None:
            continue
        if isinstance(v, bool):
            v = "true" if v else "false"
        out.append((k, str(v)))
    return out


def to_mask(indices: np.ndarray, n: int) -> np.ndarray:
    """A boolean mask of length n, True at `indices`."""
    mask = np.zeros(n, dtype=bool)
    mask[np.asarray(indices, dtype=np.int64)] = True
    return mask


def _result(indices: np.ndarray, n: int, as_mask: bool) -> np.ndarray:
    return to_mask(indices, n) if as_mask else indices


def _viewpoint(eye: ArrayLike) -> Camera:
    """A spherical camera at `eye`: HPR needs only the viewpoint."""
    e = _vec3(eye, "eye")
    return Camera.look_at("spherical", e, [e[0] + 1.0, e[1], e[2]], [0.0, 0.0, 1.0], 2, 1)


def hpr(
    points: ArrayLike,
    eye: ArrayLike,
    *,
    gamma: Optional[Union[float, str]] = None,
    radius: Optional[float] = None,
    kernel: Optional[str] = None,
    hull: Optional[str] = None,
    perturb: Optional[float] = None,
    seed: Optional[int] = None,
    as_mask: bool = False,
) -> np.ndarray:
    """Hidden Point Removal (Katz, Tal, Basri 2007): the points visible from `eye`.

    Spherical flipping about the eye with R = max|p - eye| * 10**gamma (`radius` gives R
    directly, Open3D's meaning), then the convex hull (`hull`: "own", our exact hull, or
    "qhull", "parry", "quickhull", "chull"). `kernel="exp"` is Katz & Tal's exponential kernel
    (gamma < 0). `perturb` adds seed 000's +-perturb*R noise (seeded). A keyword left out is
    the registry's default, as everywhere (``methods()`` lists them): gamma "auto"
    (hpr::auto's rule from the cloud and the eye; Katz's paper used 3), the linear kernel, our
    hull, no perturbation, seed 2007. Returns sorted int64 indices, or a boolean mask with
    `as_mask=True`.
    """
    p = _points(points)
    (v,) = _native.visible(
        "hpr",
        p,
        [_viewpoint(eye)],
        _params(gamma=gamma, radius=radius, kernel=kernel, hull=hull, perturb=perturb, seed=seed),
    )
    return _result(v, len(p), as_mask)


def hpr_many(points: ArrayLike, eyes: ArrayLike, **kwargs: Any) -> list:
    """`hpr` from every eye of `eyes` (M, 3), views in parallel; one result per eye."""
    p = _points(points)
    e = np.asarray(eyes, dtype=np.float64)
    if e.ndim != 2 or e.shape[1] != 3:
        raise ValueError(f"eyes: expected shape (M, 3), got {e.shape}")
    as_mask = kwargs.pop("as_mask", False)
    allowed = {"gamma", "radius", "kernel", "hull", "perturb", "seed"}
    unknown = set(kwargs) - allowed
    if unknown:
        raise TypeError(f"hpr_many: unexpected keyword arguments {sorted(unknown)}")
    out = _native.visible("hpr", p, [_viewpoint(x) for x in e], _params(**kwargs))
    return [_result(v, len(p), as_mask) for v in out]


def hidden_point_removal(pcd_or_points: ArrayLike, camera_location: ArrayLike, radius: float) -> np.ndarray:
    """Open3D's `PointCloud.hidden_point_removal(camera_location, radius)`, same meaning.

    `radius` is the absolute flipping radius (Open3D's tutorial: 100 * the cloud's diameter).
    Accepts an (N, 3) array or anything with `.points` (an Open3D PointCloud). Returns the
    indices of the visible points (Open3D's second return value; no mesh is returned), sorted.
    Our hull is exact where Open3D's Qhull (`Qt`) merges nearly coplanar facets, so the sets can
    differ on degenerate input.
    """
    if not (isinstance(radius, (int, float)) and radius > 0):
        raise ValueError(f"radius must be a positive number, got {radius!r}")
    return hpr(pcd_or_points, camera_location, radius=float(radius))


def _camera(camera: Union[Camera, str, dict]) -> Camera:
    if isinstance(camera, Camera):
        return camera
    if isinstance(camera, dict):
        return Camera.from_json(json.dumps(camera))
    if isinstance(camera, str):
        return Camera.from_json(camera)
    raise TypeError(f"camera: expected a pointsight.Camera, its JSON or a dict, got {type(camera).__name__}")


def _cameras(camera: Any) -> list:
    """One camera (a Camera, its JSON or a dict) or a list of them, as a list."""
    if isinstance(camera, (list, tuple)):
        return [_camera(c) for c in camera]
    return [_camera(camera)]


def visible(
    method: str,
    points: ArrayLike,
    camera: Any,
    *,
    vertices: Optional[ArrayLike] = None,
    faces: Optional[ArrayLike] = None,
    as_mask: bool = False,
    catalogue: Optional["Catalogue"] = None,
    **params: Any,
) -> Union[np.ndarray, list]:
    """The points `method` (any name of `methods()`: built-in, or loaded with `load_methods`;
    or of `catalogue`, a `Catalogue` of your own) finds visible from `camera`, at the setting
    `params` (the registry's keys, as the command line's ``--set``). A list of cameras gives
    one result per camera (the method prepared once; the position in the list is the view
    index). `vertices`/`faces`: the mesh, for methods that need one (``reference``)."""
    p = _points(points)
    cams = _cameras(camera)
    mesh: tuple = ()
    if (vertices is None) != (faces is None):
        raise ValueError("give vertices and faces together")
    if vertices is not None:
        f = np.asarray(faces)
        if not np.issubdtype(f.dtype, np.integer):
            raise TypeError(f"faces: expected an (F, 3) integer array, got dtype {f.dtype}")
        mesh = (_points(vertices, "vertices"), np.ascontiguousarray(f, dtype=np.int64))
    if not mesh:
        mesh = (None, None)
    out = _native.visible(
        str(method), p, cams, _params(**params), *mesh, _catalogue_or_default(catalogue)
    )
    res = [_result(v, len(p), as_mask) for v in out]
    return res if isinstance(camera, (list, tuple)) else res[0]


#: The methods a caller runs: the built-in ones and the external folders loaded into it
#: (``Catalogue().load(folder)``). Two catalogues side by side know only their own folders;
#: pass one as ``catalogue=`` to `visible`, `Lod` and `methods`.
Catalogue = _native.Catalogue

#: The catalogue of calls that name none: `load_methods` loads into it.
_default_catalogue = _native.Catalogue()


def _catalogue_or_default(catalogue: Optional["Catalogue"]) -> "Catalogue":
    if catalogue is None:
        return _default_catalogue
    if not isinstance(catalogue, _native.Catalogue):
        raise TypeError(f"catalogue: expected a pointsight.Catalogue, got {type(catalogue).__name__}")
    return catalogue


def load_methods(folder: str) -> list:
    """Loads the external methods under `folder` (one ``NAME/method.toml`` each, the protocol
    of the repository's ``methods/README.md``) into the module's default catalogue, which every
    call that names no ``catalogue=`` uses; returns their names."""
    return _default_catalogue.load(str(folder))


def raycast(
    points: ArrayLike,
    camera: Union[Camera, str, dict],
    *,
    radius: Optional[float] = None,
    radius_factor: Optional[float] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    traversal: Optional[str] = None,
    as_mask: bool = False,
) -> np.ndarray:
    """Ray-cast point filtering (Jensen 2012): one ray per pixel of a `width` x `height` image
    (default 1280 x 720, the registry's; a camera of another size is resampled, its vertical
    field kept) through a point hierarchy (a bucketed BVH, or the seed's k-d tree), points as spheres of `radius` (default "auto":
    1.5 density spacings; `radius_factor` gives the spacings). Any camera model. `traversal`:
    "exact" (nearest hit, default) or "seed" (S1-S9)."""
    p = _points(points)
    (v,) = _native.visible(
        "raycast",
        p,
        [_camera(camera)],
        _params(radius=radius, radius_factor=radius_factor, width=width, height=height, traversal=traversal),
    )
    return _result(v, len(p), as_mask)


def splat_visibility(
    points: ArrayLike,
    camera: Union[Camera, str, dict],
    *,
    radius_px: Optional[float] = None,
    depth_tolerance: Optional[float] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    as_mask: bool = False,
) -> np.ndarray:
    """The z-buffer splat baseline: discs of `radius_px` pixels (default 2) into a depth
    buffer; visible within `depth_tolerance` (default 0.01, relative) of the nearest."""
    p = _points(points)
    (v,) = _native.visible(
        "splat",
        p,
        [_camera(camera)],
        _params(radius_px=radius_px, depth_tolerance=depth_tolerance, width=width, height=height),
    )
    return _result(v, len(p), as_mask)


def reference(
    vertices: ArrayLike,
    faces: ArrayLike,
    points: ArrayLike,
    camera: Union[Camera, str, dict],
    *,
    tolerance_px: Optional[float] = None,
    as_mask: bool = False,
) -> np.ndarray:
    """The ground truth: which `points` (lying on the mesh) the mesh (vertices (V, 3), faces
    (F, 3) integer) lets `camera` see (a depth buffer of at least 2048 px, each point's own ray,
    exact segment tests at silhouettes; spherical cameras: exact tests for every point)."""
    p = _points(points)
    v = _points(vertices, "vertices")
    f = np.asarray(faces)
    if not np.issubdtype(f.dtype, np.integer):
        raise TypeError(f"faces: expected an (F, 3) integer array, got dtype {f.dtype}")
    f = np.ascontiguousarray(f, dtype=np.int64)
    (out,) = _native.visible("reference", p, [_camera(camera)], _params(tolerance_px=tolerance_px), v, f)
    return _result(out, len(p), as_mask)


def score(visible: ArrayLike, truth: ArrayLike, n: int) -> dict:
    """Precision, recall, F1 and Jaccard of `visible` against `truth` (index arrays or boolean
    masks of length n)."""

    def idx(a: ArrayLike) -> np.ndarray:
        a = np.asarray(a)
        if a.dtype == np.bool_:
            if a.shape != (n,):
                raise ValueError(f"a mask must have length n = {n}, got {a.shape}")
            return np.flatnonzero(a).astype(np.int64)
        return np.ascontiguousarray(a, dtype=np.int64).reshape(-1)

    return _native.score(idx(visible), idx(truth), int(n))


def convex_hull_vertices(points: ArrayLike, impl: str = "own") -> np.ndarray:
    """Indices of the convex hull's vertices, sorted: our exact hull ("own") or "qhull",
    "parry", "quickhull" (f32), "chull"."""
    return _native.convex_hull_vertices(_points(points), impl)


def read_cloud(path: str, *, format: Optional[str] = None, classes: Optional[Sequence[int]] = None, scan: Optional[int] = None) -> dict:
    """Reads a point file (ply, off, obj, xyz, las, laz, e57, pcd; `format` names it when the
    extension does not, `classes` keeps only those LAS/LAZ classification codes, `scan` reads
    one E57 scan). Returns a dict of numpy arrays, each key present only where the file has it:
    `positions` (N, 3) float64, always (the file's coordinates, LAS scale and offset applied);
    `normals` (N, 3) float64; `colors` (N, 3) uint8; `intensity` (N,) uint16;
    `classification` (N,) uint8; `scan` (N,) uint16, each point's E57 scan; `faces` (F, 3)
    int64, a mesh file's triangles; `scanner_positions` (S, 3) float64, the E57 scanners.
    Raises ValueError naming the file and the line or byte when it cannot be read."""
    return _native.read(str(path), format, list(classes) if classes is not None else None, scan)


def read_mesh(path: str) -> tuple:
    """Reads a mesh file (off, ply, obj with faces): (vertices (V, 3), faces (F, 3) int64)."""
    d = _native.read(str(path), None, None, None)
    if "faces" not in d:
        raise ValueError(f"{path} has no faces: a mesh file is needed")
    return d["positions"], d["faces"]


def _colors(colors: Optional[ArrayLike]) -> Optional[np.ndarray]:
    if colors is None:
        return None
    c = np.asarray(colors)
    if c.dtype == np.uint8:
        c = c.astype(np.float64) / 255.0
    return _points(c, "colors")


class Lod:
    """A level-of-detail method of the registry (`qsplat`, `spt`, `srn`, `random`, or one
    registered at run time), built once on `points` through the measurement kernel, then
    selected per camera with the registry's parameters (as the ``lod`` experiment does).

    `normals` (N, 3) unit (else k-nearest-neighbour estimates, 16 neighbours), `colors` (N, 3)
    in [0, 1] or uint8, `uvs` (N, 2) texture coordinates and `texture` (H, W, 3) uint8 (the
    colours then come from it; SRN's importance is its visual masking, so SRN needs one),
    full-detail splats of `radius` world units (else `radius_spacings` density spacings),
    every random choice from `seed`.
    """

    def __init__(
        self,
        method: str,
        points: ArrayLike,
        normals: Optional[ArrayLike] = None,
        *,
        colors: Optional[ArrayLike] = None,
        uvs: Optional[ArrayLike] = None,
        texture: Optional[ArrayLike] = None,
        radius: Optional[float] = None,
        radius_spacings: float = 1.0,
        seed: int = 0,
        catalogue: Optional["Catalogue"] = None,
    ) -> None:
        p = _points(points)
        n = None if normals is None else _points(normals, "normals")
        u = None if uvs is None else np.ascontiguousarray(uvs, dtype=np.float64)
        t = None
        if texture is not None:
            t = np.asarray(texture)
            if t.dtype != np.uint8:
                raise TypeError(f"texture: expected uint8 (H, W, 3), got {t.dtype}")
            t = np.ascontiguousarray(t)
        self._native = _native.Lod(
            str(method), p, n, _colors(colors), u, t,
            None if radius is None else float(radius), float(radius_spacings), int(seed),
            _catalogue_or_default(catalogue),
        )

    def select(self, camera: Any, *, repeats: int = 1, **params: Any) -> Union[dict, list]:
        """The splats drawn for `camera` (or each of a list of cameras) at the setting `params`
        (e.g. ``threshold_px=2`` for qsplat, ``epsilon_px=1`` for spt): a dict of `centers`,
        `radii`, `normals`, `colors` arrays and the selection's `seconds`."""
        out = self._native.select(_cameras(camera), _params(**params), int(repeats))
        return out if isinstance(camera, (list, tuple)) else out[0]

    @property
    def method(self) -> str:
        return self._native.method

    @property
    def radius(self) -> float:
        """The full-detail splat radius, world units."""
        return self._native.radius

    @property
    def bytes(self) -> float:
        """Bytes of the built structure (0 when not meaningful)."""
        return self._native.bytes

    @property
    def build_seconds(self) -> float:
        return self._native.build_seconds

    def __len__(self) -> int:
        """Nodes or entries of the built structure."""
        return len(self._native)


class QSplat(Lod):
    """QSplat (Rusinkiewicz & Levoy 2000, seed 002): the registry's `qsplat`, leaves of
    `leaf_radius`; `select(camera, threshold_px)`."""

    def __init__(self, points: ArrayLike, normals: Optional[ArrayLike], leaf_radius: float, colors: Optional[ArrayLike] = None) -> None:
        super().__init__("qsplat", points, normals, colors=colors, radius=leaf_radius)

    def select(self, camera: Any, threshold_px: Optional[float] = None, **kw: Any) -> Union[dict, list]:
        """The splats of `camera` at `threshold_px` (left out: the registry's default, 2)."""
        return super().select(camera, threshold_px=threshold_px, **kw)

    @classmethod
    def open(cls, path: Union[str, "os.PathLike[str]"], *, cache_bytes: int = 64 << 20) -> "QSplat":
        """A QSplat file written by ``pointsight lod-build``, selected from without loading it:
        each selection reads the pages its view needs through a cache of at most
        `cache_bytes`; its dicts also give `bytes_read` (by a view's first selection) and
        `cache_bytes` (held after it). `radius` is 0: the file's leaves carry their own."""
        q = cls.__new__(cls)
        q._native = _native.Lod.open_qsplat_file(os.fspath(path), int(cache_bytes))
        return q


class SequentialPointTree(Lod):
    """Sequential Point Trees (Dachsbacher et al. 2003, seed 002): the registry's `spt`, leaf
    discs of `leaf_diameter`; `select(camera, epsilon_px)` cuts at a screen-space error of
    `epsilon_px` pixels (`epsilon_for_pixels` gives the world-space ε it means)."""

    def __init__(self, points: ArrayLike, normals: Optional[ArrayLike], leaf_diameter: float, colors: Optional[ArrayLike] = None) -> None:
        super().__init__("spt", points, normals, colors=colors, radius=leaf_diameter / 2.0)

    def select(self, camera: Any, epsilon_px: Optional[float] = None, **kw: Any) -> Union[dict, list]:
        """The splats of `camera` at `epsilon_px` (left out: the registry's default, 1)."""
        return super().select(camera, epsilon_px=epsilon_px, **kw)

    @classmethod
    def open(cls, path: Union[str, "os.PathLike[str]"]) -> "SequentialPointTree":
        """A sequential point tree file written by ``pointsight lod-build --method spt``, cut
        without loading it: each selection reads the prefix of the list its view needs, block
        by block, and the splats it selects; its dicts also give `bytes_read` (by a view's
        first selection). `radius` is 0: the file's discs carry their own."""
        q = cls.__new__(cls)
        q._native = _native.Lod.open_file(os.fspath(path))
        if q._native.method != "spt":
            raise ValueError(f"{os.fspath(path)}: a {q._native.method} file, not a sequential point tree")
        return q

    @staticmethod
    def epsilon_for_pixels(camera: Camera, px: float) -> float:
        """ε (world units per unit distance) for `px` pixels of error through `camera`."""
        return _native.spt_epsilon_for_pixels(camera, float(px))


def srn_select(uvs: ArrayLike, image: ArrayLike, *, scale: float = 1.0, seed: int = 0) -> tuple:
    """SRN (Qu et al. 2006): the points kept at density `scale` with the JPEG2000 masking
    importance of `image` ((H, W, 3) uint8) at texture coordinates `uvs` ((N, 2) in [0, 1]):
    (indices, radius factors 1/sqrt(I))."""
    u = np.ascontiguousarray(uvs, dtype=np.float64)
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise TypeError(f"image: expected uint8 (H, W, 3), got {img.dtype}")
    return _native.srn_select(u, np.ascontiguousarray(img), float(scale), int(seed))


def set_num_threads(n: int) -> None:
    """Use `n` threads for every later call (0: one per core)."""
    if not (isinstance(n, int) and n >= 0):
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    _native.set_num_threads(n)


def methods(catalogue: Optional["Catalogue"] = None) -> list:
    """Every method of `catalogue` (default: the built-in ones and those loaded with
    `load_methods`), visibility then level of detail: (name, summary, [(key, default, help),
    ...])."""
    return _native.methods(_catalogue_or_default(catalogue))
