#!/usr/bin/env bash
# Regenerate the "foreign" meshes: small 3D meshes made differently from data/meshes/
# (other tools, algorithms, kernels, file layouts), for reader acceptance tests.
# Development tool only; the outputs are committed. Needs gmsh 4.8.4 and tetgen 1.5.0
# (Debian packages gmsh, tetgen). Deterministic.
set -euo pipefail
cd "$(dirname "$0")"
gmsh cylinder_hxt.geo -3 -nt 1 -format msh41 -o cylinder_hxt.msh >/dev/null
tetgen -pq1.4a0.00002AF lblock.poly >/dev/null   # -> lblock.1.node, lblock.1.ele
tetgen -pq1.3a0.00001F tube.poly >/dev/null      # -> tube.1.node, tube.1.ele
python3 ../../../../data/meshes/check_meshes.py cylinder_hxt.msh lblock.1.node tube.1.node
