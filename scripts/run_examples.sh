#!/usr/bin/env bash
# The main job: install missing Debian packages, Release build, then run every example program at
# quick quality. Everything (EXR, PNG, CSV, JSON, logs) goes to one folder, ./out by default, and
# OUT/index.html (scripts/make_results_page.py) shows it together: one section per paper and program.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=${GRAINLIGHT_BUILD_DIR:-$ROOT/build/release}
OUT=${GRAINLIGHT_OUT:-$ROOT/out}
QUALITY=${GRAINLIGHT_QUALITY:-quick}
JOBS=${GRAINLIGHT_JOBS:-$(nproc)}

scripts/install_deps.sh
cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DGRAINLIGHT_BUILD_TESTS=OFF \
      -DGRAINLIGHT_BUILD_BENCHMARKS=OFF -DGRAINLIGHT_HEADER_CHECK=OFF >/dev/null
cmake --build "$BUILD" -j"$JOBS"
mkdir -p "$OUT"

# Calculators take their own arguments; figure/table programs take the shared convention.
declare -A ARGS=(
  [slab]="--albedo 0.9 --optical-depth 2 --g 0 --ior 1.4 --mu0 1 --paths 1000000 --seed 1 --out $OUT/slab"
  [mie]="--n 1.33 --k 0 --x 100 --angles 0,30,60,90,120,150,180 --out $OUT/mie"
  [packing]="--fraction 0.63 --spheres 2000 --seed 1 --out $OUT/packing/tile_f063_n2000.gltile"
  [grain_stats]="--preset glass-bead --rays 200000 --seed 1 --out $OUT/grain_stats"
)

failed=()
job_t0=$(date +%s)
for exe in "$BUILD"/bin/*; do
  name=$(basename "$exe")
  [[ -x "$exe" && "$name" != bench_* ]] || continue
  mkdir -p "$OUT/$name"
  if [[ -n "${ARGS[$name]:-}" ]]; then
    args=${ARGS[$name]}
  else
    args="--quality $QUALITY --out $OUT/$name --seed 1"
  fi
  echo "== $name $args" >&2
  echo "${exe#"$ROOT"/} ${args//"$ROOT"\//}" > "$OUT/$name/command.txt"
  t0=$(date +%s)
  # shellcheck disable=SC2086
  if "$exe" $args > "$OUT/$name/stdout.txt"; then
    echo "ok $(( $(date +%s) - t0 ))" > "$OUT/$name/status.txt"
    echo "   ok in $(( $(date +%s) - t0 )) s: $(tail -n 1 "$OUT/$name/stdout.txt" | cut -c1-200)" >&2
  else
    rc=$?
    echo "failed $rc $(( $(date +%s) - t0 ))" > "$OUT/$name/status.txt"
    echo "   FAILED ($name, exit $rc)" >&2
    failed+=("$name")
  fi
done
# The Python module's example (built when pybind11 + numpy are present; skipped otherwise).
if compgen -G "$BUILD/python/grainlight*.so" >/dev/null && [ -x /usr/bin/python3 ]; then
  name=python_phase
  mkdir -p "$OUT/$name"
  echo "== $name (examples/python/plot_phase.py)" >&2
  echo "PYTHONPATH=${BUILD#"$ROOT"/}/python /usr/bin/python3 examples/python/plot_phase.py --out ${OUT#"$ROOT"/}/$name" \
    > "$OUT/$name/command.txt"
  t0=$(date +%s)
  if PYTHONPATH="$BUILD/python" /usr/bin/python3 examples/python/plot_phase.py --out "$OUT/$name" > "$OUT/$name/stdout.txt"; then
    echo "ok $(( $(date +%s) - t0 ))" > "$OUT/$name/status.txt"
    echo "   ok in $(( $(date +%s) - t0 )) s" >&2
  else
    rc=$?
    echo "failed $rc $(( $(date +%s) - t0 ))" > "$OUT/$name/status.txt"
    echo "   FAILED ($name, exit $rc)" >&2
    failed+=("$name")
  fi
else
  echo "note: Python module not built (pybind11/numpy missing); python_phase skipped" >&2
fi
echo "examples took $(( $(date +%s) - job_t0 )) s" >&2
# The results page (Debian's python: standard library only). Written even when an example failed.
if [ -x /usr/bin/python3 ]; then
  if /usr/bin/python3 scripts/make_results_page.py "$OUT" --quality "$QUALITY"; then
    # Every image and link on the page must resolve, every PNG must be on it.
    /usr/bin/python3 tests/results_page/check_results_page.py --page "$OUT" >&2 || failed+=("results_page")
  else
    echo "results page not written" >&2
    failed+=("results_page")
  fi
else
  echo "note: /usr/bin/python3 not found; $OUT/index.html not written" >&2
fi
if [ ${#failed[@]} -gt 0 ]; then
  echo "examples failed: ${failed[*]}" >&2
  exit 1
fi
echo "all examples done; results in $OUT (open $OUT/index.html)" >&2
