#!/usr/bin/env bash
# A real Slurm on this machine: starts munged, slurmctld and slurmd (Debian's slurm-wlm and munge) with a
# private configuration, key, ports and state; submits a small sweep with scripts/slurm/submit.sh as a job
# array of 4 shards; cancels the shard holding brute force mid-run and resubmits it, which must resume its
# file; checks the merged file has exactly the cells of a single-process run, with the same found counts. Then
# a small ICP experiment as a job array of 2 shards (submit.sh --program run_icp, run_icp beside run_sweep),
# merged to the runs of a single process with the same poses.
# Every daemon it started is stopped and its state removed on exit, also when it fails.
#
# Any user can run it: the daemons run as that user (munged as munge when it is root), and jobs run as it.
#
#   tests/slurm/test_slurm.sh RUN_SWEEP WORKDIR
set -euo pipefail

[ $# -eq 2 ] || { echo "usage: $0 RUN_SWEEP WORKDIR" >&2; exit 2; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
run_sweep=$(realpath "$1")
run_icp="$(dirname "${run_sweep}")/run_icp"
build=$(dirname "$(dirname "${run_sweep}")")
work=$(realpath -m "$2")
state=""      # the daemons' configuration, key, sockets, spool and logs (made below, removed on exit)
results="${work}/results"
shards=4
pids=()       # slurmctld and slurmd
munge_pid=""
watchdog=""    # the subshell that ends a run past its time

fail() {
  echo "test_slurm: FAIL: $*" >&2
  exit 1
}
# The daemons live in /usr/sbin, which an ordinary user's PATH may lack.
daemon() {
  command -v "$1" || { [ -x "/usr/sbin/$1" ] && echo "/usr/sbin/$1"; } ||
    fail "$1 not found: install slurm-wlm and munge (scripts/install_deps.sh)"
}
munged=$(daemon munged)
slurmctld=$(daemon slurmctld)
slurmd=$(daemon slurmd)
for tool in sbatch squeue scancel sinfo; do daemon "${tool}" > /dev/null; done
user=$(id -un)

show_logs() {
  for log in "${state}"/*.log "${state}"/munge/*.log "${results}"/logs/*.log; do
    [ -f "${log}" ] && { echo "--- ${log}"; tail -n 20 "${log}"; }
  done
}

# Stops by PID, SIGTERM then SIGKILL after 5 s.
stop_pid() {
  local pid=$1
  kill -TERM "${pid}" 2>/dev/null || return 0
  for _ in $(seq 50); do kill -0 "${pid}" 2>/dev/null || return 0; sleep 0.1; done
  kill -KILL "${pid}" 2>/dev/null || true
}

# Processes of our jobs carry our SLURM_CONF in their environment: found by it, not by a name.
stop_job_processes() {
  local environ pid
  for environ in /proc/[0-9]*/environ; do
    pid=${environ#/proc/}
    pid=${pid%/environ}
    [ "${pid}" = $$ ] || [[ " ${pids[*]} " == *" ${pid} "* ]] && continue
    { tr '\0' '\n' < "${environ}"; } 2>/dev/null | grep -qx "SLURM_CONF=${state}/slurm.conf" && stop_pid "${pid}"
  done
  return 0
}

cleanup() {
  local status=$?
  trap - EXIT
  set +e  # every step runs: a failed one (show_logs ends on a missing log) must not leave the daemons running
  [ -z "${watchdog}" ] || kill "${watchdog}" 2>/dev/null || true
  if [ -f "${state}/slurm.conf" ]; then
    scancel --full --quiet --user "${user}" 2>/dev/null || true
    for _ in $(seq 50); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.1; done
    stop_job_processes
  fi
  [ "${status}" -ne 0 ] && show_logs
  local pid
  for pid in "${pids[@]}"; do stop_pid "${pid}"; done  # slurmctld, slurmd, then munged
  [ -n "${munge_pid}" ] && stop_pid "${munge_pid}"
  [ -f "${state}/munge/munged.pid" ] && stop_pid "$(cat "${state}/munge/munged.pid")"
  rm -rf "${state}"
  [ "${status}" -eq 0 ] && rm -rf "${work}"
  exit "${status}"
}
trap cleanup EXIT
# A short folder of their own, whatever folder the build is in: slurm.conf's values end at a space, and a
# socket's path at 107 bytes.
state=$(mktemp -d /tmp/nnb-slurm.XXXXXX)
chmod 0755 "${state}"   # munged runs as munge
trap 'exit 130' INT TERM
# ctest ends a test past its time-out with SIGKILL, which no trap sees: give up first, and clean up.
watchdog_seconds=${NNB_SLURM_TEST_SECONDS:-780}
( sleep "${watchdog_seconds}" </dev/null >/dev/null 2>&1 &
  sleeper=$!
  trap 'kill "${sleeper}" 2>/dev/null; exit 0' TERM
  wait "${sleeper}"
  echo "test_slurm: FAIL: not done after ${watchdog_seconds} s" >&2
  kill -TERM $$; pkill -TERM -P $$ ) &
watchdog=$!

# Waits until COMMAND prints nothing (e.g. squeue of a finished job); fails after SECONDS.
wait_empty() {
  local seconds=$1 what=$2
  shift 2
  local deadline=$((SECONDS + seconds))
  while [ -n "$("$@" 2>/dev/null)" ]; do
    [ ${SECONDS} -lt ${deadline} ] || { squeue; fail "${what}: not done after ${seconds} s"; }
    sleep 0.2
  done
}

# munged refuses a key others can read, and root runs it as Debian's munge user.
start_munge() {
  local as_user=()
  install -d -m 0755 "${state}/munge"
  head -c 1024 /dev/urandom > "${state}/munge/munge.key"
  chmod 0400 "${state}/munge/munge.key"
  if [ "$(id -u)" -eq 0 ]; then
    chown -R munge:munge "${state}/munge"
    as_user=(runuser -u munge --)
  fi
  setsid "${as_user[@]}" "${munged}" -F --socket="${state}/munge/munge.socket" \
    --key-file="${state}/munge/munge.key" --pid-file="${state}/munge/munged.pid" --log-file="${state}/munge/munged.log" \
    --seed-file="${state}/munge/munged.seed" &
  munge_pid=$!
  for _ in $(seq 50); do munge -n --socket="${state}/munge/munge.socket" 2>/dev/null |
    unmunge --socket="${state}/munge/munge.socket" >/dev/null 2>&1 && return 0; sleep 0.1; done
  fail "munged did not answer"
}

write_slurm_conf() {
  local node cpus memory
  node=$(hostname -s)
  cpus=$("${slurmd}" -C | sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' | head -n 1)
  memory=$("${slurmd}" -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -n 1)
  [ "${memory}" -gt 2000 ] && memory=2000
  mkdir -p "${state}/ctld" "${state}/spool"
  # Another Slurm on this machine would leave our daemons unreachable until the time-out: say so at once.
  python3 -c 'import socket,sys
for port in (16817, 16818):
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try: s.bind(("127.0.0.1", port))
        except OSError: sys.exit(f"port {port} is taken: another Slurm is running here")' || fail "ports 16817-16818 are not free"
  cat > "${state}/slurm.conf" <<EOF
ClusterName=nnbtest
SlurmctldHost=localhost
SlurmUser=${user}
SlurmdUser=${user}
AuthType=auth/munge
AuthInfo=socket=${state}/munge/munge.socket
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=${state}/ctld
SlurmdSpoolDir=${state}/spool
SlurmctldPidFile=${state}/slurmctld.pid
SlurmdPidFile=${state}/slurmd.pid
SlurmctldLogFile=${state}/slurmctld.log
SlurmdLogFile=${state}/slurmd.log
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
KillWait=5
SchedulerParameters=sched_interval=1
NodeName=${node} CPUs=${cpus} RealMemory=${memory} State=UNKNOWN
PartitionName=debug Nodes=${node} Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="${state}/slurm.conf"
  # This test is about Slurm: a developer's modified tree still gets its figures (provenance has its own tests).
  export NNB_PLOT_FLAGS=--allow-dirty
}

start_slurm() {
  setsid "${slurmctld}" -D -f "${SLURM_CONF}" &
  pids+=($!)
  setsid "${slurmd}" -D -f "${SLURM_CONF}" &
  pids+=($!)
  local deadline=$((SECONDS + 30))
  until sinfo -h -o %T 2>/dev/null | grep -qx idle; do
    # A daemon that refused its configuration exits at once; sinfo would wait on it for a minute a call.
    kill -0 "${pids[-2]}" 2>/dev/null || fail "slurmctld exited (its stderr above, its log below)"
    kill -0 "${pids[-1]}" 2>/dev/null || fail "slurmd exited (its stderr above, its log below)"
    [ ${SECONDS} -lt ${deadline} ] || fail "the node did not become idle: $(sinfo 2>&1)"
    sleep 0.2
  done
}

# A small sweep, slow enough in brute force (many repetitions) to be cancelled mid-run.
write_experiment() {
  cat > "${work}/slurm_test.json" <<'EOF'
{
  "name": "slurm_test",
  "description": "Test of the Slurm job array: three adapters, two pairs, small clouds, many repetitions.",
  "pairs": [{"model": "hollow_sphere", "query": "hollow_cube"}, {"model": "filled_cube", "query": "filled_cube"}],
  "adapters": ["brute_force", "nanoflann_kdtree", "ours_kdtree"],
  "searches": ["ranged", "knn", "radius"],
  "k": [1],
  "dists": "0:0.3:0.1",
  "repetitions": 60,
  "build_repetitions": 1,
  "budget_seconds": 10,
  "min_time_seconds": 0,
  "neighbour_budget": 5000000,
  "synthetic_points": 2000,
  "seed": 1
}
EOF
}

# ICP on a simulated pair it really moves and a small shape; brute force on every 8th query point only.
write_icp_experiment() {
  cat > "${work}/slurm_icp.json" <<'EOF'
{
  "name": "slurm_icp",
  "description": "Test of run_icp as a Slurm job array: three adapters, two pairs, two repetitions.",
  "pairs": ["city-tls-15k", "hollow_sphere"],
  "adapters": ["brute_force", "nanoflann_kdtree", "ours_kdtree"],
  "icp": {"max_dist_m": 0.5, "iterations": 10},
  "icp_by_pair": {"city-tls-15k": {"query_stride": 8}},
  "repetitions": 2
}
EOF
}

json_count() {  # number of cells in a results file (0 when absent or half written)
  python3 -c 'import json,sys
try: print(len({r.get("run_name") or r["name"] for r in json.load(open(sys.argv[1]))["benchmarks"]}))
except Exception: print(0)' "$1"
}

submit() {
  "${repo}/scripts/slurm/submit.sh" "${work}/slurm_test.json" "${shards}" --mem 400M --time 10 \
    --out-dir "${results}" --build "${build}" "$@" > "${work}/submit.out"
  sed -n 's/^array=//p' "${work}/submit.out"
}

rm -rf "${work}"
mkdir -p "${state}" "${results}"
write_experiment
experiment="${work}/slurm_test.json"

echo "test_slurm: single-process run"
"${run_sweep}" --experiment "${experiment}" --out "${work}/whole.json" 2> "${work}/whole.log" ||
  fail "the single-process run failed: $(tail -n 5 "${work}/whole.log")"

# The shard holding brute force on the first model is the one cancelled.
victim=$("${run_sweep}" --experiment "${experiment}" --plan --json --shard "0/${shards}" |
  python3 -c 'import json,sys
print(next(u["shard"] for u in json.load(sys.stdin)["units"] if u["adapter"] == "brute_force"))')
victim_file="${results}/sweep_slurm_test.shard-${victim}-of-${shards}.json"

echo "test_slurm: starting munged, slurmctld, slurmd"
start_munge
write_slurm_conf
start_slurm

echo "test_slurm: submitting ${shards} shards"
array=$(submit)
[ -n "${array}" ] || fail "submit.sh printed no job id: $(cat "${work}/submit.out")"

deadline=$((SECONDS + 60))
until [ "$(json_count "${victim_file}")" -ge 2 ]; do
  [ ${SECONDS} -lt ${deadline} ] || fail "shard ${victim} recorded nothing in 60 s"
  sleep 0.1
done
scancel "${array}_${victim}"
wait_empty 60 "cancelled shard ${victim}" squeue -h -j "${array}_${victim}"
cp "${victim_file}" "${work}/partial.json"
partial=$(json_count "${work}/partial.json")
wanted=$("${run_sweep}" --experiment "${experiment}" --plan --json --shard "${victim}/${shards}" |
  python3 -c 'import json,sys; print(len(json.load(sys.stdin)["cells"]))')
echo "test_slurm: shard ${victim} cancelled with ${partial} of ${wanted} cells recorded"
[ "${partial}" -lt "${wanted}" ] || fail "shard ${victim} finished before it was cancelled (make it slower)"
wait_empty 120 "job array ${array}" squeue -h -j "${array}"

echo "test_slurm: resubmitting shard ${victim}"
again=$(submit --array "${victim}")
wait_empty 120 "resubmitted shard ${victim}" squeue -h -j "${again}"
wait_empty 60 "merge jobs" squeue -h
grep -q "merge.sbatch: done" "${results}"/logs/nnb-slurm_test-merge-*.log || fail "no merge job finished"
[ -s "${results}/figures/slurm_test/FINDINGS.md" ] || fail "the merge job made no findings"

python3 - "${work}" "${victim_file}" "${results}/sweep_slurm_test.json" <<'EOF' || fail "results differ (above)"
import json, sys
work, victim, merged = sys.argv[1:]
load = lambda p: json.load(open(p))
whole, partial, resumed, merged = load(f"{work}/whole.json"), load(f"{work}/partial.json"), load(victim), load(merged)
problems = []
def by_cell(doc):  # a cell's records (its repetitions and aggregates) by its run_name, in file order
    cells = {}
    for r in doc["benchmarks"]:
        cells.setdefault(r.get("run_name") or r["name"], []).append(r)
    return cells
kept = by_cell(resumed)
problems += [f"{name}: redone or changed on resume" for name, recs in by_cell(partial).items() if kept.get(name) != recs]
if len(resumed["context"].get("resumed", [])) != 1:
    problems.append("the resubmitted shard did not resume its file")
names = lambda doc: list(by_cell(doc))
if names(merged) != names(whole):
    problems.append(f"merged cells differ from the single run's: {sorted(set(names(merged)) ^ set(names(whole)))[:10]}")
found = {r["name"]: r.get("found") for r in whole["benchmarks"] if "found" in r}
problems += [f"{r['name']}: found {r.get('found')} != {found.get(r['name'])}" for r in merged["benchmarks"]
             if "found" in r and r.get("found") != found.get(r["name"])]
if [m["shard"] for m in merged["context"]["merged_from"]] != [f"{i}/4" for i in range(4)]:
    problems.append("merged_from does not list the 4 shards")
for p in problems[:20]:
    print("  " + p, file=sys.stderr)
sys.exit(1 if problems else 0)
EOF

echo "test_slurm: an ICP experiment as a job array of 2 shards"
write_icp_experiment
"${run_icp}" --experiment "${work}/slurm_icp.json" --points 500 --out "${work}/icp_whole.json" \
  > "${work}/icp_whole.log" 2>&1 || fail "the single-process ICP run failed: $(tail -n 5 "${work}/icp_whole.log")"
"${repo}/scripts/slurm/submit.sh" "${work}/slurm_icp.json" 2 --program run_icp --mem 400M --time 10 \
  --out-dir "${results}" --build "${build}" --no-figures -- --points 500 > "${work}/submit_icp.out"
icp_array=$(sed -n 's/^array=//p' "${work}/submit_icp.out")
[ -n "${icp_array}" ] || fail "submit.sh --program run_icp printed no job id: $(cat "${work}/submit_icp.out")"
wait_empty 120 "ICP job array ${icp_array} and its merge" squeue -h
grep -q "merge.sbatch: done" "${results}"/logs/nnb-slurm_icp-merge-*.log || fail "no ICP merge job finished"
python3 - "${work}/icp_whole.json" "${results}/slurm_icp.json" <<'EOF' || fail "ICP results differ (above)"
import json, sys
whole, merged = (json.load(open(p)) for p in sys.argv[1:])
runs = lambda doc: [(r["name"], r["repetition_index"], r["iterations"], r["converged"], r["final_pose"])
                    for r in doc["benchmarks"]]
if runs(merged) != runs(whole) or len(merged["context"]["merged_from"]) != 2:
    print(f"  merged {runs(merged)[:4]}...\n  whole  {runs(whole)[:4]}...", file=sys.stderr)
    sys.exit(1)
EOF
echo "test_slurm: ok: ${shards} shards under Slurm merged to the single run's cells; the cancelled shard resumed;" \
  "an ICP experiment's 2 shards merged to the single run's"
