#!/usr/bin/env python3
"""How run B's times compare with run A's, cell by cell: python3 plots/compare_runs.py A.json B.json.

Per adapter, search kind, strategy and data set (and distance): the ratio B/A of the median times with its
relative spread, and a flag when the change is beyond the noise: |ln ratio| > SIGMAS x the combined relative
spread of A and B, and |ratio - 1| > --threshold. Then, per adapter, the geometric mean ratio, and per model cloud
of the search cells, over every adapter and each. For ICP runs in both files, whether each ended at the same pose
(bit for bit, else the largest element difference) after as many iterations. Reads both shapes of record: one per
cell with median/min/stddev fields, or Google Benchmark's repetitions (`run_type: iteration`) with aggregates
(`run_type: aggregate`, `aggregate_name` median/mean/stddev/cv)."""
import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import provenance  # noqa: E402
import results_io  # noqa: E402

SIGMAS = 3.0


def _seconds(rec, field):
    value = results_io._number(rec.get(field))
    return value


def aggregate_seconds(rec):
    """An aggregate record's value in seconds (real_time in time_unit); cv is a fraction, returned as is."""
    if rec.get("aggregate_name") == "cv" or rec.get("aggregate_unit") == "percentage":
        return results_io._number(rec.get("real_time"))
    return results_io.record_seconds(rec, ())


def cell_stats(records):
    """(median seconds, relative spread) of one cell's records, or None when it was not measured."""
    if any(results_io._skip_reason(r) for r in records):
        return None
    aggregates = {r.get("aggregate_name"): aggregate_seconds(r) for r in records if r.get("run_type") == "aggregate"}
    runs = [r for r in records if r.get("run_type") != "aggregate"]
    if aggregates.get("median") is not None:
        median = aggregates["median"]
        if aggregates.get("cv") is not None:
            return median, aggregates["cv"]
        spread = aggregates.get("stddev")
        return median, (spread / (aggregates.get("mean") or median) if spread is not None and median else 0.0)
    if len(runs) == 1:
        return one_record_stats(runs[0])
    times = [results_io.record_seconds(r, ()) for r in runs]
    times = [t for t in times if t is not None]
    if not times:
        return None
    median, mean = results_io._median(times), sum(times) / len(times)
    stddev = math.sqrt(sum((t - mean) ** 2 for t in times) / (len(times) - 1)) if len(times) > 1 else 0.0
    return median, stddev / mean if mean else 0.0


def one_record_stats(rec):
    median = results_io.record_seconds(rec, ("median_s", "median_seconds", "build_seconds", "icp_seconds"))
    if median is None or median <= 0:
        return None
    stddev = next((v for v in (_seconds(rec, f) for f in ("stddev_s", "stddev_seconds")) if v is not None), None)
    minimum = next((v for v in (_seconds(rec, f) for f in ("min_s", "min_seconds")) if v is not None), None)
    if stddev is None and minimum is not None:
        stddev = median - minimum  # only the fastest repetition known: its distance from the median
    return median, (stddev or 0.0) / median


def cell_key(rec):
    """(adapter, search, strategy, data set, distance) of a record, from its fields or its name."""
    parts = results_io.run_name(rec).split("/")
    kind = parts[0] if parts else "?"
    if kind == "sweep":
        model = rec.get("model") or (parts[1] if len(parts) > 1 else "?")
        query = rec.get("query") or (parts[2] if len(parts) > 2 else "?")
        adapter = rec.get("adapter") or (parts[3] if len(parts) > 3 else "?")
        search = rec.get("search") or (parts[4] if len(parts) > 4 else "?")
        rest = "/".join(parts[5:])
        return adapter, search, rec.get("strategy") or "?", f"{model} <- {query}", rest or "-"
    if kind == "build":
        return (rec.get("adapter") or (parts[2] if len(parts) > 2 else "?")), "build", "-", \
            (rec.get("model") or (parts[1] if len(parts) > 1 else "?")), "-"
    if kind == "icp":
        return (rec.get("adapter") or (parts[2] if len(parts) > 2 else "?")), "icp", rec.get("search") or "-", \
            (rec.get("pair") or (parts[1] if len(parts) > 1 else "?")), "/".join(parts[3:]) or "-"
    return rec.get("adapter") or "?", kind, "-", "/".join(parts[1:]) or "-", "-"


def load_doc(path):
    doc = json.loads(Path(path).read_text())
    if not isinstance(doc, dict) or not isinstance(doc.get("benchmarks"), list):
        raise ValueError("not a results file (no 'benchmarks' list)")
    return doc


def read_cells(path, doc=None):
    """(context, {cell key: stats or None}) of one results file."""
    doc = load_doc(path) if doc is None else doc
    by_cell = {}
    for rec in doc["benchmarks"]:
        if isinstance(rec, dict):
            by_cell.setdefault(results_io.run_name(rec), []).append(rec)
    cells = {}
    for recs in by_cell.values():
        first = next((r for r in recs if r.get("run_type") != "aggregate"), recs[0])
        cells[cell_key({**recs[0], **first})] = cell_stats(recs)
    context = doc.get("context") if isinstance(doc.get("context"), dict) else {}
    return context, cells


def compare(a_cells, b_cells, threshold, sigmas=SIGMAS):
    """[(key, a stats, b stats, ratio, spread, flag)] for cells in both; flag '' / 'faster' / 'slower'."""
    rows = []
    for key in sorted(set(a_cells) & set(b_cells)):
        a, b = a_cells[key], b_cells[key]
        if a is None or b is None:
            rows.append((key, a, b, None, None, "not measured"))
            continue
        ratio, spread = b[0] / a[0], math.hypot(a[1], b[1])
        beyond = abs(math.log(ratio)) > sigmas * spread and abs(ratio - 1.0) > threshold
        rows.append((key, a, b, ratio, spread, ("slower" if ratio > 1 else "faster") if beyond else ""))
    return rows


def icp_outcomes(doc):
    """{cell key: (final pose as a flat list of numbers, iterations)} of a file's ICP runs that ended with a pose."""
    outcomes = {}
    for rec in doc["benchmarks"]:
        if not isinstance(rec, dict) or rec.get("run_type") == "aggregate" or results_io._skip_reason(rec):
            continue
        key, pose = cell_key(rec), rec.get("final_pose")
        if key[1] != "icp" or not isinstance(pose, list):
            continue
        flat = [v for row in pose if isinstance(row, list) for v in row]
        if len(flat) == 16 and all(isinstance(v, (int, float)) and math.isfinite(v) for v in flat):
            outcomes[key] = (flat, rec.get("iterations"))
    return outcomes


def pose_rows(a_outcomes, b_outcomes):
    """[(key, largest element difference of the final poses, A's iterations, B's)] for ICP runs in both."""
    rows = []
    for key in sorted(set(a_outcomes) & set(b_outcomes)):
        (a_pose, a_its), (b_pose, b_its) = a_outcomes[key], b_outcomes[key]
        rows.append((key, max(abs(x - y) for x, y in zip(a_pose, b_pose)), a_its, b_its))
    return rows


def pose_lines(rows):
    same = sum(1 for _, diff, a_its, b_its in rows if diff == 0 and a_its == b_its)
    lines = [f"ICP's final poses: {same} of {len(rows)} runs in both files end at the same pose, bit for bit, "
             f"after as many iterations" + ("." if same == len(rows) else "; the others:")]
    if same < len(rows):
        lines += ["", "| adapter | pair | settings | largest pose difference | iterations A | iterations B |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {key[0]} | {key[3]} | {key[4]} | {diff:.3g} | {a_its} | {b_its} |"
                  for key, diff, a_its, b_its in rows if diff != 0 or a_its != b_its]
    return lines


def fmt_time(seconds):
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds / 1e-9:.3g} ns"


def table_lines(rows):
    lines = ["| adapter | search | strategy | data set | distance | A | B | B/A | spread | change |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for (adapter, search, strategy, dataset, dist), a, b, ratio, spread, flag in rows:
        a_text, b_text = (fmt_time(x[0]) if x else "not measured" for x in (a, b))
        ratio_text = "-" if ratio is None else f"{ratio:.3f}"
        spread_text = "-" if spread is None else f"±{100 * spread:.1f}%"
        lines.append(f"| {adapter} | {search} | {strategy} | {dataset} | {dist} | {a_text} | {b_text} | "
                     f"{ratio_text} | {spread_text} | {flag.upper() if flag in ('faster', 'slower') else flag} |")
    return lines


def summary_lines(rows):
    """Per adapter: geometric mean of B/A over the cells measured in both, and how many changed."""
    by_adapter = {}
    for key, _, _, ratio, _, flag in rows:
        entry = by_adapter.setdefault(key[0], {"logs": [], "faster": 0, "slower": 0, "missing": 0})
        if ratio is None:
            entry["missing"] += 1
            continue
        entry["logs"].append(math.log(ratio))
        entry[flag] = entry.get(flag, 0) + 1
    lines = ["| adapter | cells | geometric mean B/A | faster beyond noise | slower beyond noise | not measured |",
             "|---|---|---|---|---|---|"]
    for adapter, e in sorted(by_adapter.items()):
        gmean = f"{math.exp(sum(e['logs']) / len(e['logs'])):.3f}" if e["logs"] else "-"
        lines.append(f"| {adapter} | {len(e['logs'])} | {gmean} | {e['faster']} | {e['slower']} | {e['missing']} |")
    return lines


def model_lines(rows):
    """Per model cloud of the search cells (builds and ICP left out): the geometric mean of B/A over every
    adapter's cells, then each adapter's. A resumed run keeps a model's rounds together, so a model mostly ran
    on one machine."""
    logs = {}
    for (adapter, search, _, dataset, _), _, _, ratio, _, _ in rows:
        if ratio is None or search in ("build", "icp") or " <- " not in dataset:
            continue
        model = dataset.split(" <- ")[0]
        for who in ("all", adapter):
            logs.setdefault((model, who), []).append(math.log(ratio))
    lines = ["| model | adapter | cells | geometric mean B/A |", "|---|---|---|---|"]
    for (model, who), values in sorted(logs.items(), key=lambda kv: (kv[0][0], kv[0][1] != "all", kv[0][1])):
        lines.append(f"| {model} | {who} | {len(values)} | {math.exp(sum(values) / len(values)):.3f} |")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a", type=Path, help="baseline results file")
    parser.add_argument("b", type=Path, help="results file compared with it")
    parser.add_argument("--threshold", type=float, default=0.05,
                        help="smallest relative change flagged, on top of the noise test (default 0.05 = 5%%)")
    parser.add_argument("--sigmas", type=float, default=SIGMAS,
                        help="a change is beyond the noise when |ln ratio| exceeds this many combined relative "
                             "spreads (default 3)")
    args = parser.parse_args(argv)
    loaded = []
    for path in (args.a, args.b):
        try:
            doc = load_doc(path)
            loaded.append((*read_cells(path, doc), icp_outcomes(doc)))
        except (OSError, ValueError, RecursionError) as err:
            print(f"compare_runs: {path}: cannot read results ({err})", file=sys.stderr)
            return 2
    (a_ctx, a_cells, a_icp), (b_ctx, b_cells, b_icp) = loaded
    print(f"A: {provenance.describe(args.a, a_ctx)}")
    print(f"B: {provenance.describe(args.b, b_ctx)}")
    rows = compare(a_cells, b_cells, args.threshold, args.sigmas)
    only = len(set(a_cells) ^ set(b_cells))
    print(f"\n{len(rows)} cells in both files ({only} in only one, not compared); a change is flagged when "
          f"|ln(B/A)| > {args.sigmas:g} x the combined relative spread and |B/A - 1| > {args.threshold:.0%}\n")
    print("\n".join(table_lines(rows)))
    print()
    print("\n".join(summary_lines(rows)))
    by_model = model_lines(rows)
    if len(by_model) > 2:
        print()
        print("\n".join(by_model))
    poses = pose_rows(a_icp, b_icp)
    if poses:
        print()
        print("\n".join(pose_lines(poses)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
