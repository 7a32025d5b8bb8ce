#!/usr/bin/env bash
# A/B of two revisions of ours/ in one process: each side is bench/ours_ab/side.cpp compiled against one
# revision's ours/include into a shared object of its own, and build/release/bench/ours_ab answers the same
# batches with A and B in turn (A B B A ...), the fastest of each, every answer of B checked against A's
# (exit 1 when one differs). A side is a git revision (its ours/include, from this repository) or a folder
# holding ours/include (a working copy). On a machine whose slow spells last seconds, two binaries timed one
# after the other cannot show a change of a few per cent; alternating batches can. Header: both sides, the
# compiler flags and the load before and after. --cxx-a and --cxx-b compile a side with another compiler (both
# c++ by default), so that one revision against itself measures what the compiler is worth.
#
#   scripts/ours_ab.sh [--bin OURS_AB] [--cxxflags FLAGS] [--cxx-a CXX] [--cxx-b CXX] A B [ours_ab options: --rounds N --pairs P,... --trees T,... --dists D,...]
set -euo pipefail
die() { echo "ours_ab: error: $*" >&2; exit 2; }
here=$(cd "$(dirname "$0")/.." && pwd)
command_line="$0 $*"
bin=$here/build/release/bench/ours_ab
# The Release preset's flags, plus what a shared object of hidden symbols needs.
cxxflags="-O3 -DNDEBUG -ffp-contract=off"
cxx_A=c++ cxx_B=c++
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=${2:?}; shift 2 ;;
    --cxxflags) cxxflags=${2:?}; shift 2 ;;
    --cxx-a) cxx_A=${2:?}; shift 2 ;;
    --cxx-b) cxx_B=${2:?}; shift 2 ;;
    *) break ;;
  esac
done
[ $# -ge 2 ] || die "usage: $0 [--bin OURS_AB] [--cxxflags FLAGS] A B [ours_ab options]"
a=$1 b=$2
shift 2
[ -x "$bin" ] || die "no executable $bin (build the release preset first)"
for cxx in "$cxx_A" "$cxx_B"; do command -v "$cxx" > /dev/null || die "no compiler '$cxx'"; done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# side NAME REV: writes $work/NAME.so from REV (a folder with ours/include, or a git revision) with cxx_NAME.
side() {
  local name=$1 rev=$2 include cxx_var=cxx_$1
  if [ -d "$rev/ours/include" ]; then
    include=$rev/ours/include
  elif [ -d "$rev" ]; then
    die "$rev holds no ours/include"
  else
    git -C "$here" rev-parse --verify --quiet "$rev^{commit}" > /dev/null || die "'$rev' is neither a folder nor a revision"
    mkdir -p "$work/$name"
    git -C "$here" archive "$rev" ours/include | tar -x -C "$work/$name" || die "$rev has no ours/include"
    include=$work/$name/ours/include
  fi
  # shellcheck disable=SC2086 # the flags are words
  "${!cxx_var}" -std=c++17 $cxxflags -fPIC -shared -fvisibility=hidden -fvisibility-inlines-hidden -I"$include" \
    "$here/bench/ours_ab/side.cpp" -o "$work/$name.so" 2> "$work/$name.log" ||
    die "side $name ($rev) does not compile: $(grep -m1 'error' "$work/$name.log" || head -1 "$work/$name.log")"
}

side A "$a"
side B "$b"
echo "# ours_ab: $(date -u +%Y-%m-%dT%H:%M:%SZ); command: $command_line"
for s in "A $a" "B $b"; do
  name=${s%% *} rev=${s#* }
  cxx_var=cxx_$name
  if [ -d "$rev" ]; then
    what="folder $rev"
  else
    what="$(git -C "$here" rev-parse --short "$rev") ($rev)"
  fi
  echo "# $name: $what; compiler: $("${!cxx_var}" --version 2>&1 | head -1)"
done
echo "# flags: $cxxflags; driver: $("$bin" --version 2>&1 | head -1)"
echo "# load before: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
rc=0
"$bin" --a "$work/A.so" --b "$work/B.so" "$@" || rc=$?
echo "# load after: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo unknown)"
exit $rc
