#!/usr/bin/env bash
# The README's main command: install the dependencies, build Release, run the default experiment
# (`quick`: the paper's Figure 3 pair with every adapter, plus construction costs) and regenerate the
# figures and findings from its results.
#   EXPERIMENT=paper scripts/run_main.sh   runs another experiment (bench/experiments/*.json)
#   RESUME=1 scripts/run_main.sh           finishes a killed run instead of starting afresh
set -euo pipefail
if [ $# -gt 0 ]; then
  echo "run_main: error: no arguments taken ('$1'); settings are environment variables, see the head of $0" >&2
  exit 2
fi
cd "$(dirname "$0")/.."
experiment="${EXPERIMENT:-quick}"
./scripts/install_deps.sh
. scripts/anchors.sh
. scripts/jobs.sh
jobs=$(build_jobs)
cmake --preset release
cmake --build --preset release -j "${jobs}"

out="results/sweep_${experiment}.json"
resume=()
if [ "${RESUME:-0}" = 1 ] && [ -f "${out}" ]; then resume=(--resume); fi
build/release/bench/run_sweep --experiment "${experiment}" --out "${out}" "${resume[@]}"

# A run from a modified tree is still plotted, marked "not a clean run" on every output.
plot_flags=(--allow-dirty)
/usr/bin/python3 plots/make_figures.py "${out}" --out "results/figures/${experiment}" "${plot_flags[@]}"
/usr/bin/python3 plots/findings.py "${out}" --out "results/figures/${experiment}/FINDINGS.md" "${plot_flags[@]}"
/usr/bin/python3 plots/report.py "${out}" --out "results/figures/${experiment}" "${plot_flags[@]}"
echo "main: results in ${out}, figures and findings in results/figures/${experiment}/"
echo "main: interactive report: results/figures/${experiment}/report.html"
