"""read_mesh(path, attributes=True) and write_mesh(..., attributes=...):
what a file carries beyond positions and triangles, as numpy arrays, and
the user's edits of it written back (issue 38)."""

import base64
import copy
import json
import struct

from pathlib import Path

import numpy as np
import pytest

import normalnet

# A square pyramid: a quad base and four triangles; vertex colours and
# texture coordinates; one triangle has no `vt`.
OBJ = """\
# pyramid
o pyramid
v 0 0 0 1 0 0
v 1 0 0 0 1 0
v 1 1 0 0 0 1
v 0 1 0 0.5 0.5 0.5
v 0.5 0.5 1 0.25 0.75 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
f 1/1 4/4 3/3 2/2
f 1/1 2/2 5/5
f 2 3 5
f 3/3 4/4 5/5
f 4/4 1/1 5/5
"""
POSITIONS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=np.float64)
OBJ_FACES = np.array([[0, 3, 2], [0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
OBJ_COLORS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.5], [0.25, 0.75, 1]])
OBJ_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], dtype=np.float64)
OBJ_CORNER_UV = np.array([[0, 3, 2], [0, 2, 1], [0, 1, 4], [-1, -1, -1], [2, 3, 4], [3, 0, 4]])

# The same pyramid as PLY: uchar colours, a float `quality` per vertex, a
# `quality` and a `flags` per face, and a list property `extra` per face.
PLY_COLORS = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30], [200, 100, 50]], dtype=np.float64)
PLY_QUALITY = np.array([0.5, 1.5, 2.5, 3.5, 4.5])
PLY_POLYGONS = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
PLY_FACE_QUALITY = np.array([0.25, 1.0, 2.0, 3.0, 4.0])
PLY_FLAGS = np.array([7, 1, 2, 3, 4], dtype=np.float64)
PLY_HEADER = """\
ply
format {encoding} 1.0
comment made by test_attributes
element vertex 5
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
property float quality
element face 5
property list uchar int vertex_indices
property float quality
property uchar flags
property list uchar uchar extra
end_header
"""


def ply_bytes(encoding):
    header = PLY_HEADER.format(encoding=encoding).encode()
    if encoding == "ascii":
        lines = []
        for p, c, q in zip(POSITIONS, PLY_COLORS, PLY_QUALITY):
            lines.append("%g %g %g %d %d %d %g" % (*p, *c, q))
        for poly, q, fl in zip(PLY_POLYGONS, PLY_FACE_QUALITY, PLY_FLAGS):
            lines.append(" ".join(map(str, [len(poly), *poly])) + " %g %d 2 1 2" % (q, fl))
        return header + ("\n".join(lines) + "\n").encode()
    e = "<" if encoding == "binary_little_endian" else ">"
    body = b""
    for p, c, q in zip(POSITIONS, PLY_COLORS, PLY_QUALITY):
        body += struct.pack(e + "fffBBBf", *p, *c.astype(int), q)
    for poly, q, fl in zip(PLY_POLYGONS, PLY_FACE_QUALITY, PLY_FLAGS):
        body += struct.pack(e + "B%di" % len(poly), len(poly), *poly)
        body += struct.pack(e + "fBBBB", q, int(fl), 2, 1, 2)
    return header + body


@pytest.fixture
def obj_file(tmp_path):
    path = tmp_path / "pyramid.obj"
    path.write_text(OBJ)
    return path


@pytest.fixture(params=["ascii", "binary_little_endian", "binary_big_endian"])
def ply_file(tmp_path, request):
    path = tmp_path / "pyramid.ply"
    path.write_bytes(ply_bytes(request.param))
    return path


def test_default_read_mesh_is_still_a_pair(obj_file, ply_file):
    for path in (obj_file, ply_file):
        out = normalnet.read_mesh(path)
        assert isinstance(out, tuple) and len(out) == 2
        v, f = out
        np.testing.assert_array_equal(v, POSITIONS)
        assert f.shape == (6, 3)


def test_obj_attributes_are_what_the_file_holds(obj_file):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    np.testing.assert_array_equal(v, POSITIONS)
    np.testing.assert_array_equal(f, OBJ_FACES)
    assert a["format"] == "obj" and "encoding" not in a
    assert a["warnings"] == []
    assert a["polygon_sizes"].dtype == np.int64
    np.testing.assert_array_equal(a["polygon_sizes"], [4, 3, 3, 3, 3])
    assert a["uv"].dtype == np.float64 and a["uv"].shape == (5, 2)
    np.testing.assert_array_equal(a["uv"], OBJ_UV)
    assert a["corner_uv"].dtype == np.int64 and a["corner_uv"].shape == f.shape
    np.testing.assert_array_equal(a["corner_uv"], OBJ_CORNER_UV)
    np.testing.assert_array_equal(a["vertex_colors"], OBJ_COLORS)
    assert "vertex_properties" not in a and "face_properties" not in a
    assert a["_file"].format == "obj"


def test_ply_attributes_are_what_the_file_holds(ply_file):
    v, f, a = normalnet.read_mesh(ply_file, attributes=True)
    np.testing.assert_array_equal(v, POSITIONS)
    assert a["format"] == "ply"
    assert a["encoding"] in ("ascii", "binary_little_endian", "binary_big_endian")
    np.testing.assert_array_equal(a["polygon_sizes"], [4, 3, 3, 3, 3])
    np.testing.assert_array_equal(a["vertex_colors"], PLY_COLORS)
    props = a["vertex_properties"]
    assert list(props) == ["red", "green", "blue", "quality"]
    np.testing.assert_array_equal(props["quality"], PLY_QUALITY)
    np.testing.assert_array_equal(props["green"], PLY_COLORS[:, 1])
    faces = a["face_properties"]
    assert list(faces) == ["quality", "flags"]  # lists (vertex_indices, extra) are not in the dict
    np.testing.assert_array_equal(faces["quality"], PLY_FACE_QUALITY)
    np.testing.assert_array_equal(faces["flags"], PLY_FLAGS)
    assert "uv" not in a and "corner_uv" not in a


def assert_same_attributes(a, b):
    assert set(a) == set(b)
    for key in a:
        if key in ("_file", "warnings"):
            continue
        if isinstance(a[key], dict):
            assert list(a[key]) == list(b[key]), key
            for name in a[key]:
                np.testing.assert_array_equal(a[key][name], b[key][name], err_msg=f"{key}[{name}]")
        elif isinstance(a[key], np.ndarray):
            assert a[key].dtype == b[key].dtype, key
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
        else:
            assert a[key] == b[key], key


@pytest.mark.parametrize("which", ["obj", "ply"])
def test_round_trip_with_new_positions(which, obj_file, ply_file, tmp_path):
    src = obj_file if which == "obj" else ply_file
    v, f, a = normalnet.read_mesh(src, attributes=True)
    moved = v + np.array([0.5, -0.25, 0.125])  # exact in float32 too
    out = tmp_path / f"out.{which}"
    normalnet.write_mesh(out, moved, f, attributes=a)
    v2, f2, a2 = normalnet.read_mesh(out, attributes=True)
    np.testing.assert_array_equal(v2, moved)
    np.testing.assert_array_equal(f2, f)
    assert_same_attributes(a, a2)
    if which == "obj":  # the other statements are kept in their place
        text = out.read_text()
        assert text.startswith("# pyramid\no pyramid\n") and "f 1/1 4/4 3/3 2/2\n" in text


def test_unchanged_dict_keeps_the_file_text(obj_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    out = tmp_path / "same.obj"
    normalnet.write_mesh(out, v, f, attributes=a)
    assert out.read_text() == OBJ


def test_edited_obj_colors_and_uv_are_written(obj_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    a["vertex_colors"][1] = [0.125, 0.5, 0.875]
    a["uv"][4] = [0.25, 0.75]
    out = tmp_path / "edited.obj"
    normalnet.write_mesh(out, v, f, attributes=a)
    _, _, b = normalnet.read_mesh(out, attributes=True)
    np.testing.assert_array_equal(b["vertex_colors"], a["vertex_colors"])
    np.testing.assert_array_equal(b["uv"], a["uv"])
    np.testing.assert_array_equal(b["corner_uv"], OBJ_CORNER_UV)
    lines = out.read_text().splitlines()
    assert "v 1 0 0 0.125 0.5 0.875" in lines
    assert "v 0 1 0 0.5 0.5 0.5" in lines  # unchanged rows keep their text
    assert "vt 0.25 0.75" in lines


def test_edited_ply_colors_and_properties_are_written(ply_file, tmp_path):
    v, f, a = normalnet.read_mesh(ply_file, attributes=True)
    colors = a["vertex_colors"].copy()
    colors[2] = [1, 2, 3]
    a["vertex_colors"] = colors.astype(np.uint8)  # any numeric dtype
    a["vertex_properties"]["quality"][0] = -7.25
    a["face_properties"]["flags"][:] = [9, 8, 7, 6, 5]
    a["face_properties"]["quality"] = a["face_properties"]["quality"].tolist()  # lists too
    out = tmp_path / "edited.ply"
    normalnet.write_mesh(out, v, f, attributes=a)
    _, _, b = normalnet.read_mesh(out, attributes=True)
    assert b["encoding"] == a["encoding"]
    np.testing.assert_array_equal(b["vertex_colors"], colors)
    np.testing.assert_array_equal(b["vertex_properties"]["red"], colors[:, 0])
    np.testing.assert_array_equal(b["vertex_properties"]["quality"], [-7.25, *PLY_QUALITY[1:]])
    np.testing.assert_array_equal(b["face_properties"]["flags"], [9, 8, 7, 6, 5])
    np.testing.assert_array_equal(b["face_properties"]["quality"], PLY_FACE_QUALITY)


def test_ply_colour_edited_through_vertex_properties(ply_file, tmp_path):
    v, f, a = normalnet.read_mesh(ply_file, attributes=True)
    a["vertex_properties"]["blue"][0] = 99  # vertex_colors left as read
    out = tmp_path / "blue.ply"
    normalnet.write_mesh(out, v, f, attributes=a)
    _, _, b = normalnet.read_mesh(out, attributes=True)
    assert b["vertex_colors"][0].tolist() == [255, 0, 99]


def test_off_colors(tmp_path):
    src = tmp_path / "tri.off"
    src.write_text("COFF\n# r g b a\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n"
                   "0 1 0 9 9 9 128\n3 0 1 2\n3 0 2 3\n")
    v, f, a = normalnet.read_mesh(src, attributes=True)
    assert a["format"] == "off"
    assert len(a["warnings"]) == 1 and "comment" in a["warnings"][0]
    np.testing.assert_array_equal(a["vertex_colors"][3], [9, 9, 9, 128])
    a["vertex_colors"][3, 3] = 64
    out = tmp_path / "out.off"
    with pytest.warns(UserWarning, match="comment lines dropped"):  # the reader's, re-said
        normalnet.write_mesh(out, v, f, attributes=a)
    lines = out.read_text().splitlines()
    assert lines[2] == "0 0 0 255 0 0 255" and lines[5] == "0 1 0 9 9 9 64"


def test_wrong_shapes_are_value_errors_naming_the_key(obj_file, ply_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    out = tmp_path / "never.obj"
    for key, value in [
        ("vertex_colors", a["vertex_colors"][:, :2]),
        ("vertex_colors", a["vertex_colors"][:-1]),
        ("uv", np.zeros((5, 3))),
        ("uv", "not numbers"),
    ]:
        b = dict(a, **{key: value})
        with pytest.raises(ValueError, match=key):
            normalnet.write_mesh(out, v, f, attributes=b)
    v, f, a = normalnet.read_mesh(ply_file, attributes=True)
    b = copy.deepcopy(a)
    b["vertex_properties"]["quality"] = PLY_QUALITY[:3]
    with pytest.raises(ValueError, match=r"vertex_properties\[\"quality\"\].*shape \[3\].*\[5\]"):
        normalnet.write_mesh(tmp_path / "never.ply", v, f, attributes=b)
    b = copy.deepcopy(a)
    b["face_properties"]["flags"] = np.zeros((5, 2))
    with pytest.raises(ValueError, match="face_properties.*flags"):
        normalnet.write_mesh(tmp_path / "never.ply", v, f, attributes=b)
    assert not (tmp_path / "never.obj").exists() and not (tmp_path / "never.ply").exists()


def test_what_cannot_be_edited_is_a_value_error(obj_file, ply_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    out = tmp_path / "never.obj"
    cases = [
        ({"corner_uv": np.zeros_like(a["corner_uv"])}, "corner_uv"),
        ({"polygon_sizes": [3, 3, 3, 3, 3, 3]}, "polygon_sizes"),
        ({"format": "ply"}, "format"),
        ({"vertex_colours": a["vertex_colors"]}, "vertex_colours"),
        ({"vertex_properties": {"quality": np.zeros(5)}}, "vertex_properties"),
        ({"vertex_colors": np.full((5, 3), np.nan)}, "vertex_colors.*not finite"),
    ]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):
            normalnet.write_mesh(out, v, f, attributes=dict(a, **change))
    with pytest.raises(ValueError, match="_file"):
        normalnet.write_mesh(out, v, f, attributes={k: a[k] for k in a if k != "_file"})
    with pytest.raises(ValueError, match="_file"):
        normalnet.write_mesh(out, v, f, attributes={"format": "obj"})
    other = f.copy()
    other[0] = other[0][::-1]
    with pytest.raises(ValueError, match=r"faces\[0\]"):
        normalnet.write_mesh(out, v, other, attributes=a)
    with pytest.raises(ValueError, match="vertices"):
        normalnet.write_mesh(out, v[:4], f[:1], attributes=a)
    v, f, a = normalnet.read_mesh(ply_file, attributes=True)
    b = copy.deepcopy(a)
    b["vertex_colors"][0, 0] = 256
    with pytest.raises(ValueError, match="vertex_colors.*red.*256.*uchar"):
        normalnet.write_mesh(tmp_path / "never.ply", v, f, attributes=b)
    b = copy.deepcopy(a)
    b["vertex_properties"]["confidence"] = np.zeros(5)
    with pytest.raises(ValueError, match="confidence.*cannot be added"):
        normalnet.write_mesh(tmp_path / "never.ply", v, f, attributes=b)
    assert not out.exists() and not (tmp_path / "never.ply").exists()


def test_removed_keys_are_written_as_read(obj_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    out = tmp_path / "minimal.obj"
    normalnet.write_mesh(out, v, f, attributes={"_file": a["_file"]})
    assert out.read_text() == OBJ


def test_another_format_warns_what_is_dropped(obj_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    with pytest.warns(UserWarning, match="texture coordinates"):
        normalnet.write_mesh(tmp_path / "out.ply", v, f, attributes=a)
    v2, f2 = normalnet.read_mesh(tmp_path / "out.ply")
    np.testing.assert_array_equal(v2, v)
    np.testing.assert_array_equal(f2, f)


def test_stl_and_plain_meshes(tmp_path, example):
    v, f, _, _ = example
    path = tmp_path / "m.stl"
    normalnet.write_mesh(path, v, f)
    v2, f2, a = normalnet.read_mesh(path, attributes=True)
    assert a["format"] == "stl" and a["encoding"] == "binary"
    assert np.all(a["polygon_sizes"] == 3) and len(a["polygon_sizes"]) == len(f2)
    assert not {"uv", "vertex_colors", "vertex_properties"} & set(a)
    normalnet.write_mesh(tmp_path / "again.stl", v2, f2, attributes=a)
    assert (tmp_path / "again.stl").read_bytes()[:80] == path.read_bytes()[:80]  # the header
    v3, f3 = normalnet.read_mesh(tmp_path / "again.stl")
    np.testing.assert_array_equal(v3, v2)
    np.testing.assert_array_equal(f3, f2)


def test_the_dict_can_be_copied(obj_file, tmp_path):
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    b = copy.deepcopy(a)
    assert b["_file"] is a["_file"]  # immutable: shared
    b["vertex_colors"][0] = 0.0
    np.testing.assert_array_equal(a["vertex_colors"], OBJ_COLORS)
    assert "obj" in repr(a["_file"]).lower()


def test_denoise_trimesh_keeps_vertex_colors():
    trimesh = pytest.importorskip("trimesh", reason="trimesh is not installed: pip install trimesh")
    sphere = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(0)
    colors = rng.integers(0, 256, (len(sphere.vertices), 4), dtype=np.uint8)
    colored = trimesh.Trimesh(
        vertices=sphere.vertices + rng.normal(0, 0.01, sphere.vertices.shape),
        faces=sphere.faces,
        vertex_colors=colors,
        process=False,
    )
    out = normalnet.denoise_trimesh(colored, "gnf")
    assert out is not colored
    assert not np.allclose(out.vertices, colored.vertices)
    np.testing.assert_array_equal(out.faces, colored.faces)
    assert out.visual.kind == "vertex"
    np.testing.assert_array_equal(out.visual.vertex_colors, colors)
    np.testing.assert_array_equal(colored.visual.vertex_colors, colors)


def test_denoise_trimesh_keeps_uv():
    trimesh = pytest.importorskip("trimesh", reason="trimesh is not installed: pip install trimesh")
    # a trimesh texture (its material) is copied through Pillow
    pytest.importorskip("PIL", reason="trimesh's textured visuals need Pillow: pip install pillow")
    sphere = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(1)
    uv = rng.random((len(sphere.vertices), 2))
    textured = trimesh.Trimesh(
        vertices=sphere.vertices + rng.normal(0, 0.01, sphere.vertices.shape),
        faces=sphere.faces,
        visual=trimesh.visual.TextureVisuals(uv=uv),
        process=False,
    )
    out = normalnet.denoise_trimesh(textured, "gnf")
    assert not np.allclose(out.vertices, textured.vertices)
    assert out.visual.kind == "texture"
    np.testing.assert_array_equal(out.visual.uv, uv)
    np.testing.assert_array_equal(textured.visual.uv, uv)


# glTF: a unit square of two triangle primitives, welded along the diagonal;
# each has its own TEXCOORD_0 (a UV seam on the diagonal); COLOR_0 is float
# RGB on the first and normalized unsigned-byte RGBA on the second.
GLTF_POSITIONS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
GLTF_FACES = np.array([[0, 1, 2], [0, 2, 3]])
GLTF_UV = np.array([[0, 0], [1, 0], [1, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]])
GLTF_COLORS = np.array([[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1],
                        [1, 0, 0, 1], [0, 1, 0, 51 / 255], [0, 0, 1, 0]])
GLTF_CORNERS = np.array([[0, 1, 2], [3, 4, 5]])


def gltf_document(second_colour=True):
    """(JSON document, buffer bytes) of the square."""
    bin_, views, accessors = bytearray(), [], []

    def accessor(data, component_type, kind, count, normalized=False):
        while len(bin_) % 4:
            bin_.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data)})
        bin_.extend(data)
        a = {"bufferView": len(views) - 1, "componentType": component_type, "count": count, "type": kind}
        if normalized:
            a["normalized"] = True
        accessors.append(a)
        return len(accessors) - 1

    def floats(rows):
        return struct.pack("<%df" % (len(rows) * len(rows[0])), *np.ravel(rows))

    first = {
        "POSITION": accessor(floats(GLTF_POSITIONS[[0, 1, 2]]), 5126, "VEC3", 3),
        "TEXCOORD_0": accessor(floats(GLTF_UV[:3]), 5126, "VEC2", 3),
        "COLOR_0": accessor(floats(GLTF_COLORS[:3, :3]), 5126, "VEC3", 3),
    }
    second = {
        "POSITION": accessor(floats(GLTF_POSITIONS[[0, 2, 3]]), 5126, "VEC3", 3),
        "TEXCOORD_0": accessor(floats(GLTF_UV[3:]), 5126, "VEC2", 3),
    }
    if second_colour:
        rgba = bytes([255, 0, 0, 255, 0, 255, 0, 51, 0, 0, 255, 0])
        second["COLOR_0"] = accessor(rgba, 5121, "VEC4", 3, normalized=True)
    indices = accessor(struct.pack("<3H", 0, 1, 2), 5123, "SCALAR", 3)
    while len(bin_) % 4:
        bin_.append(0)
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": first}, {"attributes": second, "indices": indices}]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(bin_)}],
    }
    return doc, bytes(bin_)


def gltf_bytes(doc, bin_, glb):
    if not glb:
        doc = copy.deepcopy(doc)
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bin_).decode()
        return json.dumps(doc).encode()
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(bin_), b"BIN\0") + bin_
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


@pytest.fixture(params=["gltf", "glb"])
def gltf_file(tmp_path, request):
    path = tmp_path / f"square.{request.param}"
    path.write_bytes(gltf_bytes(*gltf_document(), glb=request.param == "glb"))
    return path


def test_gltf_uv_and_colors_per_corner(gltf_file):
    v, f, a = normalnet.read_mesh(gltf_file, attributes=True)
    np.testing.assert_array_equal(v, GLTF_POSITIONS)
    np.testing.assert_array_equal(f, GLTF_FACES)
    assert a["format"] == "gltf" and a["encoding"] == ("binary" if gltf_file.suffix == ".glb" else "json")
    assert a["warnings"] == []
    assert a["uv"].dtype == np.float64 and a["uv"].shape == (6, 2)
    np.testing.assert_array_equal(a["uv"], GLTF_UV)
    assert a["corner_uv"].dtype == np.int64
    np.testing.assert_array_equal(a["corner_uv"], GLTF_CORNERS)
    # the welded diagonal (vertices 0 and 2) has a UV per side
    assert a["uv"][a["corner_uv"][0, 0]].tolist() != a["uv"][a["corner_uv"][1, 0]].tolist()
    assert a["colors"].dtype == np.float64 and a["colors"].shape == (6, 4)
    np.testing.assert_array_equal(a["colors"], GLTF_COLORS)  # RGB gets alpha 1
    np.testing.assert_array_equal(a["corner_colors"], GLTF_CORNERS)
    assert "vertex_colors" not in a


def test_gltf_primitive_without_colors_has_no_corner_colors(tmp_path):
    path = tmp_path / "half.gltf"
    path.write_bytes(gltf_bytes(*gltf_document(second_colour=False), glb=False))
    _, _, a = normalnet.read_mesh(path, attributes=True)
    np.testing.assert_array_equal(a["colors"], GLTF_COLORS[:3, :3])
    np.testing.assert_array_equal(a["corner_colors"], [[0, 1, 2], [-1, -1, -1]])
    np.testing.assert_array_equal(a["corner_uv"], GLTF_CORNERS)


def test_gltf_seed_file_has_uv_per_corner():
    seed = Path(__file__).resolve().parents[2] / "fuzz" / "seeds" / "gltf" / "plate-two-primitives.glb"
    if not seed.exists():
        pytest.skip(f"{seed} is missing")
    v, f, a = normalnet.read_mesh(seed, attributes=True)
    assert a["corner_uv"].shape == f.shape and a["uv"].shape[1] == 2
    assert a["corner_uv"].min() >= 0 and a["corner_uv"].max() < len(a["uv"])
    assert "colors" not in a and "corner_colors" not in a


def test_gltf_round_trip_keeps_uv_and_colors_and_corners_are_read_only(gltf_file, tmp_path):
    v, f, a = normalnet.read_mesh(gltf_file, attributes=True)
    moved = v + np.array([0.5, -0.25, 0.125])
    out = tmp_path / f"out{gltf_file.suffix}"
    normalnet.write_mesh(out, moved, f, attributes=a)
    v2, f2, a2 = normalnet.read_mesh(out, attributes=True)
    np.testing.assert_array_equal(v2, moved)
    np.testing.assert_array_equal(f2, f)
    assert_same_attributes(a, a2)
    never = tmp_path / f"never{gltf_file.suffix}"
    for key, change, message in [
        ("colors", lambda x: x[:, :3], r"colors: shape \[6, 3\] differs"),
        ("corner_uv", lambda x: x[::-1], "corner_uv: cannot be edited"),
        ("corner_colors", lambda x: np.zeros_like(x), "corner_colors: cannot be edited"),
    ]:
        b = copy.deepcopy(a)
        b[key] = change(b[key])
        with pytest.raises(ValueError, match=message):
            normalnet.write_mesh(never, v, f, attributes=b)
    assert not never.exists()


def test_gltf_uv_and_color_edits_go_into_the_accessors(gltf_file, tmp_path):
    v, f, a = normalnet.read_mesh(gltf_file, attributes=True)
    b = copy.deepcopy(a)
    b["uv"] = a["uv"] * 0.5 + 0.25
    b["colors"][:, 1] = 0.5  # float rows: 0.5; normalized byte rows: 128 / 255
    out = tmp_path / f"edited{gltf_file.suffix}"
    normalnet.write_mesh(out, v, f, attributes=b)
    v2, f2, a2 = normalnet.read_mesh(out, attributes=True)
    np.testing.assert_array_equal(v2, v)
    np.testing.assert_array_equal(f2, f)
    np.testing.assert_array_equal(a2["uv"], b["uv"].astype(np.float32))
    want = b["colors"].copy()
    want[3:, 1] = 128 / 255
    np.testing.assert_array_equal(a2["colors"], want)
    for key in ("corner_uv", "corner_colors"):
        np.testing.assert_array_equal(a2[key], a[key])
    never = tmp_path / f"never{gltf_file.suffix}"
    for row, column, value, message in [
        (0, 3, 0.5, "colors: row 0 column 3 cannot be set: its accessor's elements have 3 components"),
        (3, 0, 2.0, "colors: .*COLOR_0: element 3: 2 is outside the normalized range 0..=1"),
        (0, 0, np.nan, "colors: .*COLOR_0: element 0: NaN is not finite"),
    ]:
        c = copy.deepcopy(a)
        c["colors"][row, column] = value
        with pytest.raises(ValueError, match=message):
            normalnet.write_mesh(never, v, f, attributes=c)
    assert not never.exists()


def test_gltf_keys_cannot_be_added(obj_file, tmp_path):
    doc, bin_ = gltf_document()
    for prim in doc["meshes"][0]["primitives"]:
        del prim["attributes"]["COLOR_0"]
    plain = tmp_path / "plain.gltf"
    plain.write_bytes(gltf_bytes(doc, bin_, glb=False))
    v, f, a = normalnet.read_mesh(plain, attributes=True)
    assert "colors" not in a and "uv" in a
    for key in ("colors", "corner_colors"):
        with pytest.raises(ValueError, match=f"{key}: the file has no COLOR_0"):
            normalnet.write_mesh(tmp_path / "never.gltf", v, f, attributes=dict(a, **{key: np.zeros((3, 3))}))
    v, f, a = normalnet.read_mesh(obj_file, attributes=True)
    with pytest.raises(ValueError, match="colors: only glTF files"):
        normalnet.write_mesh(tmp_path / "never.obj", v, f, attributes=dict(a, colors=np.zeros((5, 3))))


def test_gltf_broken_texcoord_is_a_warning_not_an_error(tmp_path):
    doc, bin_ = gltf_document()
    doc["accessors"][doc["meshes"][0]["primitives"][1]["attributes"]["TEXCOORD_0"]]["type"] = "SCALAR"
    doc["accessors"][doc["meshes"][0]["primitives"][1]["attributes"]["TEXCOORD_0"]]["count"] = 3
    path = tmp_path / "broken.gltf"
    path.write_bytes(gltf_bytes(doc, bin_, glb=False))
    v, f, a = normalnet.read_mesh(path, attributes=True)
    np.testing.assert_array_equal(f, GLTF_FACES)
    assert "uv" not in a and "corner_uv" not in a
    assert any("TEXCOORD_0 is not in the dict" in w and "SCALAR" in w for w in a["warnings"])
    np.testing.assert_array_equal(a["colors"], GLTF_COLORS)
    out = tmp_path / "out.gltf"
    normalnet.write_mesh(out, v, f, attributes=a)  # written back as read
    assert json.loads(out.read_text())["accessors"] == doc["accessors"]
