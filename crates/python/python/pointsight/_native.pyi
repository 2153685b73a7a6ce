"""Type stubs of the native module (the Rust half of pointsight; see __init__.py)."""

from typing import Any, Optional, Sequence

import numpy as np
import numpy.typing as npt

class Camera:
    """A camera: pinhole, orthographic or spherical, with a pose."""

    @staticmethod
    def from_json(text: str) -> "Camera": ...
    @staticmethod
    def look_at(
        model: str,
        eye: Sequence[float],
        target: Sequence[float],
        up: Sequence[float],
        width: int,
        height: int,
        fov_y_deg: Optional[float] = None,
        fx: Optional[float] = None,
        fy: Optional[float] = None,
        cx: Optional[float] = None,
        cy: Optional[float] = None,
        view_width: Optional[float] = None,
        view_height: Optional[float] = None,
    ) -> "Camera": ...
    def to_json(self) -> str: ...
    def project(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    @property
    def model(self) -> str: ...
    @property
    def eye(self) -> list[float]: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...

class Lod:
    def __init__(
        self,
        method: str,
        points: npt.NDArray[np.float64],
        normals: Optional[npt.NDArray[np.float64]] = None,
        colors: Optional[npt.NDArray[np.float64]] = None,
        uvs: Optional[npt.NDArray[np.float64]] = None,
        texture: Optional[npt.NDArray[np.uint8]] = None,
        radius: Optional[float] = None,
        radius_spacings: float = 1.0,
        seed: int = 0,
        catalogue: Optional[Catalogue] = None,
    ) -> None: ...
    @staticmethod
    def open_qsplat_file(path: str, cache_bytes: int = ...) -> Lod: ...
    def select(
        self, cameras: list[Camera], params: list[tuple[str, str]], repeats: int = 1
    ) -> list[dict[str, Any]]: ...
    @property
    def method(self) -> str: ...
    @property
    def bytes(self) -> float: ...
    @property
    def build_seconds(self) -> float: ...
    @property
    def radius(self) -> float: ...
    def __len__(self) -> int: ...

def spt_epsilon_for_pixels(camera: Camera, px: float) -> float: ...
class Catalogue:
    def __init__(self) -> None: ...
    def load(self, dir: str) -> list[str]: ...
    def names(self) -> list[str]: ...

def visible(
    method: str,
    points: npt.NDArray[np.float64],
    cameras: list[Camera],
    params: list[tuple[str, str]],
    vertices: Optional[npt.NDArray[np.float64]] = None,
    faces: Optional[npt.NDArray[np.int64]] = None,
    catalogue: Optional[Catalogue] = None,
) -> list[npt.NDArray[np.int64]]: ...
def score(visible: npt.NDArray[np.int64], truth: npt.NDArray[np.int64], n: int) -> dict[str, float]: ...
def convex_hull_vertices(points: npt.NDArray[np.float64], impl_: str) -> npt.NDArray[np.int64]: ...
def read(
    path: str, format: Optional[str] = None, classes: Optional[list[int]] = None, scan: Optional[int] = None
) -> dict[str, np.ndarray]: ...
def set_num_threads(n: int) -> None: ...
def srn_select(
    uvs: npt.NDArray[np.float64], image: npt.NDArray[np.uint8], scale: float = 1.0, seed: int = 0
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...
def methods(catalogue: Optional[Catalogue] = None) -> list[tuple[str, str, list[tuple[str, str, str]]]]: ...
