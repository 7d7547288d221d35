#!/usr/bin/env bash
# Kill a process that rewrites an EXR, a PNG, a binary container and a text file in a loop with
# SIGKILL at seeded pseudo-random moments, ROUNDS times; after each kill every target must hold one
# complete version (test_scene "[.crash_verify]"). Usage: crash_writers.sh TEST_BINARY WORKDIR [ROUNDS] [SEED]
set -euo pipefail
bin=$1
dir=$2
rounds=${3:-12}
RANDOM=${4:-20261201}
rm -rf "$dir"
mkdir -p "$dir"
export GRAINLIGHT_CRASH_DIR=$dir
# A first complete version of every file.
GRAINLIGHT_CRASH_ROUNDS=1 "$bin" "[.crash_writer]" >/dev/null
start=1
for ((i = 1; i <= rounds; i++)); do
  GRAINLIGHT_CRASH_START=$start "$bin" "[.crash_writer]" >/dev/null 2>&1 &
  pid=$!
  delay_ms=$((80 + RANDOM % 900))
  sleep "$(printf '0.%03d' "$delay_ms")"
  kill -KILL "$pid"
  wait "$pid" 2>/dev/null || true
  if ! "$bin" "[.crash_verify]" >"$dir/verify.log" 2>&1; then
    echo "crash_writers: round $i (killed after $delay_ms ms): a target is not a complete file" >&2
    cat "$dir/verify.log" >&2
    exit 1
  fi
  start=$((start + 1000))
done
leftovers=$(find "$dir" -name '*.tmp*' | wc -l)
echo "crash_writers: $rounds SIGKILLs at seeded random moments; every target whole after each ($leftovers temporary files left by killed writes)"
rm -rf "$dir"
