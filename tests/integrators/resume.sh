#!/usr/bin/env bash
# Resumable renders end to end (vpt_sphere_medium --quality full): a run stopped by the abort hook
# after its 5th checkpoint, and a run killed with SIGKILL at a random moment, each resumed with
# --resume, must give EXR and PNG files byte-identical to an uninterrupted run with the same
# arguments; a checkpoint of other arguments is refused. Usage: resume.sh EXE WORKDIR
set -euo pipefail
exe=$1
dir=$2
rm -rf "$dir"
mkdir -p "$dir"
args=(--quality full --spp 8 --seed 3 --threads 2)
ck=vpt_sphere_medium.render.checkpoint
resumed() {  # rows taken from the checkpoint, from the JSON line: must be in (0, 480)
  local n
  n=$(tail -1 "$1/stdout.txt" | sed -n 's/.*"resumed_rows":\([0-9]*\).*/\1/p')
  [ -n "$n" ] && [ "$n" -gt 0 ] && [ "$n" -lt 480 ] || { echo "resume: the resumed run did not start from the checkpoint (resumed_rows '$n')" >&2; exit 1; }
  echo "$n"
}
same() { cmp -s "$dir/ref/vpt_sphere_medium.exr" "$1/vpt_sphere_medium.exr" && cmp -s "$dir/ref/vpt_sphere_medium.png" "$1/vpt_sphere_medium.png"; }

"$exe" "${args[@]}" --out "$dir/ref" >/dev/null 2>&1

# 1. Deterministic abort right after the 5th checkpoint write, then resume.
set +e
GRAINLIGHT_ABORT_AFTER_CHECKPOINTS=5 "$exe" "${args[@]}" --out "$dir/hook" --checkpoint 0.05 >/dev/null 2>&1
rc=$?
set -e
[ "$rc" -eq 86 ] || { echo "resume: the abort hook did not stop the render (exit $rc)" >&2; exit 1; }
[ -f "$dir/hook/$ck" ] || { echo "resume: no checkpoint after the abort" >&2; exit 1; }
[ ! -f "$dir/hook/vpt_sphere_medium.exr" ] || { echo "resume: an aborted run wrote its image" >&2; exit 1; }
"$exe" "${args[@]}" --out "$dir/hook" --checkpoint 0.05 --resume >"$dir/hook/stdout.txt" 2>/dev/null
rows_hook=$(resumed "$dir/hook")
same "$dir/hook" || { echo "resume: resumed image (abort hook) differs from the uninterrupted one" >&2; exit 1; }
[ ! -f "$dir/hook/$ck" ] || { echo "resume: checkpoint left after a finished render" >&2; exit 1; }

# 2. A real SIGKILL once a checkpoint exists, at a random moment after it.
"$exe" "${args[@]}" --out "$dir/kill" --checkpoint 0.05 >/dev/null 2>&1 &
pid=$!
for _ in $(seq 1 400); do [ -f "$dir/kill/$ck" ] && break; sleep 0.02; done
sleep "0.$((RANDOM % 5))"
killed=0
if kill -KILL "$pid" 2>/dev/null; then killed=1; fi
wait "$pid" 2>/dev/null || true
[ "$killed" -eq 1 ] && [ -f "$dir/kill/$ck" ] || { echo "resume: the render finished before it could be killed" >&2; exit 1; }
"$exe" "${args[@]}" --out "$dir/kill" --checkpoint 0.05 --resume >"$dir/kill/stdout.txt" 2>/dev/null
rows_kill=$(resumed "$dir/kill")
same "$dir/kill" || { echo "resume: resumed image (SIGKILL) differs from the uninterrupted one" >&2; exit 1; }

# 3. A checkpoint written with other arguments is refused, naming the mismatch.
set +e
GRAINLIGHT_ABORT_AFTER_CHECKPOINTS=2 "$exe" "${args[@]}" --out "$dir/other" --checkpoint 0.05 >/dev/null 2>&1
msg=$("$exe" --quality full --spp 8 --seed 3 --threads 2 --ior 1.5 --out "$dir/other" --checkpoint 0.05 --resume 2>&1 >/dev/null)
rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "written by another render (key" <<<"$msg" || { echo "resume: a foreign checkpoint was not refused (exit $rc): $msg" >&2; exit 1; }
echo "resume: abort-hook run (resumed at $rows_hook of 480 rows) and SIGKILL run (at $rows_kill rows) byte-identical to the uninterrupted render; foreign checkpoint refused"
rm -rf "$dir"
