#!/usr/bin/env bash
# The main job on embedded defaults (run by `make demo` after the build).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
mesh=data/meshes/torus.msh
[ -f "$mesh" ] || mesh=tests/data/meshes/cube6_41.msh
mkdir -p out
echo "== tetcollide mesh info $mesh"
"$bin/tetcollide" mesh info "$mesh"
"$bin/tetcollide" mesh convert "$mesh" out/mesh.vtu
echo "== outputs under out/: mesh.vtu (open with ParaView)"
