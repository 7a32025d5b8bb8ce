#!/usr/bin/env bash
# Installs every system package the project needs, from Debian. Idempotent: does nothing
# when all packages are present. See ../shared/DEPENDENCIES.md for the verified list.
# Usage: scripts/install_deps.sh [PACKAGE ...]   (the given packages instead of the project's list;
# a package named name:ARCH adds ARCH to dpkg's architectures first, as scripts/test_aarch64.sh needs)
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build git pkg-config
  libeigen3-dev libnanoflann-dev libflann-dev libann-dev libspatialindex-dev
  libcgal-dev libpcl-dev libopen3d-dev libtbb-dev nlohmann-json3-dev
  libbenchmark-dev libbenchmark-tools libgtest-dev libcli11-dev
  libvtk9-dev libboost-dev libembree-dev libkdtree++-dev libcneartree-dev libfaiss-dev libgeographiclib-dev
  libopencv-dev libhnswlib-dev libalglib-dev libopenvdb-dev
  liblog4cplus-dev  # OpenVDB logs through log4cplus: its headers, to stop the thread pool it starts
  libinsighttoolkit5-dev libgdcm-tools  # ITK; GDCM's CMake targets, which ITK's config loads, name its tools
  pybind11-dev python3-dev python3-scipy python3-pykdtree python3-sklearn
  python3 python3-matplotlib python3-numpy python3-plotly chromium
  slurm-wlm munge procps valgrind
  locales  # a test compiles a locale whose decimal point is a comma (localedef's sources)
  qemu-user-static  # tests on CPUs unlike this one (x86 without AVX; 64-bit Arm)
  clang-14 libclang-rt-14-dev  # the libFuzzer targets (fuzz/)
)
for p in "$@"; do
  case $p in -*) echo "install_deps: error: '$p' is not a package name (no options taken)" >&2; exit 2 ;; esac
done
if [ $# -gt 0 ]; then PACKAGES=("$@"); fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if ! command -v sudo > /dev/null; then
    echo "install_deps: missing ${missing[*]}: installing them needs root, and there is no sudo here" >&2
    exit 1
  fi
  SUDO="sudo"
fi
echo "install_deps: installing ${missing[*]}"
for p in "${missing[@]}"; do
  arch=${p#*:}
  if [ "${arch}" != "${p}" ] && ! dpkg --print-foreign-architectures | grep -qx "${arch}"; then
    $SUDO dpkg --add-architecture "${arch}"
  fi
done
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
