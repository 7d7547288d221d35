#!/usr/bin/env bash
# An MPI run must reproduce the single-process output byte for byte and say "ranks": K.
# Usage: mpi_compare.sh MPIEXEC K WORKDIR FILE EXE ARGS...
#   runs EXE ARGS --out WORKDIR/one --threads 2, then MPIEXEC -np K EXE ARGS --out WORKDIR/mpi
#   --threads 1 (loopback, --oversubscribe, root allowed as in CI), and compares WORKDIR/*/FILE.
set -euo pipefail
mpiexec=$1
k=$2
dir=$3
file=$4
exe=$5
shift 5
rm -rf "$dir"
mkdir -p "$dir"
"$exe" "$@" --out "$dir/one" --threads 2 >"$dir/one.txt" 2>/dev/null
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader OMPI_MCA_rmaps_base_oversubscribe=1
"$mpiexec" --oversubscribe -np "$k" "$exe" "$@" --out "$dir/mpi" --threads 1 >"$dir/mpi.txt" 2>"$dir/mpi.err" ||
  { echo "mpi_compare: mpirun failed:" >&2; tail -20 "$dir/mpi.err" >&2; exit 1; }
tail -1 "$dir/mpi.txt" | grep -q "\"ranks\":$k" || { echo "mpi_compare: the JSON does not report \"ranks\":$k" >&2; tail -1 "$dir/mpi.txt" >&2; exit 1; }
tail -1 "$dir/one.txt" | grep -q '"ranks":1' || { echo "mpi_compare: the single run does not report \"ranks\":1" >&2; exit 1; }
cmp "$dir/one/$file" "$dir/mpi/$file" || { echo "mpi_compare: $file differs between 1 process and $k ranks" >&2; exit 1; }
echo "mpi_compare: $(basename "$exe") with $k ranks wrote $file byte-identical to one process"
rm -rf "$dir"
