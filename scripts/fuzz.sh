#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang++-14 in build/fuzz and fuzzes each for SECONDS (default
# 600), one after another, single job. Seeds: fuzz/seeds/<target>/ and the regression corpus. Crashes land
# in build/fuzz/artifacts/<target>/; once fixed, copy them to fuzz/regressions/<target>/ (ctest replays those).
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#   scripts/fuzz.sh --replay [TARGET...]   build, then run every seed and regression once through each target
#                                          (part of the test command: the fuzz build must not rot unseen)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
die() { echo "fuzz: error: $*" >&2; exit 2; }
all_targets=(pcd ply text3d xyz bin experiment results icp_results icp_experiment)
replay=0
if [ "${1:-}" = "--replay" ]; then replay=1; shift; else seconds="${1:-600}"; shift || true; fi
[ "$replay" = 1 ] || [[ "$seconds" =~ ^[1-9][0-9]{0,6}$ ]] || die "SECONDS must be a whole number from 1 (got '$seconds')"
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
known() { local t; for t in "${all_targets[@]}"; do [ "$t" = "$1" ] && return 0; done; return 1; }
for target in "${targets[@]}"; do
  known "$target" || die "unknown target '$target' (known: ${all_targets[*]})"
done
build="$root/build/fuzz"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DNNB_FUZZ=ON \
      -DNNB_BUILD_TESTS=OFF -DNNB_BUILD_BENCH=OFF \
      -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 >/dev/null
. "$root/scripts/jobs.sh"
jobs=$(build_jobs)
cmake --build "$build" -j "${jobs}" --target $(printf 'fuzz_%s ' "${targets[@]}")

# run_fuzzer TARGET LOG ARGS...: the target on its seeds and regressions (after ARGS' own folders), from the
# build folder, its output in LOG. rss_limit: a loader that allocates what a header claims shows up as an
# out-of-memory finding.
run_fuzzer() {
  local target=$1 log=$2
  shift 2
  (cd "$build" && ASAN_OPTIONS=detect_leaks=1 "$build/fuzz/fuzz_$target" -rss_limit_mb=1024 -malloc_limit_mb=512 \
     -timeout=10 "$@" "$root/fuzz/seeds/$target" "$root/fuzz/regressions/$target" >"$log" 2>&1)
}

status=0
if [ "$replay" = 1 ]; then
  for target in "${targets[@]}"; do
    # -runs=0: each input of the folders once, nothing generated, nothing written
    if run_fuzzer "$target" "$build/replay_$target.log" -runs=0; then
      echo "fuzz_$target: $(grep -o 'INITED.*' "$build/replay_$target.log" | head -1)"
    else
      echo "fuzz_$target: FAILED, see $build/replay_$target.log"
      status=1
    fi
  done
  exit $status
fi

for target in "${targets[@]}"; do
  corpus="$build/corpus/$target"
  artifacts="$build/artifacts/$target"
  mkdir -p "$corpus" "$artifacts"
  echo "== fuzz_$target for ${seconds}s"
  if ! run_fuzzer "$target" "$build/fuzz_$target.log" -max_total_time="$seconds" -print_final_stats=1 \
         -artifact_prefix="$artifacts/" "$corpus"; then
    echo "   finding: see $build/fuzz_$target.log and $artifacts/"
    status=1
  fi
  grep -E "^stat::(number_of_executed_units|new_units_added)" "$build/fuzz_$target.log" || true
done
exit $status
