#!/usr/bin/env python3
"""Writes probe.stl: a rigid surgical probe as a closed triangle surface (binary STL).

A cylinder of radius 3 cm along +z from z = 0.03 m to z = 0.25 m, closed by a flat disc
at the top and a hemispherical tip whose lowest point is the origin. 24 segments around
(edges about 7.9 mm), rings every 1 cm on the shaft, 6 latitude rings on the tip: finer
than the organs it presses on, so its vertices find their tets (docs/RESPONSE.md,
section 13). Outward right-hand normals. Deterministic: the same bytes each time.

Run from this folder: python3 make_probe.py
"""
import math
import struct

from mesh_gen import normal

RADIUS = 0.03
TOP = 0.25
AROUND = 24
SHAFT_RINGS = 22  # rings from z = RADIUS to z = TOP, 1 cm apart
TIP_RINGS = 6  # latitude rings of the hemisphere above its pole


def build():
    points = [(0.0, 0.0, 0.0)]  # the tip's pole
    rings = []
    # Hemisphere: latitude angle from the pole, rings at k * (pi/2) / TIP_RINGS.
    for k in range(1, TIP_RINGS + 1):
        phi = k * (math.pi / 2) / TIP_RINGS
        r, z = RADIUS * math.sin(phi), RADIUS - RADIUS * math.cos(phi)
        rings.append(len(points))
        for j in range(AROUND):
            t = 2 * math.pi * j / AROUND
            points.append((r * math.cos(t), r * math.sin(t), z))
    for k in range(1, SHAFT_RINGS + 1):
        z = RADIUS + (TOP - RADIUS) * k / SHAFT_RINGS
        rings.append(len(points))
        for j in range(AROUND):
            t = 2 * math.pi * j / AROUND
            points.append((RADIUS * math.cos(t), RADIUS * math.sin(t), z))
    top_centre = len(points)
    points.append((0.0, 0.0, TOP))
    tris = []
    first = rings[0]
    for j in range(AROUND):  # fan around the pole, normals pointing down and out
        tris.append((0, first + (j + 1) % AROUND, first + j))
    for lower, upper in zip(rings, rings[1:]):
        for j in range(AROUND):
            a, b = lower + j, lower + (j + 1) % AROUND
            c, d = upper + j, upper + (j + 1) % AROUND
            tris.append((a, b, d))
            tris.append((a, d, c))
    last = rings[-1]
    for j in range(AROUND):  # the flat top, normal +z
        tris.append((top_centre, last + j, last + (j + 1) % AROUND))
    return points, tris


def main():
    points, tris = build()
    header = b"tetcollide probe: r 0.03 m, tip at the origin, shaft to z 0.25 m"
    out = bytearray(header.ljust(80, b" "))
    out += struct.pack("<I", len(tris))
    for t in tris:
        p = [points[i] for i in t]
        out += struct.pack("<3f", *normal(*p))
        for q in p:
            out += struct.pack("<3f", *q)
        out += b"\0\0"
    with open("probe.stl", "wb") as f:
        f.write(out)
    print(f"probe.stl: {len(points)} vertices, {len(tris)} triangles")


if __name__ == "__main__":
    main()
