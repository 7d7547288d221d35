#!/usr/bin/env bash
# Install the Debian packages grainlight needs (idempotent).
# Usage: scripts/install_deps.sh            # build + tests + examples
# Nothing is downloaded at build time; this is the only place packages come from.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libglm-dev libeigen3-dev libboost-dev libboost-math-dev
  libopenexr-dev libpng-dev zlib1g-dev
  catch2 libbenchmark-dev
  python3-matplotlib
)

missing=()
if ! command -v dpkg-query >/dev/null 2>&1; then
  echo "install_deps: this is not a Debian/Ubuntu system (no dpkg-query)." >&2
  echo "install_deps: install by hand: ${PACKAGES[*]}" >&2
  exit 0
fi
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present" >&2
  exit 0
fi
echo "install_deps: installing ${missing[*]}" >&2
if ! command -v apt-get >/dev/null 2>&1; then
  echo "install_deps: apt-get not found; install by hand: ${missing[*]}" >&2
  exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install_deps: not root and no sudo; install by hand: ${missing[*]}" >&2; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
