#!/usr/bin/env bash
# The main job (run by `make demo` after building tetcollide and tetcollided): starts
# tetcollided in the background on its embedded defaults (loopback-only DDS, a domain of
# its own; the demo asks for the contact blocks its implicit integrator needs per object,
# ObjectParams.blocks), runs the torus-on-box scene against it with
# `tetcollide demo`, prints where the outputs are and stops the daemon (also on error or
# Ctrl-C).
#   scripts/demo.sh [extra `tetcollide demo` flags, e.g. --frames 400]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
scene=${TC_DEMO_SCENE:-torus_on_box}
out=out/$scene
mkdir -p "$out"
# A domain no other tetcollide session on this host is likely to use (0..232).
domain=${TC_DEMO_DOMAIN:-$((100 + $$ % 120))}
export CYCLONEDDS_URI="file://$PWD/config/cyclonedds.xml"
log=out/tetcollided.log
config=out/tetcollided.yaml
cat >"$config" <<'YAML'
# Written by scripts/demo.sh: the embedded defaults. The demo asks for the 3x3 contact
# blocks of the objects it integrates implicitly (ObjectParams.blocks; docs/DEMO.md).
version: 1
YAML
echo "== starting tetcollided ($config: embedded defaults, domain $domain, log $log)"
"$bin/tetcollided" --config "$config" --domain "$domain" >"$log" 2>&1 &
daemon=$!
stop_daemon() {
  if kill -0 "$daemon" 2>/dev/null; then
    kill -TERM "$daemon"
    wait "$daemon" || true
    echo "== tetcollided stopped"
  fi
}
trap stop_daemon EXIT
trap 'exit 130' INT TERM
# `tetcollide demo` waits for the daemon's READY announcement over DDS (no sleep here).
echo "== tetcollide demo $scene --domain $domain --out $out $*"
start=$(date +%s%N)
"$bin/tetcollide" demo "$scene" --domain "$domain" --out "$out" "$@"
ms=$((($(date +%s%N) - start) / 1000000))
printf '== demo run took %d.%03d s; outputs under %s/ (open %s/%s.pvd in ParaView)\n' \
  $((ms / 1000)) $((ms % 1000)) "$out" "$out" "$scene"
