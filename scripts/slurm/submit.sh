#!/usr/bin/env bash
# Runs an experiment on a Slurm cluster: a job array of N shards (one CPU each) and a job that, after all
# of them (afterany), merges their files and makes the figures and findings.
#
#   scripts/slurm/submit.sh EXPERIMENT N [--program run_sweep|run_icp] [--partition P] [--time T] [--account A]
#                           [--mem M] [--array LIST] [--out-dir DIR] [--build DIR] [--data-dir DIR]
#                           [--no-figures] [-- PROGRAM_FLAGS...]
#
# EXPERIMENT: a name in bench/experiments/ or a JSON file; --program: the program that runs it (default
# run_sweep; run_icp for the icp_* experiments), writing sweep_EXPERIMENT.json or EXPERIMENT.json. --mem:
# memory per shard (default 12G: run_sweep's 8 GiB build limit, the data and the answers); --time: per
# shard (default 1-00:00:00); --array: only these shards (e.g. 3 or 2,5), to resubmit them: each resumes
# its file; --out-dir: results on the shared file system (default results/ of this clone); --build: the
# build folder holding bench/PROGRAM (default build/release). Everything must be on a file system the
# compute nodes share. Prints the plan, then "array=JOBID" and "merge=JOBID".
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
usage() { sed -n '2,17p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 2 ] || usage
experiment=$1 shards=$2
shift 2
[[ "${shards}" =~ ^[1-9][0-9]*$ ]] || { echo "submit.sh: N must be a whole number >= 1, not '${shards}'" >&2; exit 2; }

program=run_sweep partition="" time_limit="1-00:00:00" account="" mem="12G" array="0-$((shards - 1))"
out_dir="${repo}/results" build="${repo}/build/release" data_dir="" figures=1 extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --program) program=$2; shift 2 ;;
    --partition) partition=$2; shift 2 ;;
    --time) time_limit=$2; shift 2 ;;
    --account) account=$2; shift 2 ;;
    --mem) mem=$2; shift 2 ;;
    --array) array=$2; shift 2 ;;
    --out-dir) out_dir=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --data-dir) data_dir=$2; shift 2 ;;
    --no-figures) figures=0; shift ;;
    --) shift; extra=("$@"); break ;;
    *) echo "submit.sh: unknown option '$1'" >&2; usage ;;
  esac
done

case "${program}" in
  run_sweep | run_icp) ;;
  *) echo "submit.sh: --program must be run_sweep or run_icp, not '${program}'" >&2; exit 2 ;;
esac
binary="$(cd "${build}" && pwd)/bench/${program}"
[ -x "${binary}" ] || { echo "submit.sh: no ${binary}: build the project first (cmake --build)" >&2; exit 2; }
name=$(basename "${experiment}" .json)  # an experiment file's name names the results files
mkdir -p "${out_dir}/logs"
out_dir=$(cd "${out_dir}" && pwd)
results="${out_dir}/${name}"  # the results files' path without ".json", as each program names its own
[ "${program}" = run_sweep ] && results="${out_dir}/sweep_${name}"

# The plan on the submitting node: a bad experiment or missing data fails here, not in N tasks.
"${binary}" --experiment "${experiment}" --shard "0/${shards}" --plan ${data_dir:+--data-dir "${data_dir}"} \
  "${extra[@]}"

common=(--parsable --kill-on-invalid-dep=yes)
[ -n "${partition}" ] && common+=(--partition "${partition}")
[ -n "${account}" ] && common+=(--account "${account}")
export NNB_REPO="${repo}" NNB_PROGRAM="${binary}" NNB_EXPERIMENT="${experiment}" NNB_NAME="${name}" \
  NNB_SHARDS="${shards}" NNB_OUT_DIR="${out_dir}" NNB_RESULTS="${results}" NNB_DATA_DIR="${data_dir}" \
  NNB_PROGRAM_ARGS="${extra[*]:-}" NNB_FIGURES="${figures}"

array_job=$(sbatch "${common[@]}" --array "${array}" --mem "${mem}" --time "${time_limit}" \
  --job-name "nnb-${name}" --output "${out_dir}/logs/%x-%A_%a.log" --export ALL \
  "${repo}/scripts/slurm/sweep.sbatch")
array_job=${array_job%%;*}
merge_job=$(sbatch "${common[@]}" --dependency "afterany:${array_job}" --mem "${mem}" --time 1:00:00 \
  --job-name "nnb-${name}-merge" --output "${out_dir}/logs/%x-%j.log" --export ALL \
  "${repo}/scripts/slurm/merge.sbatch")
merge_job=${merge_job%%;*}
echo "submit.sh: shards ${array} of ${shards}: job array ${array_job}, then merge job ${merge_job}" \
  "(logs in ${out_dir}/logs)"
echo "array=${array_job}"
echo "merge=${merge_job}"
