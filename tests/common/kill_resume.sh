#!/usr/bin/env bash
# A multi-render example killed with SIGKILL once its checkpoints exist, then resumed with
# --resume, must write the same images (byte for byte) as an uninterrupted run, and leave no
# checkpoint behind. Usage: kill_resume.sh EXE WORKDIR "FILE1 FILE2 ..." ARGS...
set -euo pipefail
exe=$1
dir=$2
files=$3
shift 3
rm -rf "$dir"
mkdir -p "$dir"
"$exe" "$@" --out "$dir/ref" >/dev/null 2>&1
mkdir -p "$dir/kill"  # exists before the polling below looks into it
"$exe" "$@" --out "$dir/kill" --checkpoint 0 >/dev/null 2>&1 &
pid=$!
# Wait for a few checkpoints (at least one finished render and one in flight when possible).
for _ in $(seq 1 1000); do
  n=$(find "$dir/kill" -name '*.checkpoint' 2>/dev/null | wc -l || true)
  [ "$n" -ge 3 ] && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.01
done
if ! kill -KILL "$pid" 2>/dev/null; then
  echo "kill_resume: the run finished before it could be killed (make it longer)" >&2
  exit 1
fi
wait "$pid" 2>/dev/null || true
left=$(find "$dir/kill" -name '*.checkpoint' | wc -l)
"$exe" "$@" --out "$dir/kill" --checkpoint 0 --resume >/dev/null 2>&1
for f in $files; do
  cmp "$dir/ref/$f" "$dir/kill/$f" || { echo "kill_resume: $f differs after kill + resume" >&2; exit 1; }
done
[ "$(find "$dir/kill" -name '*.checkpoint' | wc -l)" -eq 0 ] || { echo "kill_resume: checkpoints left after the resumed run" >&2; exit 1; }
echo "kill_resume: $(basename "$exe") killed with $left checkpoint(s) on disk, resumed: $files byte-identical"
rm -rf "$dir"
