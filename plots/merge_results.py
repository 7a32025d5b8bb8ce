#!/usr/bin/env python3
"""Merges the shard files of one sharded run (run_sweep or run_icp --shard I/N) into one results file.

    plots/merge_results.py results/sweep_paper.shard-*-of-64.json --out results/sweep_paper.json
    plots/merge_results.py results/icp_real.shard-*-of-8.json --out results/icp_real.json

Refuses shards from different git commits, experiments, configurations (the shard aside) or build types,
and a shard given twice (exit 2). Reports missing shards, missing cells (by name) and cells recorded by
two shards, and then exits 1 without writing, unless --allow-missing (missing cells only). The merged file
has the schema of a single run, its cells in a single run's order, and the cross-check of exact adapters
redone over all shards (as one process would have done it); context.merged_from says which shards it
came from. Written atomically (temporary file, then rename). A run_icp cell is one repetition of a
(pair, adapter, bucket size) unit: its record name and repetition_index.
"""
import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from files import write_atomically  # noqa: E402

PROG = "merge_results.py"


class Refused(Exception):
    """Shards that must not be merged."""


def load_shard(path):
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, ValueError, RecursionError) as e:
        raise Refused(f"{path}: not a results file ({e})")
    context = doc.get("context", {}) if isinstance(doc, dict) else {}
    if "benchmarks" not in doc or "shard" not in context or "shard" not in context.get("config", {}):
        raise Refused(f"{path}: not a shard file (no context.shard: made without --shard)")
    return doc


# What identifies a unit (in the plan and in its records) and a cell, by the program that wrote the shards.
UNIT_FIELDS = {"run_sweep": ("model", "adapter"), "run_icp": ("pair", "adapter", "bucket_size")}


def program(doc):
    return doc["context"]["shard"].get("program", "run_sweep")


def unit_key(doc, unit_or_record):
    return tuple(unit_or_record.get(field) for field in UNIT_FIELDS[program(doc)])


def cell_name(doc, rec):
    if program(doc) == "run_icp":
        return f"{rec['name']}#{rec.get('repetition_index', 0)}"
    return rec.get("run_name") or rec["name"]  # a cell's repetitions and aggregates share its run_name


def record_key(rec):
    """What makes a record one of a kind within its cell: its repetition or its aggregate."""
    return rec.get("run_type"), rec.get("repetition_index"), rec.get("aggregate_name")


def cell_groups(doc):
    """The document's records grouped by cell name, in order of first appearance, and the names of cells
    with a record given twice."""
    groups, repeated = {}, []
    for rec in doc["benchmarks"]:
        group = groups.setdefault(cell_name(doc, rec), [])
        if any(record_key(r) == record_key(rec) for r in group):
            repeated.append(cell_name(doc, rec))
        group.append(rec)
    return groups, repeated


def config_without_shard(doc):
    return {k: v for k, v in doc["context"]["config"].items() if k != "shard"}


def check_same_run(docs, paths):
    """Every shard must come from the same commit, experiment, configuration, build and plan."""
    first = docs[0]["context"]
    checks = [("program", lambda c, d: program(d)),
              ("git commit", lambda c, d: c.get("git_commit")),
              ("experiment", lambda c, d: c.get("experiment")),
              ("build type", lambda c, d: (c.get("build_type"), c.get("ndebug"), c.get("sanitizers"))),
              ("configuration", lambda c, d: config_without_shard(d)),
              ("shard count", lambda c, d: c["shard"]["count"]),
              ("shard plan", lambda c, d: c["shard"]["units"])]
    for what, value in checks:
        for doc, path in zip(docs[1:], paths[1:]):
            if value(doc["context"], doc) != value(first, docs[0]):
                raise Refused(f"{path} and {paths[0]} differ in their {what}: not shards of one run")
    if first.get("git_commit") is None:
        print(f"{PROG}: warning: the shards do not say their git commit", file=sys.stderr)


def shard_index(doc):
    return doc["context"]["shard"]["index"]


def check_distinct_shards(docs, paths):
    seen = {}
    for doc, path in zip(docs, paths):
        index = shard_index(doc)
        if index in seen:
            raise Refused(f"shard {index} given twice: {seen[index]} and {path}")
        seen[index] = path


def missing_shards(docs):
    """Lines naming each shard not given, with its units and cells (from the plan every shard carries)."""
    plan = docs[0]["context"]["shard"]
    present = {shard_index(d) for d in docs}
    lines = []
    for index in range(plan["count"]):
        if index in present:
            continue
        units = [u for u in plan["units"] if u["shard"] == index]
        cells = sum(u["cells"] for u in units)
        names = ", ".join(" ".join(str(v) for v in unit_key(docs[0], u) if v is not None) for u in units)
        lines.append(f"shard {index}/{plan['count']} missing: {len(units)} units, {cells} cells ({names or 'none'})")
    return lines


def collect_cells(docs, paths):
    """Each cell's records by cell name; missing and duplicated cell names, and the run-order key of each name."""
    records, origin, duplicated, missing, order = {}, {}, [], [], {}
    units = docs[0]["context"]["shard"]["units"]
    unit_index = {unit_key(docs[0], u): i for i, u in enumerate(units)}
    for doc, path in zip(docs, paths):
        expected = doc["context"]["shard"]["cells"]
        position = {name: i for i, name in enumerate(expected)}
        names = set()
        groups, repeated = cell_groups(doc)
        duplicated += [f"{name} (twice in {path})" for name in repeated]
        for name, group in groups.items():
            rec = group[0]
            if name in records:
                duplicated.append(f"{name} (in {origin[name]} and {path})")
                continue
            if name not in position:
                duplicated.append(f"{name} (in {path}, which is not its shard)")
                continue
            records[name], origin[name] = group, path
            names.add(name)
            order[name] = (unit_index.get(unit_key(doc, rec), len(units)), position[name])
        missing += [f"{name} (shard {shard_index(doc)}, {path})" for name in expected if name not in names]
    return records, order, duplicated, missing


def agreement_key(rec):
    last = (rec.get("run_name") or rec["name"]).rsplit("/", 1)[-1]
    k = str(rec["k"]) if "k" in rec else "-"
    return "|".join([rec["model"], rec["query"], rec["search"], k, last if "max_dist" in rec else "-"])


def as_float(value):
    return float(value)  # numbers and the non-finite markers "inf", "-inf", "nan"


def redo_agreement(records):
    """The cross-check as one process makes it: each exact cell against the first exact adapter, in run
    order, that ran the same cell (brute force whenever it ran). Returns the number of disagreements."""
    reference, disagreements = {}, 0
    for rec in records:
        if rec.get("type") != "sweep" or not rec.get("exact") or "skipped" in rec or "agrees" not in rec:
            continue
        ref = reference.setdefault(agreement_key(rec), rec)
        rec["checked_against"] = ref["adapter"]
        rec.pop("disagreement", None)
        ours, theirs = as_float(rec["dist_sum"]), as_float(ref["dist_sum"])
        tolerance = 1e-9 * max(abs(ours), abs(theirs))
        rec["agrees"] = rec["found"] == ref["found"] and abs(ours - theirs) <= tolerance
        if not rec["agrees"]:
            disagreements += 1
            rec["disagreement"] = (f"found {rec['found']} vs {ref['found']} ({ref['adapter']}), "
                                   f"dist_sum {ours:.17g} m vs {theirs:.17g} m")
    return disagreements


def merged_context(docs, paths):
    by_index = sorted(zip(docs, paths), key=lambda dp: shard_index(dp[0]))
    context = json.loads(json.dumps(by_index[0][0]["context"]))
    count = context["shard"]["count"]
    del context["shard"]
    del context["config"]["shard"]
    context["merged_from"] = [
        {"file": str(path), "shard": f"{shard_index(doc)}/{count}", "date": doc["context"].get("date"),
         "host_name": doc["context"].get("host_name"), "resumed": doc["context"].get("resumed", []),
         "records": len(doc["benchmarks"])}
        for doc, path in by_index]
    return context


def results_text(context, records):
    body = ",\n".join(json.dumps(r) for r in records)  # a record a line, as run_sweep writes them
    return "{\n\"context\": " + json.dumps(context, indent=2) + ",\n\"benchmarks\": [\n" + body + "\n]\n}\n"


def report(title, lines, limit=20):
    if not lines:
        return
    print(f"{PROG}: {len(lines)} {title}:", file=sys.stderr)
    for line in lines[:limit]:
        print(f"  {line}", file=sys.stderr)
    if len(lines) > limit:
        print(f"  ... and {len(lines) - limit} more", file=sys.stderr)


def merge(paths, out, allow_missing):
    if any(Path(p).resolve() == Path(out).resolve() for p in paths):
        raise Refused(f"--out {out} is one of the shard files")
    docs = [load_shard(p) for p in paths]
    check_same_run(docs, paths)
    check_distinct_shards(docs, paths)
    records, order, duplicated, missing = collect_cells(docs, paths)
    absent = missing_shards(docs)
    report("shards missing", absent)
    report("cells missing from the shards given", missing)
    report("cells recorded twice or by the wrong shard", duplicated)
    if duplicated or ((absent or missing) and not allow_missing):
        print(f"{PROG}: nothing written (rerun the missing shards with --resume"
              f"{'' if duplicated else ', or merge with --allow-missing'})", file=sys.stderr)
        return 1
    merged = [rec for name in sorted(records, key=order.get) for rec in records[name]]
    disagreements = redo_agreement(merged)
    write_atomically(out, results_text(merged_context(docs, paths), merged))
    print(f"{PROG}: wrote {len(merged)} records from {len(docs)} shards to {out}"
          f"{f'; {disagreements} DISAGREEMENTS between exact adapters' if disagreements else ''}", file=sys.stderr)
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("shards", nargs="+", help="shard files of one run (run_sweep or run_icp --shard I/N)")
    parser.add_argument("--out", required=True, help="the merged results file")
    parser.add_argument("--allow-missing", action="store_true",
                        help="write the merge although shards or cells are missing (duplicates still refused)")
    args = parser.parse_args(argv)
    try:
        return merge(args.shards, args.out, args.allow_missing)
    except Refused as e:
        print(f"{PROG}: refused: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
