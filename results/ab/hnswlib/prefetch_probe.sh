#!/usr/bin/env bash
# hnswlib with its SSE prefetches (as shipped) and without (NO_MANUAL_VECTORIZATION, the adapter's setting: the
# prefetch reads one link past the end of a full upper-layer list, which ASan reports). For 3-D points both use
# the same plain distance function, so the prefetches are all that differs. Rounds alternate the two builds.
# Usage: prefetch_probe.sh SCAN.3d [ROUNDS]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
scan=$1 rounds=${2:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
g++ -O2 -DNDEBUG -std=c++17 "$here/prefetch_probe.cpp" -o "$work/prefetch"
g++ -O2 -DNDEBUG -std=c++17 -DNO_MANUAL_VECTORIZATION "$here/prefetch_probe.cpp" -o "$work/plain"
for ((r = 1; r <= rounds; r++)); do
  echo "round $r prefetch: $("$work/prefetch" "$scan")"
  echo "round $r plain:    $("$work/plain" "$scan")"
done
