#!/usr/bin/env bash
# Runs every Google Benchmark program (make bench). Results: docs/BENCHMARKS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
for b in build/bin/bench_*; do
  [ -x "$b" ] || continue
  echo "== $b"
  "$b" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
done
