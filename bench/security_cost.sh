#!/bin/sh
# security_cost.sh [BUILD_DIR] [ROUNDS] [FRAMES]: CPU and latency cost of the DDS Security profile
# (config/security/). Makes a test PKI, then runs build/bin/service_latency on the
# torus-in-box scene with a plain daemon and with a secured one (secured client too),
# alternating plain/secure ROUNDS times (default 3) for two workloads:
#   contact   torus 5 mm deep (141 contacts): compute-bound frames (~4 ms pipeline)
#   free      torus 50 mm above the box (no contact): DDS-bound frames (~0.2 ms pipeline)
# both lock-step (--wait: each frame after the previous answer, at most 1 kHz), FRAMES
# measured frames each (default 1000; every frame is answered, so CPU per frame is well
# defined). Each run is in a private network namespace (tests/integration/run_isolated.sh).
# Prints every run and, per workload and metric (daemon CPU per frame, client CPU per
# frame, latency p50 and p99), the medians over the rounds, the ratio of the medians and
# the median of the per-round secure/plain ratios (robust to load drifting between
# rounds). docs/RELIABILITY.md, "DDS Security", gives the figures. About 40 s per round.
set -eu
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd)
ROUNDS=${2:-3}
FRAMES=${3:-1000}
BENCH=$BUILD/bin/service_latency
DAEMON=$BUILD/bin/tetcollided
for f in "$BENCH" "$DAEMON"; do
  [ -x "$f" ] || { echo "$0: $f not built (ninja -C $BUILD service_latency tetcollided)" >&2; exit 1; }
done
WORK=$(mktemp -d /tmp/tc-security-cost.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
"$SRC/config/security/make_test_pki.sh" "$WORK/pki" >/dev/null
NET="file://$SRC/config/cyclonedds.xml"
ISOLATE=$SRC/tests/integration/run_isolated.sh

field() { sed -n "s/.*\"$1\": \([-0-9.e+]*\).*/\1/p" "$2"; }
median() { sort -g | awk '{v[NR]=$1} END {if (NR==0) print "nan"; else if (NR%2) print v[(NR+1)/2]; else print (v[NR/2]+v[NR/2+1])/2}'; }

num() { awk -v x="$1" 'BEGIN {if (x == "") print "-"; else printf "%.3f", x}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {if (a != "" && b > 0) printf "%.2f", a / b; else print "nan"}'; }

run() {  # run WORKLOAD MODE ROUND ARGS...
  w=$1; m=$2; r=$3; shift 3
  out=$WORK/$w-$m-$r.json
  if [ "$m" = secure ]; then
    CYCLONEDDS_URI="$NET,file://$WORK/pki/cyclonedds-secure-client.xml" "$ISOLATE" "$BENCH" \
      --daemon "$DAEMON" --daemon-dds-config "$NET,file://$WORK/pki/cyclonedds-secure-service.xml" \
      --json "$@" >"$out" 2>"$out.err" || cat "$out.err" >&2
  else
    CYCLONEDDS_URI="$NET" "$ISOLATE" "$BENCH" --daemon "$DAEMON" --json "$@" >"$out" 2>"$out.err" ||
      cat "$out.err" >&2
  fi
  printf '%-8s %-7s round %s: answered %5s, daemon CPU %s ms/frame, client CPU %s ms/frame, latency p50 %s p99 %s ms\n' \
    "$w" "$m" "$r" "$(field answered "$out")" "$(num "$(field daemon_cpu_ms_per_frame "$out")")" \
    "$(num "$(field client_cpu_ms_per_frame "$out")")" "$(num "$(field latency_ms_p50 "$out")")" \
    "$(num "$(field latency_ms_p99 "$out")")"
}

r=1
while [ "$r" -le "$ROUNDS" ]; do
  for m in plain secure; do run contact "$m" "$r" --frames "$FRAMES" --wait; done
  for m in plain secure; do run free "$m" "$r" --frames "$FRAMES" --wait --depth -0.05; done
  r=$((r + 1))
done

echo
echo "over $ROUNDS rounds: median plain, median secure, ratio of the medians, median of the per-round ratios"
for w in contact free; do
  for k in daemon_cpu_ms_per_frame client_cpu_ms_per_frame latency_ms_p50 latency_ms_p99; do
    p=$(for f in "$WORK/$w-plain-"*.json; do field "$k" "$f"; done | median)
    s=$(for f in "$WORK/$w-secure-"*.json; do field "$k" "$f"; done | median)
    pr=$(r=1; while [ "$r" -le "$ROUNDS" ]; do
      ratio "$(field "$k" "$WORK/$w-secure-$r.json")" "$(field "$k" "$WORK/$w-plain-$r.json")"; echo
      r=$((r + 1)); done | median)
    printf '%-8s %-24s plain %8s  secure %8s  ratio %5s  paired %5s\n' "$w" "$k" "$(num "$p")" \
      "$(num "$s")" "$(ratio "$s" "$p")" "$pr"
  done
done
