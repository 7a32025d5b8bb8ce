#!/usr/bin/env bash
# A/B of two micro_nns binaries (say, before and after a change to ours/): for each filter, A and B are run
# one after the other ROUNDS times, so that the machine's slow spells fall on both; prints each benchmark's
# fastest wall time under A and under B and their ratio B/A (below 1: B is faster). Header: both binaries'
# versions and the load before and after. Ratios, not absolute times, are what it is for.
#
#   scripts/micro_ab.sh A_BINARY B_BINARY ROUNDS FILTER [FILTER...] > results/ab/NAME.txt
set -euo pipefail
die() { echo "micro_ab: error: $*" >&2; exit 2; }
[ $# -ge 4 ] || die "usage: $0 A_BINARY B_BINARY ROUNDS FILTER [FILTER...]"
a=$1 b=$2 rounds=$3
shift 3
for bin in "$a" "$b"; do [ -x "$bin" ] || die "no executable $bin"; done
case $rounds in '' | *[!0-9]* | 0) die "ROUNDS must be a whole number from 1 (got '$rounds')" ;; esac

echo "# micro_ab: $(date -u +%Y-%m-%dT%H:%M:%SZ), $rounds rounds; command: $0 $a $b $rounds $*"
# --version names the commit each binary was built from ("+dirty": from a modified tree).
echo "# A: $a: $("$a" --version 2>&1 | head -1)"
echo "# B: $b: $("$b" --version 2>&1 | head -1)"
echo "# load before: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
runs=$(mktemp)
trap 'rm -f "$runs"' EXIT
for filter in "$@"; do
  for _ in $(seq "$rounds"); do
    for side in A B; do
      bin=$a
      [ "$side" = B ] && bin=$b
      "$bin" --benchmark_filter="$filter" --benchmark_min_time=0.3 2>/dev/null |
        awk -v side="$side" '/^(Ranged[12]NN|Build|IcpStep)\/[^ ]* +[0-9.]+ (ns|us|ms|s) / {
          t = $2; u = $3; f = (u == "ns") ? 1e-6 : (u == "us") ? 1e-3 : (u == "s") ? 1e3 : 1
          print side, $1, t * f }' >> "$runs" || die "$bin failed on filter '$filter'"
    done
  done
done
echo "# load after: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
awk '{ key = $2 " " $1; if (!(key in best) || $3 < best[key]) best[key] = $3; names[$2] = 1 }
     END {
       printf "%-64s %10s %10s %7s\n", "benchmark (fastest wall time, ms)", "A", "B", "B/A"
       for (n in names) {
         a = best[n " A"]; b = best[n " B"]
         if (a == "" || b == "") printf "%-64s %10s %10s %7s\n", n, (a == "" ? "-" : a), (b == "" ? "-" : b), "-"
         else printf "%-64s %10.3f %10.3f %7.3f\n", n, a, b, b / a
       }
     }' "$runs" | { read -r header; echo "$header"; sort; }
