#!/usr/bin/env python3
"""A textured copy of an OBJ mesh, for trying textured denoising (issue 38).

    python3 docs/textured_example.py examples/noisy-part.obj OUT_DIR [examples/clean-part.obj]

writes OUT_DIR/<name>.obj (the same vertices and faces, with texture
coordinates by box projection: each face takes the two axes across its
normal's largest component, corners indexed per face; projected from the
third mesh when given, which must have the same faces: a texture made for
the clean surface, as a scan's would be), OUT_DIR/<name>.mtl
(one material, `map_Kd checker.png`) and OUT_DIR/checker.png (a coloured
checker with a gradient, so a misplaced texture shows at once). Standard
library only. Then, for instance:

    normalnet denoise OUT_DIR/noisy-part.obj denoised/part.obj
    normalnet render denoised/part.obj -o part.png
"""
import os
import struct
import sys
import zlib


def read_obj(path):
    vertices, faces = [], []
    for line in open(path):
        words = line.split()
        if not words:
            continue
        if words[0] == "v":
            vertices.append(tuple(map(float, words[1:4])))
        elif words[0] == "f":
            faces.append([int(w.split("/")[0]) - 1 for w in words[1:]])
    return vertices, faces


def face_axes(vertices, face):
    a, b, c = (vertices[i] for i in face[:3])
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    big = max(range(3), key=lambda k: abs(n[k]))
    return [k for k in range(3) if k != big]


def checker_png(size=256, cells=8):
    rows = []
    for y in range(size):
        row = bytearray(b"\x00")
        for x in range(size):
            dark = ((x * cells // size) + (y * cells // size)) % 2
            r = 40 + 180 * x // size
            g = 40 + 180 * y // size
            b = 200 if dark else 60
            row += bytes((r // (2 if dark else 1), g // (2 if dark else 1), b))
        rows.append(bytes(row))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b""))


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    source, out_dir = sys.argv[1], sys.argv[2]
    vertices, faces = read_obj(source)
    projected = vertices
    if len(sys.argv) == 4:
        projected, uv_faces = read_obj(sys.argv[3])
        if uv_faces != faces:
            sys.exit(f"{sys.argv[3]}: not the faces of {source}")
    lo = [min(v[k] for v in projected) for k in range(3)]
    extent = max(max(v[k] for v in projected) - lo[k] for k in range(3)) or 1.0
    name = os.path.splitext(os.path.basename(source))[0]
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "checker.png"), "wb") as fh:
        fh.write(checker_png())
    with open(os.path.join(out_dir, name + ".mtl"), "w") as fh:
        fh.write("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n")
    lines = [f"mtllib {name}.mtl"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices]
    corner = 0
    face_lines = []
    for face in faces:
        s, t = face_axes(projected, face)
        refs = []
        for i in face:
            p = projected[i]
            lines.append(f"vt {(p[s] - lo[s]) / extent:.6f} {(p[t] - lo[t]) / extent:.6f}")
            corner += 1
            refs.append(f"{i + 1}/{corner}")
        face_lines.append("f " + " ".join(refs))
    lines += ["usemtl checker"] + face_lines
    with open(os.path.join(out_dir, name + ".obj"), "w") as fh:
        fh.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
