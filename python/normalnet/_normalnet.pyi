"""Type stubs of the native module (src/lib.rs); use the wrappers in
``normalnet`` instead, which check and convert arrays."""

from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

def denoise(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    method: str,
    params_json: str,
    gt_vertices: Optional[npt.NDArray[np.float64]] = None,
    gt_faces: Optional[npt.NDArray[np.int64]] = None,
) -> Tuple[npt.NDArray[np.float64], str, Optional[str]]: ...
def methods() -> str: ...
def noise(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    level: float,
    seed: int,
    impulsive: Optional[float],
    direction: str,
) -> npt.NDArray[np.float64]: ...
def metrics(
    gt_vertices: npt.NDArray[np.float64],
    gt_faces: npt.NDArray[np.int64],
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
) -> str: ...
def read_mesh(path: str) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...
def write_mesh(path: str, vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> None: ...
def write_mesh_like(
    path: str, vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], input: str
) -> List[str]: ...

class FileAttributes:
    """What a mesh file carries beyond positions and triangles (the Rust
    ``Attributes``): the ``_file`` entry of ``read_mesh_attributes``' dict.
    Opaque and immutable; copies share it."""

    @property
    def format(self) -> str: ...
    def __copy__(self) -> "FileAttributes": ...
    def __deepcopy__(self, memo: Any) -> "FileAttributes": ...

def read_mesh_attributes(
    path: str,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], Dict[str, Any]]: ...
def write_mesh_attributes(
    path: str,
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    file: FileAttributes,
    edits: Dict[str, Any],
) -> List[str]: ...
def render(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    gt_vertices: Optional[npt.NDArray[np.float64]],
    gt_faces: Optional[npt.NDArray[np.int64]],
    width: int,
    height: int,
    azimuth: float,
    elevation: float,
    title: str,
    max_error: Optional[float],
) -> npt.NDArray[np.uint8]: ...
