#!/usr/bin/env bash
# Does the daemon's memory grow with register/unregister cycles, or is the soak's RSS
# growth the allocator's? Runs the soak (`service_load --soak`) twice with tetcollided
# under heaptrack, 5 cycles and then 20 cycles at the same pacing (9 s per cycle, two
# clients streaming throughout), SIGKILLs the daemon right after the last cycle's sample
# so that every allocation live at that moment counts as "leaked", and prints the
# difference of the live heap between the two runs (heaptrack_print --diff). A leak of
# L bytes per cycle shows as about 15 x L; memory the allocator holds but the program has
# freed (fragmentation, arenas, buffers the kernel maps lazily) does not show at all.
# docs/RELIABILITY.md "Soak" has the figures.
#
#   scripts/soak_heap.sh [BUILD_DIR]      (default build; about 5 minutes)
#
# Needs heaptrack (Debian package `heaptrack`).
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(realpath "${1:-build}")
for tool in heaptrack heaptrack_print; do
  command -v "$tool" >/dev/null || {
    echo "soak_heap.sh: $tool not found; install it with: sudo apt-get install heaptrack" >&2
    exit 2
  }
done
[ -x "$build/bin/tetcollided" ] && [ -x "$build/bin/service_load" ] || {
  echo "soak_heap.sh: $build/bin/{tetcollided,service_load} missing; run 'make build' first" >&2
  exit 2
}
out=$(mktemp -d /tmp/tc-soak-heap.XXXXXX)
echo "soak_heap.sh: outputs in $out"

# run TAG SECONDS CYCLES: one soak with the daemon under heaptrack, killed after the last
# cycle's sample.
run() {
  local tag=$1 seconds=$2 cycles=$3
  printf '#!/bin/sh\nexec heaptrack -o %s/%s "%s/bin/tetcollided" "$@"\n' "$out" "$tag" "$build" \
    >"$out/daemon_$tag.sh"
  chmod +x "$out/daemon_$tag.sh"
  tests/integration/run_isolated.sh "$build/bin/service_load" --soak --seconds "$seconds" \
    --cycles "$cycles" --daemon "$out/daemon_$tag.sh" >"$out/soak_$tag.log" 2>&1 &
  local soak=$!
  local pattern="^cycle +$cycles "
  until grep -Eq "$pattern" "$out/soak_$tag.log" 2>/dev/null; do
    if ! kill -0 "$soak" 2>/dev/null; then
      echo "soak_heap.sh: the $cycles-cycle soak ended early:" >&2
      tail -5 "$out/soak_$tag.log" >&2
      exit 1
    fi
    sleep 0.5
  done
  pkill -KILL -f "^$build/bin/tetcollided --config /tmp/tc-load-" || true
  wait "$soak" || true
  # heaptrack finishes writing its file after the process is gone.
  for _ in $(seq 1 60); do
    pgrep -f "heaptrack_interpret" >/dev/null || break
    sleep 1
  done
  echo "  $cycles cycles: $(grep -E '^cycle' "$out/soak_$tag.log" | tail -1)"
}

run c5 45 5
run c20 180 20
for tag in c5 c20; do
  printf '  %-4s live heap at the kill: %s\n' "$tag" \
    "$(heaptrack_print -f "$out/$tag.zst" 2>/dev/null | grep 'total memory leaked' | cut -d: -f2-)"
done
printf '  difference (20 cycles - 5 cycles): %s\n' \
  "$(heaptrack_print -f "$out/c20.zst" -d "$out/c5.zst" 2>/dev/null |
    grep 'total memory leaked' | cut -d: -f2-)"
