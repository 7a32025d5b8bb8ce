#!/usr/bin/env bash
# The test programs built for 64-bit Arm and run under qemu-user: our trees' plain C++ paths, the search
# API's threads on a weakly ordered CPU, and a compiler that fuses multiply-adds unless told not to.
# Cross-compiled with Debian's g++-aarch64-linux-gnu against Debian's arm64 packages (multiarch); the
# adapters whose libraries are not installed for arm64 are left out, as on any machine without them.
# Usage: scripts/test_aarch64.sh [build folder, default build/aarch64]
set -euo pipefail
cd "$(dirname "$0")/.."
case ${1:-} in -*) echo "test_aarch64: error: '$1' is not a build folder (no options taken)" >&2; exit 2 ;; esac
[ $# -le 1 ] || { echo "test_aarch64: error: one build folder at most (got $#)" >&2; exit 2; }
build=${1:-build/aarch64}
if [ "$(uname -m)" = "aarch64" ]; then
  echo "test_aarch64: this machine is aarch64, and the Release build's tests ran on it natively"
  exit 0
fi

./scripts/install_deps.sh g++-aarch64-linux-gnu qemu-user-static libstdc++6:arm64 libgtest-dev:arm64 libssl-dev:arm64

# FLANN's, ITK's and the embedded Python's CMake files sit in folders shared by every architecture and name
# the host's libraries: off here.
cmake -S . -B "${build}" -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/aarch64-linux-gnu.cmake \
      -DCMAKE_BUILD_TYPE=Release -DNNB_WITH_FLANN=OFF -DNNB_WITH_ITK=OFF -DNNB_WITH_PYTHON=OFF
. scripts/jobs.sh
jobs=$(build_jobs)
cmake --build "${build}" -j "${jobs}"
if ! ctest --test-dir "${build}" -j "${jobs}" --output-on-failure --timeout 900; then
  python3 scripts/print_failed_tests.py "${build}"
  exit 1
fi
