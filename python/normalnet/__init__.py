"""normalnet: mesh denoising on the CPU — NormalNet and the classical filters.

Five lines::

    import normalnet
    v, f = normalnet.read_mesh("examples/noisy-part.obj")
    out = normalnet.denoise(v, f)                      # NormalNet, built-in model
    out_gnf = normalnet.denoise(v, f, "gnf", mu_g=0.3)   # any registered method
    normalnet.write_mesh("denoised.obj", out, f)

Arrays: vertices ``(N, 3)`` float (converted to float64), faces ``(M, 3)``
integer (converted to int64), 0-based. Keyword parameters are the fields the
CLI prints under ``parameters`` in ``normalnet denoise --json`` (see
:func:`methods` for each method's defaults). Errors are ``ValueError`` (bad
arrays, names, parameters), ``OSError`` (files) or ``RuntimeError``, with the
Rust library's message. The work runs with the GIL released.
"""

from __future__ import annotations

import json
import math
import os
import struct
import time
import warnings
import zlib
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _normalnet

__all__ = [
    "denoise",
    "denoise_report",
    "denoise_file",
    "denoise_trimesh",
    "methods",
    "noise",
    "metrics",
    "read_mesh",
    "write_mesh",
    "render",
    "render_png",
    "MESH_SUFFIXES",
]

__version__ = _normalnet.__version__

#: file name suffixes read and written (format chosen by the suffix)
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl", ".gltf", ".glb")

Mesh = Tuple[np.ndarray, np.ndarray]


def _vertices(vertices: Any, what: str) -> np.ndarray:
    try:
        v = np.ascontiguousarray(vertices, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what}: not convertible to a float64 array ({e})") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"{what}: expected shape (N, 3), got {v.shape}")
    return v


def _faces(faces: Any, what: str) -> np.ndarray:
    f = np.asarray(faces)
    if f.size and not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"{what}: expected an integer array of vertex indices, got dtype {f.dtype}")
    f = np.ascontiguousarray(f, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"{what}: expected shape (M, 3) (triangles), got {f.shape}")
    return f


def _mesh(vertices: Any, faces: Any, what: str = "mesh") -> Mesh:
    return _vertices(vertices, f"{what} vertices"), _faces(faces, f"{what} faces")


def _gt(gt: Optional[Mesh]) -> Tuple[Optional[np.ndarray], Optional[np.ndarray]]:
    if gt is None:
        return None, None
    if not (isinstance(gt, (tuple, list)) and len(gt) == 2):
        raise ValueError("gt: expected a (vertices, faces) pair")
    return _mesh(gt[0], gt[1], "gt")


def _params_json(params: Dict[str, Any]) -> str:
    def plain(x: Any) -> Any:
        if isinstance(x, (np.generic,)):
            return x.item()
        if isinstance(x, os.PathLike):
            return os.fspath(x)
        return x

    plain_params = {k: plain(v) for k, v in params.items()}
    for k, v in plain_params.items():
        if isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"parameter `{k}` = {v}: not a finite number")
    return json.dumps(plain_params)


def denoise_report(
    vertices: Any,
    faces: Any,
    method: str = "normalnet",
    gt: Optional[Mesh] = None,
    **params: Any,
) -> Tuple[np.ndarray, Dict[str, Any], Optional[Dict[str, Any]]]:
    """Like :func:`denoise`, also returning the resolved parameters (every
    field, defaults included) and NormalNet's seconds per stage (else None)."""
    v, f = _mesh(vertices, faces)
    gv, gf = _gt(gt)
    out, parameters, stages = _normalnet.denoise(v, f, method, _params_json(params), gv, gf)
    return out, json.loads(parameters), (json.loads(stages) if stages else None)


def denoise(
    vertices: Any,
    faces: Any,
    method: str = "normalnet",
    gt: Optional[Mesh] = None,
    **params: Any,
) -> np.ndarray:
    """Denoised vertices ``(N, 3)`` float64; the faces are unchanged.

    ``method``: ``normalnet`` (default; ``model=`` a bundle folder, else
    ``$NORMALNET_MODEL``, else the built-in model), ``gnf``, ``bnf``,
    ``sun07``, ``l0``, ``bi``, ``vt``, or ``oracle`` (reads ``gt``, a
    ``(vertices, faces)`` pair of the clean mesh). ``params`` override the
    method's defaults by name, e.g. ``iterations=5`` for NormalNet or
    ``normal_iterations=5`` for GNF.
    """
    return denoise_report(vertices, faces, method, gt, **params)[0]


def methods() -> List[Dict[str, Any]]:
    """Every registered method: name, aliases, summary, kind
    (classical / learned / oracle) and default parameters."""
    return json.loads(_normalnet.methods())


def noise(
    vertices: Any,
    faces: Any,
    level: float = 0.3,
    seed: int = 0,
    impulsive: Optional[float] = None,
    direction: str = "normal",
) -> np.ndarray:
    """Noisy vertices: Gaussian noise of σ = level × mean edge length along
    the vertex normals (``direction="random"``: random directions); with
    ``impulsive=p`` only a fraction p of the vertices move. Same seed, same
    result."""
    v, f = _mesh(vertices, faces)
    return _normalnet.noise(v, f, float(level), int(seed), impulsive, direction)


def metrics(gt: Mesh, result: Union[Mesh, Any]) -> Dict[str, Any]:
    """Error metrics of ``result`` against ``gt`` (each a ``(vertices,
    faces)`` pair; ``result`` may be vertices alone, with gt's faces): the
    keys of ``normalnet metrics --json`` (``e_a_deg``, ``e_v``,
    ``e_v_over_le``, ``hausdorff``, ``flipped_faces``, ...)."""
    gv, gf = _gt(gt)
    if isinstance(result, (tuple, list)) and len(result) == 2:
        rv, rf = _mesh(result[0], result[1], "result")
    else:
        rv, rf = _vertices(result, "result vertices"), gf
    return json.loads(_normalnet.metrics(gv, gf, rv, rf))


def read_mesh(
    path: Union[str, os.PathLike], attributes: bool = False
) -> Union[Mesh, Tuple[np.ndarray, np.ndarray, Dict[str, Any]]]:
    """``(vertices, faces)`` of an OBJ / OFF / PLY / STL / glTF file; faces
    are the fan triangulation of the file's polygons.

    With ``attributes=True``: ``(vertices, faces, attrs)``, ``attrs`` a dict
    of what else the file carries (a key is absent when the file has no such
    data):

    - ``"format"``: ``"obj"``, ``"off"``, ``"ply"``, ``"stl"`` or ``"gltf"``
      (``.glb`` too); ``"encoding"`` (PLY: ``"ascii"``,
      ``"binary_little_endian"``, ``"binary_big_endian"``; STL: ``"ascii"``,
      ``"binary"``; glTF: ``"json"``, ``"binary"``);
    - ``"polygon_sizes"``: int64 ``(P,)``, corners of each file polygon;
      polygon ``p`` gave ``polygon_sizes[p] - 2`` consecutive triangles
      ``(c0, c_i, c_i+1)`` of ``faces``;
    - ``"warnings"``: list of str, what the reader could not keep;
    - ``"uv"``: float64 ``(K, 2)``, ``(K, 3)`` when a ``vt`` has w (a
      component a ``vt`` leaves out is 0), and ``"corner_uv"``: int64
      ``(M, 3)``, per triangle of ``faces`` the row of ``uv`` of each
      corner, -1 for a corner without one (OBJ ``vt`` / ``f v/t``; glTF
      ``TEXCOORD_0``, see below);
    - ``"colors"``: float64 ``(K, 3)`` or ``(K, 4)``, and
      ``"corner_colors"``: int64 ``(M, 3)``, the same per-corner layout
      (glTF ``COLOR_0``; values 0-1, alpha 1 for an RGB element of a file
      that also has RGBA ones);
    - ``"vertex_colors"``: float64 ``(N, 3)`` or ``(N, 4)``, the values as
      the file writes them (0-255 for a PLY ``uchar``, often 0-1 in OBJ):
      OBJ ``v x y z r g b`` (every vertex must have one), PLY vertex
      ``red green blue [alpha]``, OFF colours (``COFF``, or an ``OFF``
      whose every vertex has 3 or 4 numbers after x y z);
    - ``"vertex_properties"`` / ``"face_properties"`` (PLY): dict name →
      float64 array of every scalar property of the ``vertex`` (N,) /
      ``face`` (P,: per file polygon) element other than x y z and nx ny
      nz (colours included). List properties and other elements are not in
      the dict (they are written back as read);
    - ``"_file"``: an opaque handle to what was read, for :func:`write_mesh`.

    glTF / GLB: the primitives are welded into one mesh by equal positions,
    so a vertex on a seam can have one UV or colour per primitive meeting
    there; hence per corner. ``uv`` / ``colors`` hold the elements of the
    ``TEXCOORD_0`` / ``COLOR_0`` accessors (each accessor once, in the order
    the primitives first use it; float as read, normalized unsigned bytes /
    shorts divided by 255 / 65535), ``corner_uv`` / ``corner_colors`` index
    them per triangle of ``faces`` (-1 on the triangles of a primitive
    without the attribute). They are read-only (written back as read); an
    attribute whose accessor is broken is left out and named in
    ``warnings``.

    Not in the dict yet: glTF's other attributes (``TEXCOORD_1``,
    ``COLOR_1``, ...), OBJ normals, OFF face colours, STL facet attribute
    bytes; :func:`write_mesh` writes them back as read (normals recomputed
    from the new positions).
    """
    path = os.fspath(path)
    if not attributes:
        return _normalnet.read_mesh(path)
    return _normalnet.read_mesh_attributes(path)


#: the keys of the dict of ``read_mesh(..., attributes=True)`` whose
#: arrays are converted before writing: float64 (editable) and int64
#: (read-only)
_FLOAT_KEYS = ("uv", "colors", "vertex_colors")
_INT_KEYS = ("polygon_sizes", "corner_uv", "corner_colors")
_PROPERTY_KEYS = ("vertex_properties", "face_properties")


def _array(value: Any, dtype: Any, key: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(value, dtype=dtype)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{key}: not convertible to a {np.dtype(dtype).name} array ({e})") from None


def _attribute_edits(attributes: Any) -> Tuple[Any, Dict[str, Any]]:
    """The handle and the entries of an attribute dict, arrays converted."""
    handle = attributes.get("_file") if isinstance(attributes, dict) else None
    if not isinstance(handle, _normalnet.FileAttributes):
        raise ValueError(
            "attributes: expected the dict of read_mesh(path, attributes=True) "
            "(its '_file' entry is missing or was replaced)"
        )
    edits: Dict[str, Any] = {}
    for key, value in attributes.items():
        if key in _FLOAT_KEYS:
            value = _array(value, np.float64, key)
        elif key in _INT_KEYS:
            value = _array(value, np.int64, key)
        elif key in _PROPERTY_KEYS:
            if not isinstance(value, dict):
                raise ValueError(f"{key}: expected a dict name -> array, got {type(value).__name__}")
            value = {name: _array(a, np.float64, f"{key}[{name!r}]") for name, a in value.items()}
        edits[key] = value
    return handle, edits


def write_mesh(
    path: Union[str, os.PathLike],
    vertices: Any,
    faces: Any,
    attributes: Optional[Dict[str, Any]] = None,
) -> None:
    """Writes a mesh; the format comes from the suffix; the file appears
    whole or not at all (temporary file + rename).

    ``attributes``: the dict of ``read_mesh(src, attributes=True)``, with
    ``faces`` as read and new ``vertices`` (e.g. denoised). The file is
    written with everything ``src`` carries (polygons, texture coordinates,
    materials, groups, colours, PLY properties, ...; normals recomputed),
    like :func:`denoise_file` does, and with the edits of the dict's values:
    ``uv`` (OBJ and glTF), ``colors`` (glTF: stored in the accessor's
    component type, f32 or the nearest step of a normalized integer, the
    accessor's ``min`` / ``max`` updated), ``vertex_colors``, and the arrays
    of ``vertex_properties`` /
    ``face_properties`` (PLY integer properties take the value rounded; a
    value outside the property's type is a ``ValueError``). Only the values
    that differ from the file's are rewritten (an OBJ / OFF vertex whose
    colour is unchanged keeps its text as read); ``vertex_colors`` is
    applied after ``vertex_properties`` (PLY colours are in both). A changed
    shape, a changed ``format`` / ``encoding`` / ``polygon_sizes`` /
    ``corner_uv`` / ``corner_colors``, a glTF colour column the accessor
    lacks (alpha of RGB), an added key or property, other faces, or a dict not from
    :func:`read_mesh` is a ``ValueError`` naming the key; a key removed from
    the dict is written as read. What the output lacks is a
    :class:`UserWarning` (as in :func:`denoise_file`): the reader's
    ``warnings`` (e.g. OFF comments, a missing ``mtllib`` file), and a
    format other than ``src``'s (positions and triangles only).
    """
    v, f = _mesh(vertices, faces)
    if attributes is None:
        _normalnet.write_mesh(os.fspath(path), v, f)
        return
    handle, edits = _attribute_edits(attributes)
    for message in _normalnet.write_mesh_attributes(os.fspath(path), v, f, handle, edits):
        warnings.warn(message, UserWarning, stacklevel=2)


def render(
    vertices: Any,
    faces: Any,
    gt: Optional[Mesh] = None,
    size: Tuple[int, int] = (800, 600),
    view: Tuple[float, float] = (30.0, 20.0),
    title: str = "",
    max_error: Optional[float] = None,
) -> np.ndarray:
    """An ``(height, width, 3)`` uint8 picture (software rasterizer, no GPU);
    with ``gt``, faces coloured by angular error against it (colour bar, E_a
    in the title). ``view`` = (azimuth, elevation) in degrees."""
    v, f = _mesh(vertices, faces)
    gv, gf = _gt(gt)
    w, h = size
    return _normalnet.render(v, f, gv, gf, int(w), int(h), float(view[0]), float(view[1]), title, max_error)


def _png_bytes(image: np.ndarray) -> bytes:
    h, w, _ = image.shape
    raw = b"".join(b"\x00" + image[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")


def render_png(path: Union[str, os.PathLike], vertices: Any, faces: Any, **kwargs: Any) -> None:
    """:func:`render` written to a PNG file."""
    image = render(vertices, faces, **kwargs)
    path = os.fspath(path)
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "wb") as fh:
        fh.write(_png_bytes(np.ascontiguousarray(image)))
    os.replace(tmp, path)


def denoise_file(
    input: Union[str, os.PathLike],
    output: Union[str, os.PathLike],
    method: str = "normalnet",
    skip_existing: bool = True,
    **params: Any,
) -> Dict[str, Any]:
    """Denoises one file into ``output`` and returns a summary row
    (``input``, ``output``, ``status`` = done / skipped / failed, ``faces``,
    ``seconds``, ``error``) — the unit of work of :mod:`normalnet.distributed`
    and of ``normalnet batch``. Never raises for a bad mesh: the error goes
    into the row; never leaves a partial output. The output keeps what the
    input file carries beyond positions and triangles (polygons, texture
    coordinates, materials, colours, extra PLY properties; issue 38), and a
    :class:`UserWarning` says what could not be kept."""
    input, output = os.fspath(input), os.fspath(output)
    row: Dict[str, Any] = {"input": input, "output": output, "method": method,
                           "status": "done", "faces": None, "seconds": 0.0, "error": None}
    if skip_existing and os.path.exists(output):
        row["status"] = "skipped"
        return row
    start = time.perf_counter()
    try:
        v, f = read_mesh(input)
        row["faces"] = int(f.shape[0])
        out = denoise(v, f, method, **params)
        out_v, out_f = _mesh(out, f)
        for message in _normalnet.write_mesh_like(os.fspath(output), out_v, out_f, input):
            warnings.warn(message, stacklevel=2)
    except (ValueError, OSError, RuntimeError) as e:
        row["status"] = "failed"
        row["error"] = str(e)
    row["seconds"] = time.perf_counter() - start
    return row


def denoise_trimesh(mesh: Any, method: str = "normalnet", **params: Any) -> Any:
    """A denoised copy of a ``trimesh.Trimesh`` (needs trimesh)."""
    try:
        import trimesh  # noqa: F401
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("denoise_trimesh needs trimesh: pip install trimesh") from e
    out = denoise(mesh.vertices, mesh.faces, method, **params)
    copy = mesh.copy()
    copy.vertices = out
    return copy
