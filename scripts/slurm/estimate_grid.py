#!/usr/bin/env python3
"""How long the paper's grid takes on a cluster, from the measured cost of its cells.

    scripts/slurm/estimate_grid.py build/release/bench/run_sweep [--nodes 1,8,16,32,64] [REFERENCE.json ...]

For each node count N it asks run_sweep for the plan of `--experiment paper --shard 0/N` (one shard a node,
one CPU each) and prices every (model, adapter) unit with the reference runs (default
results/reference/sweep_paper_grid*.json, 3 repetitions and a 0.5 s budget, then sweep_quick.json for
brute force): a cell costs its measured
median call time x its repetitions (up to 100, as many as fit in the experiment's min_time_seconds), a build
its median x build_repetitions (5). Cells the
reference skipped over its budget take the last time measured in their sweep (a lower bound: calls grow
with the distance) until that passes the experiment's budget (10 s), after which one call ends the sweep.
Units the reference lacks (libspatialindex past the first models, the real pairs) take their adapter's
measured seconds per query point and cell (and per model point for brute force). Prints the
hours of the slowest shard per N, which is the wall time of the job array with N nodes free at once.
"""
import argparse
import json
import math
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "plots"))

import results_io  # noqa: E402


def plan_for(run_sweep, nodes):
    out = subprocess.run([run_sweep, "--experiment", "paper", "--plan", "--json", "--shard", f"0/{nodes}"],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def experiment_settings():
    e = json.loads((REPO / "bench" / "experiments" / "paper.json").read_text())
    return Repetitions(e["repetitions"], e.get("min_time_seconds", 0)), e["build_repetitions"], e["budget_seconds"]


class Repetitions:
    """How many calls run_sweep makes of a cell whose call takes `seconds`: all of them, or with a minimum
    time, until the calls took that long together."""
    def __init__(self, most, min_time_s):
        self.most, self.min_time_s = most, min_time_s

    def of(self, seconds):
        if self.min_time_s <= 0 or seconds <= 0:
            return self.most
        return min(self.most, max(1, math.ceil(self.min_time_s / seconds)))

    def __str__(self):
        return f"up to {self.most}" + (f" (until {self.min_time_s:g} s)" if self.min_time_s > 0 else "")


def measured_cells(files):
    """Cell name -> its record (the median aggregate when repetitions are records), the first file that has
    the cell winning."""
    cells = {}
    for path in files:
        records = json.loads(Path(path).read_text())["benchmarks"]
        for rec in results_io.one_record_per_cell(records):
            cells.setdefault(results_io.run_name(rec), rec)
    return cells


def sweep_of(name):
    """The sweep a cell belongs to (its name without the distance)."""
    return name.rsplit("/", 1)[0] if "/max_dist:" in name else name


def unit_seconds(cells, measured, repetitions, build_repetitions, budget):
    """Seconds to run a unit's cells, or None when the reference did not measure it."""
    if not any(name in measured and "skipped" not in measured[name] for name in cells):
        return None
    total, last, closed = 0.0, {}, set()
    for name in cells:  # in run order: increasing distance within a sweep
        rec, sweep = measured.get(name), sweep_of(name)
        if sweep in closed:
            continue
        if rec is not None and "skipped" not in rec:
            seconds = rec["median_s"]
            last[sweep] = seconds
        elif sweep in last:
            seconds = last[sweep]
        else:
            continue
        if name.startswith("build/"):
            total += seconds * build_repetitions
        elif seconds > budget:
            total += seconds
            closed.add(sweep)
        else:
            total += seconds * repetitions.of(seconds)
    return total


def data_sizes():
    """Points of each model and query by spec (synthetic: the experiment's; real pairs: the manifest's)."""
    synthetic = json.loads((REPO / "bench" / "experiments" / "paper.json").read_text())["synthetic_points"]
    models, queries = {}, {}
    for pair in json.loads((REPO / "datasets" / "manifest.json").read_text())["pairs"]:
        models[pair["name"]], queries[pair["name"]] = pair["model"]["points"], pair["query"]["points"]
    return models, queries, synthetic


def estimate(plan, unit_cells, measured, settings, sizes):
    """Seconds per unit and the number of units not measured. An unmeasured unit takes its adapter's median
    measured seconds per query point and cell (per model point too for brute force) on the other data."""
    models, queries, synthetic = sizes
    def work(unit, cells):
        n = sum(queries.get(c.split("/")[2], synthetic) for c in cells if c.startswith("sweep/"))
        return n * (models.get(unit["model"], synthetic) if unit["adapter"] == "brute_force" else 1)
    seconds = [unit_seconds(cells, measured, *settings) for cells in unit_cells]
    rates = {}
    for s, u, cells in zip(seconds, plan["units"], unit_cells):
        if s is not None:
            rates.setdefault(u["adapter"], []).append(s / work(u, cells))
    per_cost = statistics.median(s / u["cost"] for s, u in zip(seconds, plan["units"]) if s is not None)
    def guess(u, cells):
        return statistics.median(rates[u["adapter"]]) * work(u, cells) if u["adapter"] in rates else u["cost"] * per_cost
    estimated = [s if s is not None else guess(u, cells) for s, u, cells in zip(seconds, plan["units"], unit_cells)]
    return estimated, sum(s is None for s in seconds)


def unit_cells(plan):
    """The cell names of each unit: a one-shard plan lists every cell, unit after unit."""
    result, start = [], 0
    for u in plan["units"]:
        result.append(plan["cells"][start:start + u["cells"]])
        start += u["cells"]
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_sweep")
    parser.add_argument("reference", nargs="*",
                        default=sorted(str(p) for p in (REPO / "results" / "reference").glob("sweep_paper_grid*.json"))
                        + [str(REPO / "results" / "reference" / "sweep_quick.json")])
    parser.add_argument("--nodes", default="1,8,16,32,64")
    args = parser.parse_args()
    settings = experiment_settings()
    measured = measured_cells(args.reference)
    print(f"paper grid: {settings[0]} repetitions, {settings[1]} builds, budget {settings[2]} s; "
          f"cell times from {', '.join(Path(p).name for p in args.reference)}")
    print("nodes  units  scaled  total CPU h  slowest shard h  largest unit h")
    cells = unit_cells(plan_for(args.run_sweep, 1))  # the same units, in the same order, for every N
    sizes = data_sizes()
    for nodes in [int(n) for n in args.nodes.split(",")]:
        plan = plan_for(args.run_sweep, nodes)
        seconds, scaled = estimate(plan, cells, measured, settings, sizes)
        per_shard = [0.0] * nodes
        for s, u in zip(seconds, plan["units"]):
            per_shard[u["shard"]] += s
        print(f"{nodes:5d}  {len(seconds):5d}  {scaled:6d}  {sum(seconds) / 3600:11.1f}  {max(per_shard) / 3600:15.1f}"
              f"  {max(seconds) / 3600:14.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
