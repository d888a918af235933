#!/usr/bin/env python3
"""Writes the TetGen pairs of the self-contact CLI tests (tests/cli/CMakeLists.txt):

  cube2.node/.ele         the unit cube in 2 x 2 x 2 cells, 6 tets each (48 tets)
  self_overlap.node/.ele  the same cube twice in one mesh (two components), the second
                          moved by (0.5, 0.1, 0.2) m: the two overlap. `respond
                          self_overlap.node --self` must give what `respond cube2.node
                          cube2.node --move-b 0.5 0.1 0.2` gives for two objects.

Deterministic. Run from this folder: python3 make_self_overlap.py
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "data" / "meshes"))
from mesh_gen import cube_tets, write_tetgen  # noqa: E402

N = 2
SHIFT = (0.5, 0.1, 0.2)


def cube():
    nodes = [(i / N, j / N, k / N) for k in range(N + 1) for j in range(N + 1) for i in range(N + 1)]
    index = lambda i, j, k: (k * (N + 1) + j) * (N + 1) + i
    tets = []
    for k in range(N):
        for j in range(N):
            for i in range(N):
                c = [index(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1)) for q in range(8)]
                tets += cube_tets(c, nodes)
    return nodes, tets


def main():
    nodes, tets = cube()
    write_tetgen("cube2", nodes, tets)
    moved = [(x + SHIFT[0], y + SHIFT[1], z + SHIFT[2]) for x, y, z in nodes]
    n = len(nodes)
    write_tetgen("self_overlap", nodes + moved, tets + [[v + n for v in t] for t in tets])


if __name__ == "__main__":
    main()
