#!/usr/bin/env python3
"""Writes the TetGen pairs of the self-contact CLI tests (tests/cli/CMakeLists.txt):

  cube2.node/.ele         the unit cube in 2 x 2 x 2 cells, 6 tets each (48 tets)
  self_overlap.node/.ele  the same cube twice in one mesh (two components), the second
                          moved by (0.5, 0.1, 0.2) m: the two overlap. `respond
                          self_overlap.node --self` must give what `respond cube2.node
                          cube2.node --move-b 0.5 0.1 0.2` gives for two objects.

Deterministic. Run from this folder: python3 make_self_overlap.py
"""
N = 2
SHIFT = (0.5, 0.1, 0.2)
PATHS = [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]


def cube():
    nodes = [(i / N, j / N, k / N) for k in range(N + 1) for j in range(N + 1) for i in range(N + 1)]
    index = lambda i, j, k: (k * (N + 1) + j) * (N + 1) + i
    tets = []
    for k in range(N):
        for j in range(N):
            for i in range(N):
                c = [index(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1)) for q in range(8)]
                for a, b in PATHS:
                    t = [c[0], c[a], c[b], c[7]]
                    p = [nodes[v] for v in t]
                    e = [[p[m][d] - p[0][d] for d in range(3)] for m in (1, 2, 3)]
                    det = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                           e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                           e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
                    if det < 0:
                        t[1], t[2] = t[2], t[1]
                    tets.append(t)
    return nodes, tets


def write(stem, nodes, tets):
    with open(stem + ".node", "w") as f:
        f.write(f"{len(nodes)} 3 0 0\n")
        for n, p in enumerate(nodes, start=1):
            f.write(f"{n} {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
    with open(stem + ".ele", "w") as f:
        f.write(f"{len(tets)} 4 0\n")
        for n, t in enumerate(tets, start=1):
            f.write(f"{n} {t[0] + 1} {t[1] + 1} {t[2] + 1} {t[3] + 1}\n")


def main():
    nodes, tets = cube()
    write("cube2", nodes, tets)
    moved = [(x + SHIFT[0], y + SHIFT[1], z + SHIFT[2]) for x, y, z in nodes]
    n = len(nodes)
    write("self_overlap", nodes + moved, tets + [[v + n for v in t] for t in tets])


if __name__ == "__main__":
    main()
