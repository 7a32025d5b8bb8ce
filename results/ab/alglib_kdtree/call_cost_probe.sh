#!/usr/bin/env bash
# Builds and runs call_cost_probe.cpp against Debian's ALGLIB (libalglib-dev), -O3 as the project's Release builds.
# Usage: results/ab/alglib_kdtree/call_cost_probe.sh > results/ab/alglib_kdtree/call_cost_probe.txt
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
g++ -O3 -std=c++17 -I/usr/include/libalglib "$here/call_cost_probe.cpp" -lalglib -o "$out/probe"
echo "# results/ab/alglib_kdtree/call_cost_probe.sh at $(git -C "$here" rev-parse --short HEAD)$(git -C "$here" diff --quiet HEAD || echo +dirty), $(date -u +%FT%TZ)"
echo "# $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load before: $(cut -d' ' -f1-3 /proc/loadavg)"
"$out/probe"
echo "# load after: $(cut -d' ' -f1-3 /proc/loadavg)"
