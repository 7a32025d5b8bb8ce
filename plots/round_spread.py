#!/usr/bin/env python3
"""How a cell's time moves between rounds and within one: python3 plots/round_spread.py FILE.json.

A run_sweep file made with --rounds R (R >= 2) holds, for each timed cell, R rounds of `repetitions` calls in
the order timed: within a round the calls ran back to back, between rounds a whole pass over the plan lay
between them. Per cell: the spread within rounds (the median over its rounds of a round's slowest call over
its fastest) and between rounds (the slowest round's median over the fastest's). Per adapter: their geometric
means, the cells that moved more between rounds than within, how far the first round's median alone (what a
run of one round reports) lay from the median of all the cell's calls, and which round was the slowest (a
warm-up shows as the first, slow spells of the machine fall on any). --first-round N lists the N cells whose first
round lay farthest from all their calls, with each round's median; --budget-cuts the series that a call over the
time budget ended on a cell whose calls' median lies within it (the call that ended it was an outlier)."""
import argparse
import json
import math
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import results_io  # noqa: E402


def cell_rounds(doc):
    """{(adapter, cell name): [[seconds of each call] per round]} of the cells that hold every round in full."""
    config = (doc.get("context") or {}).get("config") or {}
    rounds, per_round = config.get("rounds", 1), config.get("repetitions")
    if not isinstance(rounds, int) or rounds < 2 or not isinstance(per_round, int):
        raise ValueError("not a run of two rounds or more (context.config.rounds)")
    calls = {}
    for rec in doc.get("benchmarks", []):
        if rec.get("type") != "sweep" or rec.get("run_type") != "iteration" or results_io._skip_reason(rec):
            continue
        seconds = results_io.record_seconds(rec, ())
        if seconds is not None:
            calls.setdefault((rec.get("adapter"), results_io.run_name(rec)), []).append(
                (rec.get("repetition_index", 0), seconds))
    cells = {}
    for key, timed in calls.items():
        times = [t for _, t in sorted(timed)]
        if len(times) == rounds * per_round:  # fewer: --min-time cut some round short
            cells[key] = [times[i * per_round:(i + 1) * per_round] for i in range(rounds)]
    return cells


def spreads(rounds):
    """(within, between, first round's median over all calls' median, slowest round from 0) of one cell."""
    within = results_io._median([max(r) / min(r) for r in rounds])
    medians = [results_io._median(r) for r in rounds]
    every = results_io._median([t for r in rounds for t in r])
    return within, max(medians) / min(medians), medians[0] / every, medians.index(max(medians))


def geomean(values):
    return math.exp(sum(math.log(v) for v in values) / len(values))


def summary(cells):
    """[(adapter, cells, within, between, cells moving more between than within, cells whose first round
    lay over 10 % from all, the largest such distance, [cells whose slowest round was each round])],
    adapters sorted, then 'all'."""
    by_adapter = {}
    for (adapter, _), rounds in cells.items():
        by_adapter.setdefault(adapter, []).append(spreads(rounds))
    n_rounds = len(next(iter(cells.values())))
    rows = []
    for adapter in sorted(by_adapter) + ["all"]:
        stats = [s for a in by_adapter for s in by_adapter[a]] if adapter == "all" else by_adapter[adapter]
        off = [max(f, 1 / f) for _, _, f, _ in stats]
        slowest = [sum(s[3] == i for s in stats) for i in range(n_rounds)]
        rows.append((adapter, len(stats), geomean([s[0] for s in stats]), geomean([s[1] for s in stats]),
                     sum(s[1] > s[0] for s in stats), sum(o > 1.1 for o in off), max(off), slowest))
    return rows


def first_round_outliers(cells, n):
    """[(first round's median over all calls' median, adapter, cell name, [each round's median])] of the n cells
    whose first round lay farthest from all their calls (either way), farthest first."""
    rows = []
    for (adapter, name), rounds in cells.items():
        offset = spreads(rounds)[2]
        rows.append((offset, adapter, name, [results_io._median(r) for r in rounds]))
    rows.sort(key=lambda r: (-max(r[0], 1 / r[0]), r[1], r[2]))
    return rows[:n]


CUT = re.compile(r"^over budget: \S+ s at max_dist (\S+) > \S+ s$")


def budget_cuts(doc):
    """(series ended over the time budget, [(cutting cell, its calls' median s, its calls)] of those whose
    cutting cell's median lies within the budget), the cells sorted."""
    budget = ((doc.get("context") or {}).get("config") or {}).get("budget_seconds")
    if not isinstance(budget, (int, float)):
        raise ValueError("no time budget (context.config.budget_seconds)")
    cutting, calls = set(), {}
    for rec in doc.get("benchmarks", []):
        if rec.get("type") != "sweep":
            continue
        name = results_io.run_name(rec)
        match = CUT.match(str(results_io._skip_reason(rec) or ""))
        if match and "max_dist:" in name:
            cutting.add(name.rsplit("max_dist:", 1)[0] + "max_dist:" + match.group(1))
        elif rec.get("run_type") == "iteration" and not results_io._skip_reason(rec):
            seconds = results_io.record_seconds(rec, ())
            if seconds is not None:
                calls.setdefault(name, []).append(seconds)
    within = [(name, results_io._median(calls[name]), len(calls[name])) for name in sorted(cutting)
              if calls.get(name) and results_io._median(calls[name]) <= budget]
    return len(cutting), within


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", help="a run_sweep results file made with --rounds 2 or more")
    parser.add_argument("--first-round", type=int, default=0, metavar="N",
                        help="also list the N cells whose first round lay farthest from all their calls")
    parser.add_argument("--budget-cuts", action="store_true",
                        help="also list the series ended over the time budget on a cell whose median lies within it")
    args = parser.parse_args()
    path = args.file
    if args.first_round < 0:
        print(f"round_spread.py: --first-round must be 0 or more, not {args.first_round}", file=sys.stderr)
        return 2
    try:
        doc = json.loads(Path(path).read_text())
        cells = cell_rounds(doc)
        cuts = budget_cuts(doc) if args.budget_cuts else None
    except (OSError, ValueError, AttributeError, RecursionError) as e:
        print(f"round_spread.py: {path}: {e}", file=sys.stderr)
        return 2
    if not cells:
        print(f"round_spread.py: {path}: no cell holds every round in full", file=sys.stderr)
        return 2
    print("| adapter | cells | within rounds | between rounds | more between than within | first round > 10 % off "
          "| largest first-round offset | slowest round: cells a round |")
    print("|---|---|---|---|---|---|---|---|")
    for adapter, n, within, between, more, off, worst, slowest in summary(cells):
        print(f"| {adapter} | {n} | {within:.3f} | {between:.3f} | {more} | {off} | {worst:.3f} | "
              f"{' / '.join(map(str, slowest))} |")
    if args.first_round:
        print()
        print("| first round over all calls | adapter | cell | each round's median, ms |")
        print("|---|---|---|---|")
        for offset, adapter, name, medians in first_round_outliers(cells, args.first_round):
            print(f"| {offset:.3f} | {adapter} | {name} | {' / '.join(f'{m * 1e3:.3g}' for m in medians)} |")
    if cuts is not None:
        series, within = cuts
        print()
        print(f"{series} series ended over the time budget; {len(within)} of them on a cell whose calls' median "
              "lies within it:")
        print("| cell | median of its calls, ms | calls |")
        print("|---|---|---|")
        for name, median_s, n in within:
            print(f"| {name} | {median_s * 1e3:.3g} | {n} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
