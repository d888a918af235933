#!/usr/bin/env bash
# Cost of each depth-map method relative to CPFM, counted in instructions (callgrind),
# so that the ratio does not depend on the load of a shared machine (docs/DEPTH_MAPS.md,
# "CFFM on the pawn with orphan nodes": one wall-time run of `bench distance` on the
# loaded machine gave anything from 1.7x to 6.3x for the same 3.1x of work).
#
# Per mesh and method: valgrind callgrind over `tetcollide distance MESH --method M
# --repeat R` for R = 1 and R = 4, collecting only inside DepthSolver::compute; the
# steady-state frame is (R4 - R1) / 3. Prints a Markdown table: instructions per frame
# (millions) and the ratio to cpfm on the same mesh. With CACHE=1 also simulated L1 and
# last-level misses (last level modelled as a 2 MiB L2), about 3x slower.
#
# Usage: scripts/depth_cost_ratio.sh MESH... [-- METHOD...]   (default methods: cpfm cffm)
#   e.g. scripts/depth_cost_ratio.sh data/meshes/generated/large.msh -- cpfm cffm cffm:near
# Needs valgrind (Debian package valgrind). About 20-60 s per mesh and method for
# ~300k tets. TC_CLI=path picks the binary (default build/bin/tetcollide).
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${TC_CLI:-build/bin/tetcollide}
command -v valgrind >/dev/null || { echo "error: valgrind not found (apt-get install valgrind)" >&2; exit 1; }
[ -x "$cli" ] || { echo "error: $cli not found (make build)" >&2; exit 1; }
meshes=()
methods=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then
    shift
    methods=("$@")
    break
  fi
  meshes+=("$1")
  shift
done
[ ${#meshes[@]} -gt 0 ] || { sed -n '2,17p' "$0"; exit 2; }
[ ${#methods[@]} -gt 0 ] || methods=(cpfm cffm)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cache_opts=()
[ "${CACHE:-0}" = 1 ] && cache_opts=(--cache-sim=yes --LL=2097152,16,64)

# Sum of each event over the profile (the "totals:" or "summary:" line).
totals() {
  awk '/^events:/ { n = split($0, ev, " ") } /^(totals|summary):/ {
         for (i = 2; i <= NF; ++i) printf "%s=%s ", ev[i], $i; print ""; exit }' "$1"
}
event() {  # event NAME "E1=v1 E2=v2 ..."
  tr ' ' '\n' <<<"$2" | awk -F= -v k="$1" '$1 == k { print $2 }'
}

if [ "${CACHE:-0}" = 1 ]; then
  echo "| mesh | method | instructions per frame (M) | vs cpfm | L1 misses (k) | LL misses (k) |"
  echo "|---|---|---:|---:|---:|---:|"
else
  echo "| mesh | method | instructions per frame (M) | vs cpfm |"
  echo "|---|---|---:|---:|"
fi
for mesh in "${meshes[@]}"; do
  base=""
  for method in "${methods[@]}"; do
    declare -A t=()
    for r in 1 4; do
      out="$tmp/cg.$r.out"
      valgrind --tool=callgrind "${cache_opts[@]}" \
        --toggle-collect='tc::BasicDepthSolver<3>::compute(*' --callgrind-out-file="$out" \
        "$cli" distance "$mesh" --method "$method" --repeat "$r" >/dev/null 2>"$tmp/log" ||
        { cat "$tmp/log" >&2; exit 1; }
      t[$r]=$(totals "$out")
    done
    ir=$(awk -v a="$(event Ir "${t[1]}")" -v b="$(event Ir "${t[4]}")" 'BEGIN { print (b - a) / 3 }')
    [ -n "$base" ] || base=$ir
    row=$(awk -v ir="$ir" -v base="$base" 'BEGIN { printf "%.2f | %.2fx", ir / 1e6, ir / base }')
    if [ "${CACHE:-0}" = 1 ]; then
      miss() {  # steady-state sum of the given events, thousands
        local s=0 e
        for e in "$@"; do
          s=$(awk -v s="$s" -v a="$(event "$e" "${t[1]}")" -v b="$(event "$e" "${t[4]}")" \
            'BEGIN { print s + (b - a) / 3 }')
        done
        awk -v s="$s" 'BEGIN { printf "%.0f", s / 1e3 }'
      }
      row="$row | $(miss D1mr D1mw) | $(miss DLmr DLmw)"
    fi
    echo "| $(basename "$mesh") | $method | $row |"
    unset t
  done
done
