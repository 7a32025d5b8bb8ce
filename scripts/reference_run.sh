#!/usr/bin/env bash
# The reference run: every results file of results/reference, one step after the other, from the clean commit
# checked out in the source tree, written to a folder outside it (the tree must stay clean while it runs).
# Resumable across sessions: a finished step is not run again, a stopped one resumes its file. Nothing else
# may run meanwhile; the log records each step's command, commit and load before and after.
#
#   scripts/reference_run.sh --out DIR [--until TIME] [--steps a,b] [--source TREE] [--no-build]
#   scripts/reference_run.sh --out DIR --list          the steps and their commands; runs nothing
#   scripts/reference_run.sh --out DIR --install       copy DIR's files into this clone's results/reference
#                                                      (finished ones in place, unfinished ones gzipped to pending/,
#                                                      the log's new lines added to reference_run_log.txt)
#   scripts/reference_run.sh --out DIR --end-early STEP --reason TEXT
#                                                      call STEP's file finished as it stands (the log says why);
#                                                      for a step whose last settings would take days
#   scripts/reference_run.sh --out DIR --from-pending ...   first copy this clone's pending/ files into DIR,
#                                                      so that a new machine resumes them
# --until TIME (what date -d reads: 03:05 means today's, so past midnight give the date) stops the step in
# flight then (it resumes next time) and starts none after it.
# --noise-limit X (default 1.10): before a sitting's first step, scripts/machine_noise.py times a few benchmarks
# and the run refuses to start when their repetitions spread more than X (slowest over fastest): a busy host
# under a virtual machine shows there, not in the load. 'none' runs anyway. The log records the spread before
# and after each sitting, and micro_nns's own (the median and largest over its benchmarks).
# ICP on the real pairs runs this clone's definition of it (which adapters it leaves out), even from an older
# --source; the results file records the definition it ran.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
src=$here out="" until="" only="" build=1 list=0 install=0 from_pending=0 end_early="" reason="" noise_limit=1.10
die() { echo "reference_run: error: $*" >&2; exit 2; }
# Microseconds make each log line its event's alone, so --install can skip the lines a clone already has.
now() { date +%Y-%m-%dT%H:%M:%S.%6N%:z; }
# A command as the programs record theirs, each word in single quotes: a path with a space stays one word.
quoted() {
  local word line=""
  for word in "$@"; do line+=" '${word//\'/\'\\\'\'}'"; done
  printf '%s' "${line# }"
}
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=${2:?}; shift ;;
    --until) until=${2:?}; shift ;;
    --steps) only=${2:?}; shift ;;
    --source) src=$(cd "${2:?}" && pwd) || die "no folder $2"; shift ;;
    --no-build) build=0 ;;
    --list) list=1 ;;
    --install) install=1 ;;
    --from-pending) from_pending=1 ;;
    --end-early) end_early=${2:?}; shift ;;
    --reason) reason=${2:?}; shift ;;
    --noise-limit) noise_limit=${2:?}; shift ;;
    *) die "unknown option '$1' (see the head of $0)" ;;
  esac
  shift
done
[ -n "$out" ] || die "--out DIR is required (a folder outside the source tree)"
[ "$noise_limit" = none ] || [[ $noise_limit =~ ^[0-9]+(\.[0-9]+)?$ ]] || die "--noise-limit takes a number (1.10) or none"
mkdir -p "$out" && out=$(cd "$out" && pwd)
case $out/ in "$src"/*) die "--out $out lies inside the source tree $src: the tree would not stay clean" ;; esac
bench=${NNB_BENCH_DIR:-build/release/bench}

steps=(micro_nns registry checks quick scale icp_accuracy real_pairs icp_hints icp_no_hints icp_track icp_bucket icp_real paper_grid
       paper_grid_spatialindex real)
# The approximate adapter counted against brute force (results/reference/checks), model:query.
check_pairs=(hollow_sphere:hollow_cube hollow_cube:hollow_sphere filled_cube:hollow_sphere)
# The output of each step, as results/reference names it.
output_of() {
  case $1 in
    micro_nns) echo micro_nns/micro_nns.json ;;
    registry) echo registry/adapters.json ;;
    checks) echo "checks/pcl_octree_approx_${check_pairs[-1]/:/_}.json" ;;  # the last of its files
    icp_hints | icp_no_hints | icp_track) echo "hints/$1.json" ;;
    quick | scale | paper_grid | paper_grid_spatialindex | real) echo "sweep_$1.json" ;;
    *) echo "$1.json" ;;
  esac
}

# Where --install keeps STEP's unfinished file in this clone, compressed (a half grid is 50 MB of JSON).
pending_of() { local f; f=$(output_of "$1"); echo "$here/results/reference/pending/$(basename "${f%.json}").partial.json.gz"; }

grid_datasets() {
  local shapes=(hollow_sphere filled_sphere hollow_cube filled_cube) m q pairs=()
  for m in "${shapes[@]}"; do for q in "${shapes[@]}"; do pairs+=("$m:$q"); done; done
  (IFS=,; echo "${pairs[*]}")
}

# Every adapter of this build but the named ones, comma-separated.
adapters_but() {
  "$bench/nns_query" --list | cut -f1 | grep -vxF -f <(printf '%s\n' "$@") | paste -sd,
}

# The command of STEP into the array cmd; the paper grid at a 0.5 s budget (as written, with up to 100
# repetitions and a 10 s budget, it takes days here), libspatialindex in a file of its own. The sweeps time
# each cell in 3 rounds of one call, not 3 calls back to back, and micro_nns's repetitions are interleaved at
# random across all its benchmarks, so that a slow spell of the machine falls on both sides of a ratio rather
# than on one cell's calls in a row.
command_of() {
  local o
  o=$out/$(output_of "$1")
  local grid=(--experiment paper --datasets "$(grid_datasets)" --strategies default --repetitions 1 --rounds 3
              --budget 0.5)
  case $1 in
    micro_nns) cmd=("$bench/micro_nns" --benchmark_repetitions=7 --benchmark_min_time=0.2
                    --benchmark_enable_random_interleaving=true "--benchmark_out=$o" --benchmark_out_format=json) ;;
    registry) cmd=("$bench/nns_query" --list --json) ;;
    checks) cmd=("$bench/nns_query" --adapter pcl_octree_approx --search knn --k 1 --points 100000 --check
                 --out -) ;;  # run_checks adds each pair's --model, --query and --stats, and drops the answers
    icp_hints | icp_no_hints | icp_track) cmd=("$bench/run_icp" --experiment "$1" --out "$o") ;;
    quick | scale) cmd=("$bench/run_sweep" --experiment "$1" --out "$o") ;;
    icp_accuracy) cmd=("$bench/run_icp" --experiment icp_accuracy --out "$o") ;;
    real_pairs) cmd=("$bench/nns_query" --describe-real-pairs "$o") ;;
    icp_bucket) cmd=("$bench/run_icp" --experiment icp_bucket_coarse --out "$o") ;;
    icp_real) cmd=("$bench/run_icp" --experiment "$here/bench/experiments/icp_real.json"
                   --buckets-from "$out/icp_bucket.json" --out "$o") ;;
    paper_grid) cmd=("$bench/run_sweep" "${grid[@]}" --adapters
                     "$(adapters_but brute_force spatialindex_quadratic spatialindex_rstar)" --out "$o") ;;
    paper_grid_spatialindex)
      cmd=("$bench/run_sweep" "${grid[@]}" --adapters "spatialindex_quadratic,spatialindex_rstar" --out "$o") ;;
    real) cmd=("$bench/run_sweep" --experiment real --strategies default --repetitions 1 --rounds 3 --budget 1
               --out "$o") ;;
  esac
  if [ -f "$o" ] && [[ ! " micro_nns registry checks real_pairs " =~ " $1 " ]]; then cmd+=(--resume); fi
}

selected=("${steps[@]}")
if [ -n "$only" ]; then IFS=, read -r -a selected <<< "$only"; fi
for s in "${selected[@]}"; do [[ " ${steps[*]} " == *" $s "* ]] || die "unknown step '$s' (steps: ${steps[*]})"; done

if [ $install = 1 ]; then
  dest=$here/results/reference
  for s in "${steps[@]}"; do
    f=$(output_of "$s"); [ -f "$out/$f" ] || continue
    if [ -f "$out/.done/$s" ]; then
      mkdir -p "$(dirname "$dest/$f")"; cp "$out/$f" "$dest/$f"; rm -f "$(pending_of "$s")"
      [ "$s" = micro_nns ] && cp "$out/micro_nns/micro_nns.txt" "$dest/micro_nns/"
      [ "$s" = checks ] && cp "$out"/checks/*.json "$dest/checks/"
      echo "installed $f"
    else
      mkdir -p "$dest/pending"; gzip -9c "$out/$f" > "$(pending_of "$s")"
      echo "pending $f (unfinished; --from-pending resumes it)"
    fi
  done
  # The log keeps every run's lines: a later run of some steps (from a later commit) adds its own after
  # those of the run that made the other files, whose sittings provenance checks from them. A line already
  # there is the same event (see now), so installing a run twice adds nothing.
  if [ -f "$out/log.txt" ]; then
    touch "$dest/reference_run_log.txt"
    grep -vxF -f "$dest/reference_run_log.txt" "$out/log.txt" >> "$dest/reference_run_log.txt" || true
    echo "installed the log"
  fi
  exit 0
fi

if [ -n "$end_early" ]; then
  [[ " ${steps[*]} " == *" $end_early "* ]] || die "unknown step '$end_early' (steps: ${steps[*]})"
  [ -n "$reason" ] || die "--end-early needs --reason: the log says why the step stopped short"
  [ -f "$out/$(output_of "$end_early")" ] || die "$end_early has no file in $out to keep"
  [ ! -f "$out/.done/$end_early" ] || die "$end_early is already done"
  mkdir -p "$out/.done"
  echo "$(now) ended $end_early early, its file as it stands: $reason | load $(cut -d' ' -f1-3 /proc/loadavg)" \
    | tee -a "$out/log.txt"
  touch "$out/.done/$end_early"
  exit 0
fi

if [ $from_pending = 1 ]; then
  for s in "${selected[@]}"; do
    f=$(output_of "$s")
    if [ ! -f "$out/$f" ] && [ -f "$(pending_of "$s")" ]; then
      mkdir -p "$(dirname "$out/$f")"; gunzip -c "$(pending_of "$s")" > "$out/$f"; echo "resuming $f from $(pending_of "$s")"
    fi
  done
fi

cd "$src"
if [ $list = 1 ]; then
  for s in "${selected[@]}"; do
    command_of "$s"; state=to-do; [ -f "$out/.done/$s" ] && state="done"
    printf '%s\t%s\t%s\n' "$s" "$state" "$(quoted "${cmd[@]}")"
  done
  exit 0
fi

clean_commit() {
  [ -z "$(git status --porcelain)" ] || die "the tree $src has changes: a reference run comes from a clean commit"
  git rev-parse HEAD
}
commit=$(clean_commit)
if [ -f "$out/commit" ]; then
  [ "$(cat "$out/commit")" = "$commit" ] || die "$out holds a run from commit $(cat "$out/commit"), HEAD is $commit"
else
  echo "$commit" > "$out/commit"
fi
deadline=""
if [ -n "$until" ]; then deadline=$(date -d "$until" +%s) || die "--until '$until' is not a time"; fi

if [ $build = 1 ]; then
  ./scripts/install_deps.sh
  . scripts/anchors.sh
  . scripts/jobs.sh
  jobs=$(build_jobs)
  cmake --preset release
  cmake --build --preset release -j "${jobs}"
fi
# The binaries name the commit they were built from: a build older than HEAD would mislabel every file.
built=$("$bench/nns_query" --version 2>/dev/null | sed -n 's/.*(git \([^,]*\),.*/\1/p')
[ "$built" = "$commit" ] || die "$bench was built from ${built:-an unknown commit}, not the clean HEAD $commit: build it (or drop --no-build)"

log() { echo "$(now) $* | load $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/log.txt"; }

# The machine's timing noise (scripts/machine_noise.py), logged; before a sitting, a spread over the limit
# stops the run.
noise() {
  local line rc=0 limit=()
  if [ "$1" = before ] && [ "$noise_limit" != none ]; then limit=(--limit "$noise_limit"); fi
  line=$(/usr/bin/python3 "$here/scripts/machine_noise.py" --micro-nns "$bench/micro_nns" "${limit[@]}" 2>&1) || rc=$?
  log "noise $1: ${line:-no output}"
  if [ ${#limit[@]} -gt 0 ] && [ $rc != 0 ]; then
    [ $rc = 1 ] || die "the noise probe failed (--noise-limit none runs without its verdict): $line"
    die "the machine is noisy: ${line%% (*} above --noise-limit $noise_limit; wait for a quiet spell, or pass --noise-limit none (the log keeps the spread)"
  fi
}

run_micro_nns() {  # its JSON lacks the load and the tree state: a header and footer in micro_nns.txt say them
  mkdir -p "$out/micro_nns"
  {
    echo "# $(quoted "${cmd[@]}")"
    echo "# $("$bench/micro_nns" --version), tree clean; nothing else running"
    echo "# before: $(uptime)"
    "${cmd[@]}" 2>&1
    echo "# after: $(uptime)"
  } > "$out/micro_nns/micro_nns.txt"
}

run_registry() {  # written whole, then moved: a stopped step leaves no half file
  mkdir -p "$out/registry"
  "${cmd[@]}" > "$out/registry/adapters.json.tmp" && mv "$out/registry/adapters.json.tmp" "$out/registry/adapters.json"
}

run_checks() {
  local pair
  mkdir -p "$out/checks"
  for pair in "${check_pairs[@]}"; do
    "${cmd[@]}" --model "${pair%%:*}" --query "${pair##*:}" \
      --stats "$out/checks/pcl_octree_approx_${pair/:/_}.json" > /dev/null || return
  done
}

mkdir -p "$out/.done"
to_do=0
for s in "${selected[@]}"; do [ -f "$out/.done/$s" ] || to_do=1; done
[ $to_do = 0 ] || noise before
for s in "${selected[@]}"; do
  [ -f "$out/.done/$s" ] && continue
  [ "$(clean_commit)" = "$commit" ] || die "HEAD moved during the run"
  left=""
  if [ -n "$deadline" ]; then
    left=$((deadline - $(date +%s)))
    if [ "$left" -le 0 ]; then log "stop before $s (--until $until)"; noise after; exit 0; fi
  fi
  command_of "$s"
  mkdir -p "$(dirname "$out/$(output_of "$s")")"
  log "start $s at $(git rev-parse --short HEAD), tree clean: $(quoted "${cmd[@]}")"
  rc=0
  if [ "$s" = micro_nns ]; then
    run_micro_nns || rc=$?
  elif [ "$s" = registry ] || [ "$s" = checks ]; then
    "run_$s" 2> "$out/$s.stderr" || rc=$?
  elif [ -n "$left" ]; then
    timeout --signal=TERM "$left" "${cmd[@]}" > "$out/$s.stdout" 2> "$out/$s.stderr" || rc=$?
  else
    "${cmd[@]}" > "$out/$s.stdout" 2> "$out/$s.stderr" || rc=$?
  fi
  log "end $s rc=$rc"
  # The step's own repetitions say how steady the machine was while it ran (a probe sees seconds of it).
  if [ "$s" = micro_nns ] && [ $rc = 0 ]; then
    log "noise in micro_nns: $(/usr/bin/python3 "$here/scripts/machine_noise.py" --results "$out/$(output_of micro_nns)" 2>&1)"
  fi
  if [ $rc != 0 ]; then
    [ $rc = 124 ] && { log "stopped $s at --until $until; rerun to resume it"; noise after; exit 0; }
    echo "reference_run: $s failed (exit $rc); its stderr: $out/$s.stderr" >&2; exit 1
  fi
  touch "$out/.done/$s"
done
[ $to_do = 0 ] || noise after
log "all steps done"
