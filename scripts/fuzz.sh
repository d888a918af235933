#!/usr/bin/env bash
# Runs every libFuzzer target of build/asan-ubsan for FUZZ_SECONDS each (default 60) and prints
# a summary: runs, execs/s, coverage (libFuzzer's cov/ft counters), corpus size, result.
# Usage: scripts/fuzz.sh [target...]   (default: all eight; `make fuzz`, `make fuzz-short`)
# Env:   FUZZ_SECONDS, FUZZ_BUILD (default build/asan-ubsan).
# The working corpus grows in $FUZZ_BUILD/corpus/<target> (seeded read-only from
# fuzz/corpus/<target>); a crash, hang (> 10 s per input) or leak leaves its input in
# $FUZZ_BUILD/artifacts/<target>/ and makes this script fail. Keep such an input as
# fuzz/regressions/<target>/<name> once the bug is fixed (docs/RELIABILITY.md).
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-60}
build=${FUZZ_BUILD:-build/asan-ubsan}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(gmsh stl obj tetgen mesh samples config recording)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=0
summary=()
for t in "${targets[@]}"; do
  bin="$build/bin/fuzz_$t"
  if [ ! -x "$bin" ]; then
    echo "fuzz.sh: $bin not built (make fuzz-build)" >&2
    exit 2
  fi
  corpus="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  log="$build/logs/$t.log"
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  dict=()
  [ -f "fuzz/dict/$t.dict" ] && dict=(-dict="fuzz/dict/$t.dict")
  echo "== fuzz_$t for ${seconds} s (log: $log)"
  start=$(date +%s)
  "$bin" "$corpus" "fuzz/corpus/$t" "${dict[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1
  rc=$?
  elapsed=$(( $(date +%s) - start ))
  # The last status line: "#N  DONE|pulse|NEW  cov: C ft: F corp: K/S ... exec/s: E ..."
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  runs=$(grep -oE '^stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$')
  eps=$(grep -oE '^stat::average_exec_per_sec: *[0-9]+' "$log" | grep -oE '[0-9]+$')
  cov=$(sed -nE 's/.* cov: ([0-9]+).*/\1/p' <<<"$last")
  ft=$(sed -nE 's/.* ft: ([0-9]+).*/\1/p' <<<"$last")
  corp=$(sed -nE 's/.* corp: ([0-9]+\/[0-9]+[a-zA-Z]*).*/\1/p' <<<"$last")
  if [ $rc -eq 0 ]; then
    result=ok
  else
    result="FAILED (rc $rc, input in $artifacts/)"
    failed=1
    grep -E 'ERROR: |runtime error|fuzz check failed|SUMMARY' "$log" | head -5
  fi
  summary+=("$(printf '%-10s %5ss %10s %8s %6s %7s %12s  %s' "$t" "$elapsed" "${runs:-?}" \
    "${eps:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$result")")
done
echo
printf '%-10s %6s %10s %8s %6s %7s %12s  %s\n' target time runs exec/s cov ft corpus result
printf '%s\n' "${summary[@]}"
if [ $failed -ne 0 ]; then
  echo "fuzz: FAILED (see the logs above)"
  exit 1
fi
echo "fuzz: ${#targets[@]} targets, no crash"
