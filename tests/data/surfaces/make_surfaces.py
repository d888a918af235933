#!/usr/bin/env python3
"""Writes the surface files of tests/data/surfaces (README.md there says what each is).

Run from this folder: python3 make_surfaces.py. Deterministic: the same bytes each time.
"""
import struct
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "data" / "meshes"))
from mesh_gen import normal  # noqa: E402

# The unit cube as 12 triangles with outward right-hand normals; node i at
# (i & 1, i >> 1 & 1, i >> 2 & 1).
CUBE_POINTS = [(i & 1, (i >> 1) & 1, (i >> 2) & 1) for i in range(8)]
CUBE_QUADS = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
CUBE_TRIS = [t for q in CUBE_QUADS for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]


def ascii_stl(points, tris, name="cube"):
    lines = [f"solid {name}"]
    for t in tris:
        p = [points[i] for i in t]
        n = normal(*p)
        lines.append(f"  facet normal {n[0]:g} {n[1]:g} {n[2]:g}")
        lines.append("    outer loop")
        for q in p:
            lines.append(f"      vertex {q[0]:g} {q[1]:g} {q[2]:g}")
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append(f"endsolid {name}")
    return "\n".join(lines) + "\n"


def binary_stl(points, tris, header=b"solid cube (binary STL, header begins with solid)",
               count=None, records=None):
    out = header.ljust(80, b" ")[:80]
    out += struct.pack("<I", len(tris) if count is None else count)
    for t in tris if records is None else tris[:records]:
        p = [points[i] for i in t]
        out += struct.pack("<3f", *normal(*p))
        for q in p:
            out += struct.pack("<3f", *q)
        out += b"\0\0"
    return out


def write(name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(name, mode) as f:
        f.write(data)


write("cube.stl", ascii_stl(CUBE_POINTS, CUBE_TRIS))
write("cube_bin.stl", binary_stl(CUBE_POINTS, CUBE_TRIS))

# The octahedron |x| + |y| + |z| <= 1 (volume 4/3), closed, every corner form of OBJ.
write("octahedron.obj", """# octahedron |x| + |y| + |z| <= 1, volume 4/3, outward normals
o octahedron
v 1 0 0
v -1 0 0
v 0 1 0
v 0 -1 0
v 0 0 1
v 0 0 -1
vt 0 0
vn 0 0 1
f 1 3 5
f 3/1 2/1 5/1
f 2//1 4//1 5//1
f 4/1/1 1/1/1 5/1/1
f -4 -6 -1
f 2 3 6
f 4 2 6
f 1 4 6
""")

# An open plate: [0, 2] x [0, 2] at z = 0 as four quads (fan-triangulated: 8 triangles).
write("plate.obj", """# open plate [0, 2]^2, 9 vertices, 4 quads
v 0 0 0
v 1 0 0
v 2 0 0
v 0 1 0
v 1 1 0
v 2 1 0
v 0 2 0
v 1 2 0
v 2 2 0
g plate
usemtl steel
f 1 2 5 4
f 2 3 6 5
f 4 5 8 7
f 5 6 9 8
""")

# Hostile files: each fails in one place.
cube = ascii_stl(CUBE_POINTS, CUBE_TRIS).split("\n")
write("broken_truncated.stl", "\n".join(cube[:40]) + "\n")
bad = list(cube)
bad[10] = "      vertex 1 0"  # line 11
write("broken_vertex.stl", "\n".join(bad))
write("broken_count.stl", binary_stl(CUBE_POINTS, CUBE_TRIS, header=b"cube", records=11))
nan = bytearray(binary_stl(CUBE_POINTS, CUBE_TRIS, header=b"cube"))
nan[84 + 50 * 2 + 12 + 4 * 7:84 + 50 * 2 + 12 + 4 * 8] = struct.pack("<f", float("nan"))
write("broken_nan.stl", bytes(nan))
# A facet whose first two corners are the same point: after merging, a repeated node.
write("broken_repeated.stl", ascii_stl(CUBE_POINTS + [(0, 0, 0)], CUBE_TRIS + [(0, 8, 1)]))
write("broken_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n")
write("broken_face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2\n")
write("broken_nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n")
write("broken_empty.stl", "")
