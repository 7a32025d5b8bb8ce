#!/usr/bin/env bash
# Writes agreement.txt beside it: how many queries hnswlib's graph answers as brute force does (nns_query
# --check: the neighbours at brute force's distances), 1-NN, 10-NN and ranged 1-NN at 0.1 m (its default, via
# k-NN), on Figure 3's pair at 60,000 points and on every shared real pair. Run from a clean checkout after a
# Release build: results/ab/hnswlib/agreement.sh
set -euo pipefail
cd "$(dirname "$0")/../../.."
out=results/ab/hnswlib/agreement.txt
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
{
  echo "# hnswlib_hnsw (HierarchicalNSW, M 16, ef_construction 200, ef 10: the library's defaults) against brute force:"
  echo "# queries whose neighbours lie at brute force's distances (nns_query --check). Made by $0"
  echo "# commit $(git rev-parse --short HEAD)$(git diff --quiet HEAD && echo '' || echo '+dirty'), $(date -u +%FT%TZ), $(lscpu | grep 'Model name' | sed 's/ *Model name: *//')"
  echo "# each line: build/release/bench/nns_query --adapter hnswlib_hnsw --model PAIR --query PAIR SEARCH --out F --stats S --check"
  echo "# (figure3: --model hollow_sphere --query hollow_cube, 60,000 points each)"
  printf "%-26s %-36s %8s %9s %7s\n" pair search queries agreeing share
} > "$tmp/out"
run() {  # label model query search flags...
  local label=$1 model=$2 query=$3; shift 3
  build/release/bench/nns_query --adapter hnswlib_hnsw --model "$model" --query "$query" "$@" \
      --out "$tmp/o.csv" --stats "$tmp/o.json" --check > /dev/null 2>&1
  python3 - "$tmp/o.json" "$label" "$*" >> "$tmp/out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
n, a = d["query_points"], d["agreeing_with_brute_force"]
print(f"{sys.argv[2]:26} {sys.argv[3]:36} {n:8,} {a:9,} {100 * a / n:6.2f}%")
PY
}
for s in "--search knn --k 1" "--search knn --k 10" "--search ranged --k 1 --max-dist 0.1"; do
  run figure3 hollow_sphere hollow_cube $s
  for p in office-sick-3dtk velodyne-hdl32-fastgicp kitti00-hdl64-gtsampoints office-kinect-pcl bunny-stanford; do
    run "$p" "$p" "$p" $s
  done
done
mv "$tmp/out" "$out"
cat "$out"
