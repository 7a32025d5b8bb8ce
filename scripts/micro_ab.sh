#!/usr/bin/env bash
# A/B of two micro_nns binaries (say, before and after a change to ours/): for each filter, A and B are run
# one after the other ROUNDS times, so that the machine's slow spells fall on both; prints each benchmark's
# fastest wall time under A and under B and their ratio B/A (below 1: B is faster). Header: both binaries'
# versions and the load before and after. Ratios, not absolute times, are what it is for.
# --noise runs A a second time after B in each round and adds the column A2/A: how far the same binary's fastest
# times lie apart in this sitting, the noise a B/A must stand clear of (on some machines of this kind a binary
# against itself moves by a third).
#
#   scripts/micro_ab.sh [--noise] A_BINARY B_BINARY ROUNDS FILTER [FILTER...] > results/ab/NAME.txt
set -euo pipefail
export LC_ALL=C  # awk reads and prints the times with a decimal point, as micro_nns writes them, in any locale
die() { echo "micro_ab: error: $*" >&2; exit 2; }
noise=0
if [ "${1:-}" = --noise ]; then noise=1; shift; fi
[ $# -ge 4 ] || die "usage: $0 [--noise] A_BINARY B_BINARY ROUNDS FILTER [FILTER...]"
a=$1 b=$2 rounds=$3
shift 3
for bin in "$a" "$b"; do [ -x "$bin" ] || die "no executable $bin"; done
case $rounds in '' | *[!0-9]* | 0) die "ROUNDS must be a whole number from 1 (got '$rounds')" ;; esac

echo "# micro_ab: $(date -u +%Y-%m-%dT%H:%M:%SZ), $rounds rounds; command: $0 $([ $noise = 1 ] && echo "--noise ")$a $b $rounds $*"
# --version names the commit each binary was built from ("+dirty": from a modified tree).
echo "# A: $a: $("$a" --version 2>&1 | head -1)"
echo "# B: $b: $("$b" --version 2>&1 | head -1)"
echo "# load before: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
runs=$(mktemp)
trap 'rm -f "$runs"' EXIT
for filter in "$@"; do
  for _ in $(seq "$rounds"); do
    sides="A B"
    [ $noise = 1 ] && sides="A B A2"
    for side in $sides; do
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
awk -v noise=$noise '{ key = $2 " " $1; if (!(key in best) || $3 < best[key]) best[key] = $3; names[$2] = 1 }
     function cell(v) { return v == "" ? sprintf("%10s", "-") : sprintf("%10.3f", v) }
     function ratio(x, y) { return (x == "" || y == "") ? sprintf("%7s", "-") : sprintf("%7.3f", x / y) }
     END {
       printf "%-64s %10s %10s %7s", "benchmark (fastest wall time, ms)", "A", "B", "B/A"
       if (noise) printf " %10s %7s", "A2", "A2/A"
       printf "\n"
       for (n in names) {
         a = best[n " A"]; b = best[n " B"]; a2 = best[n " A2"]
         printf "%-64s %s %s %s", n, cell(a), cell(b), ratio(b, a)
         if (noise) printf " %s %s", cell(a2), ratio(a2, a)
         printf "\n"
       }
     }' "$runs" | { read -r header; echo "$header"; sort; }
