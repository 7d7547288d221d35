#!/usr/bin/env bash
# The test command: install missing Debian packages, Release build of the library, tests,
# examples and benchmarks, run every test, then build and run a separate consumer project
# against the *installed* package (find_package(grainlight CONFIG REQUIRED)).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=${GRAINLIGHT_BUILD_DIR:-$ROOT/build/release}
JOBS=${GRAINLIGHT_JOBS:-$(nproc)}
start=$(date +%s)

scripts/install_deps.sh

echo "== configure + build ($BUILD, $JOBS jobs)" >&2
cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD" -j"$JOBS"

echo "== tests" >&2
ctest --test-dir "$BUILD" --output-on-failure -j"$JOBS"

echo "== install + consumer project" >&2
rm -rf "$BUILD/_install" "$BUILD/_consumer"
cmake --install "$BUILD" --prefix "$BUILD/_install" >/dev/null
cmake -S "$ROOT/tests/consumer" -B "$BUILD/_consumer" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$BUILD/_install" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >/dev/null
cmake --build "$BUILD/_consumer" -j"$JOBS"
"$BUILD/_consumer/consumer"
"$BUILD/_consumer/consumer_noexcept"

echo "== consumer project via add_subdirectory" >&2
rm -rf "$BUILD/_consumer_subdir"
cmake -S "$ROOT/tests/consumer" -B "$BUILD/_consumer_subdir" -DCMAKE_BUILD_TYPE=Release \
      -DGRAINLIGHT_SOURCE_DIR="$ROOT" >/dev/null
cmake --build "$BUILD/_consumer_subdir" --target consumer -j"$JOBS"
"$BUILD/_consumer_subdir/consumer"

echo "== all tests passed in $(( $(date +%s) - start )) s" >&2
