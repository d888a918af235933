#!/usr/bin/env bash
# Error against run time of the contact depth (issue 12; docs/BENCHMARKS.md "Contact
# depth"): for each pose, each depth map (cpfm, cffm, exact) and each evaluation
# (nearest-face, the default; interpolate, the paper's 5.1), one `tetcollide respond`
# with --exact-check and --repeat N. Prints a Markdown table: the share of point contacts
# within 10% (+1e-3 of the bounding-box diagonal) of the exact depth, those off by more
# than 1.5x, the largest depth/exact ratio, and the median depth and response stage
# times with their ratio to cpfm + interpolate of the same pose (same run).
#
# Usage: scripts/bench_contact_depth.sh [REPEAT] (default 21; from the repository root,
# after `make build`).
set -euo pipefail
cd "$(dirname "$0")/.."
repeat=${1:-21}
cli=${TC_CLI:-build/bin/tetcollide}
m=data/meshes
poses=(
  "box_on_box_offset|$m/box.msh $m/box.msh --move-b 0.05 0.03 0.295"
  "torus_on_box|$m/box.msh $m/torus.msh --move-b 0.02 -0.01 0.24"
  "ball_in_2cm_plate|$m/box.msh $m/ball.msh --scale-a 3 3 0.0666667 --scale-b 0.5 0.5 0.5 --move-b 0.013 -0.021 0.105"
  "coarse_ellipsoids|$m/ellipsoid.msh $m/ellipsoid.msh --move-b 0.012 0.004 0.052"
)
echo "| pose | depth map | evaluation | point contacts | within 10% | beyond 1.5x | max depth/exact | depth ms | response ms | depth+response vs cpfm+interpolate |"
echo "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"
for entry in "${poses[@]}"; do
  name=${entry%%|*}
  args=${entry#*|}
  base=""
  for depth in cpfm cffm exact; do
    for evaluation in interpolate nearest-face; do
      # shellcheck disable=SC2086
      json=$("$cli" respond $args --response point --depth "$depth" --evaluation "$evaluation" \
        --exact-check --repeat "$repeat" --json)
      row=$(python3 -c '
import json, sys
j = json.loads(sys.argv[1]); e = j["exact_check"]; s = j["stage_ms"]
n = max(e["point_contacts"], 1)
print("%d %.1f %d %.3f %.3f %.3f" % (e["point_contacts"], 100.0 * e["within_10_percent"] / n,
      e["beyond_1_5x"], e["max_ratio"], s["depth"], s["response"]))' "$json")
      read -r contacts within beyond ratio depth_ms response_ms <<<"$row"
      cost=$(python3 -c "print('%.4f' % ($depth_ms + $response_ms))")
      [ -z "$base" ] && base=$cost
      rel=$(python3 -c "print('%.2fx' % ($cost / $base if $base > 0 else 0))")
      echo "| $name | $depth | $evaluation | $contacts | $within% | $beyond | $ratio | $depth_ms | $response_ms | $rel |"
    done
  done
done
