#!/usr/bin/env python3
"""Writes fold_u.msh: a soft U lying on its side, the mesh of the sheet_fold demo scene.

Two arms 10 cm long, 2 cm wide and 1 cm thick, one above the other with a 1 cm slot
between them, joined by a 2 cm base at x in [0, 0.02]: the box [0, 0.10] x [0, 0.02] x
[0, 0.03] m in 5 mm cubes, less the cubes of the slot (x >= 0.02, 0.01 <= z < 0.02).
Each cube is split into 6 positively oriented tets around its main diagonal (conforming,
as tests/support's structured_box). The upper arm, free at x = 0.10, is what folds onto
the lower one (config/scenes/sheet_fold.yaml).

The script writes a TetGen pair to a temporary folder and converts it with
`tetcollide mesh convert` (Gmsh 4.1 ASCII, like every mesh here). Deterministic.

Run from this folder: python3 make_fold_u.py [path/to/tetcollide]
"""
import os
import subprocess
import sys
import tempfile

from mesh_gen import cube_tets, write_tetgen

CELL = 0.005
NX, NY, NZ = 20, 4, 6  # cubes along x, y, z


def in_slot(i, k):
    """The cube (i, *, k) lies in the slot between the arms."""
    return i >= 4 and 2 <= k < 4


def build():
    node_of = {}
    nodes = []
    tets = []

    def node(i, j, k):
        key = (i, j, k)
        if key not in node_of:
            node_of[key] = len(nodes)
            nodes.append((i * CELL, j * CELL, k * CELL))
        return node_of[key]

    for k in range(NZ):
        for j in range(NY):
            for i in range(NX):
                if in_slot(i, k):
                    continue
                corner = [node(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)) for c in range(8)]
                tets += cube_tets(corner, nodes)
    return nodes, tets


def main():
    tool = sys.argv[1] if len(sys.argv) > 1 else "../../build/bin/tetcollide"
    nodes, tets = build()
    with tempfile.TemporaryDirectory() as tmp:
        stem = os.path.join(tmp, "fold_u")
        write_tetgen(stem, nodes, tets)
        subprocess.run([tool, "mesh", "convert", stem + ".node", "fold_u.msh"], check=True)
    print(f"fold_u.msh: {len(nodes)} nodes, {len(tets)} tets")


if __name__ == "__main__":
    main()
