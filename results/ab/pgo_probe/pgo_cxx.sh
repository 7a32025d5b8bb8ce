#!/usr/bin/env bash
# A compiler for scripts/ours_ab.sh --cxx-b that builds the side with gcc's profile-guided optimisation:
# PGO_MODE=generate writes an instrumented side (its run leaves the profile in PGO_DIR), PGO_MODE=use builds from
# that profile. The side is compiled to a fixed object path so that both builds name the profile alike.
set -euo pipefail
: "${PGO_DIR:?the profile folder}" "${PGO_MODE:?generate, use or none}"
case $PGO_MODE in
  generate) pgo=(-fprofile-generate="$PGO_DIR" -fprofile-update=single) ;;
  use) pgo=(-fprofile-use="$PGO_DIR" -fprofile-partial-training -Wno-missing-profile) ;;
  none) pgo=() ;;
  *) echo "pgo_cxx: PGO_MODE is generate, use or none (the same two steps, no profile: the control)" >&2; exit 2 ;;
esac
[ "${1:-}" = --version ] && { c++ --version | sed "1s/\$/ with -fprofile-$PGO_MODE/"; exit 0; }
args=() out=""
while [ $# -gt 0 ]; do
  case $1 in
    -o) out=$2; shift 2 ;;
    -shared) shift ;;
    *) args+=("$1"); shift ;;
  esac
done
[ -n "$out" ] || { echo "pgo_cxx: no -o" >&2; exit 2; }
obj=$PGO_DIR/obj/side.o
mkdir -p "$PGO_DIR/obj"
c++ "${args[@]}" "${pgo[@]}" -c -o "$obj"
c++ -shared -fPIC "${pgo[@]}" "$obj" -o "$out"
