"""Type stubs of the native module (the Rust half of pointsight; see __init__.py)."""

from typing import Optional, Sequence

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

class QSplat:
    def __init__(
        self,
        points: npt.NDArray[np.float64],
        normals: npt.NDArray[np.float64],
        leaf_radius: float,
        colors: Optional[npt.NDArray[np.float64]] = None,
    ) -> None: ...
    def select(self, camera: Camera, threshold_px: float) -> dict[str, np.ndarray]: ...

class SequentialPointTree:
    def __init__(
        self,
        points: npt.NDArray[np.float64],
        normals: npt.NDArray[np.float64],
        leaf_diameter: float,
        colors: Optional[npt.NDArray[np.float64]] = None,
    ) -> None: ...
    def cut(self, eye: Sequence[float], epsilon: float) -> dict[str, np.ndarray]: ...
    @staticmethod
    def epsilon_for_pixels(camera: Camera, px: float) -> float: ...
    def __len__(self) -> int: ...

def visible(
    method: str,
    points: npt.NDArray[np.float64],
    cameras: list[Camera],
    params: list[tuple[str, str]],
    vertices: Optional[npt.NDArray[np.float64]] = None,
    faces: Optional[npt.NDArray[np.int64]] = None,
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
def methods() -> list[tuple[str, str, list[tuple[str, str, str]]]]: ...
