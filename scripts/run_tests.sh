#!/usr/bin/env bash
# The README's test command: install the dependencies, build the release and the sanitizer presets,
# and run the whole ctest suite under both; in between, the release built with clang 14 and its compiled
# tests (the clang preset leaves out the Python, Slurm, Valgrind and emulated ones, which no compiler
# changes); then build the libFuzzer targets and replay their inputs; then the test programs again, built
# for 64-bit Arm and run under an emulator.
set -euo pipefail
if [ $# -gt 0 ]; then
  echo "run_tests: error: no arguments taken ('$1'); NNB_JOBS=N sets the jobs, see the README" >&2
  exit 2
fi
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
. scripts/anchors.sh
. scripts/jobs.sh
jobs=$(build_jobs)
for preset in release clang sanitize; do
  echo "=== ${preset}: configure, build, test ==="
  cmake --preset "${preset}"
  cmake --build --preset "${preset}" -j "${jobs}"
  if ! ctest --preset "${preset}" -j "${jobs}"; then
    python3 scripts/print_failed_tests.py "build/${preset}"
    exit 1
  fi
done
echo "=== fuzz: build the libFuzzer targets, replay their seeds and regressions ==="
./scripts/fuzz.sh --replay
echo "=== aarch64: cross-build the test programs, run them under qemu-user ==="
./scripts/test_aarch64.sh
