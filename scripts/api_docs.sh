#!/usr/bin/env bash
# Build the API reference (HTML) from the public headers' /// comments with Debian's doxygen and
# check its warnings (undocumented public symbols, documentation errors).
# Usage: scripts/api_docs.sh [OUT_DIR]            # default build/api; open OUT_DIR/html/index.html
#        GRAINLIGHT_API_STRICT=1 scripts/api_docs.sh  # fail on any warning
# Without GRAINLIGHT_API_STRICT the run fails when the warning count exceeds the recorded baseline
# (docs/api/warnings_baseline.txt), so new undocumented symbols fail CI while the existing ones
# are being documented; lower the baseline as they go.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=$(realpath -m "${1:-build/api}")
if ! command -v doxygen >/dev/null 2>&1; then
  echo "api_docs: doxygen not found (Debian: doxygen; scripts/install_deps.sh installs it)" >&2
  exit 1
fi
mkdir -p "$OUT"
rm -f "$OUT/warnings.txt"
GRAINLIGHT_API_OUT=$OUT doxygen docs/api/Doxyfile
warnings=$(grep -c "warning:" "$OUT/warnings.txt" || true)
baseline=$(tr -dc '0-9' < docs/api/warnings_baseline.txt)
echo "api_docs: $OUT/html/index.html; $warnings doxygen warnings (baseline $baseline; list: $OUT/warnings.txt)" >&2
if [ "${GRAINLIGHT_API_STRICT:-0}" = "1" ] && [ "$warnings" -gt 0 ]; then
  sed -n 1,20p "$OUT/warnings.txt" >&2
  exit 1
fi
if [ "$warnings" -gt "$baseline" ]; then
  echo "api_docs: more warnings than the baseline: new undocumented or badly documented public symbols:" >&2
  sed -n 1,40p "$OUT/warnings.txt" >&2
  exit 1
fi
