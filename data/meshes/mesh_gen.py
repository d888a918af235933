"""Helpers shared by the mesh and surface generators (data/meshes/make_*.py and the test
data's make_*.py, which put this folder on sys.path): the 6-tet split of a cube, the
TetGen writer and the unit normal of a triangle."""
import math

# The 6 tets of a cube around its diagonal from corner 0 to corner 7 (corner c at
# (c & 1, c >> 1 & 1, c >> 2 & 1)); each path 0 -> a -> b -> 7 is one tet. Conforming
# between neighbouring cubes (as tests/support's structured_box).
CUBE_PATHS = [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]


def cube_tets(corner, nodes):
    """The 6 tets of the cube whose 8 node indices are `corner` (in the order above), each
    positively oriented (`nodes` gives the coordinates)."""
    tets = []
    for a, b in CUBE_PATHS:
        t = [corner[0], corner[a], corner[b], corner[7]]
        p = [nodes[v] for v in t]
        e = [[p[m][d] - p[0][d] for d in range(3)] for m in (1, 2, 3)]
        det = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
               e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
               e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
        if det < 0:
            t[1], t[2] = t[2], t[1]
        tets.append(t)
    return tets


def write_tetgen(stem, nodes, tets):
    """Writes stem.node and stem.ele (1-based, coordinates to 17 significant digits)."""
    with open(stem + ".node", "w") as f:
        f.write(f"{len(nodes)} 3 0 0\n")
        for n, p in enumerate(nodes, start=1):
            f.write(f"{n} {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
    with open(stem + ".ele", "w") as f:
        f.write(f"{len(tets)} 4 0\n")
        for n, t in enumerate(tets, start=1):
            f.write(f"{n} {t[0] + 1} {t[1] + 1} {t[2] + 1} {t[3] + 1}\n")


def normal(a, b, c):
    """The unit normal of triangle abc (right-hand rule); (0, 0, 0) if it is degenerate."""
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    length = math.sqrt(sum(x * x for x in n)) or 1.0
    return [x / length for x in n]
