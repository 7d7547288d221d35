#!/usr/bin/env bash
# Build and run the libFuzzer targets of tests/fuzz/ (one per loader: tiles, packing libraries,
# grain statistics, shell tables, multiple-scattering tables, OBJ) with clang 14
# (-fsanitize=fuzzer,address,undefined). Each target first re-runs the kept crash inputs of
# tests/data/fuzz/<target>/ (regression tests), then fuzzes for GRAINLIGHT_FUZZ_SECONDS (default
# 25) from a corpus seeded with valid files (written by the target itself when empty). A new
# crash is copied into tests/data/fuzz/<target>/ (commit it with the fix) and fails the script.
# GRAINLIGHT_JOBS (default nproc) targets are built and fuzzed at once.
# Usage: scripts/fuzz.sh [build dir, default build/fuzz] [target names...]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
OUT=${1:-$ROOT/build/fuzz}
shift || true
SECONDS_PER_TARGET=${GRAINLIGHT_FUZZ_SECONDS:-25}
JOBS=${GRAINLIGHT_JOBS:-$(nproc)}
CXX=${GRAINLIGHT_FUZZ_CXX:-clang++-14}
FLAGS=(-std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
       -I"$ROOT/include" -I"$ROOT/tests" -isystem /usr/include/eigen3)
mkdir -p "$OUT"
LAUNCH=()
if command -v ccache >/dev/null 2>&1 && [ "${GRAINLIGHT_CCACHE:-ON}" != OFF ]; then
  LAUNCH=(env CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=true ccache)
fi
if [ $# -gt 0 ]; then
  targets=("$@")
else
  targets=()
  for f in "$ROOT"/tests/fuzz/fuzz_*.cpp; do targets+=("$(basename "$f" .cpp)"); done
fi

echo "fuzz: building ${#targets[@]} targets with $CXX ($JOBS jobs)" >&2
pids=()
for t in "${targets[@]}"; do
  # Rebuild only when the target or a header changed (make-like check on mtimes).
  if [ ! -x "$OUT/$t" ] || [ -n "$(find "$ROOT/tests/fuzz" "$ROOT/include" -newer "$OUT/$t" -name '*.?pp' -print -quit)" ]; then
    # Compile (through ccache when installed, as the CMake builds do), then link.
    ( "${LAUNCH[@]}" "$CXX" "${FLAGS[@]}" -c "$ROOT/tests/fuzz/$t.cpp" -o "$OUT/$t.o" &&
      "$CXX" "${FLAGS[@]}" "$OUT/$t.o" -o "$OUT/$t" ) &
    pids+=($!)
    if [ ${#pids[@]} -ge "$JOBS" ]; then wait "${pids[0]}"; pids=("${pids[@]:1}"); fi
  fi
done
for p in "${pids[@]}"; do wait "$p"; done

export ASAN_OPTIONS=halt_on_error=1:abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# One target: its kept inputs, then the fuzzing run. Reports to its own file (printed in target
# order below), so that JOBS targets can run at once without interleaving their messages.
fuzz_one() {
  local t=$1 report=$2 status=0
  local kept="$ROOT/tests/data/fuzz/$t" corpus="$OUT/corpus/$t" artifacts="$OUT/artifacts/$t"
  : >"$report"
  if [ -d "$kept" ] && [ -n "$(ls -A "$kept")" ]; then
    echo "fuzz: $t: $(ls "$kept" | wc -l) kept inputs (regression)" >>"$report"
    "$OUT/$t" -runs=1 "$kept"/* >"$OUT/$t.regression.log" 2>&1 || { echo "fuzz: $t: a kept input fails again:" >>"$report"; tail -30 "$OUT/$t.regression.log" >>"$report"; status=1; }
  fi
  mkdir -p "$corpus" "$artifacts"
  if "$OUT/$t" -max_total_time="$SECONDS_PER_TARGET" -rss_limit_mb=2048 -timeout=20 -print_final_stats=1 \
       -artifact_prefix="$artifacts/" "$corpus" >"$OUT/$t.log" 2>&1; then
    echo "fuzz: $t: $(grep -o 'stat::number_of_executed_units: *[0-9]*' "$OUT/$t.log" | grep -o '[0-9]*$') runs, corpus $(ls "$corpus" | wc -l) files, no finding" >>"$report"
  else
    echo "fuzz: $t: FINDING (log $OUT/$t.log):" >>"$report"
    grep -E "ERROR|SUMMARY|==[0-9]+==|terminate|what\(\)" "$OUT/$t.log" | head -20 >>"$report" || true
    mkdir -p "$kept"
    for a in "$artifacts"/*; do [ -f "$a" ] && cp "$a" "$kept/" && echo "fuzz: kept $kept/$(basename "$a")" >>"$report"; done
    status=1
  fi
  return $status
}

failed=0
running=()   # pids of the targets now fuzzing, oldest first
for t in "${targets[@]}"; do
  fuzz_one "$t" "$OUT/$t.report" &
  running+=($!)
  if [ ${#running[@]} -ge "$JOBS" ]; then wait "${running[0]}" || failed=1; running=("${running[@]:1}"); fi
done
for p in "${running[@]}"; do wait "$p" || failed=1; done
for t in "${targets[@]}"; do cat "$OUT/$t.report" >&2; done
exit $failed
