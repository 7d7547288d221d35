#!/usr/bin/env bash
# Install the Debian packages grainlight needs (idempotent).
# Usage: scripts/install_deps.sh            # build + tests + examples (+ optional components)
#        GRAINLIGHT_OPTIONAL=0 scripts/install_deps.sh   # required packages only
# Optional components are built when their packages are present and skipped cleanly otherwise; a
# failure to install one of them is reported but does not fail the set-up.
# Nothing is downloaded at build time; this is the only place packages come from.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libglm-dev libeigen3-dev libboost-dev libboost-math-dev
  libopenexr-dev libpng-dev zlib1g-dev
  catch2 libbenchmark-dev
  python3-matplotlib
)
# Optional: the Python module (pybind11 + numpy, tested with pytest), the Embree adapter, MPI
# scale-out of the examples (OpenMPI), the third-party baselines of bench_third_party
# (tinyobjloader, nlohmann-json), the API reference (doxygen) and a compiler cache (ccache: the
# build goes through it when present, so repeated builds recompile only what changed).
OPTIONAL_PACKAGES=(
  pybind11-dev python3-dev python3-numpy python3-pytest
  libembree-dev
  libopenmpi-dev openmpi-bin
  libtinyobjloader-dev nlohmann-json3-dev
  doxygen
  ccache
)
if [ "${GRAINLIGHT_OPTIONAL:-1}" = "0" ]; then OPTIONAL_PACKAGES=(); fi

missing=()
optional_missing=()
if ! command -v dpkg-query >/dev/null 2>&1; then
  echo "install_deps: this is not a Debian/Ubuntu system (no dpkg-query)." >&2
  echo "install_deps: install by hand: ${PACKAGES[*]} (optional: ${OPTIONAL_PACKAGES[*]})" >&2
  exit 0
fi
is_installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
for p in "${PACKAGES[@]}"; do
  is_installed "$p" || missing+=("$p")
done
for p in "${OPTIONAL_PACKAGES[@]}"; do
  is_installed "$p" || optional_missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ] && [ ${#optional_missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages (+ ${#OPTIONAL_PACKAGES[@]} optional) present" >&2
  exit 0
fi
echo "install_deps: installing ${missing[*]} ${optional_missing[*]}" >&2
if ! command -v apt-get >/dev/null 2>&1; then
  echo "install_deps: apt-get not found; install by hand: ${missing[*]} (optional: ${optional_missing[*]})" >&2
  [ ${#missing[@]} -eq 0 ] && exit 0
  exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install_deps: not root and no sudo; install by hand: ${missing[*]} (optional: ${optional_missing[*]})" >&2
    [ ${#missing[@]} -eq 0 ] && exit 0
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
if [ ${#missing[@]} -gt 0 ]; then
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
if [ ${#optional_missing[@]} -gt 0 ]; then
  $SUDO apt-get install -y -q --no-install-recommends "${optional_missing[@]}" ||
    echo "install_deps: optional packages not installed (${optional_missing[*]}); their components are skipped" >&2
fi
