#!/usr/bin/env bash
# Make a ~300,000-tet object on demand (paper Fig. 7: "large objects ... composed of
# 300000 tetrahedrons"), for benchmarks. The output goes to data/meshes/generated/, which
# is git-ignored: never commit it (about 14 MB of ASCII).
#
# Usage: data/meshes/make_large.sh [pawn|box] [--check]
#   pawn (default) -> generated/large.msh      chess pawn, ~301k tets, ~55.5k nodes
#   box            -> generated/large_box.msh  1.0 x 1.0 x 0.3 m box, ~308k tets, ~56k nodes
#   --check        also run check_meshes.py on the result (about 15 s more)
# Deterministic with Gmsh 4.8.4 (one thread, fixed seed/algorithms, fixed mesh size).
# GMSH=/path/to/gmsh picks the binary.
set -euo pipefail
cd "$(dirname "$0")"
GMSH=${GMSH:-gmsh}
variant=pawn
check=0
for arg in "$@"; do
  case "$arg" in
    pawn|box) variant=$arg ;;
    --check) check=1 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "usage: $0 [pawn|box] [--check]" >&2; exit 2 ;;
  esac
done
command -v "$GMSH" >/dev/null || { echo "error: gmsh not found (apt-get install gmsh)" >&2; exit 1; }

case "$variant" in
  pawn) geo=pawn.geo; h=0.0045; out=generated/large.msh ;;
  box)  geo=box.geo;  h=0.0165; out=generated/large_box.msh ;;
esac
mkdir -p generated
log=generated/$(basename "$out" .msh).log
echo "[make_large] $GMSH $geo -3 -nt 1 -format msh41 -setnumber h $h -o $out"
echo "[make_large] meshing (about 15-30 s on one core); Gmsh log in $log"
start=$(date +%s.%N)
# Show Gmsh's stage messages as progress while keeping the full log.
set +e
"$GMSH" "$geo" -3 -nt 1 -format msh41 -setnumber h "$h" -o "$out" 2>&1 | tee "$log" |
  grep --line-buffered -E 'Meshing (1D|2D|3D)|Done meshing|tetrahedra created|Optimiz.*done|Writing|nodes [0-9]+ elements|Error' |
  sed -u 's/^/[make_large]   /'
status=${PIPESTATUS[0]}
set -e
end=$(date +%s.%N)
if [ "$status" -ne 0 ] || [ ! -s "$out" ]; then
  echo "[make_large] gmsh failed (exit $status); see $log" >&2
  exit 1
fi
printf '[make_large] wrote %s (%s bytes) in %.1f s\n' "$out" "$(stat -c %s "$out")" \
  "$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')"
if [ "$check" -eq 1 ]; then
  echo "[make_large] checking..."
  python3 check_meshes.py "$out"
fi
