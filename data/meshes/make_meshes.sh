#!/usr/bin/env bash
# Regenerate every committed mesh in data/meshes/ from its .geo source with Gmsh.
# Gmsh is a development tool only: the build and the tests read the committed .msh files.
# Deterministic: one thread (-nt 1), fixed seed and algorithms (common_options.geo), and a
# fixed mesh size per mesh; with the same Gmsh version (4.8.4) the output is byte-identical.
# Usage: data/meshes/make_meshes.sh            (GMSH=/path/to/gmsh to pick a binary)
set -euo pipefail
cd "$(dirname "$0")"
GMSH=${GMSH:-gmsh}
command -v "$GMSH" >/dev/null || { echo "error: gmsh not found (apt-get install gmsh)" >&2; exit 1; }
version=$("$GMSH" --version 2>&1 | tail -1)
if [ "$version" != "4.8.4" ]; then
  echo "warning: Gmsh $version; the committed meshes were made with 4.8.4 and will differ" >&2
fi

# name  dimension  mesh size h (m)  [extra -setnumber pairs]
meshes=(
  "torus     3 0.0349"
  "box       3 0.08"
  "ball      3 0.032"
  "ellipsoid 3 0.023"
  "slab      3 0.05   layers 2"
  "disc2d    2 0.0922"
  "rect2d    2 0.05004"
)

for entry in "${meshes[@]}"; do
  read -r name dim h extra_name extra_value <<<"$entry"
  args=(-setnumber h "$h")
  if [ -n "${extra_name:-}" ]; then args+=(-setnumber "$extra_name" "$extra_value"); fi
  echo "== $name: $GMSH $name.geo -$dim -nt 1 -format msh41 ${args[*]} -o $name.msh"
  "$GMSH" "$name.geo" "-$dim" -nt 1 -format msh41 "${args[@]}" -o "$name.msh" >"/tmp/gmsh_$name.log" 2>&1 \
    || { cat "/tmp/gmsh_$name.log" >&2; exit 1; }
  unset extra_name extra_value
done

python3 check_meshes.py torus.msh box.msh ball.msh ellipsoid.msh slab.msh disc2d.msh rect2d.msh
