#!/usr/bin/env python3
"""Writes sphere_shell.obj: the deformable sphere of the sphere_on_tissue demo scene.

An icosphere of radius 0.2 m centred on the origin (the size of ball.msh): the 12
vertices of an icosahedron, each triangle split into 4 three times with the new vertices
pushed onto the sphere, giving 642 vertices and 1280 triangles with edges of 2.2-2.8 cm
(finer than the slab's tets it lands on, so its vertices find their tets; docs/RESPONSE.md,
section 13). Closed, outward right-hand normals. Deterministic: the same bytes each time.

Run from this folder: python3 make_sphere_shell.py
"""
import math

RADIUS = 0.2
LEVELS = 3


def icosphere(levels):
    t = (1.0 + math.sqrt(5.0)) / 2.0
    raw = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
           (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    points = [unit(p) for p in raw]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                pa, pb = points[a], points[b]
                points.append(unit(tuple((pa[k] + pb[k]) / 2.0 for k in range(3))))
                middle[key] = len(points) - 1
            return middle[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = split
    return points, faces


def unit(p):
    n = math.sqrt(sum(c * c for c in p))
    return tuple(c / n for c in p)


def main():
    points, faces = icosphere(LEVELS)
    with open("sphere_shell.obj", "w", encoding="ascii") as f:
        f.write("# sphere_shell.obj: icosphere, radius %g m, %d subdivisions, %d vertices, "
                "%d triangles\n# written by make_sphere_shell.py\n"
                % (RADIUS, LEVELS, len(points), len(faces)))
        for p in points:
            f.write("v %.9f %.9f %.9f\n" % tuple(RADIUS * c for c in p))
        for a, b, c in faces:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


if __name__ == "__main__":
    main()
