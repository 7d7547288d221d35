#!/usr/bin/env bash
# The test command (what .ci/run calls). Phases:
#   1. install missing Debian packages;
#   2. Release build (g++) of the library, tests, examples, benchmarks and the header check; run
#      every ctest entry;
#   3. install + a separate consumer project against the *installed* package
#      (find_package(grainlight CONFIG REQUIRED)) and through add_subdirectory;
#   4. clang 14 + ASan + UBSan build of the Catch2 test binaries (`cmake --preset sanitize`: no
#      examples, benchmarks or header check) and run them with halt_on_error=1
#      (GRAINLIGHT_SANITIZE_TESTS selects ctest entries by regex; default: every test binary). This is
#      also the clang build of the tests: clang's UBSan checks more than g++'s (float-to-integer
#      overflow), and clang compiles them in about two thirds of g++'s time;
#   5. the libFuzzer targets of tests/fuzz/ (scripts/fuzz.sh: clang 14, ASan + UBSan), each
#      loader for GRAINLIGHT_FUZZ_SECONDS (default 25 s), after re-running kept crash inputs, as many
#      at once as there are jobs.
# Each phase prints its wall time and CPU time (children's user + sys) at the end.
# Environment: GRAINLIGHT_BUILD_DIR (Release build, default build/release),
# GRAINLIGHT_SANITIZE_BUILD_DIR (default <release dir>-sanitize), GRAINLIGHT_JOBS (default nproc),
# GRAINLIGHT_SKIP_SANITIZE=1, GRAINLIGHT_SKIP_FUZZ=1 (local shortcuts; CI runs everything).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=${GRAINLIGHT_BUILD_DIR:-$ROOT/build/release}
SAN_BUILD=${GRAINLIGHT_SANITIZE_BUILD_DIR:-$BUILD-sanitize}
JOBS=${GRAINLIGHT_JOBS:-$(nproc)}
start=$(date +%s)
timings=()

# CPU seconds (user + sys) used so far by this shell's finished children. `times` must run in
# this shell itself (not in a pipeline or a $(...) subshell, whose counters start at zero), so
# it writes to a file and only the parsing runs in a subshell.
TIMES_FILE=$(mktemp)
trap 'rm -f "$TIMES_FILE"' EXIT
cpu_seconds_from_file() {  # line 2 of `times`: "XmY.YYYs XmY.YYYs", the children's user and sys time
  awk 'NR == 2 { n = split($0, a, /[ms ]+/); s = 0; for (i = 1; i + 1 <= n; i += 2) s += a[i] * 60 + a[i + 1]; print s }' "$TIMES_FILE"
}
phase_name=""
phase_start=0
phase_cpu=0
phase() {  # phase "<name>": close the running phase (if any) and open the next one
  local now cpu
  now=$(date +%s)
  times >"$TIMES_FILE"
  cpu=$(cpu_seconds_from_file)
  if [ -n "$phase_name" ]; then
    local line
    line=$(awk -v n="$phase_name" -v w=$((now - phase_start)) -v c0="$phase_cpu" -v c1="$cpu" \
               'BEGIN { printf "%-34s %6d s wall %8.0f s CPU", n, w, c1 - c0 }')
    timings+=("$line")
    echo "== done: $line" >&2
  fi
  phase_name=$1
  phase_start=$now
  phase_cpu=$cpu
  [ -n "$phase_name" ] && echo "== $phase_name" >&2
  return 0
}

phase "dependencies"
scripts/install_deps.sh

phase "release: configure + build (g++)"
echo "   ($BUILD, $JOBS jobs)" >&2
# Every part switched on explicitly: a build directory last configured by the main job
# (scripts/run_examples.sh turns tests, benchmarks and the header check off) must not drop them.
cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DGRAINLIGHT_BUILD_TESTS=ON -DGRAINLIGHT_BUILD_EXAMPLES=ON \
      -DGRAINLIGHT_BUILD_BENCHMARKS=ON -DGRAINLIGHT_HEADER_CHECK=ON >/dev/null
cmake --build "$BUILD" -j"$JOBS"

phase "release: ctest"
ctest --test-dir "$BUILD" --output-on-failure -j"$JOBS"

phase "install + consumer projects"
rm -rf "$BUILD/_install" "$BUILD/_consumer"
cmake --install "$BUILD" --prefix "$BUILD/_install" >/dev/null
cmake -S "$ROOT/tests/consumer" -B "$BUILD/_consumer" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$BUILD/_install" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >/dev/null
cmake --build "$BUILD/_consumer" -j"$JOBS"
"$BUILD/_consumer/consumer"
"$BUILD/_consumer/consumer_noexcept"
rm -rf "$BUILD/_consumer_subdir"
cmake -S "$ROOT/tests/consumer" -B "$BUILD/_consumer_subdir" -DCMAKE_BUILD_TYPE=Release \
      -DGRAINLIGHT_SOURCE_DIR="$ROOT" >/dev/null
cmake --build "$BUILD/_consumer_subdir" --target consumer -j"$JOBS"
"$BUILD/_consumer_subdir/consumer"

if [ "${GRAINLIGHT_SKIP_SANITIZE:-0}" != 1 ]; then
  phase "sanitize: clang 14 + ASan+UBSan build"
  echo "   ($SAN_BUILD, tests only)" >&2
  cmake --preset sanitize -B "$SAN_BUILD" >/dev/null
  cmake --build "$SAN_BUILD" -j"$JOBS"

  phase "sanitize: ctest (halt_on_error=1)"
  # Any sanitizer report aborts the test binary (non-zero exit), so ctest fails.
  export ASAN_OPTIONS=halt_on_error=1:abort_on_error=1:detect_leaks=1:strict_string_checks=1
  export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
  ctest --test-dir "$SAN_BUILD" --output-on-failure -j"$JOBS" -L unit ${GRAINLIGHT_SANITIZE_TESTS:+-R "$GRAINLIGHT_SANITIZE_TESTS"}
  unset ASAN_OPTIONS UBSAN_OPTIONS
fi

if [ "${GRAINLIGHT_SKIP_FUZZ:-0}" != 1 ]; then
  phase "fuzz: build + run (clang 14 libFuzzer)"
  # Every loader for GRAINLIGHT_FUZZ_SECONDS (default 25) each; kept crash inputs re-run first.
  scripts/fuzz.sh "$BUILD-fuzz"
fi

phase ""
echo "== phase timings ($JOBS jobs; CPU = user + sys of all processes)" >&2
for t in "${timings[@]}"; do echo "   $t" >&2; done
echo "== all tests passed in $(( $(date +%s) - start )) s" >&2
